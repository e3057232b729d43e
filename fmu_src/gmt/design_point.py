"""Is the coil current the sinusoid the model is defined for? The design point of eq 30.

The paper characterises the rod by its complex permeability mu' - j mu'' at a sinusoidal
excitation i = I_m cos(w t) of known frequency and amplitude (eqs 1-2, 12-20; Table 1's
B_m falls from 0.0637 T at 50 Hz to 0.0531 T at 100 Hz), and eq 31 rebuilds the
quadrature term i tan(w t) = +-sqrt(I_m^2 - i^2) from the current assuming that very
sinusoid. Driven otherwise, the model answers with plausible but wrong numbers:

* another frequency: mu', mu'' and the quadrature belong to f, not to the drive (100 Hz
  through the 50 Hz model: 44.3 um peak to peak instead of the 36.0 um the model gives
  at 100 Hz);
* another amplitude: sqrt(I_m^2 - i^2) is the quadrature of another ellipse (at 50 Hz,
  1 % in the amplitude moves the peak-to-peak displacement by 2 %);
* a constant current (DC, or the current held after a step) has no quadrature part, yet
  eq 31 gives +-sqrt(I_m^2 - i^2): 13 um of rise with no current, and a contraction on a
  positive step.

:class:`DriveMonitor` watches the current sample by sample and says when it departs
from the operating point (f, I_m):

* **period** -- between successive upward zero crossings (armed only after the current
  fell below -I_m/4, so that noise about zero does not count; crossing times by linear
  interpolation between samples): the frequency 1/T against f
  (:data:`FREQUENCY_TOLERANCE`), the amplitude (max - min)/2 against I_m and the offset
  (max + min)/2 against 0 (:data:`AMPLITUDE_TOLERANCE`, plus the under-estimate of a
  sampled peak, 1 - cos(pi f h)); the extremes are refined by the parabola through the
  three samples about each;
* **standing still** -- over every half period (T/2 at f, judged when the steps are at
  most T/8) a sinusoid of amplitude I_m spans at least I_m (1 - cos(3 pi/8)) = 0.62 I_m
  between its samples; a range below I_m/4 is DC, a step's plateau or a drive much slower
  than f;
* **a step** (without the compensator; its current jumps where Figure 9 switches
  branch) -- a change between two samples more than three times the largest a sinusoid
  at (f, I_m) makes over that step, I_m w h, plus I_m/20;
* **at rest near zero** (without the compensator, whose current is held over its own
  sample period) -- two samples within I_m/4 of zero, a step of at most T/8 apart, that
  differ by less than I_m sin(pi f h)/2: a sinusoid of amplitude I_m passing there moves
  by at least 2 I_m sin(pi f h) cos(asin(1/4) + pi f h) >= 1.6 I_m sin(pi f h), over three
  times that (only one of amplitude below I_m/4 stays under it, the bound of standing
  still above);
* **the first sample** (without the compensator, whose Figure 9 drive starts at 0.70 A)
  -- the model's drive is i = I_m cos(w t) from its start (eqs 1-2), which begins at its
  peak, where eq 31's quadrature sqrt(I_m^2 - i^2) is zero and its sign does not matter.
  Anywhere else one sample cannot say which arc of the loop the current is on: the
  stepper takes the + branch (a falling current), so u = 0 at the start gives the B, M
  and F of the quadrature term alone (0.027 T, 21 kA/m, 1.7 kN with Table 2), right only
  for a sinusoid falling through zero. A first sample below I_m (1 - AMPLITUDE_TOLERANCE)
  in magnitude is therefore flagged, provisionally: the flag stays while the
  current does not move (its branch is still the guess), becomes standing still or a
  step where those rules say so, and clears as soon as the current moves otherwise (a
  sinusoid of another phase, whose branch the second sample gives; the period checks
  then judge it as any drive). A current at rest from the start is so flagged from the
  first sample, and as standing still from the second.

The verdict stays until a full period passes every check again. With ``follow`` the
monitor instead asks its owner (:class:`gmt.Transducer`) to move the operating point to
the measured frequency and amplitude of a period that is a sinusoid of another (f, I_m)
but otherwise clean (no offset), so that the model follows the drive it sees; DC and
steps it cannot follow.

The tolerances are chosen on the paper's 50 Hz case: 5 % in frequency moves the
peak-to-peak displacement by 1.3 %, 1 % in amplitude by 2.1 % (``tests/test_design_point.py``
measures both), so a drive within them keeps the stroke within about 2.5 % of the
model at the drive's own point.
"""
from __future__ import annotations

import math

#: Relative departure of the drive's frequency from f that counts as outside, [-].
FREQUENCY_TOLERANCE = 0.05
#: Relative departure of the drive's amplitude from I_m (and offset, as a fraction of
#: I_m) that counts as outside, [-].
AMPLITUDE_TOLERANCE = 0.01
#: Fraction of I_m the current must fall below before an upward crossing counts.
_ARM = 0.25
#: A half-period window spanning less than this fraction of I_m is standing still.
_STILL = 0.25
#: Reasons, by code (the code is part of the state).
REASONS = ("", "frequency", "amplitude", "offset", "standing still", "step", "start")
#: The code of the first sample's provisional verdict (module docstring).
_START = REASONS.index("start")


