"""Diagnosis of the paper model's misfit: which physical effect does it miss?

Issue #5, items 3-5. Given measured runs (sinusoidal current at several
frequencies and amplitudes, displacement y and sensing-coil voltage E), the
workflow

1. **reduces each run to features** (:func:`run_features`): by linear least
   squares over the whole cycles after the first (the first is the mechanical
   transient), the complex harmonics k = 1 ... :data:`HARMONICS` of y and of
   B (from E, eq 21: B_k = j E_k / (k w N_c A_c)), all referred to the phase of
   the current's fundamental; the drift of y's offset and of its fundamental
   (a linear-in-time term and a linear-in-time fundamental in the same basis);
   B_m = |B_1| (eq 22). The **noise** comes from the data alone: the
   cycle-to-cycle scatter of y (and E) at the same phase, after a straight
   line over the cycle index at each phase (so a slow drift of offset or gain
   does not count as noise). Each feature's variance follows from that noise
   and the least-squares design; the B_m error is carried into y's
   harmonics through the model's sensitivity.
2. **fits the paper's model** (eq 30 in periodic steady state, the sampled
   model of the project at the data's step: force harmonics through the ZOH
   response of eq 27, as :func:`gmt.periodic_response` with ``step``) on the
   training runs: B_m of each run is its measured one, mu'' comes from eq 16
   with the four loss coefficients (K_h, n, K_e, K_ex) shared by all runs and
   fitted to the features of y and B together (weighted by their noise; the
   start values are :func:`smeha.identify.identify`'s), mu' from eq 20.
3. **characterises the residuals** (:func:`characterise`): by branch (rising
   and falling current), by harmonic (amplitude and phase of y's and B's
   residual against f and I_m), the measured loop opening against f (its
   intercept at f -> 0 and whether it grows like f or sqrt f), the extra lag
   and gain of y and of B against f, and the drift of offset and gain within
   each run, with z-scores.
4. **fits every candidate extension** (:mod:`gmt.extensions`) on the same
   training runs, loss coefficients refitted together with the extension's
   own few parameters, shared across runs, and **scores** it on the held-out
   runs: chi^2 of the held-out features (y and B; a candidate that does not act
   on B predicts the paper's B) plus a BIC penalty k ln n for its k added
   parameters. The drift candidate predicts the drift features as the
   least-squares slope of its heating dose over each run's samples (the same
   functional the features are). Two causes come in several formulations
   (:data:`FORMS`), each fitted and scored as a candidate of its own, so the
   penalty for parameters also arbitrates between them: eddy currents as a
   lumped lag of the field, or as the exact diffusion of the field into a
   lamination (slab) or a solid rod (cylinder) with its profile across the
   section (:class:`gmt.extensions.EddyCurrentDiffusion`); the mechanics as
   eq 27 with re-identified m, c, K (one DOF), or as rod and output mass on a
   compliant joint (:class:`gmt.extensions.TwoMassMechanics`). Decision
   (:func:`decide`):

   * ``none`` when the paper's model is within noise on the training fit and
     on the held-out runs: reduced chi^2 at most :data:`WITHIN_NOISE`;
   * the best candidate's cause when it lowers the held-out BIC by more than
     :data:`MIN_BIC_DROP` and removes at least :data:`MIN_EXPLAINED` of the
     paper's held-out excess chi^2 (chi^2 - n);
   * ``unexplained`` otherwise (structure beyond noise that no candidate
     removes).

5. **measures the gain**: held-out RMS error of y, over the samples of the
   held-out runs after the first cycle (a constant offset per run fitted, as
   displacements are relative), paper vs extended model, and their ratio.

Default held-out runs (:func:`default_holdout`): with at least five distinct
frequencies, all runs at the middle frequency (index (n - 1) // 2 of the sorted
frequencies) and at the second-highest one, so the held-out runs lie inside
the trained range; with three or four frequencies, the runs at the middle one;
fewer needs ``holdout`` explicitly.

A run without a sense voltage has no B features: B_m comes from y's
fundamental (eq 19, :func:`smeha.identify.flux_density_from_displacement`),
re-derived through each candidate's own path from M to y, and only y's
harmonics and drift are compared. Other causes within the BIC margin of the
named one are reported as :func:`also_consistent` (the rule is unchanged).

SI inside; micrometres only in the report.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares

import gmt
from gmt import extensions as ext
from gmt.constants import MU_0

from .identify import flux_density_from_displacement
from .measured import DataError, Run

#: Harmonics of y and B in the features and the models.
HARMONICS = 8
#: Points per period of the models' periodic evaluation.
GRID = 128
#: Periods discarded at the start of a run (mechanical transient, memory of operators).
TRANSIENT_CYCLES = 1
#: Fewest whole cycles after the transient (noise needs a line over >= 3 cycles).
MIN_CYCLES = 3
#: Reduced chi^2 at or below which the paper's model "explains the data within noise".
WITHIN_NOISE = 2.0
#: A candidate must lower the held-out BIC by more than this.
MIN_BIC_DROP = 25.0
#: ... and remove at least this fraction of the paper's held-out excess chi^2.
MIN_EXPLAINED = 0.5
#: Play-operator thresholds as fractions of the largest field amplitude of the runs.
PLAY_THRESHOLDS = (0.2, 0.4, 0.6, 0.8)

CAUSES = ext.CAUSES

#: What each candidate changes, for the evidence text.
SIGNALS = {
    "rate_independent_hysteresis": "B and y",
    "magnetization_saturation": "B and y",
    "eddy_current_diffusion": "B and y",
    "transport_delay": "y only",
    "mechanical_resonance": "y only",
    "thermal_drift": "y only",
}

#: Without B (no sense voltage) these candidates are told apart only by the shape of y:
#: each magnetic cause that changes B and y together against the causes that change y only
#: and leave a similar trace in y's harmonics against f.
CONFUSABLE_WITHOUT_B = (
    ("eddy_current_diffusion", "mechanical_resonance"),
    ("eddy_current_diffusion", "transport_delay"),
    ("rate_independent_hysteresis", "magnetization_saturation"),
)


# ================================================================== features


@dataclass
class RunFeatures:
    """One run reduced to what the models are compared on (SI).

    Phasors X_k mean x(t) = Re(sum_k X_k e^{j k theta}), theta = w t + phi_i,
    the current's fundamental being I_m cos(theta).
    """

    name: str
    frequency: float
    current_amplitude: float
    current_phase: float
    step: float
    cycles: int
    y: np.ndarray  # complex harmonics 1..K of y, [m]
    y_var: np.ndarray  # variance of each real component, [m^2]
    b: np.ndarray | None  # complex harmonics 1..K of B, [T]; None without a sense voltage
    b_var: np.ndarray | None
    offset_slope: float  # d(mean y)/dt, [m/s]
    offset_slope_var: float
    y1_slope: complex  # d Y_1 / dt, [m/s]
    y1_slope_var: float
    flux_density_amplitude: float  # B_m = |B_1|, [T]
    flux_density_stderr: float
    noise_y: float  # per-sample standard deviation of y, [m]
    noise_e: float | None  # per-sample standard deviation of E, [V]; None without E
    time: np.ndarray  # samples used (after the transient), [s]
    displacement: np.ndarray
    current: np.ndarray
    t_start: float
    t_mid: float
    y_prop_var: np.ndarray = field(default=None)  # B_m error carried into y, [m^2]
    #: where B_m comes from: "sense_voltage" (eq 22) or "displacement" (eq 19, from y's
    #: fundamental as smeha.identify does); without a sense voltage B is not a feature
    flux_density_source: str = "sense_voltage"
    #: without B: M_1/H_m that y's fundamental gives through the paper's mechanics,
    #: (mu' - 1) - j mu'' of smeha.identify.flux_density_from_displacement, [-]
    magnetization_ratio: complex | None = None

    @property
    def has_b(self) -> bool:
        """True when B's harmonics are features (the run has a sense voltage)."""
        return self.b is not None

    @property
    def angular_frequency(self):
        return 2.0 * math.pi * self.frequency

    def phase(self, time):
        """theta at ``time``, [rad]."""
        return self.angular_frequency * np.asarray(time) + self.current_phase


