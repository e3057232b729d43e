"""What every extension of the paper's model provides, and the shared helpers.

An extension (one effect in one formulation) is one class, a subclass of
:class:`Extension`, in the module of its effect. The class holds

* its **parameter spec** in SI names (:attr:`Extension.parameters`, a tuple of
  :class:`Parameter`), the names ``smeha diagnose --json`` reports and
  :class:`gmt.ModelVariant`, the FMU's ``variant_parameters`` and
  ``smeha flow --variant`` read;
* the diagnosis' **internal parametrisation** (:attr:`Extension.fit`, a
  :class:`FitSpec`: well-scaled unknowns, their start values and bounds) and
  the map from it to the SI parameters (:meth:`Extension.from_fit`);
* its **periodic form**: hooks that the steady-state evaluation of eq 30
  (:func:`gmt.extensions.steady.steady_state`) calls at the extension's
  *stage* of the model (field in the rod, magnetisation, strain, mechanics,
  sensor);
* its **time-stepped form**: an instance, built with the SI parameters, the
  transducer and the operating point, advances the same effect sample by
  sample inside :class:`gmt.variants.ExtendedStepper` (hooks
  :meth:`Extension.magnetics`, :meth:`Extension.adjust`,
  :attr:`Extension.mechanics`, :meth:`Extension.sensed`, and its memory).

The stages, in the order the model passes through them, decide how
extensions combine (:data:`STAGES`): one per stage, except the magnetisation
stage, where hysteresis and saturation may both act (hysteresis first).
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ..errors import ParameterError, check_range
from ..forward import Magnetics, magnetics

#: The stages of the paper's model an extension acts at, in the order the signal passes:
#: the field inside the rod (eddy currents), the magnetisation (hysteresis, saturation),
#: the strain (thermal drift), the mechanics (eq 27), the displacement sensor (delay).
STAGES = ("field", "magnetization", "strain", "mechanics", "sensor")


@dataclass(frozen=True)
class Parameter:
    """One SI parameter of an extension, named as ``smeha diagnose --json`` names it.

    Attributes
    ----------
    name : str
        Key in the candidate's ``parameters`` (SI, unit suffix as in the diagnosis).
    unit : str
        Unit shown in messages.
    low, high : float
        Allowed range; ``low_open``/``high_open`` exclude the bound.
    is_list : bool
        A non-empty list of numbers rather than one number.
    optional : bool
        A value that may be left out: one the diagnosis reports but derives
        from the others (e.g. the joint's frequency from its stiffness and
        mass; when given, :meth:`Extension.validate` checks that it agrees), or
        one with a default (the extension says which).
    """

    name: str
    unit: str
    low: float = -math.inf
    high: float = math.inf
    low_open: bool = True
    high_open: bool = True
    is_list: bool = False
    optional: bool = False

    def check(self, cause, value):
        """``value`` as a float (or tuple of floats), or ParameterError naming it."""
        where = f"{cause} parameter {self.name}"
        if self.is_list:
            if isinstance(value, (str, bytes, Mapping)) or not hasattr(value, "__iter__"):
                raise ParameterError(f"{where} = {value!r} must be a non-empty list of numbers")
            items = list(value)
            if not items:
                raise ParameterError(f"{where} = [] must be a non-empty list of numbers")
            return tuple(self._one(f"{where}[{k}]", v) for k, v in enumerate(items))
        return self._one(where, value)

    def _one(self, where, value):
        if isinstance(value, bool) or not isinstance(value, (int, float, np.floating,
                                                             np.integer)):
            raise ParameterError(f"{where} = {value!r} is not a number")
        low = None if self.low == -math.inf else self.low
        high = None if self.high == math.inf else self.high
        v = float(value)
        if math.isinf(v) and ((v > 0 and self.high == math.inf and not self.high_open)
                              or (v < 0 and self.low == -math.inf and not self.low_open)):
            return v
        if not math.isfinite(v):
            lo = "-inf" if low is None else f"{low:g}"
            hi = "inf" if high is None else f"{high:g}"
            raise ParameterError(f"{where} = {v!r} {self.unit} is outside the allowed range "
                                 f"{'(' if self.low_open else '['}{lo}, {hi}"
                                 f"{')' if self.high_open else ']'} {self.unit}")
        return check_range(where, v, low, high, unit=self.unit, low_open=self.low_open,
                           high_open=self.high_open)


@dataclass(frozen=True)
class FitSpec:
    """The diagnosis' unknowns of an extension: names, start vectors and bounds.

    The unknowns are scaled to be of order 1 (ratios to Table 2, logarithms of
    time constants); :meth:`Extension.from_fit` maps them to the SI parameters.
    The fit tries every start vector and keeps the best. ``neutral``: the unknowns
    where the effect leaves the paper's model unchanged, or as nearly as its bounds
    allow (a delay of 0, a saturation magnetisation 1000 times M_b, a time constant
    of 0.1 us); a combination whose fit stopped short of the model it extends is
    refitted from there (:mod:`smeha.diagnose.decision`). None where there is none.
    ``method``: how the fit starts ("trf": scipy's trf alone; "dogbox": a short dogbox
    fit first, for a long curved chi^2 valley; a combination takes "dogbox" if a member
    asks for it, :func:`smeha.diagnose.fit.solver_method`).
    """

    names: tuple = ()
    starts: tuple = ((),)
    lower: tuple = ()
    upper: tuple = ()
    neutral: tuple | None = None
    method: str = "trf"

    def __post_init__(self):
        if self.method not in ("trf", "dogbox"):
            raise ParameterError(f"FitSpec method = {self.method!r}: one of 'trf', 'dogbox'")
        if self.neutral is None:
            return
        if len(self.neutral) != len(self.names) or not all(
                lo <= v <= hi for v, lo, hi in zip(self.neutral, self.lower, self.upper)):
            raise ParameterError(f"FitSpec neutral = {self.neutral!r}: needs one value per "
                                 f"unknown {self.names!r}, each within [{self.lower!r}, "
                                 f"{self.upper!r}]")

    @property
    def size(self) -> int:
        """Number of unknowns."""
        return len(self.names)


class FieldState(NamedTuple):
    """The field stage's periodic result, all phasors referred to the current's phase.

    ``magnetization`` M_1 [A/m] (the section mean), ``flux_density`` B_1 [T]
    (what the sensing coil sees), ``force_first``/``force_second`` the
    magnetostrictive force's harmonics F_1, F_2 [N] (eqs 25, 28).
    """

    magnetization: complex
    flux_density: complex
    force_first: complex
    force_second: complex


class Steady(NamedTuple):
    """What the periodic evaluation of one run gives to the hooks (SI).

    ``params`` the transducer, ``frequency`` [Hz], ``angular_frequency``
    [rad/s], ``current_amplitude`` [A], ``field_amplitude`` H_m [A/m],
    ``flux_density_amplitude`` B_m [T] (what the coil measures), ``loss`` the
    coefficients (K_h, n, K_e, K_ex) of eq 16, ``step`` None for the
    continuous model or h [s] for the ZOH-sampled one, ``switching_gain`` the field
    the magnetisation stage's hysteresis switches on per unit applied field at the
    fundamental (the field stage's :meth:`Extension.switching_gain`). Arrays of runs or
    scalars.
    """

    params: object
    frequency: float
    angular_frequency: float
    current_amplitude: float
    field_amplitude: float
    flux_density_amplitude: float
    loss: tuple
    step: float | None = None
    switching_gain: complex = 1.0


def harmonic_remainder(values):
    """One period of samples minus its fundamental (mean and harmonics >= 2 kept).

    Parameters
    ----------
    values : array
        Samples over exactly one period, uniformly spaced, last axis.

    Returns
    -------
    array
        ``values`` with the first harmonic removed.

    Examples
    --------
    >>> th = np.linspace(0, 2 * np.pi, 8, endpoint=False)
    >>> np.allclose(harmonic_remainder(1.0 + np.cos(th) + 0.5 * np.cos(3 * th)),
    ...             1.0 + 0.5 * np.cos(3 * th))
    True
    """
    x = np.asarray(values, dtype=float)
    spec = np.fft.rfft(x, axis=-1)
    spec[..., 1] = 0.0
    return np.fft.irfft(spec, n=x.shape[-1], axis=-1)


def agrees(cause, name, values, unit, implied, how):
    """ParameterError unless the derived ``values[name]`` agrees with ``implied`` (1e-6)."""
    given = values[name]
    if not math.isclose(given, implied, rel_tol=1e-6):
        raise ParameterError(f"{cause} parameter {name} = {given:g} {unit} disagrees with "
                             f"{how} = {implied:g} {unit}; leave it out (it is derived) or "
                             "give a consistent value")


#: The caution for a cause that changes y alone and linearly (a delay, re-identified
#: one-DOF mechanics). A filter in the displacement sensor's chain (a conditioner's
#: low-pass: first order, Butterworth or Bessel) is a linear filter on y too; below its
#: corner it is 1 - j w tau_g - a w^2 + ..., and so are a delay (a = 0) and eq 27 with
#: raised c and m: y alone fits each with the others to second order in w. Measured on
#: the independent generator's order-2 Bessel sensor (group delay 100 us): named
#: mechanical_resonance (one_dof) in 10 of 10 seeds (docs/DIAGNOSE.md, Limits).
Y_LINEAR_LOOKALIKE = (
    "y alone cannot tell a low-pass filter in the displacement sensor's chain (its "
    "conditioner's bandwidth) from a delay or from changed mechanics: all are linear "
    "filters on y that agree to second order in frequency; check the sensor chain's "
    "bandwidth and delay before reading this as the named cause")

#: The ``signature`` of a nonlinearity of M (a hysteresis loop, whatever its shape): y's
#: and B's harmonics from the third up, which a change of the fundamentals alone (a linear
#: lag of M) does not produce (smeha.diagnose.rules.shows_signature).
HIGHER_HARMONICS = "higher harmonics"
#: The ``signature`` of a memoryless nonlinearity of M (a saturation): what it changes grows
#: with the drive faster than a linear effect's (misfit proportional to the drive, chi^2 to
#: its square), even where its harmonics are within noise (smeha.diagnose.rules.grows_with_drive).
GROWS_WITH_DRIVE = "grows with the drive"


class Extension:
    """One effect in one formulation: spec, periodic form and time-stepped form.

    Class attributes (the spec)
    ---------------------------
    cause : str
        The effect's name, as the diagnosis names it.
    form : str
        The formulation when the cause has several (the first is the
        default), "" otherwise.
    stage : str
        One of :data:`STAGES`.
    signals : str
        What it changes: "B and y" or "y only" (for the evidence text).
    evidence : str
        The held-out channel that tells it apart from the rest of the model: "" for the
        channels of its ``signals``; "drift" for the drift terms of y, which no periodic
        form (another cause's, or the paper's misfit) can produce.
    signature : str
        What a cause of this form must also explain to be named, first or beside
        others: :data:`HIGHER_HARMONICS` for y's and B's harmonics from the third up (a
        nonlinearity of M, which a change of the fundamentals alone does not show);
        :data:`GROWS_WITH_DRIVE` for a change that grows with the drive faster than a
        linear effect's (a memoryless nonlinearity of M); ""
        nothing more than its channels (smeha.diagnose.rules.shows_signature).
    lookalike : str
        What else, outside the candidates, leaves the same signature in the
        data (for the report's caution), "" when nothing known does.
    finer : type or None
        The same form on a finer discretisation (a Preisach density's grid), which
        the diagnosis fits before a later cause joins it on the same channels; None
        for a form that is not discretised. A form with one gives ``finer_start(x)``,
        its unknowns carried to the finer form's.
    parameters : tuple of Parameter
        SI parameters.
    fit : FitSpec
        The diagnosis' unknowns.

    An instance is the time-stepped form: ``Extension(values, params, point,
    upstream)`` with the checked SI ``values``, the transducer, the operating
    point and the waveform of the magnetisation the stages before it give
    over one period (``upstream(theta)``, [A/m]; used by the magnetisation
    stage to keep the describing-function split).
    """

    cause = ""
    form = ""
    stage = ""
    signals = ""
    evidence = ""
    signature = ""
    lookalike = ""
    finer = None
    parameters: tuple = ()
    fit = FitSpec()

    # ------------------------------------------------------------------ the spec

    @classmethod
    def validate(cls, values) -> None:
        """Checks that need more than each parameter's own range (no transducer needed)."""

    @classmethod
    def from_fit(cls, x, context) -> dict:
        """The SI parameters of the diagnosis' unknowns ``x``.

        ``context`` holds ``params`` (the transducer) and ``thresholds`` (the
        play operators' thresholds, [A/m], fixed by the data).
        """
        raise NotImplementedError

    @classmethod
    def stack_values(cls, values_list, runs):
        """The SI parameters of a batch of runs stacked once per entry of ``values_list``
        (``runs`` runs a copy, copy after copy), as the periodic form reads them with one
        value per run; None (the default) where the form takes its parameters for all
        runs only (the diagnosis then evaluates each copy apart)."""
        return None

    @classmethod
    def at_bounds(cls, x, tolerance=1e-3) -> tuple:
        """Names of the unknowns within ``tolerance`` of the bound range of a bound."""
        out = []
        for name, v, lo, hi in zip(cls.fit.names, x, cls.fit.lower, cls.fit.upper):
            if math.isfinite(lo) and math.isfinite(hi):
                span = hi - lo
                if v <= lo + tolerance * span or v >= hi - tolerance * span:
                    out.append(name)
        return tuple(out)

    # ------------------------------------------------------------------ periodic form
    # Hooks of gmt.extensions.steady.steady_state; the defaults leave the paper's model.

    @classmethod
    def steady_field(cls, values, steady: Steady, adder=None) -> FieldState | None:
        """Field stage: the paper part's M_1, B_1, F_1, F_2 of the run.

        ``adder`` gives the fundamental the magnetisation stage adds per unit
        H_m for the paper part's M_1, for
        :func:`gmt.extensions.paperpart.paper_permeability` (None: none).
        """
        return None

    @classmethod
    def loss_flux_factor(cls, values, angular_frequency):
        """Field stage: the flux density eq 16 is evaluated at, per mu_0 |mu| H_m, [-]."""
        return 1.0

    @classmethod
    def steady_output(cls, values, steady: Steady, magnetization, theta, memo=None):
        """Magnetisation stage: M after this effect from M before it over one period, [A/m].

        ``magnetization`` has a row per run, ``theta`` the phases of its columns;
        ``memo`` (a dict, or None) may keep what does not depend on M between
        calls for the same runs.
        """
        return magnetization

    @classmethod
    def steady_mechanics(cls, values, params, angular_frequencies, step=None):
        """Mechanics stage: Y/F at the harmonics [m/N], or None for eq 27's."""
        return None

    @classmethod
    def steady_sensor(cls, values, angular_frequencies):
        """Sensor stage: factor on y's harmonics, [-]."""
        return np.ones(np.shape(angular_frequencies))

    @classmethod
    def vacuum_share(cls, values, angular_frequency):
        """Field stage: the vacuum field per H_m the coil sees outside the rod's lag, in
        B_1 / mu_0, [-] (0: the coil sees the field stage's mean field whole)."""
        return 0.0

    @classmethod
    def field_gain(cls, values, angular_frequency) -> complex:
        """Mean field in the rod per applied field at the fundamental, [-] (1 without eddies)."""
        return 1.0

    @classmethod
    def switching_gain(cls, values, angular_frequency) -> complex:
        """Field stage: the field the magnetisation stage's hysteresis switches on, per
        applied field at the fundamental, [-] (1: the applied field H).

        Relays and plays switch on the field in the material. Where the eddy currents
        shield the rod's field (the field forms), that is the field inside, taken as its
        section mean <g> H: one field switches the whole population (the spread of the
        switching field across the section is not resolved); where they act on the
        magnetisation, the applied field reaches the section and the hysteresis switches
        on H. :attr:`shields_field` says which: the field stage's :meth:`field_gain`, or 1."""
        return cls.field_gain(values, angular_frequency) if cls.shields_field else 1.0

    #: Field stage: the eddy currents shield the field inside the rod, so the
    #: magnetisation stage's hysteresis switches on the mean field inside
    #: (:meth:`switching_gain`); False where they act on the magnetisation.
    shields_field = False

    # ------------------------------------------------------------------ time-stepped form

    def __init__(self, values, params, point, upstream=None):
        self.values = values
        self.params = params
        self.point = point
        self.mechanics = (params.mass, params.damping, params.stiffness)

    #: The stepper class the form runs in (None: the extended stepper; two masses need
    #: their own, :class:`gmt.variants.TwoMassStepper`).
    stepper = None
    #: Field stage that shields the field: the section-mean field inside over the last step
    #: of :meth:`magnetics`, [A/m], what the hysteresis switches on (None before the first
    #: step or without diffusion; :meth:`switching_gain`).
    held_switching_field = None

    def magnetics(self, current, quadrature, step, time) -> Magnetics:
        """Field stage: H, H_q, B, M, lambda, F held over the step; may advance memory."""
        return magnetics(self.params, self.point, current, quadrature)

    def adjust(self, mag: Magnetics, step, time) -> Magnetics:
        """Magnetisation and strain stages: the magnetics after this effect."""
        return mag

    def sensed(self, displacement, time) -> float:
        """Sensor stage: what a displacement sensor reads at ``time`` [s], [m]."""
        return displacement

    def waveform(self, theta, upstream):
        """M over one period at the operating point after this stage, [A/m]."""
        return upstream(theta)

    def reset(self, rest_displacement) -> None:
        """Memory to its rest value."""

    def get_state(self) -> tuple:
        """The extension's memory as floats."""
        return ()

    def set_state(self, state) -> None:
        """Restore :meth:`get_state`."""
        if len(state):
            raise ParameterError(f"{self.cause or 'this variant'} has no state; got "
                                 f"{len(state)} values")

    @property
    def state_size(self):
        """Number of floats of the memory; None when it varies (the delay line)."""
        return len(self.get_state())
