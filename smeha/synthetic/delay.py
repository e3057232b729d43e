"""Truth of ``transport_delay``: a delay line on the displacement sensor."""
from __future__ import annotations

import numpy as np
from scipy.interpolate import CubicSpline

from gmt.forward import bias_displacement

__all__ = ["delayed"]


def delayed(params, time, displacement, delay):
    """The displacement record read through a delay line, y(t_k - tau), [m].

    The sensor's analog output is the smooth displacement y(t) delayed by tau;
    it is rebuilt from the finely sampled record (256 samples a period by
    default) by a cubic spline (:class:`scipy.interpolate.CubicSpline`, not-a-knot;
    interpolation error ~ (w h)^4 / 384, 1e-9 of the amplitude) and read at
    t_k - tau. Before t = 0 the rod rests at the bias displacement.
    """
    t = np.asarray(time, dtype=float)
    y = np.asarray(displacement, dtype=float)
    # the record's first sample is the rest state before the step: spline from
    # the second sample on, so the start jump does not ring into the record
    spline = CubicSpline(t[1:], y[1:])
    ts = t - delay
    out = np.full(t.size, bias_displacement(params))
    inside = ts >= t[1]
    out[inside] = spline(ts[inside])
    # between the rest state and the first settled sample: linear
    ramp = (ts >= t[0]) & ~inside
    out[ramp] = np.interp(ts[ramp], t[:2], y[:2])
    return out