class DriveMonitor:
    """Says whether the coil current is the sinusoid at (f, I_m) the model assumes.

    Parameters
    ----------
    frequency : float
        f of the operating point, [Hz].
    current_amplitude : float
        I_m of the operating point, [A].
    steps : bool
        Also flag a step (a jump between samples); off for a compensated drive, whose
        current jumps where the compensator switches branch (Figure 9).
    follow : bool
        Ask for the operating point to follow the measured sinusoid (:meth:`observe`
        returns it).

    Notes
    -----
    The state is a flat tuple of floats (:meth:`get_state`), saved with the FMU state.
    """

    def __init__(self, frequency: float, current_amplitude: float, steps: bool = True,
                 follow: bool = False):
        self.steps = bool(steps)
        self.follow = bool(follow)
        self.design = (float(frequency), float(current_amplitude))
        self.reset()

    def reset(self):
        """Back to no samples, inside the design point, the model at the design point."""
        nan, inf = math.nan, math.inf
        self.time = 0.0  # start of the current sample's interval, [s]
        self.i1 = self.t1 = self.h1 = self.i2 = self.t2 = nan  # the two previous samples
        self.armed = False  # the current has fallen below -I_m/4 since the last crossing
        self.crossing = nan  # time of the last upward zero crossing, [s]
        self.high, self.low = -inf, inf  # extremes since that crossing, [A]
        self.longest = 0.0  # longest step since that crossing, [s]
        # the standing-still window: start [s], max and min [A], samples
        self.w_start, self.w_high, self.w_low, self.w_count = 0.0, -inf, inf, 0
        self.outside, self.reason = False, 0
        self.measured = (nan, nan)  # f [Hz] and amplitude [A] of the last full period
        self.departures = 0  # times the verdict went outside
        self.set_model(self.design)

    def set_model(self, model) -> None:
        """Judge against the operating point (f, I_m) = ``model`` from now on."""
        f, im = self.model = (float(model[0]), float(model[1]))
        self._jump = 3.0 * im * 2.0 * math.pi * f  # times the previous step, [A]
        self._jump0 = 0.05 * im
        self._arm = -_ARM * im
        self._half = 0.5 / f
        self._still = _STILL * im

    # -- state -----------------------------------------------------------------------
    def get_state(self) -> tuple:
        """Every piece of state as a flat tuple of floats."""
        return (self.time, self.i1, self.t1, self.h1, self.i2, self.t2, float(self.armed),
                self.crossing, self.high, self.low, self.longest, self.w_start, self.w_high,
                self.w_low, float(self.w_count), float(self.outside), float(self.reason),
                *self.measured, *self.model, float(self.departures))

    def set_state(self, state) -> None:
        """Restore a state from :meth:`get_state`."""
        s = tuple(float(x) for x in state)
        (self.time, self.i1, self.t1, self.h1, self.i2, self.t2, armed, self.crossing,
         self.high, self.low, self.longest, self.w_start, self.w_high, self.w_low,
         count, outside, reason) = s[:17]
        self.armed, self.w_count = armed > 0.0, int(count)
        self.outside, self.reason = outside > 0.0, int(reason)
        self.measured = s[17:19]
        self.departures = int(s[21])
        self.set_model(s[19:21])

    STATE_SIZE = 22

    # -- verdict -----------------------------------------------------------------------
    @property
    def is_outside(self) -> bool:
        """True while the drive departs from the model's operating point."""
        return self.outside

    @property
    def provisional(self) -> bool:
        """True while the only verdict is the first sample's (not at the drive's peak)."""
        return self.outside and self.reason == _START

    def describe(self) -> str:
        """The verdict in words (for a warning)."""
        f, im = self.model
        if not self.outside:
            return f"the coil current is the sinusoid at f = {f:g} Hz, I_m = {im:g} A"
        fm, am = self.measured
        seen = {"frequency": f"it oscillates at {fm:.4g} Hz",
                "amplitude": f"its amplitude is {am:.4g} A",
                "offset": "it is offset from zero",
                "standing still": "it stands still (DC, a step's plateau, or a much slower "
                                  "drive)",
                "step": "it steps",
                "start": (f"its first sample, {self.i1:.4g} A, is not the peak I_m of that "
                          "drive at its start, and one sample does not tell which arc of "
                          "the loop it is on (eq 31's quadrature takes the + branch: a "
                          "current at rest, u = 0, shows the B, M and F of the quadrature "
                          "term alone); the flag stays while the current does not move"),
                }[REASONS[self.reason]]
        return (f"the coil current departs from the operating point of the complex-"
                f"permeability model (eqs 1-2, 31: i = I_m cos(2 pi f t) with f = {f:g} Hz, "
                f"I_m = {im:g} A): {seen} (tolerances {FREQUENCY_TOLERANCE:.0%} in "
                f"frequency, {AMPLITUDE_TOLERANCE:.0%} in amplitude); the outputs are outside "
                "the model's design point")

    def depart(self, reason: int) -> None:
        """Set the verdict outside, for ``reason`` (an index of :data:`REASONS`)."""
        if not self.outside:
            self.departures += 1
        self.outside, self.reason = True, reason

    # -- observation ------------------------------------------------------------------
    def observe(self, current: float, step: float):
        """Take the current held over the next ``step`` seconds; return a new (f, I_m) or None.

        The return value is not None only with ``follow``, when a full period showed a
        clean sinusoid of another frequency or amplitude: the owner should move the
        model there (the monitor already judges against it). Called at every step, so
        written for plain floats and few attribute lookups.
        """
        i, t, i1 = current, self.time, self.i1
        retune = None
        if self.steps:
            change = abs(i - i1)  # NaN before the first sample: every comparison False
            if change > self._jump * self.h1 + self._jump0:
                self.depart(5)
            elif (abs(i) < self._still and abs(i1) < self._still
                  and self.h1 <= self._half / 4.0
                  and change < 0.5 * self.model[1] * math.sin(math.pi * self.model[0]
                                                               * self.h1)):
                self.depart(4)
            elif i1 != i1:  # the first sample: inside only at the drive's peak
                if abs(i) < (1.0 - AMPLITUDE_TOLERANCE) * self.model[1]:
                    self.depart(_START)
            elif self.reason == _START and change > 0.0:  # it moves: its branch is known
                self.outside, self.reason = False, 0
        # standing still: the range over every half period
        if i > self.w_high:
            self.w_high = i
        if i < self.w_low:
            self.w_low = i
        self.w_count += 1
        if t - self.w_start >= self._half:
            self._close_window(i, t)
        # zero crossings and the period's extremes
        if i < self._arm:
            self.armed = True
        if self.armed and i1 < 0.0 <= i:
            crossing = self.t1 + (t - self.t1) * (-i1) / (i - i1)
            if self.crossing == self.crossing:  # not NaN: a full period
                retune = self._judge_period(crossing - self.crossing)
            self.crossing, self.armed = crossing, False
            self.high = self.low = i
            self.longest = step
        else:
            if i > self.high:
                self.high = i
            if i < self.low:
                self.low = i
            i0 = self.i2
            if (i1 >= i0 and i1 >= i) or (i1 <= i0 and i1 <= i):  # NaN compares False
                self._refine(i0, i1, i, t)
            if step > self.longest:
                self.longest = step
        self.i2, self.t2 = i1, self.t1
        self.i1, self.t1, self.h1 = i, t, step
        self.time = t + step
        return retune

    def _refine(self, i0, i1, i, t):
        """A local extreme at the previous sample: the parabola's peak counts too."""
        peak = _parabola_extreme(self.t2, i0, self.t1, i1, t, i)
        if peak is not None:
            if peak > self.high:
                self.high = peak
            if peak < self.low:
                self.low = peak

    def _close_window(self, i, t):
        longest_allowed = self._half / 4.0  # steps of at most T/8
        if (self.w_count >= 3 and self.longest <= longest_allowed
                and self.w_high - self.w_low < self._still):
            self.depart(4)
        self.w_start, self.w_high, self.w_low, self.w_count = t, i, i, 1

    def _judge_period(self, period):
        f, im = self.model
        fm = 1.0 / period
        am = 0.5 * (self.high - self.low)
        offset = 0.5 * (self.high + self.low)
        self.measured = (fm, am)
        sampling = 1.0 - math.cos(math.pi * fm * self.longest)  # a sampled peak's shortfall
        off_f = abs(fm / f - 1.0) > FREQUENCY_TOLERANCE
        off_a = abs(am / im - 1.0) > AMPLITUDE_TOLERANCE + sampling
        off_o = abs(offset) > (AMPLITUDE_TOLERANCE + sampling) * im
        if self.follow and (off_f or off_a) and not off_o and 0.0 < fm <= 1000.0 and am > 0.0:
            self.set_model((fm, am))
            self.outside, self.reason = False, 0
            return self.model
        if off_f or off_a or off_o:
            self.depart(1 if off_f else 2 if off_a else 3)
        else:
            self.outside, self.reason = False, 0
        return None


def _parabola_extreme(t0, i0, t1, i1, t2, i2):
    """Extreme value of the parabola through three samples, or None if it is a line."""
    d0, d2 = t0 - t1, t2 - t1
    if not (d0 < 0.0 < d2):
        return None
    # i(x) = i1 + b x + c x^2 with x = t - t1
    s0, s2 = (i0 - i1) / d0, (i2 - i1) / d2
    c = (s2 - s0) / (d2 - d0)
    b = s0 - c * d0
    if c == 0.0:
        return None
    x = -b / (2.0 * c)
    if not (d0 <= x <= d2):
        return None
    return i1 + b * x + c * x * x
