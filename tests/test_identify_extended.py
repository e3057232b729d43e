"""The extended loss law identified from sinusoidal runs (smeha.identify.fit_extended_losses)."""
import math
from types import SimpleNamespace

import numpy as np
import pytest

from smeha.coreloss.measurements import WAVEFORMS, CoreLossData
from smeha.coreloss.models import ExtendedLaw
from smeha.identify import fit_extended_losses

#: A truth with hysteresis, a rate field steeper than eddy currents and a relaxation.
TRUTH = ExtendedLaw(hysteresis_coefficient=8.6e4, steinmetz_exponent=1.8, eddy_coefficient=0.0,
                    excess_coefficient=0.0, rate_coefficient=0.5, rate_exponent=2.4,
                    swing_exponent=2.2, relaxation_coefficient=2e5, relaxation_time=2e-4)


def _runs(freqs, amps, seed=1):
    rng = np.random.default_rng(seed)
    f, b = (a.ravel() for a in np.meshgrid(freqs, amps))
    n = len(f)
    rows = CoreLossData("truth", f, b, np.full(n, WAVEFORMS.index("sine")), -np.ones((n, 4)),
                        np.zeros((n, 4)), np.zeros((n, 4)), np.ones(n))
    loss = TRUTH.predict(rows) * (1.0 + 0.005 * rng.standard_normal(n))  # 0.5 % noise
    return [SimpleNamespace(frequency=fk, flux_density_amplitude=bk, mu_imag=1.0,
                            loss_density=pk) for fk, bk, pk in zip(f, b, loss)], rows


def test_recovers_the_loss_of_seeded_runs():
    # synthetic runs from TRUTH's closed-form sinusoidal losses (gmt.timedomain.dynamic),
    # 5-500 Hz x 3 amplitudes with 0.5 % noise; the law must reproduce the truth's loss
    # within 2 % also at frequencies between the runs (the parameters themselves trade off)
    runs, _ = _runs(np.geomspace(5.0, 500.0, 6), [0.03, 0.06, 0.1])
    law, why = fit_extended_losses(runs)
    assert law is not None, why
    _, check = _runs(np.geomspace(7.0, 400.0, 5), [0.04, 0.08])
    truth = TRUTH.predict(check)
    np.testing.assert_allclose(law.predict(check), truth, rtol=0.02)


def test_refuses_too_few_runs_or_a_narrow_band():
    runs, _ = _runs([50.0, 100.0, 150.0], [0.03, 0.06, 0.1])
    law, why = fit_extended_losses(runs)
    assert law is None and "needs 10" in why
    runs, _ = _runs(np.linspace(50.0, 100.0, 6), [0.03, 0.06])
    law, why = fit_extended_losses(runs)
    assert law is None and "frequency ratio" in why
