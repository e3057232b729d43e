"""Whether a model variant stays physical in the system study: weak findings, circuit modes.

``smeha flow --variant`` runs the transducer with the extension a diagnosis
names. Two things make such a run say more about the variant than about the
pump, and every output that uses the variant (the flow comparison's table,
its JSON and the plot) says so, with the reason (:func:`check_variant`):

* **a weak finding**: the diagnosis fitted the extension with an unknown on a
  bound of its fit (docs/DIAGNOSE.md: "named, but reported as such ...
  never as a physical result"). Read from the file (a diagnosis' ``weak``
  and ``extended.at_bounds``, or a variant file's ``weak`` and ``at_bounds``,
  as ``data/paper_variant.json`` carries them) and, for the mechanics, whose
  fit unknowns follow from the SI parameters in closed form, recomputed from
  the parameters themselves (:func:`bound_unknowns`), so a hand-written or
  edited variant is caught too;
* **a circuit mode the variant moves onto the pumping frequency**: the pump
  delivers f A_d dy (eqs 39-41) while the pump piston follows the
  magnetostrictive force, that is well below the lowest mode of the
  transducer's mechanics coupled with the oil and the cylinder's load
  (:func:`system_models.modes.circuit_modes`). How far below shows in the
  piston's lag behind the force at f (:func:`system_models.modes.piston_receptance`,
  the linear coupled model). A single degree of freedom lags by
  arctan(2 zeta r / (1 - r^2)), r = f/f_n (Inman, *Engineering Vibration*,
  4th ed. 2014, sec. 2.2): :data:`LAG_LIMIT_DEG` = 45 deg where the damping
  force c w has grown to the net restoring force |K - m w^2|, from where the
  mode rather than the stiffness sets the stroke, and 90 deg at the mode
  itself, past which the piston moves against the rod between the valve
  switches. A variant row is marked when, in a stage of the pump, the
  piston's lag at f exceeds 45 deg with the variant and not with the paper's
  model; or when the variant has an under-damped mode (zeta < 1/sqrt(2), the
  damping below which a resonant peak exists, sec. 2.2) whose half-power band
  f_n (1 -+ zeta) (exact as zeta -> 0, a fair width up to the limit) holds f or one of its next :data:`HARMONICS` - 1 harmonics
  and the paper's model has none there. The rule is relative: the mark is
  for what the variant puts there; the paper model's own modes and lags are
  listed beside it;
* **a rebound the variant magnifies**: at each valve switch the chamber's
  pressure steps (with a differential cylinder its cavities' pressures
  differ by the area ratio and the load; :func:`system_models.modes.pressure_step`),
  and across the static compliance 1/K (+ 1/k_j) that force step moves the
  pump piston. Once that exceeds the free stroke the oil's pressure, not the
  rod, sets the stroke (the pump rings between two rest positions that the
  valve timing rectifies). A row is marked when that holds with the variant
  and not with the paper's model (after the run: it needs the row's load
  and free stroke).

Examples
--------
>>> import gmt
>>> delay = gmt.ModelVariant("transport_delay", {"delay_s": 4e-4})
>>> check_variant(delay, "realistic").reasons(100.0)
[]
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import gmt

__all__ = ["HARMONICS", "VariantCheck", "bound_unknowns", "check_variant",
           "declared_weakness", "mark_rows", "rod_of"]

#: The pumping frequency and its harmonics up to this order are compared with the
#: circuit's modes: the valves switch at the drive's extremes, so the chamber's
#: force is close to a square wave, whose k-th harmonic falls as 1/k.
HARMONICS = 3

#: Damping ratio below which a mode has a resonant peak (Inman, sec. 2.2).
PEAK_DAMPING = 1.0 / math.sqrt(2.0)
#: Lag of the pump piston behind the magnetostrictive force beyond which a mode sets the
#: stroke, [deg] (module docstring: the damping force equals the net restoring force).
LAG_LIMIT_DEG = 45.0


def declared_weakness(data) -> tuple[bool, tuple]:
    """(weak, unknowns on their bounds) as a JSON file states them.

    A whole diagnosis (``smeha diagnose --json``) states ``weak`` and
    ``extended.at_bounds``; a variant file may state ``weak`` and
    ``at_bounds`` (``data/paper_variant.json``). Absent keys state nothing.
    """
    if not isinstance(data, Mapping):
        return False, ()
    extended = data.get("extended") if isinstance(data.get("extended"), Mapping) else {}
    names = data.get("at_bounds") or extended.get("at_bounds") or ()
    names = tuple(str(n) for n in names) if isinstance(names, (list, tuple)) else ()
    return bool(data.get("weak")) or bool(names), names


def _fit_unknowns(cls, values, params) -> tuple | None:
    """The diagnosis' unknowns x of a mechanics form from its SI parameters (the inverse of
    its ``from_fit``), or None for a form without a closed-form inverse."""
    if (cls.cause, cls.form) == ("mechanical_resonance", "one_dof"):
        return (values["mass_kg"] / params.mass, values["damping_N_s_per_m"] / params.damping,
                values["stiffness_N_per_m"] / params.stiffness)
    if (cls.cause, cls.form) == ("mechanical_resonance", "two_dof"):
        m1, m2 = values["rod_mass_kg"], values["output_mass_kg"]
        kj, cj = values["joint_stiffness_N_per_m"], values["joint_damping_N_s_per_m"]
        return (m2 / (m1 + m2), math.log10(math.sqrt(kj / m2) / (2.0 * math.pi)),
                cj / (2.0 * math.sqrt(kj * m2)), (m1 + m2) / params.mass)
    return None


def bound_unknowns(variant: gmt.ModelVariant,
                   params: gmt.TransducerParameters | None = None) -> tuple:
    """Each fit unknown of the variant's mechanics that lies on a bound of its fit.

    Returns
    -------
    tuple of str
        ``"name = value on its lower|upper bound [lo, hi]"`` for each such unknown
        (:meth:`gmt.extensions.Extension.at_bounds`'s tolerance); empty for the
        paper, for mechanics inside their bounds and for the forms whose
        unknowns do not follow from the parameters in closed form.
    """
    params = params or gmt.TransducerParameters()
    out = []
    for cls, values in variant.steady_components():
        x = _fit_unknowns(cls, values, params)
        if x is None:
            continue
        named = dict(zip(cls.fit.names, x))
        for name in cls.at_bounds(x):
            k = cls.fit.names.index(name)
            lo, hi = cls.fit.lower[k], cls.fit.upper[k]
            side = "lower" if abs(named[name] - lo) <= abs(named[name] - hi) else "upper"
            out.append(f"{name} = {named[name]:.4g} on its {side} bound [{lo:g}, {hi:g}]")
    return tuple(out)


def rod_of(variant: gmt.ModelVariant | None, frequency: float | None = None):
    """The mechanics the magnetostrictive force drives (:meth:`gmt.Transducer.rod_mechanics`)
    as :class:`system_models.rod.RodParameters`.

    ``frequency`` [Hz]: the operating point the transducer is built at (the
    mechanics do not depend on it; a study passes one of its own, so that a
    variant valid there is not refused at another); default gmt's.
    """
    from system_models.rod import RodParameters
    excitation = None if frequency is None else gmt.Excitation(frequency, 1.0)
    model = gmt.Transducer(excitation=excitation,
                           variant=variant if variant is not None else gmt.ModelVariant())
    return RodParameters(*model.rod_mechanics())


@dataclass(frozen=True)
class VariantCheck:
    """A variant's weakness and its coupled circuit modes beside the paper model's.

    Attributes
    ----------
    variant : str
        The variant's name.
    circuit : str
        The circuit's name (:data:`system_models.presets.CIRCUITS`).
    weak_reasons : tuple of str
        Why the variant is a weak finding; empty if it is not.
    paper_modes, variant_modes : tuple of StageModes
        (compressing, expanding) of :func:`system_models.modes.circuit_modes`.
    static_deflection_m : dict
        The pump piston's rest deflection under the chamber's force at the
        linearisation pressure, A_d p (1/K + 1/k_j), for ``"paper"`` and
        ``"variant"``, [m].
    rods : dict
        The :class:`system_models.rod.RodParameters` of ``"paper"`` and ``"variant"``.
    plant : CircuitParameters
        The circuit the modes are of.
    """

    variant: str
    circuit: str
    weak_reasons: tuple
    paper_modes: tuple
    variant_modes: tuple
    static_deflection_m: dict = field(default_factory=dict)
    rods: dict = field(default_factory=dict)
    plant: object = None

    def piston_lags_deg(self, frequency: float) -> dict:
        """The pump piston's lag behind the force at ``frequency`` [Hz], [deg], per stage
        (compressing, expanding), for ``"paper"`` and ``"variant"``; and its stroke per
        unit force times K (``"..._stroke"``, 1 for the free rod at rest)."""
        from system_models.modes import piston_receptance
        out = {}
        for model, rod in self.rods.items():
            h = piston_receptance(rod, self.plant, frequency)
            out[model] = tuple(-math.degrees(math.atan2(z.imag, z.real)) for z in h)
            out[f"{model}_stroke"] = tuple(abs(z) * rod.stiffness for z in h)
        return out

    @property
    def weak(self) -> bool:
        return bool(self.weak_reasons)

    def resonance_reasons(self, frequency: float) -> list[str]:
        """Why a circuit mode the variant moves makes the run at ``frequency`` [Hz] unphysical."""
        f = float(frequency)
        out = []
        lags = self.piston_lags_deg(f) if self.rods else None
        for k, (paper, var) in enumerate(zip(self.paper_modes, self.variant_modes)):
            low_v, low_p = var.natural_frequencies_Hz[0], paper.natural_frequencies_Hz[0]
            if lags is not None and lags["variant"][k] > LAG_LIMIT_DEG >= lags["paper"][k]:
                where = "below" if low_v <= f else "near"
                out.append(
                    f"circuit mode {where} the pumping frequency: while the pump is "
                    f"{var.stage}, the transducer's mechanics with the oil and the cylinder's "
                    f"load have their lowest mode at {low_v:.3g} Hz (the paper's model: "
                    f"{low_p:.3g} Hz); at f = {f:g} Hz the pump piston lags the "
                    f"magnetostrictive force by {lags['variant'][k]:.0f} deg (the paper's "
                    f"model: {lags['paper'][k]:.0f} deg) with {lags['variant_stroke'][k]:.2g} "
                    f"of the free rod's static stroke: past {LAG_LIMIT_DEG:g} deg the mode, "
                    f"not the stiffness, sets the stroke, past 90 deg the piston moves "
                    f"against the rod between the valve switches{self._deflection()}")
            for fn, zeta in var.resonances:
                hit = [k for k in range(1, HARMONICS + 1)
                       if zeta < PEAK_DAMPING and abs(k * f - fn) <= zeta * fn
                       and not any(z < PEAK_DAMPING and abs(k * f - fp) <= z * fp
                                   for fp, z in paper.resonances)]
                if hit:
                    which = " and ".join("f" if k == 1 else f"{k} f" for k in hit)
                    out.append(f"circuit resonance at a pumping harmonic: while the pump is "
                               f"{var.stage}, a mode at {fn:.4g} Hz (damping ratio "
                               f"{zeta:.2g}) has {which} = "
                               f"{', '.join(f'{k * f:g}' for k in hit)} Hz in its half-power "
                               f"band; the paper's model has no mode there")
        return out

    def rebound_reason(self, load_force: float, free_stroke: float,
                       paper_free_stroke: float) -> str:
        """Why the chamber's pressure step, not the rod, sets the variant's stroke ("" if not).

        At each valve switch the chamber's pressure steps
        (:func:`system_models.modes.pressure_step`, at rest with ``load_force``
        [N]); across the static compliance 1/K + 1/k_j that force step moves the
        pump piston. Marked when that exceeds the variant's free stroke
        ``free_stroke`` [m] while with the paper's model (compliance 1/K) it
        stays within ``paper_free_stroke`` [m].
        """
        from system_models.modes import pressure_step
        step = pressure_step(self.plant, load_force)
        force = abs(step) * self.plant.chamber.piston_area
        moved = {k: force * _compliance(r) for k, r in self.rods.items()}
        if not moved["variant"] > free_stroke or moved["paper"] > paper_free_stroke:
            return ""
        law = "1/K + 1/k_j" if self.rods["variant"].output_mass > 0.0 else "1/K"
        return (f"rebound: at each valve switch the chamber's pressure steps by "
                f"{abs(step) / 1e6:.3g} MPa (the cylinder's balance p_B A_B - p_S A_S = "
                f"F_load, {load_force:g} N); across the variant's static compliance "
                f"{law} that moves the pump piston by {moved['variant'] * 1e6:.3g} um, "
                f"more than its free stroke of {free_stroke * 1e6:.3g} um (the paper's model: "
                f"{moved['paper'] * 1e6:.2g} um against {paper_free_stroke * 1e6:.3g} um): the "
                f"oil's pressure, not the rod, sets the stroke")

    def reasons(self, frequency: float, rebound: tuple | None = None) -> list[str]:
        """Every reason the variant's run at ``frequency`` is marked (empty: unmarked).

        ``rebound``: (load [N], the variant's free stroke [m], the paper's [m]) of
        the run, for :meth:`rebound_reason` (left out when None).
        """
        weak = ([f"weak finding: {'; '.join(self.weak_reasons)}, so its parameters are "
                 "not a physical result (docs/DIAGNOSE.md)"] if self.weak else [])
        out = weak + self.resonance_reasons(frequency)
        if rebound is not None and self.rods:
            out += [r for r in (self.rebound_reason(*rebound),) if r]
        return out

    def _deflection(self) -> str:
        d = self.static_deflection_m
        if not d:
            return ""
        return (f" (at rest the chamber's force deflects the pump piston by "
                f"{d['variant'] * 1e3:.3g} mm, with the paper's model by "
                f"{d['paper'] * 1e3:.3g} mm)")


    def as_dict(self, frequencies=()) -> dict:
        """JSON-able: weakness, the modes of both models, the reasons at each frequency."""
        return {"variant": self.variant, "circuit": self.circuit, "weak": self.weak,
                "weak_reasons": list(self.weak_reasons),
                "modes": {"paper": [m.as_dict() for m in self.paper_modes],
                          "variant": [m.as_dict() for m in self.variant_modes]},
                "static_deflection_um": {k: v * 1e6
                                         for k, v in self.static_deflection_m.items()},
                "piston_lag_deg": ({f"{float(f):g}": self.piston_lags_deg(f)
                                    for f in frequencies} if self.rods else {}),
                # before the run; each row's variant_marks add the rebound (mark_rows)
                "marks": {f"{float(f):g}": self.reasons(f) for f in frequencies},
                "rule": ("marked when the variant is a weak finding, or when in a stage of "
                         f"the pump it makes the piston lag the force by more than "
                         f"{LAG_LIMIT_DEG:g} deg at the pumping frequency (the paper's model "
                         "not), or puts an under-damped mode with the pumping frequency or "
                         f"one of its harmonics up to {HARMONICS} f in its half-power band "
                         "(the paper's model none there), or (each row's variant_marks) "
                         "when the chamber's pressure step at a valve switch moves the "
                         "piston by more than its free stroke across the variant's static "
                         "compliance (the paper's model not); smeha.studies.variantcheck")}


def check_variant(variant: gmt.ModelVariant, circuit="realistic",
                  declared: Mapping | None = None,
                  frequency: float | None = None) -> VariantCheck:
    """Check a variant for the flow study on a named circuit (module docstring).

    Parameters
    ----------
    variant : gmt.ModelVariant
    circuit : str or CircuitParameters
        A name of :data:`system_models.presets.CIRCUITS`, or the circuit itself.
    declared : mapping, optional
        The JSON the variant was read from: its weakness as stated there
        (:func:`declared_weakness`) is kept beside the one recomputed from
        the parameters (:func:`bound_unknowns`).
    frequency : float, optional
        A frequency of the study [Hz], for :func:`rod_of`.
    """
    from system_models import presets
    from system_models.circuit import initial_state
    from system_models.modes import circuit_modes

    weak, names = declared_weakness(declared)
    reasons = list(bound_unknowns(variant))
    if weak:
        said = f" ({', '.join(names)} on their bounds)" if names else ""
        reasons.append(f"the diagnosis reports it weak{said}")
    plant = presets.circuit(circuit) if isinstance(circuit, str) else circuit
    circuit = circuit if isinstance(circuit, str) else "custom"
    rods = {"paper": rod_of(None, frequency), "variant": rod_of(variant, frequency)}
    modes = {k: circuit_modes(r, plant) for k, r in rods.items()}
    force = plant.chamber.piston_area * float(initial_state(plant)[0])
    deflection = {k: force * _compliance(r) for k, r in rods.items()}
    return VariantCheck(variant.name, circuit, tuple(reasons), modes["paper"],
                        modes["variant"], deflection, rods, plant)


def mark_rows(rows, check: VariantCheck) -> list:
    """Each of the variant's rows of a flow study with ``variant_marks`` (the reasons) and,
    when marked, ``variant_note`` (one sentence): a new list (typed rows,
    :class:`~smeha.studies.flowrow.FlowRow`, are frozen; plain dicts are marked in place)."""
    from dataclasses import replace
    from .flowrow import FlowRow

    def key(r):
        return (r["frequency_Hz"], r["mode"], r["load_N"])

    paper = {key(r): r["dy_free_um"] * 1e-6 for r in rows
             if r.get("model", "paper") == "paper"}
    out = []
    for row in rows:
        if row.get("model", "paper") == "paper":
            out.append(row)
            continue
        free = row["dy_free_um"] * 1e-6
        marks = list(check.reasons(row["frequency_Hz"], (
            row["load_N"], free, paper.get(key(row), free))))
        note = "; ".join(marks) if marks else None
        if isinstance(row, FlowRow):
            row = replace(row, variant_marks=tuple(marks), variant_note=note)
        else:
            row["variant_marks"] = marks
            if note:
                row["variant_note"] = note
        out.append(row)
    return out


def _compliance(rod) -> float:
    """Static compliance of the pump piston, 1/K (+ 1/k_j with two masses), [m/N]."""
    return 1.0 / rod.stiffness + (1.0 / rod.joint_stiffness if rod.output_mass > 0.0 else 0.0)
