"""Thermal drift: offset and gain of y drifting with the coil's heating.

Coil heating i^2 R (mean I_m^2 R / 2 for a sinusoid) warms rod and sensor
mount. K_lambda and M_b fall with temperature and the rod and mount expand
(Engdahl (ed.), *Handbook of Giant Magnetostrictive Materials*, Academic Press
2000, ch. 2 and 4; Clark, "Magnetostrictive rare earth-Fe2 compounds",
Ferromagnetic Materials vol. 1, North-Holland 1980), so with the heating
"dose" u(t) = (I_m^2 - I_s^2) t_th (1 - e^{-t/t_th}) (a first-order thermal lag
from the start temperature towards the run's equilibrium; u = (I_m^2 - I_s^2) t,
a linear drift, for t_th -> inf)

    y_meas(t) = (1 + g u(t)) y(t) + o u(t),

t from the start of the run, with o [m/(A^2 s)] and g [1/(A^2 s)]. I_s is the
current whose equilibrium temperature the rod has at the start of a run: 0 for
a run started cold, more when the runs follow one another with the coil still
warm, so that a run at a lower current cools while it is recorded (the
equilibrium temperature rise of a coil is proportional to its Joule loss,
I_m^2 R / 2). A constant temperature offset of all runs changes K_lambda
alike in every run; the diagnosis' strain scale (``smeha.diagnose``) takes it.

**Heating before the record.** A lab switches the drive on and records once the
response is periodic, some periods later: the coil heats from the switch-on, so a
record's first sample is n_p periods of its drive into the dose, t above runs from
the switch-on, t = t_rec + n_p / f, and a run's mean gain over its record is lower by
g (I_m^2 - I_s^2) n_p / f (linear drift) than a dose from the record's start gives.
Measured from the record alone, the long periods of the low-frequency runs put the
most heating before their records (labsim's fixed 20 kHz clock, its drift alone: the
form without n_p fitted t_th = 0.7 s to the 5 Hz runs' records, against their 30 s,
and left 27 % of the held-out excess; with n_p, 3.0 periods, t_th on its linear end,
I_s 0.497 A against labsim's 0.5, within noise). n_p is one unknown for all runs (a
lab waits a number of periods; labsim 2 to 3.3); 0 is a record from the switch-on.

* periodic form: the drift is not periodic; the diagnosis compares the gain
  it gives the harmonics on average over a run and its slopes of the offset and
  of the fundamental with the features', and applies it to the samples
  (:meth:`DriftForm.feature_drift`, :meth:`DriftForm.apply_samples`);
* time-stepped form: on the strain, about the operating point's mean strain
  lambda_0 (eq 25's mean term): lambda' = lambda_0 + (1 + g u) (lambda - lambda_0)
  + (o / L) u, o / L being the rod's free thermal strain rate, so the rod pushes
  on its load with the drifted force. Quasi-statically (the drift is slow
  against the mechanics) the displacement is then the periodic form about its
  mean; t is the time since the start of the run (the FMU's initialisation: a
  simulation starts at the switch-on, so n_p does not enter);
* parameters: o, g, t_th [s] (inf for a linear drift), I_s [A] and n_p [-] (the last
  two optional, 0 by default).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError, check_range
from ..forward import strain_harmonics
from ..magnetostriction import magnetostrictive_force
from ._base import Extension, FitSpec, Parameter


@dataclass(frozen=True)
class LinearDrift:
    """Offset and gain of y drifting with the coil's heating, linearly in time at first.

    Coil heating i^2 R (mean I_m^2 R / 2 for a sinusoid) warms rod and sensor
    mount. K_lambda and M_b fall with temperature and the rod and mount expand
    (Engdahl 2000, ch. 2 and 4; Clark 1980), so with the heating "dose"
    u(t) = (I_m^2 - I_s^2) t_th (1 - e^{-t/t_th}) (first-order thermal lag from
    the equilibrium of I_s; u = (I_m^2 - I_s^2) t, a linear drift, for
    t_th -> inf, the default)

        y_meas(t) = (1 + g u(t)) y(t) + o u(t),

    t from the start of the run, with o [m/(A^2 s)] and g [1/(A^2 s)] (module
    docstring).

    Attributes
    ----------
    offset_rate : float
        o, [m/(A^2 s)].
    gain_rate : float
        g, [1/(A^2 s)].
    thermal_time_constant : float
        t_th, [s], > 0; inf (default) for a drift linear in time.
    start_current : float
        I_s, [A], >= 0 (default 0: the run starts cold).
    """

    offset_rate: float
    gain_rate: float
    thermal_time_constant: float = math.inf
    start_current: float = 0.0

    def __post_init__(self):
        for name in ("offset_rate", "gain_rate"):
            if not math.isfinite(getattr(self, name)):
                raise ParameterError(f"{name} = {getattr(self, name)!r} is not finite")
        check_range("thermal_time_constant", self.thermal_time_constant, 0.0, math.inf,
                    unit="s", high_open=False)
        check_range("start_current", self.start_current, 0.0, math.inf, unit="A",
                    low_open=False)

    def dose(self, time, current_amplitude):
        """u(t) = (I_m^2 - I_s^2) t_th (1 - e^{-t/t_th}), [A^2 s]; t from the run's start."""
        t = np.asarray(time, dtype=float)
        tc = self.thermal_time_constant
        base = t if math.isinf(tc) else -tc * np.expm1(-t / tc)
        return (current_amplitude ** 2 - self.start_current ** 2) * base

    def apply(self, displacement, time, current_amplitude):
        """y_meas from the drift-free y (about its mean), [m]; per sample as is."""
        u = self.dose(time, current_amplitude)
        return (1.0 + self.gain_rate * u) * displacement + self.offset_rate * u