def _basis(t, w, harmonics, t_mid):
    tau = t - t_mid
    cols = [np.ones_like(t), tau]
    for k in range(1, harmonics + 1):
        cols += [np.cos(k * w * t), np.sin(k * w * t)]
    cols += [tau * np.cos(w * t), tau * np.sin(w * t)]
    return np.column_stack(cols)


def _cycle_noise(t, x, f, t0, cycles):
    """Per-sample noise: scatter at equal phase about a line over the cycle index."""
    span = 1.0 / f
    h = float(np.median(np.diff(t)))
    per = span / h
    n_per = int(round(per))
    if abs(per - n_per) < 1e-6 * per and n_per >= 8:
        k0 = int(np.searchsorted(t, t0 - 1e-9 * span))
        rows = x[k0:k0 + cycles * n_per]
        if rows.size == cycles * n_per:
            mat = rows.reshape(cycles, n_per)
        else:
            mat = None
    else:
        mat = None
    if mat is None:  # not an integer number of samples a period: interpolate
        grid = (np.arange(cycles)[:, None] + np.arange(256)[None, :] / 256.0) * span + t0
        mat = np.interp(grid.ravel(), t, x).reshape(cycles, 256)
    c = np.arange(mat.shape[0], dtype=float)
    c -= c.mean()
    mean = mat.mean(axis=0)
    slope = (c @ mat) / (c @ c)
    res = mat - mean[None, :] - c[:, None] * slope[None, :]
    dof = (mat.shape[0] - 2) * mat.shape[1]
    return math.sqrt(float((res * res).sum()) / dof)


def run_features(run: Run, params: gmt.TransducerParameters | None = None,
                 harmonics: int = HARMONICS) -> RunFeatures:
    """Reduce a run to its features (module docstring, step 1).

    Without a sense voltage the run has no B features (``b`` is None) and B_m
    comes from y's fundamental over the same cycles, as
    :func:`smeha.identify.flux_density_from_displacement` gives it (eq 19).

    Raises
    ------
    DataError
        With fewer than :data:`MIN_CYCLES` whole cycles after the first, or a
        B_m from the displacement that is not positive.
    """
    params = params or gmt.TransducerParameters()
    f = float(run.frequency)
    w = 2.0 * math.pi * f
    t = np.asarray(run.time, dtype=float)
    h = float(np.median(np.diff(t)))
    t_start = float(t[0])
    # current fundamental: I = I_m e^{j phi}
    bi = _basis(t, w, 3, float(t.mean()))[:, :8]
    ci, *_ = np.linalg.lstsq(bi, run.current, rcond=None)
    i1 = complex(ci[2], -ci[3])
    im, phi = abs(i1), math.atan2(i1.imag, i1.real)
    if not im > 0:
        raise DataError(f"{run.where()}: the current has no fundamental at {f:g} Hz",
                        run.source, run.name)
    span = (t[-1] - t[0] + h) * f
    cycles = int(math.floor(span + 1e-6)) - TRANSIENT_CYCLES
    if cycles < MIN_CYCLES:
        raise DataError(f"{run.where()}: {span:.3g} periods; diagnose needs at least "
                        f"{MIN_CYCLES + TRANSIENT_CYCLES} whole periods (the first is "
                        "discarded)", run.source, run.name)
    t0 = t_start + TRANSIENT_CYCLES / f
    t1 = t0 + cycles / f
    mask = (t >= t0 - 1e-9 / f) & (t < t1 - 1e-9 / f)
    ts, ys = t[mask], run.displacement[mask]
    t_mid = float(ts.mean())
    basis = _basis(ts, w, harmonics, t_mid)
    gram_inv = np.linalg.pinv(basis.T @ basis)
    cy, *_ = np.linalg.lstsq(basis, ys, rcond=None)
    noise_y = _cycle_noise(t, run.displacement, f, t0, cycles)
    k = np.arange(1, harmonics + 1)
    rot = np.exp(-1j * k * phi)
    yk = (cy[2:2 + 2 * harmonics:2] - 1j * cy[3:3 + 2 * harmonics:2]) * rot
    diag = np.diag(gram_inv)
    dvar = 0.5 * (diag[2:2 + 2 * harmonics:2] + diag[3:3 + 2 * harmonics:2])
    if run.sense_voltage is not None:
        es = run.sense_voltage[mask]
        ce, *_ = np.linalg.lstsq(basis, es, rcond=None)
        noise_e = _cycle_noise(t, run.sense_voltage, f, t0, cycles)
        ek = (ce[2:2 + 2 * harmonics:2] - 1j * ce[3:3 + 2 * harmonics:2]) * rot
        na = params.sense_turns * params.sense_area
        bk = 1j * ek / (k * w * na)
        b_var = noise_e ** 2 * dvar / (k * w * na) ** 2
        bm, se_b, source = float(abs(bk[0])), float(math.sqrt(b_var[0])), "sense_voltage"
    else:
        # no B: B_m from y's fundamental (eq 19), as smeha.identify does
        bk = b_var = noise_e = None
        bm, se_b, mu_r, mu_i = flux_density_from_displacement(run, params, mask, h)
        bm, se_b, source = float(bm), float(se_b), "displacement"
        ratio = complex(mu_r - 1.0, -mu_i)
        if not (bm > 0 and math.isfinite(bm)):
            raise DataError(f"{run.where()}: B_m = {bm:g} T from the displacement's "
                            "fundamental is not positive (no sense voltage)",
                            run.source, run.name)
    if run.sense_voltage is not None:
        ratio = None
    y1s = complex(cy[-2], -cy[-1]) * np.exp(-1j * phi)
    return RunFeatures(
        name=run.name, frequency=f, current_amplitude=im, current_phase=phi, step=h,
        cycles=cycles, y=yk, y_var=noise_y ** 2 * dvar, b=bk, b_var=b_var,
        offset_slope=float(cy[1]), offset_slope_var=noise_y ** 2 * float(diag[1]),
        y1_slope=y1s, y1_slope_var=noise_y ** 2 * 0.5 * float(diag[-1] + diag[-2]),
        flux_density_amplitude=bm, flux_density_stderr=se_b,
        noise_y=noise_y, noise_e=noise_e, time=ts, displacement=ys,
        current=run.current[mask], t_start=t_start, t_mid=t_mid,
        flux_density_source=source, magnetization_ratio=ratio)


# ================================================================== models


def _mu_imag(loss, f, bm, hm):
    """mu'' of eq 16 (eqs 7, 9, 11 and 14) for loss = (K_h, n, K_e, K_ex), [-]."""
    kh, n, ke, kex = loss
    p = kh * bm ** n * f + ke * (bm * f) ** 2 + kex * (bm * f) ** 1.5
    return p / (math.pi * f * MU_0 * hm * hm)


@dataclass(frozen=True)
class Candidate:
    """A model: the paper's (``cause = "none"``) or the paper's plus one extension.

    ``names`` are the extension's own parameters (internal units, mapped to SI
    by :func:`physical_parameters`); ``starts`` several start vectors (the fit
    keeps the best), ``lower``/``upper`` their bounds. ``form`` names the
    formulation when a cause has several (:data:`FORMS`); "" is the cause's
    first.
    """

    cause: str
    names: tuple = ()
    starts: tuple = ((),)
    lower: tuple = ()
    upper: tuple = ()
    form: str = ""

    @property
    def n_params(self):
        return len(self.names)

    @property
    def label(self):
        return _label(self.cause, self.form)


#: Formulations of the causes that have more than one (the first is the default):
#: the eddy currents as a lumped lag, or as diffusion into a lamination (slab) or a
#: solid rod (cylinder); the mechanics with one re-identified DOF, or two masses.
FORMS = {
    "eddy_current_diffusion": ("lag", "slab", "cylinder"),
    "mechanical_resonance": ("one_dof", "two_dof"),
}


