"""A pure delay of the displacement sensor's chain: y_meas(t) = y(t - tau).

Electronics, filtering or acquisition skew between the displacement channel
and the current delay the displacement signal. On the k-th harmonic of a
period a pure delay is the phase factor e^{-j k w tau}: an extra lag exactly
linear in frequency and no change of amplitude.

Where it acts: the diagnosis delays y's harmonics but not B's, both referred
to the measured current, so the delay lies between the rod and the
displacement signal, not in the amplifier (a delayed coil current would delay
B as much as y). The time-stepped form therefore delays only the *sensed*
displacement (:attr:`gmt.TransducerOutput.sensed_displacement`): the rod, its
force on the oil and the cylinder flow of the system study are exactly the
paper's.

* periodic form: e^{-j k w tau} on y's harmonics;
* time-stepped form: a delay line on the sensed displacement;
* parameter: tau [s] in [0, 0.1]; the diagnosis fits tau in ms.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError, check_range
from ._base import Y_LINEAR_LOOKALIKE, Extension, FitSpec, Parameter


@dataclass(frozen=True)
class TransportDelay:
    """A pure delay tau, y_meas(t) = y(t - tau) (module docstring).

    Attributes
    ----------
    delay : float
        tau, [s], >= 0.
    """

    delay: float

    def __post_init__(self):
        check_range("delay", self.delay, 0.0, math.inf, unit="s", low_open=False)

    def factor(self, angular_frequency):
        """e^{-j w tau}, [-]."""
        return np.exp(-1j * np.asarray(angular_frequency, dtype=float) * self.delay)

    def delay_samples(self, step):
        """Delay in samples of ``step`` [s]: a FIFO this long, the fraction interpolated."""
        return self.delay / step


class DelayForm(Extension):
    """A pure delay of the displacement sensor (:class:`TransportDelay`).

    The sensed displacement at t is y(t - tau), interpolated linearly in a
    history of (t_k, y_k) at the ends of the steps; before t = tau it is the
    rest displacement. At a fixed step h this is the FIFO of
    ``TransportDelay.delay_samples(h)`` samples with the fraction
    interpolated; the history keeps variable steps too. Memory: the history
    (2 values per kept sample; about tau / h samples).
    """

    cause = "transport_delay"
    stage = "sensor"
    signals = "y only"
    lookalike = Y_LINEAR_LOOKALIKE
    fit = FitSpec(("tau_ms",), ((0.05,), (1.0,)), (0.0,), (20.0,), neutral=(0.0,))
    #: the line holds tau / h samples and is saved with every FMU state
    parameters = (Parameter("delay_s", "s", 0.0, 0.1, low_open=False, high_open=False),)

    @classmethod
    def from_fit(cls, x, context):
        return {"delay_s": x[0] * 1e-3}

    @classmethod
    def at_bounds(cls, x, tolerance=1e-3):
        # no delay (tau = 0) is the paper's model, not a bound pressed on
        return tuple(n for n in super().at_bounds(x, tolerance)
                     if x[0] >= cls.fit.upper[0] * (1.0 - tolerance))

    # periodic form
    @classmethod
    def steady_sensor(cls, values, angular_frequencies):
        return TransportDelay(values["delay_s"]).factor(angular_frequencies)

    # time-stepped form
    def __init__(self, values, params, point, upstream=None):
        super().__init__(values, params, point, upstream)
        self.delay = TransportDelay(values["delay_s"])
        self.times, self.values_ = [0.0], [math.nan]

    def sensed(self, displacement, time):
        tau = self.delay.delay
        times, ys = self.times, self.values_
        times.append(time)
        ys.append(displacement)
        target = time - tau
        while len(times) > 2 and times[1] <= target:
            del times[0], ys[0]
        if target <= times[0]:
            return ys[0]
        t0, t1 = times[0], times[1]
        if not t1 > t0:  # a step too small to advance the clock
            return ys[1]
        frac = (target - t0) / (t1 - t0)
        return ys[0] + frac * (ys[1] - ys[0])

    def reset(self, rest_displacement):
        self.times, self.values_ = [0.0], [float(rest_displacement)]

    def get_state(self):
        return tuple(v for pair in zip(self.times, self.values_) for v in pair)

    def set_state(self, state):
        if len(state) < 2 or len(state) % 2:
            raise ParameterError(f"{self.cause} state has {len(state)} values; the delay line "
                                 "needs (time, displacement) pairs")
        self.times = [float(v) for v in state[0::2]]
        self.values_ = [float(v) for v in state[1::2]]

    @property
    def state_size(self):
        return None  # the line holds about tau / h samples