class DriftForm(Extension):
    """Strain drifting with the heating dose (:class:`LinearDrift`).

    lambda' = lambda_0 + (1 + g u(t)) (lambda - lambda_0) + (o / L) u(t) with
    u(t) = (I_m^2 - I_s^2) t_th (1 - e^{-t/t_th}), t from the start of the run
    (module docstring); I_m is the operating point's. No memory beyond the elapsed
    time the stepper keeps.
    """

    cause = "thermal_drift"
    stage = "strain"
    signals = "y only"
    evidence = "drift"
    fit = FitSpec(("offset_rate_um_per_A2s", "gain_rate_pct_per_A2s", "log10_time_constant_s",
                   "I_s2_A2", "periods_before_record"),
                  ((0.0, 0.0, 0.0, 0.0, 2.0), (0.0, 0.0, 2.0, 0.0, 2.0), (0.0, 0.0, 1.0, 0.3, 2.0)),
                  (-math.inf, -math.inf, -1.5, 0.0, 0.0), (math.inf, math.inf, 3.0, 4.0, 20.0),
                  neutral=(0.0, 0.0, 0.0, 0.0, 0.0))
    parameters = (Parameter("offset_rate_m_per_A2s", "m/(A^2 s)"),
                  Parameter("gain_rate_per_A2s", "1/(A^2 s)"),
                  Parameter("thermal_time_constant_s", "s", 0.0, math.inf, high_open=False),
                  Parameter("start_current_A", "A", 0.0, math.inf, low_open=False,
                            optional=True),
                  Parameter("periods_before_record", "-", 0.0, math.inf, low_open=False,
                            optional=True))

    @classmethod
    def validate(cls, values):
        cls.drift_of(values)

    @staticmethod
    def drift_of(values) -> LinearDrift:
        return LinearDrift(values["offset_rate_m_per_A2s"], values["gain_rate_per_A2s"],
                           values["thermal_time_constant_s"], values.get("start_current_A", 0.0))

    @classmethod
    def from_fit(cls, x, context):
        return {"offset_rate_m_per_A2s": x[0] * 1e-6, "gain_rate_per_A2s": x[1] * 1e-2,
                "thermal_time_constant_s": 10.0 ** x[2],
                "start_current_A": math.sqrt(max(x[3], 0.0)),
                "periods_before_record": float(x[4])}

    @classmethod
    def at_bounds(cls, x, tolerance=1e-3):
        # a thermal time constant at its upper end is a drift linear in time, a form the
        # drift may take; the short end is a bound pressed on
        span = cls.fit.upper[2] - cls.fit.lower[2]
        out = tuple(n for n, v in zip(cls.fit.names[2:3], x[2:3])
                    if v <= cls.fit.lower[2] + tolerance * span)
        # I_s^2 = 0 is a run started cold, no periods before the record a record from the
        # switch-on; their upper ends are bounds pressed on
        return out + tuple(n for n, v, hi in zip(cls.fit.names[3:], x[3:], cls.fit.upper[3:])
                           if v >= hi * (1.0 - tolerance))

    # periodic form: the drift of the features (the diagnosis' least-squares terms)
    @staticmethod
    def heated_before(values, frequency) -> float:
        """The drive's time on before a record's first sample: n_p / f, [s] (0 without
        n_p or ``frequency`` [Hz]; module docstring, "Heating before the record")."""
        periods = values.get("periods_before_record", 0.0)
        return periods / frequency if periods and frequency else 0.0

    @classmethod
    def feature_drift(cls, values, time, start, middle, current_amplitude, fundamental,
                      frequency=None):
        """(gain at the middle [-], d mean y/dt [m/s], d Y_1/dt [m/s]) the drift gives a run.

        The features are least-squares terms over the run's samples ``time`` [s]
        about ``middle`` [s]: harmonics at the middle, scaled by 1 + g times the
        mean heating dose over the samples, and slopes, those of the dose times o and
        g Y_1 (``fundamental``, [m]). The dose runs from the drive's switch-on,
        :meth:`heated_before` the record's first sample ``start`` [s] (the run's drive
        ``frequency``, [Hz]).
        """
        since = np.asarray(time) - start + cls.heated_before(values, frequency)
        u = cls.drift_of(values).dose(since, current_amplitude)
        tau = np.asarray(time) - middle
        slope = float(tau @ (u - u.mean()) / (tau @ tau))
        g = values["gain_rate_per_A2s"]
        return (1.0 + g * float(u.mean()), values["offset_rate_m_per_A2s"] * slope,
                g * slope * fundamental)

    @classmethod
    def apply_samples(cls, values, displacement, time_since_start, current_amplitude,
                      frequency=None):
        """y_meas of the drift-free y samples (about its mean), [m]; the dose from the
        switch-on (:meth:`heated_before`)."""
        since = time_since_start + cls.heated_before(values, frequency)
        return cls.drift_of(values).apply(displacement, since, current_amplitude)

    # time-stepped form
    def __init__(self, values, params, point, upstream=None):
        super().__init__(values, params, point, upstream)
        # on the strain: the offset is the rod's free thermal strain, o / L per unit dose
        self.drift = LinearDrift(values["offset_rate_m_per_A2s"] / params.rod_length,
                                 values["gain_rate_per_A2s"], values["thermal_time_constant_s"],
                                 values.get("start_current_A", 0.0))
        self.mean_strain = float(np.real(strain_harmonics(params, point)[0]))

    def adjust(self, base, step, time):
        p = self.params
        lam = self.mean_strain + float(self.drift.apply(base.strain - self.mean_strain, time,
                                                        self.point.current_amplitude))
        return base._replace(strain=lam, force=magnetostrictive_force(lam, p.rod_area,
                                                                      p.youngs_modulus))