def _form(cause, form):
    """The form's name, "" (the default) resolved to the cause's first."""
    forms = FORMS.get(cause, ("",))
    if not form:
        return forms[0]
    if form not in forms:
        raise ValueError(f"form {form!r} is not one of {forms} for {cause}")
    return form


def _label(cause, form):
    """Display name: the cause, with its form when it has several."""
    if cause not in FORMS:
        return cause
    return f"{cause} ({_form(cause, form)})"


def candidates(all_forms: bool = False) -> tuple:
    """The paper's model and the candidate extensions, internal parametrisation.

    By default one candidate per cause, its first form (:data:`FORMS`); with
    ``all_forms`` every form, as :func:`diagnose` fits them.
    """
    first = _first_forms()
    if not all_forms:
        return first
    return first + (
        Candidate("eddy_current_diffusion", ("log10_tau",), ((-4.0,), (-3.0,), (-2.0,)),
                  (-7.0,), (0.0,), form="slab"),
        Candidate("eddy_current_diffusion", ("log10_tau",), ((-4.0,), (-3.0,), (-2.0,)),
                  (-7.0,), (0.0,), form="cylinder"),
        Candidate("mechanical_resonance", ("m2/m", "log10_f_joint_Hz", "zeta_joint"),
                  ((0.5, 2.7, 0.1), (0.3, 3.0, 0.3), (0.7, 2.4, 0.05)),
                  (0.02, 1.5, 0.005), (0.98, 4.5, 3.0), form="two_dof"),
    )


def _first_forms() -> tuple:
    return (
        Candidate("none"),
        Candidate("rate_independent_hysteresis",
                  tuple(f"w_{k + 1}" for k in range(len(PLAY_THRESHOLDS))),
                  ((0.5,) * len(PLAY_THRESHOLDS), (0.05,) * len(PLAY_THRESHOLDS)),
                  (0.0,) * len(PLAY_THRESHOLDS), (100.0,) * len(PLAY_THRESHOLDS)),
        Candidate("magnetization_saturation", ("M_b/M_s",), ((0.3,), (0.6,)), (1e-3,), (0.97,)),
        Candidate("eddy_current_diffusion", ("log10_tau", "order"),
                  ((-4.0, 0.5), (-3.0, 1.0), (-2.5, 0.5)), (-6.0, 0.3), (-1.0, 1.0),
                  form="lag"),
        Candidate("transport_delay", ("tau_ms",), ((0.05,), (1.0,)), (0.0,), (20.0,)),
        Candidate("mechanical_resonance", ("m/m0", "c/c0", "K/K0"),
                  ((1.0, 1.0, 1.0), (3.0, 0.5, 1.0), (0.5, 2.0, 1.0)),
                  (0.02, 0.02, 0.3), (50.0, 50.0, 3.0), form="one_dof"),
        Candidate("thermal_drift", ("offset_rate_um_per_A2s", "gain_rate_pct_per_A2s",
                                    "log10_time_constant_s"),
                  ((0.0, 0.0, 0.0), (0.0, 0.0, 2.0)),
                  (-np.inf, -np.inf, -1.5), (np.inf, np.inf, 3.0)),
    )


def physical_parameters(cause, extra, context, form="") -> dict:
    """The extension's parameters in SI (for the report)."""
    x = list(extra)
    p = context["params"]
    form = _form(cause, form)
    if form in ("slab", "cylinder"):
        tau = 10.0 ** x[0]
        # the skin depth equals the half thickness or radius at w tau = 2
        return {"time_constant_s": tau, "skin_depth_equals_size_at_Hz": 1.0 / (math.pi * tau)}
    if form == "two_dof":
        m = _two_mass(p, x)
        return {"rod_mass_kg": m.rod_mass, "output_mass_kg": m.output_mass,
                "joint_stiffness_N_per_m": m.joint_stiffness,
                "joint_damping_N_s_per_m": m.joint_damping,
                "joint_frequency_Hz": 10.0 ** x[1], "joint_damping_ratio": x[2]}
    if cause == "rate_independent_hysteresis":
        return {"thresholds_A_per_m": list(context["thresholds"]),
                "weights": [0.1 * v for v in x]}
    if cause == "magnetization_saturation":
        return {"saturation_magnetization_A_per_m": p.bias_magnetization / x[0]}
    if cause == "eddy_current_diffusion":
        return {"time_constant_s": 10.0 ** x[0], "order": x[1]}
    if cause == "transport_delay":
        return {"delay_s": x[0] * 1e-3}
    if cause == "mechanical_resonance":
        return {"mass_kg": p.mass * x[0], "damping_N_s_per_m": p.damping * x[1],
                "stiffness_N_per_m": p.stiffness * x[2]}
    if cause == "thermal_drift":
        return {"offset_rate_m_per_A2s": x[0] * 1e-6, "gain_rate_per_A2s": x[1] * 1e-2,
                "thermal_time_constant_s": 10.0 ** x[2]}
    return {}


def _two_mass(params, extra):
    """The two-mass mechanics of the ``two_dof`` form: eq 27's m, c, K with the output's
    share m_2/m, the joint's frequency 10^x [Hz] and damping ratio."""
    return ext.TwoMassMechanics.from_joint(params.mass, params.damping, params.stiffness,
                                           extra[0], 10.0 ** extra[1], extra[2])


