"""The identification's loop model steps eq 27 as one linear filter: the same as gmt.simulate.

smeha.identify evaluates the model displacement some 70 times per run (the mu'' scan,
Brent, the Gauss-Newton step and the sensitivities). It takes the field and its
quadrature part from one gmt.simulate run and then passes each force through the ZOH
recurrence of eq 27 as a linear filter (smeha.identify.zoh_displacement), instead of
gmt.simulate's loop over samples. Both must give the same displacement to rounding.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

import gmt
from smeha.identify import _LoopModel, zoh_displacement
from smeha.measured import Run

P = gmt.TransducerParameters()


def _run(f, per_cycle, cycles=4, jitter=False):
    h = 1.0 / (f * per_cycle)
    t = h * np.arange(int(cycles * per_cycle))
    if jitter:  # non-uniform sample times: the model resamples the current
        t = t + 0.2 * h * np.sin(7.3 * np.arange(t.size))
    i = np.cos(2 * math.pi * f * t) + 1e-3 * np.sin(37.0 * t)
    return Run(f"f{f:g}", f, t, i, np.zeros_like(t), None)


def test_zoh_displacement_is_gmt_simulate():
    rng = np.random.default_rng(1)
    h = 1 / 12800
    point = gmt.operating_point(P, gmt.Excitation(50.0, 1.0))
    i = np.cos(2 * math.pi * 50 * h * np.arange(1024)) + 0.01 * rng.standard_normal(1024)
    out = gmt.simulate(P, point, i, h)
    y = zoh_displacement(P, out["force"], h)
    assert np.max(np.abs(y - out["displacement"])) < 1e-12 * np.ptp(out["displacement"])
    assert y[0] == gmt.bias_displacement(P)  # the rest state, as gmt.simulate


@pytest.mark.parametrize("f, per_cycle, oversample, jitter", [
    (5.0, 2000, 1, False), (200.0, 256, 1, False), (50.0, 200, 4, False), (50.0, 200, 1, True)])
def test_loop_model_is_gmt_simulate(f, per_cycle, oversample, jitter):
    run = _run(f, per_cycle, jitter=jitter)
    model = _LoopModel(run, P, 1.0, oversample)
    for bm, mu in ((0.06, 0.3), (0.05, 1.2), (0.06, 0.0)):
        y = model.predict(bm, mu)
        ref = gmt.simulate(P, model.point(bm, mu), model.current, model.step)["displacement"]
        if model.resampled:
            ref = np.interp(run.time, model.grid, ref)
        ref = ref[model.mask]
        assert np.max(np.abs(y - ref)) < 1e-12 * np.ptp(ref)