class _Evaluator:
    """Periodic steady state of a candidate for a run's features (module docstring)."""

    def __init__(self, params, thresholds, harmonics=HARMONICS, grid=GRID):
        self.params = params
        self.thresholds = tuple(thresholds)
        self.k = np.arange(1, harmonics + 1)
        self.grid = grid
        self.theta = 2.0 * np.pi * np.arange(grid) / grid
        self._mech = {}
        self._two = {}

    def mechanics(self, m, c, kk, w, h):
        key = (m, c, kk, w, h)
        g = self._mech.get(key)
        if g is None:
            g = ext.zoh_frequency_response(m, c, kk, self.k * w, h)
            if len(self._mech) < 4096:
                self._mech[key] = g
        return g

    def two_mass(self, extra):
        """The ``two_dof`` form's mechanics, one object per parameter vector (all runs)."""
        key = tuple(extra)
        sys2 = self._two.get(key)
        if sys2 is None:
            if len(self._two) >= 256:
                self._two.clear()
            sys2 = self._two[key] = _two_mass(self.params, key)
        return sys2

    def predict(self, rf: RunFeatures, loss, cause="none", extra=(), flux=None, form=""):
        """(Y_k [m], B_k [T], offset slope [m/s], Y_1 slope [m/s]) of the model.

        The magnetisation's fundamental M_1 (referred to the current's phase) is
        the paper's (mu - 1) H_m, or the eddy forms' field inside the rod. While M
        is that sinusoid, the force of eqs 25 and 28, A_r E^H K_lambda (M_b + M)^2,
        has a mean and two harmonics, F_1 = 2 c M_b M_1 and F_2 = c M_1^2 / 2
        (c = A_r E^H K_lambda; harmonic balance, as gmt.forward.strain_harmonics).
        Hysteresis and saturation add harmonics to M, so with them M and the
        force are sampled over one period and their harmonics taken by FFT.
        """
        p = self.params
        form = _form(cause, form)
        f, w = rf.frequency, rf.angular_frequency
        hm = p.field_per_ampere * rf.current_amplitude
        if form == "one_dof":
            g = ext.zoh_frequency_response(p.mass * extra[0], p.damping * extra[1],
                                           p.stiffness * extra[2], self.k * w, rf.step)
        elif form == "two_dof":
            g = self.two_mass(extra).response(self.k * w, rf.step)
        else:
            g = self.mechanics(p.mass, p.damping, p.stiffness, w, rf.step)
        if flux is not None:
            bm = flux
        elif getattr(rf, "magnetization_ratio", None) is None:  # B_m measured (eq 22)
            bm = rf.flux_density_amplitude
        else:  # no sense voltage: B_m from y through this candidate's path
            bm = self._flux_from_y(rf, g[0], cause, extra, form)
        mod = bm / (MU_0 * hm)
        c_force = p.rod_area * p.youngs_modulus * p.magnetostriction_coefficient
        mb = p.bias_magnetization
        kk = self.k.size
        fk = np.zeros(kk, complex)
        mk = np.zeros(kk, complex)
        b1 = None
        if form == "lag":
            mu_i = min(_mu_imag(loss, f, bm, hm), 0.999 * mod)
            g1 = complex(ext.EddyCurrentLag(10.0 ** extra[0], extra[1]).transfer(w))
            mu_r = ext.eddy_calibrated_permeability(bm, hm, mu_i, g1)
            if not math.isfinite(mu_r):
                mu_r = 1.0
            mu_c = complex(mu_r, -mu_i)
            m1 = (mu_c - 1.0) * g1 * hm
            b1 = MU_0 * mu_c * g1 * hm  # B = mu_0 mu H_in, H_in = g H
            f2 = 0.5 * c_force * m1 * m1
        elif form in ("slab", "cylinder"):
            m1, f2, b1 = self._diffusion(loss, f, w, bm, hm, form, extra[0])
        else:
            mu_i = min(_mu_imag(loss, f, bm, hm), 0.999 * mod)
            mu_r = math.sqrt(mod * mod - mu_i * mu_i)
            m1 = complex(mu_r - 1.0, -mu_i) * hm
            f2 = 0.5 * c_force * m1 * m1
        if cause in ("rate_independent_hysteresis", "magnetization_saturation"):
            th = self.theta
            m = np.real(m1 * np.exp(1j * th))
            if cause == "rate_independent_hysteresis":
                pi_op = ext.PrandtlIshlinskii(self.thresholds, tuple(0.1 * v for v in extra))
                m = m + ext.harmonic_remainder(pi_op.periodic(hm, th))
            else:
                sat = ext.SoftSaturation(p.bias_magnetization / extra[0], p.bias_magnetization)
                m = m + ext.harmonic_remainder(sat.magnetization(m) - m)
            n = self.grid
            fk = np.fft.rfft(c_force * (mb + m) ** 2)[self.k] * (2.0 / n)
            mk = np.fft.rfft(m)[self.k] * (2.0 / n)
        else:
            fk[0] = 2.0 * c_force * mb * m1
            fk[1] = f2
            mk[0] = m1
        y = fk * g
        if cause == "transport_delay":
            y = y * ext.TransportDelay(extra[0] * 1e-3).factor(self.k * w)
        hk = np.zeros(kk, complex)
        hk[0] = hm
        b = MU_0 * (hk + mk)
        if b1 is not None:
            b[0] = b1
        s_off, s_y1 = 0.0, 0.0j
        if cause == "thermal_drift":
            # the features' slope is the least-squares slope of the dose over the samples
            u = self._drift(extra).dose(rf.time - rf.t_start, rf.current_amplitude)
            tau = rf.time - rf.t_mid
            slope = float(tau @ (u - u.mean()) / (tau @ tau))
            s_off = extra[0] * 1e-6 * slope
            s_y1 = extra[1] * 1e-2 * slope * y[0]
        return y, b, s_off, s_y1

    def _flux_from_y(self, rf, g1, cause, extra, form):
        """B_m of a run without B, through the candidate's own path from M_1 to y, [T].

        rf.magnetization_ratio is M_1/H_m as y's fundamental gives it through the
        paper's mechanics G (:func:`smeha.identify.flux_density_from_displacement`);
        with the paper's model this returns that function's B_m (eq 19). A
        candidate that changes the path (mechanics g1, a delay) divides by its
        ratio to the paper's, and the eddy forms, where M_1 = (mu - 1) <g> H_m and
        B_1 = mu_0 mu <g> H_m, give B_m = mu_0 H_m |M_1/H_m + <g>|. Otherwise the
        measured B_m would carry the very effect the candidate describes.
        """
        p, w = self.params, rf.angular_frequency
        hm = p.field_per_ampere * rf.current_amplitude
        g0 = self.mechanics(p.mass, p.damping, p.stiffness, w, rf.step)[0]
        path = complex(g1 / g0)
        if cause == "transport_delay":
            path *= complex(np.ravel(ext.TransportDelay(extra[0] * 1e-3).factor(w))[0])
        m = rf.magnetization_ratio / path
        if form == "lag":
            gin = complex(ext.EddyCurrentLag(10.0 ** extra[0], extra[1]).transfer(w))
        elif form in ("slab", "cylinder"):
            gin = complex(ext.EddyCurrentDiffusion(10.0 ** extra[0], form).transfer(w))
        else:
            gin = 1.0
        return MU_0 * hm * abs(m + gin)

    def _diffusion(self, loss, f, w, bm, hm, geometry, log10_tau):
        """M_1, the force's F_2 and B_1 with the field diffusing into the rod.

        ext.EddyCurrentDiffusion: H_in(x) = g(x) H, M(x) = (mu - 1) H_in(x) and
        B(x) = mu_0 mu H_in(x) locally. The coil sees the mean, B_1 = mu_0 mu <g> H_m,
        and mu is the material's at the applied field: its flux density amplitude
        at the surface, B_s = B_m / |<g>|, enters eq 16 for mu'', and
        |mu| = B_s / (mu_0 H_m) (eq 20). Magnetostriction is local and the section
        moves as one, so the force is A_r E^H K_lambda <(M_b + M(x))^2> (eqs 25, 28):
        with M_s = (mu - 1) H_m at the surface, its fundamental is 2 c M_b <g> M_s and
        its second harmonic c M_s^2 <g^2> / 2 (the mean, with <|g|^2>, does not
        reach the features).
        """
        dif = ext.EddyCurrentDiffusion(10.0 ** log10_tau, geometry)
        g1 = complex(dif.transfer(w))
        g_sq = complex(dif.mean_squares(w)[0])
        b_surface = bm / abs(g1)
        mod = b_surface / (MU_0 * hm)
        mu_i = min(_mu_imag(loss, f, b_surface, hm), 0.999 * mod)
        mu_c = complex(math.sqrt(mod * mod - mu_i * mu_i), -mu_i)
        ms = (mu_c - 1.0) * hm
        p = self.params
        c_force = p.rod_area * p.youngs_modulus * p.magnetostriction_coefficient
        return ms * g1, 0.5 * c_force * ms * ms * g_sq, MU_0 * mu_c * g1 * hm

    @staticmethod
    def _drift(extra):
        return ext.LinearDrift(extra[0] * 1e-6, extra[1] * 1e-2, 10.0 ** extra[2])

    def residuals(self, rf: RunFeatures, loss, cause="none", extra=(), form=""):
        """Model minus data over each feature's standard deviation.

        y's harmonics, B's (only when the run has them, :attr:`RunFeatures.has_b`),
        then the three drift features.
        """
        y, b, s_off, s_y1 = self.predict(rf, loss, cause, extra, form=form)
        sy = np.sqrt(rf.y_var + (rf.y_prop_var if rf.y_prop_var is not None else 0.0))
        dy = (y - rf.y) / sy
        ds = (s_y1 - rf.y1_slope) / math.sqrt(rf.y1_slope_var)
        parts = [dy.real, dy.imag]
        if rf.has_b:
            db = (b - rf.b) / np.sqrt(rf.b_var)
            parts += [db.real, db.imag]
        parts.append([(s_off - rf.offset_slope) / math.sqrt(rf.offset_slope_var),
                      ds.real, ds.imag])
        return np.concatenate(parts)

    def n_features(self, rf) -> tuple:
        """Number of features of y, of B (0 without a sense voltage), of the drift."""
        return 2 * self.k.size, 2 * self.k.size * rf.has_b, 3

    def parts(self, rf, loss, cause="none", extra=(), form=""):
        """chi^2 of y (harmonics), of B (0 without B), of the drift features."""
        r = self.residuals(rf, loss, cause, extra, form)
        ny, nb, _ = self.n_features(rf)
        ry, rb, rd = r[:ny], r[ny:ny + nb], r[ny + nb:]
        return float(ry @ ry), float(rb @ rb), float(rd @ rd)

    def samples(self, rf: RunFeatures, loss, cause="none", extra=(), form=""):
        """Model y at the run's samples, best constant offset fitted, [m]."""
        y, _, _, _ = self.predict(rf, loss, cause, extra, form=form)
        th = rf.phase(rf.time)
        out = np.zeros_like(rf.time)
        for k, yk in zip(self.k, y):
            out += np.real(yk * np.exp(1j * k * th))
        if cause == "thermal_drift":
            out = self._drift(extra).apply(out, rf.time - rf.t_start, rf.current_amplitude)
        return out + float(np.mean(rf.displacement - out))


# ================================================================== fitting

LOSS_LOWER = (0.0, 1.0, 0.0, 0.0)
LOSS_UPPER = (np.inf, 3.0, np.inf, np.inf)


@dataclass
class Fit:
    """A candidate fitted on the training runs and scored on the held-out runs."""

    cause: str
    loss: tuple
    extra: tuple
    n_params: int
    train_chi2: float
    train_n: int
    heldout_chi2: float
    heldout_n: int
    heldout_chi2_y: float
    heldout_chi2_b: float
    heldout_chi2_drift: float
    heldout_rms: float
    score: float
    parameters: dict
    form: str = ""

    @property
    def heldout_excess(self):
        return self.heldout_chi2 - self.heldout_n

    @property
    def label(self):
        return _label(self.cause, self.form)


def _loss_scale(loss0):
    return np.array([max(abs(loss0[0]), 1.0), 1.0, max(abs(loss0[2]), 1.0),
                     max(abs(loss0[3]), 1.0)])


def fit_candidate(ev: _Evaluator, train, cand: Candidate, loss0) -> tuple:
    """Least squares on the training features: (loss, extra, chi^2)."""
    scale = _loss_scale(loss0)
    l0 = np.clip(np.asarray(loss0, float), LOSS_LOWER, LOSS_UPPER) / scale
    l0[1] = min(max(loss0[1], 1.0 + 1e-6), 3.0 - 1e-6)
    lo = np.concatenate(([0.0, 1.0, 0.0, 0.0], cand.lower)).astype(float)
    hi = np.concatenate(([np.inf, 3.0, np.inf, np.inf], cand.upper)).astype(float)
    nl = 4

    def fun(x):
        loss = tuple(x[:nl] * np.array([scale[0], 1.0, scale[2], scale[3]]))
        return np.concatenate([ev.residuals(rf, loss, cand.cause, tuple(x[nl:]), cand.form)
                               for rf in train])

    best = None
    for start in cand.starts:
        x0 = np.concatenate((l0, np.asarray(start, float)))
        pad = 1e-9 * (1.0 + np.abs(np.where(np.isfinite(lo), lo, 0.0)))
        x0 = np.minimum(np.maximum(x0, lo + pad), np.where(np.isfinite(hi), hi - pad, np.inf))
        try:
            sol = least_squares(fun, x0, bounds=(lo, hi), x_scale="jac", max_nfev=400,
                                xtol=1e-10, ftol=1e-10)
        except (ValueError, gmt.ParameterError, FloatingPointError):
            continue
        if best is None or sol.cost < best.cost:
            best = sol
    x = best.x
    loss = tuple(float(v) for v in x[:nl] * np.array([scale[0], 1.0, scale[2], scale[3]]))
    return loss, tuple(float(v) for v in x[nl:]), float(2.0 * best.cost), int(best.fun.size)


def _score(ev, cand, loss, extra, chi2_train, n_train, heldout, context) -> Fit:
    chi_y = chi_b = chi_d = 0.0
    n = 0
    sq = 0.0
    ns = 0
    for rf in heldout:
        a, b, d = ev.parts(rf, loss, cand.cause, extra, cand.form)
        chi_y, chi_b, chi_d = chi_y + a, chi_b + b, chi_d + d
        n += sum(ev.n_features(rf))
        r = rf.displacement - ev.samples(rf, loss, cand.cause, extra, cand.form)
        sq += float(r @ r)
        ns += r.size
    chi = chi_y + chi_b + chi_d
    score = chi + cand.n_params * math.log(max(n, 2))
    return Fit(cause=cand.cause, loss=loss, extra=extra, n_params=cand.n_params,
               train_chi2=chi2_train, train_n=n_train, heldout_chi2=chi, heldout_n=n,
               heldout_chi2_y=chi_y, heldout_chi2_b=chi_b, heldout_chi2_drift=chi_d,
               heldout_rms=math.sqrt(sq / max(ns, 1)), score=score,
               parameters=physical_parameters(cand.cause, extra, context, cand.form),
               form=_form(cand.cause, cand.form))


# ================================================================== holdout


def default_holdout(runs) -> list[str]:
    """Names of the default held-out runs (module docstring)."""
    freqs = sorted({float(r.frequency) for r in runs})
    if len(freqs) >= 5:
        chosen = {freqs[(len(freqs) - 1) // 2], freqs[-2]}
    elif len(freqs) >= 3:
        chosen = {freqs[(len(freqs) - 1) // 2]}
    else:
        raise ValueError(f"{len(freqs)} distinct frequencies: the default hold-out needs at "
                         "least 3; name the held-out runs (holdout=...)")
    return [r.name for r in runs if float(r.frequency) in chosen]


# ================================================================== characterisation


def _synth(harm, theta):
    k = np.arange(1, len(harm) + 1)
    return np.real(np.exp(1j * np.outer(theta, k)) @ harm)


def characterise(ev: _Evaluator, feats, loss) -> dict:
    """Residual structure of the paper's model over all runs (module docstring, step 3)."""
    theta = ev.theta
    falling = theta < np.pi  # i = I_m cos(theta) falls on (0, pi)
    rows = []
    for rf in feats:
        y, b, _, _ = ev.predict(rf, loss)
        ry = rf.y - y
        rb = rf.b - b if rf.has_b else None
        r = _synth(ry, theta)
        sy = math.sqrt(float(np.sum(rf.y_var)))  # noise of the periodic residual (RMS-ish)
        data = _synth(rf.y, theta)
        opening = float(_synth(rf.y, np.array([np.pi / 2]))[0]
                        - _synth(rf.y, np.array([3 * np.pi / 2]))[0])
        cy_y, cy_b, cy_d = ev.parts(rf, loss)
        n_y, n_b, n_d = ev.n_features(rf)
        rows.append({
            "run": rf.name, "frequency_Hz": rf.frequency,
            "current_amplitude_A": rf.current_amplitude,
            "flux_density_source": rf.flux_density_source,
            "noise_um": rf.noise_y * 1e6,
            "periodic_residual_rms_um": float(np.sqrt(np.mean(r * r))) * 1e6,
            "periodic_noise_rms_um": sy * 1e6,
            "falling_rms_um": float(np.sqrt(np.mean(r[falling] ** 2))) * 1e6,
            "rising_rms_um": float(np.sqrt(np.mean(r[~falling] ** 2))) * 1e6,
            "y_residual_harmonics_um": [float(abs(v)) * 1e6 for v in ry[:3]],
            "y_residual_phases_deg": [math.degrees(float(np.angle(v))) for v in ry[:3]],
            # the B entries are None for a run without a sense voltage
            "b_residual_harmonics_mT": ([float(abs(v)) * 1e3 for v in rb[:3]]
                                        if rf.has_b else None),
            "y_extra_lag_deg": math.degrees(float(np.angle(y[0] / rf.y[0]))),
            "y_gain_ratio": float(abs(rf.y[0]) / abs(y[0])),
            "b_extra_lag_deg": (math.degrees(float(np.angle(b[0] / rf.b[0])))
                                if rf.has_b else None),
            "y3_over_y1_pct": 100.0 * float(abs(rf.y[2]) / abs(rf.y[0])),
            "b3_over_b1_pct": (100.0 * float(abs(rf.b[2]) / abs(rf.b[0]))
                               if rf.has_b else None),
            "loop_opening_um": opening * 1e6,
            "loop_opening_rel": opening / float(np.ptp(data)),
            "offset_drift_um_per_s": rf.offset_slope * 1e6,
            "offset_drift_z": rf.offset_slope / math.sqrt(rf.offset_slope_var),
            "gain_drift_per_s": float((rf.y1_slope / rf.y[0]).real),
            "gain_drift_z": float((rf.y1_slope * np.conj(rf.y[0]) / abs(rf.y[0])).real
                                  / math.sqrt(rf.y1_slope_var)),
            "chi2_y": cy_y, "chi2_b": cy_b, "chi2_drift": cy_d,
            "n_y": n_y, "n_b": n_b, "n_drift": n_d,
        })
    # loop opening against f, at the largest amplitude
    amps = sorted({round(r["current_amplitude_A"], 2) for r in rows})
    top = [r for r in rows if round(r["current_amplitude_A"], 2) == amps[-1]]
    top.sort(key=lambda r: r["frequency_Hz"])
    f = np.array([r["frequency_Hz"] for r in top])
    o = np.array([r["loop_opening_rel"] for r in top])
    law = {}
    if f.size >= 3:
        for name, x in (("linear", f), ("sqrt", np.sqrt(f))):
            a = np.column_stack((np.ones_like(x), x))
            coef, *_ = np.linalg.lstsq(a, o, rcond=None)
            law[name] = {"intercept": float(coef[0]), "slope": float(coef[1]),
                         "rms": float(np.sqrt(np.mean((a @ coef - o) ** 2)))}
    # extra lag of y against f: through the origin (a delay) or not
    lag = np.array([math.radians(r["y_extra_lag_deg"]) for r in rows])
    fr = np.array([r["frequency_Hz"] for r in rows])
    tau = float((fr @ lag) / (2 * np.pi * (fr @ fr)))
    return {"runs": rows, "opening_vs_f": law,
            "opening_lowest_f_rel": float(o[0]) if o.size else None,
            "opening_highest_f_rel": float(o[-1]) if o.size else None,
            "y_lag_as_delay_s": tau,
            "y_lag_as_delay_rms_deg": math.degrees(float(np.sqrt(np.mean(
                (lag - 2 * np.pi * fr * tau) ** 2))))}


# ================================================================== the workflow


@dataclass
class Diagnosis:
    """Result of :func:`diagnose`."""

    cause: str
    evidence: list
    heldout_runs: list
    training_runs: list
    paper: Fit
    extended: Fit
    fits: list
    noise_um: float
    characterisation: dict
    context: dict = field(repr=False, default=None)
    #: other causes the held-out data do not separate from the named one (:func:`also_consistent`)
    also_consistent: list = field(default_factory=list)

    @property
    def runs_without_sense_voltage(self) -> list:
        """Names of the runs without a sense voltage (B_m from the displacement)."""
        return [name for name, rf in self.context["features"].items() if not rf.has_b]

    def sense_voltage_report(self) -> dict:
        """What the missing sense voltage leaves undetermined (``sense_voltage`` in JSON)."""
        without = self.runs_without_sense_voltage
        return {"runs_without": without,
                "flux_density_source": {name: rf.flux_density_source
                                        for name, rf in self.context["features"].items()},
                "hard_to_separate": [list(p) for p in CONFUSABLE_WITHOUT_B] if without else []}

    @property
    def gain(self):
        return self.paper.heldout_rms / self.extended.heldout_rms

    def as_dict(self) -> dict:
        """JSON-able report (the ``--json`` output)."""
        def fitd(fit):
            return {"cause": fit.cause, "form": fit.form,
                    "heldout_rms_um": fit.heldout_rms * 1e6,
                    "score": fit.score, "heldout_chi2": fit.heldout_chi2,
                    "heldout_n": fit.heldout_n,
                    "heldout_chi2_y": fit.heldout_chi2_y, "heldout_chi2_b": fit.heldout_chi2_b,
                    "heldout_chi2_drift": fit.heldout_chi2_drift,
                    "train_chi2": fit.train_chi2, "train_n": fit.train_n,
                    "added_parameters": fit.n_params, "parameters": fit.parameters,
                    "loss_coefficients": dict(zip(("K_h", "n", "K_e", "K_ex"), fit.loss))}
        return {
            "cause": self.cause,
            "form": self.extended.form,
            "evidence": list(self.evidence),
            "heldout_runs": list(self.heldout_runs),
            "training_runs": list(self.training_runs),
            "noise_um": self.noise_um,
            "heldout_rms_um": {"paper": self.paper.heldout_rms * 1e6,
                               "extended": self.extended.heldout_rms * 1e6},
            "gain": self.gain,
            "also_consistent": [{"cause": f.cause, "form": f.form, "score": f.score,
                                 "score_above_named": f.score - self.extended.score,
                                 "heldout_rms_um": f.heldout_rms * 1e6}
                                for f in self.also_consistent],
            "sense_voltage": self.sense_voltage_report(),
            "candidates": [fitd(f) for f in self.fits if f.cause != "none"],
            "paper": fitd(self.paper),
            "characterisation": self.characterisation,
            "decision_rule": {"within_noise_reduced_chi2": WITHIN_NOISE,
                              "min_bic_drop": MIN_BIC_DROP,
                              "min_explained_excess": MIN_EXPLAINED},
        }


def decide(paper: Fit, fits) -> tuple[str, Fit]:
    """The cause and the chosen model (module docstring, step 4)."""
    red_train = paper.train_chi2 / max(paper.train_n - 4, 1)
    red_ho = paper.heldout_chi2 / paper.heldout_n
    if red_train <= WITHIN_NOISE and red_ho <= WITHIN_NOISE:
        return "none", paper
    cands = [f for f in fits if f.cause != "none"]
    best = min(cands, key=lambda f: f.score)
    drop = paper.score - best.score
    excess = max(paper.heldout_excess, 1e-12)
    explained = 1.0 - max(best.heldout_excess, 0.0) / excess
    if drop > MIN_BIC_DROP and explained >= MIN_EXPLAINED:
        return best.cause, best
    return "unexplained", paper


def also_consistent(paper: Fit, fits, chosen: Fit) -> list:
    """Other causes the held-out data do not separate from the named one.

    The best form of each other cause that passes the same two tests as the
    named one (:func:`decide`) and whose score is within :data:`MIN_BIC_DROP`
    of the named one's: the data prefer the named cause, but not by the margin
    the rule asks of a name. The decision itself is unchanged. Empty for
    ``none`` and ``unexplained``.
    """
    if chosen.cause not in CAUSES:
        return []
    excess = max(paper.heldout_excess, 1e-12)
    best = {}
    for f in fits:
        if f.cause in ("none", chosen.cause):
            continue
        explained = 1.0 - max(f.heldout_excess, 0.0) / excess
        if (paper.score - f.score > MIN_BIC_DROP and explained >= MIN_EXPLAINED
                and f.score - chosen.score <= MIN_BIC_DROP):
            if f.cause not in best or f.score < best[f.cause].score:
                best[f.cause] = f
    return sorted(best.values(), key=lambda f: f.score)


def _propagate_flux_error(ev, feats, loss):
    """Carry each run's B_m error into the variance of its y harmonics."""
    for rf in feats:
        if not rf.has_b:
            # B_m comes from y's own fundamental: its error is y's noise, already counted
            rf.y_prop_var = np.zeros(rf.y.size)
            continue
        d = 1e-3 * rf.flux_density_amplitude
        y0 = ev.predict(rf, loss, flux=rf.flux_density_amplitude)[0]
        y1 = ev.predict(rf, loss, flux=rf.flux_density_amplitude + d)[0]
        rf.y_prop_var = 0.5 * (np.abs(y1 - y0) / d * rf.flux_density_stderr) ** 2


def diagnose(runs, holdout=None, params: gmt.TransducerParameters | None = None,
             causes=CAUSES) -> Diagnosis:
    """Fit, characterise, name the cause and measure the gain (module docstring).

    Parameters
    ----------
    runs : sequence of Run
        Measured runs with current and displacement, and the sense voltage
        where measured: a run without it is fitted on y alone, with B_m from
        y's fundamental (:func:`run_features`).
    holdout : sequence of str, optional
        Names of the held-out runs; default :func:`default_holdout`.
    params : TransducerParameters, optional
        Rod, coil, magnetostriction and mechanics (default Table 2); its loss
        coefficients are only the fallback start values.
    causes : sequence of str
        Candidates to try (default all six).

    Raises
    ------
    ValueError
        Unknown held-out names, too few training runs (fewer than 4: the four
        loss coefficients) or none held out; DataError for unusable runs.
    """
    from . import identify as identify_mod

    params = params or gmt.TransducerParameters()
    runs = list(runs)
    names = [r.name for r in runs]
    if len(set(names)) != len(names):
        raise ValueError("run names must be unique")
    holdout = list(holdout) if holdout else default_holdout(runs)
    unknown = [h for h in holdout if h not in names]
    if unknown:
        raise ValueError(f"held-out run(s) {', '.join(map(repr, unknown))} not in the data "
                         f"(runs: {', '.join(names)})")
    train_runs = [r for r in runs if r.name not in holdout]
    if len(train_runs) < 4:
        raise ValueError(f"{len(train_runs)} training run(s); the four loss coefficients of "
                         "eq 16 need at least 4 (hold out fewer runs)")
    unknown_c = [c for c in causes if c not in CAUSES]
    if unknown_c:
        raise ValueError(f"unknown cause(s) {unknown_c}; choose from {CAUSES}")
    feats = {r.name: run_features(r, params) for r in runs}
    train = [feats[r.name] for r in train_runs]
    held = [feats[h] for h in holdout]
    hmax = max(params.field_per_ampere * rf.current_amplitude for rf in feats.values())
    thresholds = tuple(c * hmax for c in PLAY_THRESHOLDS)
    ev = _Evaluator(params, thresholds)
    context = {"params": params, "thresholds": thresholds, "evaluator": ev, "features": feats}
    # start values of the loss coefficients: the paper's procedure (smeha.identify)
    try:
        ident = identify_mod.identify(train_runs, params)
        loss0 = ident.loss_fit.values if ident.loss_fit is not None else None
    except (ValueError, gmt.ParameterError):
        loss0 = None
    if loss0 is None or not all(math.isfinite(v) for v in loss0):
        loss0 = (params.hysteresis_coefficient, params.steinmetz_exponent,
                 params.eddy_coefficient, params.excess_coefficient)
    loss0 = (max(loss0[0], 0.0), loss0[1], max(loss0[2], 0.0), max(loss0[3], 0.0))
    _propagate_flux_error(ev, feats.values(), loss0)
    fits = []
    for cand in candidates(all_forms=True):
        if cand.cause != "none" and cand.cause not in causes:
            continue
        start = loss0 if cand.cause == "none" else fits[0].loss
        loss, extra, chi2, n = fit_candidate(ev, train, cand, start)
        fits.append(_score(ev, cand, loss, extra, chi2, n, held, context))
    paper = fits[0]
    cause, chosen = decide(paper, fits)
    character = characterise(ev, list(feats.values()), paper.loss)
    noise = float(np.median([rf.noise_y for rf in feats.values()])) * 1e6
    diag = Diagnosis(cause=cause, evidence=[], heldout_runs=holdout,
                     training_runs=[r.name for r in train_runs], paper=paper,
                     extended=chosen, fits=fits, noise_um=noise,
                     characterisation=character, context=context,
                     also_consistent=also_consistent(paper, fits, chosen))
    diag.evidence = _evidence(diag)
    return diag


# ================================================================== evidence


def _evidence(d: Diagnosis) -> list[str]:
    p, c = d.paper, d.characterisation
    rows = c["runs"]
    brows = [r for r in rows if r["b_residual_harmonics_mT"] is not None]  # runs with B
    without = d.runs_without_sense_voltage
    out = []
    if without:
        magnetic = ", ".join(k for k, v in SIGNALS.items() if v == "B and y")
        pairs = "; ".join(f"{a} vs {b}" for a, b in CONFUSABLE_WITHOUT_B)
        out.append(f"no sense voltage in {len(without)} of {len(rows)} runs "
                   f"({', '.join(without)}): B_m of those from y's fundamental (eq 19, as "
                   "smeha.identify), and only y's harmonics and drift are compared. Without B "
                   f"the magnetic causes, which change B and y together ({magnetic}), are "
                   "told from those that change y only by the shape of y alone; hard to tell "
                   f"apart: {pairs}")
    e_noise = [d.context["features"][r["run"]].noise_e for r in brows]
    out.append(f"noise (cycle-to-cycle scatter at equal phase): y {d.noise_um:.3g} um per "
               "sample (median over runs), sense voltage "
               + (f"{np.median(e_noise):.3g} V" if e_noise else "not measured"))
    ny = sum(r["n_y"] for r in rows)
    nb = sum(r["n_b"] for r in rows)
    nd = sum(r["n_drift"] for r in rows)
    cy = sum(r["chi2_y"] for r in rows)
    cb = sum(r["chi2_b"] for r in rows)
    cd = sum(r["chi2_drift"] for r in rows)
    b_text = f"{cb / nb:.3g} on B harmonics" if nb else "no B harmonics (no sense voltage)"
    out.append(f"paper's model, all runs: chi^2/n = {cy / ny:.3g} on y harmonics, "
               f"{b_text}, {cd / nd:.3g} on the drift terms "
               f"(1 = within noise); training reduced chi^2 "
               f"{p.train_chi2 / max(p.train_n - 4, 1):.3g}, held-out "
               f"{p.heldout_chi2 / p.heldout_n:.3g} (threshold {WITHIN_NOISE:g})")
    carriers = [name for name, v in (("y", cy / ny), ("B", cb / nb if nb else 0.0),
                                     ("drift of y", cd / nd))
                if v > WITHIN_NOISE]
    out.append("the discrepancy is carried by: " + (", ".join(carriers) if carriers
                                                     else "neither signal (within noise)"))
    res = np.array([r["periodic_residual_rms_um"] for r in rows])
    nse = np.array([r["periodic_noise_rms_um"] for r in rows])
    out.append(f"periodic residual RMS of y per run: {res.min():.3g} to {res.max():.3g} um "
               f"against a noise level of the averaged period of {nse.min():.2g} to "
               f"{nse.max():.2g} um")
    fall = np.array([r["falling_rms_um"] for r in rows])
    rise = np.array([r["rising_rms_um"] for r in rows])
    out.append(f"by branch: residual RMS falling current {np.mean(fall):.3g} um, rising "
               f"{np.mean(rise):.3g} um (mean over runs)")
    lo, hi = min(rows, key=lambda r: r["frequency_Hz"]), max(rows,
                                                              key=lambda r: r["frequency_Hz"])
    def bres(r):
        v = r["b_residual_harmonics_mT"]
        return "/".join(f"{x:.3g}" for x in v) if v is not None else "not measured"
    out.append(
        f"by harmonic (y residual, um, k = 1..3): {lo['run']} "
        + "/".join(f"{v:.3g}" for v in lo["y_residual_harmonics_um"])
        + f"; {hi['run']} " + "/".join(f"{v:.3g}" for v in hi["y_residual_harmonics_um"])
        + f"; B residual (mT): {bres(lo)} and {bres(hi)}")
    amps = sorted({round(r["current_amplitude_A"], 2) for r in rows})
    if len(amps) >= 2:
        def mean3(a, key):
            v = [r[key] for r in rows
                 if round(r["current_amplitude_A"], 2) == a and r[key] is not None]
            return float(np.mean(v)) if v else None

        b_lo, b_hi = mean3(amps[0], "b3_over_b1_pct"), mean3(amps[-1], "b3_over_b1_pct")
        b_part = (f"third harmonic of B: {b_lo:.3g} % of the fundamental at {amps[0]:g} A, "
                  f"{b_hi:.3g} % at {amps[-1]:g} A; " if b_lo is not None and b_hi is not None
                  else "third harmonic of B: not measured (no sense voltage); ")
        out.append(b_part + f"of y: {mean3(amps[0], 'y3_over_y1_pct'):.3g} % at {amps[0]:g} "
                   f"A and {mean3(amps[-1], 'y3_over_y1_pct'):.3g} % at {amps[-1]:g} A")
    law = c["opening_vs_f"]
    if law:
        better = min(law, key=lambda k: law[k]["rms"])
        out.append(f"loop opening (y at i = 0, falling minus rising, over peak-to-peak) at the "
                   f"largest amplitude: {c['opening_lowest_f_rel']:.3g} at the lowest f, "
                   f"{c['opening_highest_f_rel']:.3g} at the highest; best law {better} in f "
                   f"with intercept {law[better]['intercept']:.3g} at f -> 0")
    lag = " ".join(f"{r['frequency_Hz']:g}Hz:{r['y_extra_lag_deg']:+.2f}" for r in rows
                   if round(r["current_amplitude_A"], 2) == amps[-1])
    out.append(f"extra lag of y's fundamental behind the model (deg): {lag}; as a delay "
               f"{c['y_lag_as_delay_s'] * 1e3:.3g} ms leaves {c['y_lag_as_delay_rms_deg']:.2g} "
               "deg RMS")
    bl = " ".join(f"{r['frequency_Hz']:g}Hz:{r['b_extra_lag_deg']:+.2f}" for r in brows
                  if round(r["current_amplitude_A"], 2) == amps[-1])
    out.append("extra lag of B's fundamental behind the model (deg): "
               + (bl or "not measured (no sense voltage)"))
    gains = " ".join(f"{r['frequency_Hz']:g}Hz:{r['y_gain_ratio']:.3f}" for r in rows
                     if round(r["current_amplitude_A"], 2) == amps[-1])
    out.append(f"gain of y's fundamental, measured over model: {gains}")
    zo = max(rows, key=lambda r: abs(r["offset_drift_z"]))
    zg = max(rows, key=lambda r: abs(r["gain_drift_z"]))
    out.append(f"drift within runs: largest offset drift {zo['offset_drift_um_per_s']:.3g} um/s "
               f"(z = {zo['offset_drift_z']:.3g}, {zo['run']}), largest gain drift "
               f"{zg['gain_drift_per_s'] * 100:.3g} %/s (z = {zg['gain_drift_z']:.3g}, "
               f"{zg['run']})")
    ranked = sorted((f for f in d.fits if f.cause != "none"), key=lambda f: f.score)
    out.append(f"held-out RMS of y: paper {p.heldout_rms * 1e6:.4g} um; candidates "
               + ", ".join(f"{f.label} {f.heldout_rms * 1e6:.4g} um (score {f.score:.4g})"
                           for f in ranked) + f"; paper's score {p.score:.4g}")
    if d.cause in CAUSES:
        e = d.extended
        explained = 1.0 - max(e.heldout_excess, 0.0) / max(p.heldout_excess, 1e-12)
        out.append(f"named {e.label} (acts on {SIGNALS[d.cause]}): held-out BIC lower by "
                   f"{p.score - e.score:.4g} (threshold {MIN_BIC_DROP:g}), "
                   f"{100 * explained:.3g} % of the paper's excess chi^2 removed; parameters "
                   f"{_fmt_params(e.parameters)}; held-out RMS {p.heldout_rms * 1e6:.4g} -> "
                   f"{e.heldout_rms * 1e6:.4g} um, gain {d.gain:.3g}x")
        if d.also_consistent:
            out.append("also consistent: " + ", ".join(
                f"{f.label} (score {f.score - e.score:+.3g} from the named one, held-out RMS "
                f"{f.heldout_rms * 1e6:.4g} um)" for f in d.also_consistent)
                + f"; the data prefer {e.label} by less than the BIC margin "
                f"({MIN_BIC_DROP:g}), so they do not separate these causes"
                + (" (without B, see above)" if without else ""))
    elif d.cause == "none":
        out.append("none: the paper's model is within noise on training and held-out runs")
    else:
        out.append("unexplained: the paper's model is outside noise and no candidate removes "
                   f"at least {100 * MIN_EXPLAINED:g} % of its held-out excess with a BIC drop "
                   f"above {MIN_BIC_DROP:g}")
    return out


def _fmt_params(p: dict) -> str:
    def f(v):
        if isinstance(v, list):
            return "[" + ", ".join(f"{x:.3g}" for x in v) + "]"
        return f"{v:.4g}"
    return ", ".join(f"{k} = {f(v)}" for k, v in p.items())


def format_diagnosis(d: Diagnosis, path: str = "") -> str:
    """Plain-text report."""
    lines = []
    if path:
        lines.append(f"diagnosis of {path}")
    lines.append(f"cause: {d.cause}" + (f" (model: {d.extended.form})"
                                         if d.cause in FORMS else ""))
    if d.also_consistent:
        lines.append("also consistent: " + ", ".join(f.label for f in d.also_consistent))
    without = d.runs_without_sense_voltage
    if without:
        lines.append(f"no sense voltage: {', '.join(without)} (B_m from the displacement; "
                     "y's features only)")
    lines.append(f"held-out runs: {', '.join(d.heldout_runs)}")
    lines.append(f"held-out RMS of y: paper {d.paper.heldout_rms * 1e6:.4g} um, extended "
                 f"{d.extended.heldout_rms * 1e6:.4g} um, gain {d.gain:.3g}x")
    lines.append("")
    head = f"{'candidate':<42} {'held-out RMS [um]':>18} {'chi2/n':>10} {'score':>12} {'k':>3}"
    lines += [head, "-" * len(head)]
    for f in sorted(d.fits, key=lambda f: f.score):
        lines.append(f"{('paper (none)' if f.cause == 'none' else f.label):<42} "
                     f"{f.heldout_rms * 1e6:>18.4g} {f.heldout_chi2 / f.heldout_n:>10.4g} "
                     f"{f.score:>12.5g} {f.n_params:>3}")
    lines.append("")
    lines.append("evidence:")
    lines += [f"  - {e}" for e in d.evidence]
    return "\n".join(lines)


# ================================================================== report plots


def write_report(d: Diagnosis, directory) -> list:
    """PNG figures: per run, the loop (measured, paper, extended) and the residual
    against phase by branch, before (paper) and after (extended). Returns the paths."""
    from pathlib import Path

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    ev = d.context["evaluator"]
    paths = []
    for name, rf in d.context["features"].items():
        yp = ev.samples(rf, d.paper.loss)
        ye = ev.samples(rf, d.extended.loss, d.extended.cause, d.extended.extra,
                        d.extended.form)
        th = np.mod(rf.phase(rf.time), 2 * np.pi)
        falling = th < np.pi
        fig, axes = plt.subplots(1, 3, figsize=(14, 4))
        ax = axes[0]
        ax.plot(rf.current, rf.displacement * 1e6, ".", ms=1.5, color="0.6", label="measured")
        order = np.argsort(rf.time)
        ax.plot(rf.current[order], yp[order] * 1e6, "-", lw=0.8, label="paper")
        if d.extended.cause != "none":
            ax.plot(rf.current[order], ye[order] * 1e6, "--", lw=0.8,
                    label=f"extended ({d.extended.label})")
        ax.set_xlabel("current i [A]")
        ax.set_ylabel("displacement y [um]")
        tag = " (held out)" if name in d.heldout_runs else ""
        ax.set_title(f"{name}{tag}: loop")
        ax.legend(fontsize=7)
        for ax, model, label in ((axes[1], yp, "paper"), (axes[2], ye, "extended")):
            r = (rf.displacement - model) * 1e6
            ax.plot(th[falling], r[falling], ".", ms=1.5, label="falling current")
            ax.plot(th[~falling], r[~falling], ".", ms=1.5, label="rising current")
            ax.axhline(0.0, color="k", lw=0.5)
            ax.set_xlabel("phase of the current [rad]")
            ax.set_ylabel("measured - model [um]")
            ax.set_title(f"residual, {label} (RMS {np.sqrt(np.mean(r * r)):.3g} um)")
            ax.legend(fontsize=7)
        fig.tight_layout()
        path = out / f"diagnose_{name}.png"
        fig.savefig(path, dpi=90)
        plt.close(fig)
        paths.append(path)
    return paths
