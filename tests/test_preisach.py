"""The Preisach candidate family (gmt.extensions.preisach) and its penalised NNLS fit.

References: I. D. Mayergoyz, *Mathematical Models of Hysteresis and Their Applications*,
Elsevier 2003, ch. 1 (relays, the loop area of a relay 2 (a - b), the demagnetised state);
Hastie, Tibshirani & Friedman, *The Elements of Statistical Learning*, 2009, sec. 7.6 (the
effective degrees of freedom of a penalised fit, trace of its hat matrix).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

import gmt
from gmt.extensions.preisach import (COERCIVE_GRID, INTERACTION_GRID, FinerPreisachForm,
                                     PreisachForm, _relays, node_grid, node_harmonics,
                                     projected_weights, relay_harmonics, synthesise)
from smeha.diagnose.linearfit import effective_dof

H_MAX = 14000.0
#: node weights of the diagnosis' density (coercive x interaction nodes)
N_NODES = COERCIVE_GRID[2] * INTERACTION_GRID[2]


def stepped_relays(a, b, weights, field):
    """Brute force: each relay switched sample by sample from the demagnetised state (up
    iff its loop centre is below 0), the output sum w R less its value there."""
    hu = 0.5 * (a + b)
    state = np.where(hu < 0, 1.0, np.where(hu > 0, -1.0, 0.0))
    rest = weights @ state
    out = np.empty(field.size)
    for k, h in enumerate(field):
        state = np.where(h >= a, 1.0, np.where(h <= b, -1.0, state))
        out[k] = weights @ state - rest
    return out


@pytest.mark.parametrize("amplitude", [H_MAX, 0.6 * H_MAX, 0.2 * H_MAX])
def test_closed_form_harmonics_match_relays_switched_in_time(amplitude):
    # the exact Fourier series of the periodic relays against relays switched sample by
    # sample over two periods (4000 samples: the switching instants are late by up to one
    # sample, 2 pi / 4000 = 1.6e-3 rad; harmonics agree to that order)
    hc, hu = node_grid(H_MAX)
    a, b, weight = _relays(tuple(hc), tuple(hu))
    w = np.random.default_rng(1).uniform(0.0, 3e3, weight.shape[1])
    theta = np.linspace(0, 2 * np.pi, 4000, endpoint=False)
    stepped = stepped_relays(a, b, weight @ w, amplitude * np.cos(np.tile(theta, 2)))[4000:]
    coeff = w @ node_harmonics(hc, hu, amplitude)
    measured = 2.0 * np.fft.rfft(stepped)[:9] / theta.size
    assert np.abs(measured[1:] - coeff[1:9]).max() <= 2e-3 * abs(coeff[1])
    assert abs(measured[0].real - coeff[0].real) <= 2e-3 * abs(coeff[1])
    # the synthesised waveform is the band-limited series of the relays: it converges in the
    # mean square (Parseval: its error is the energy of the harmonics above the band), not
    # uniformly at the relays' jumps (Gibbs), which cluster near the drive's crest where the
    # relays with interaction fields near the amplitude switch within a few samples
    err = synthesise(coeff, theta)[0] - stepped
    assert math.sqrt(np.mean(err * err)) <= 0.01 * np.ptp(stepped)


def test_periodic_output_of_several_runs_matches_relays_switched_in_time():
    # PreisachForm.periodic_output (one density, or one density per row as the fit's stacked
    # Jacobian asks, rows at repeated amplitudes) against the relays stepped sample by
    # sample over two periods, each row alone; rate factor 1 (f_r = inf). The band-limited
    # series against the stepped relays: rms within 1 % of the swing (Parseval, as above)
    hc, hu = node_grid(H_MAX)
    a, b, weight = _relays(tuple(hc), tuple(hu))
    rng = np.random.default_rng(4)
    amplitudes = np.array([H_MAX, 0.6 * H_MAX, H_MAX, 0.2 * H_MAX])
    rows = rng.uniform(0.0, 3e3, (amplitudes.size, weight.shape[1]))
    theta = np.linspace(0, 2 * np.pi, 2000, endpoint=False)
    values = {"weights_A_per_m": rows, "coercive_fields_A_per_m": list(hc),
              "interaction_fields_A_per_m": list(hu), "rate_frequency_Hz": math.inf,
              "rate_exponent": 1.0}
    out = PreisachForm.periodic_output(values, amplitudes, theta)
    assert out.shape == (amplitudes.size, theta.size)
    for r, hm in enumerate(amplitudes):
        stepped = stepped_relays(a, b, weight @ rows[r], hm * np.cos(np.tile(theta, 2)))[2000:]
        err = out[r] - stepped
        assert math.sqrt(np.mean(err * err)) <= 0.01 * np.ptp(stepped)
    # one density for every run: each row as that density alone
    one = PreisachForm.periodic_output(dict(values, weights_A_per_m=rows[1]), amplitudes, theta)
    for r, hm in enumerate(amplitudes):
        alone = PreisachForm.periodic_output(dict(values, weights_A_per_m=rows[1]), [hm], theta)
        assert np.allclose(one[r], alone[0], rtol=0, atol=1e-9 * np.ptp(alone))


@pytest.mark.parametrize("spread", [0.3, 1.0])
def test_a_density_carried_to_the_finer_grid_is_the_same_population(spread):
    # a smooth population (log-normal in h_c about 0.3 H_max, normal in h_u about
    # 0.05 H_max) on the diagnosis' grid, and projected_weights' weights for it on the
    # finer one, each switched relay by relay over two periods (stepped_relays, not the
    # closed form the projection matches): the same loops at every drive level. The
    # finer grid's relays sit elsewhere, so a density that curves within one coarse cell
    # (0.35 in ln h_c) is matched, not reproduced. Measured: within 1.03 % of the H_max
    # loop's swing at 0.1-1 H_max (tolerance 1.5 %); of each loop's own swing 2.4 % at
    # 0.4 H_max and 0.8 % at H_max (tolerance 3 %; bilinear interpolation of the density
    # instead measures 3.1 % and 1.2 %). The total weight (the
    # saturation magnetisation) is not matched as such, only the outputs, and the relays
    # by the triangle's edge switch at H_max alone: within 1 % (0.02 % and 0.48 %)
    hc, hu = node_grid(1.0)
    c, u = np.meshgrid(np.log(hc), hu, indexing="ij")
    w = np.exp(-(c - math.log(0.3)) ** 2 / spread - (u - 0.05) ** 2 / (0.1 * spread)).ravel()
    w *= 1e5 / w.sum()
    fine = projected_weights(w, PreisachForm.grid, FinerPreisachForm.grid)
    assert fine.size == FinerPreisachForm.fit.size - 2
    assert np.all(fine >= 0)
    assert fine.sum() == pytest.approx(w.sum(), rel=1e-2)
    theta = np.linspace(0, 2 * np.pi, 2000, endpoint=False)
    swing = None
    for amplitude in (H_MAX, 0.7 * H_MAX, 0.4 * H_MAX, 0.1 * H_MAX):
        field = amplitude * np.cos(np.tile(theta, 2))
        loops = []
        for cls, weights in ((PreisachForm, w), (FinerPreisachForm, fine)):
            a, b, weight = _relays(*(tuple(g) for g in node_grid(H_MAX, *cls.grid)))
            loops.append(stepped_relays(a, b, weight @ weights, field)[2000:])
        swing = np.ptp(loops[0]) if swing is None else swing
        miss = np.abs(loops[1] - loops[0]).max()
        assert miss <= 0.015 * swing
        if amplitude >= 0.4 * H_MAX:
            assert miss <= 0.03 * np.ptp(loops[0])


def test_loss_per_cycle_is_the_relays_loop_area_and_never_negative():
    # Mayergoyz 2003, sec. 1.2: a relay's loop in (H, M) has area 2 (a - b); a population
    # with a nonnegative density loses sum w_i 2 (a_i - b_i) per cycle. Here the loss per
    # cycle from the closed form's fundamental, pi H_m |Im c_1| with c_1 lagging
    # (the work H dM, only the fundamental of M contributes for a sinusoidal H)
    hc, hu = node_grid(H_MAX)
    a, b, weight = _relays(tuple(hc), tuple(hu))
    rng = np.random.default_rng(2)
    for amplitude in (H_MAX, 0.5 * H_MAX):
        w = rng.uniform(0.0, 2e3, weight.shape[1])
        c1 = (w @ node_harmonics(hc, hu, amplitude))[1]
        loss = -math.pi * amplitude * c1.imag  # J/m^3 / mu_0 per cycle: int H dM
        switched = (a <= amplitude) & (b >= -amplitude)
        area = float(np.sum((weight @ w)[switched] * 2.0 * (a - b)[switched]))
        assert c1.imag < 0  # M lags H: the loop runs anticlockwise
        assert loss == pytest.approx(area, rel=1e-9)


def test_a_relay_that_switches_at_half_the_amplitude_is_a_shifted_square_wave():
    # relay (a, b) = (H_m/2, -H_m/2) under H_m cos(theta): down where H falls to -H_m/2
    # (theta = 2 pi/3), up where it rises to H_m/2 (5 pi/3): +1 on a rectangle of width pi
    # centred on pi/6, whose Fourier coefficients are e^{-j k pi/6} 4 sin(k pi/2)/(pi k)
    # (the shifted rectangle's series), and mean 0
    c = relay_harmonics(np.array([0.5]), np.array([-0.5]), 1.0, 5)[0]
    for k in (1, 2, 3, 4, 5):
        expected = np.exp(-1j * k * math.pi / 6) * 4.0 * math.sin(k * math.pi / 2) / (math.pi * k)
        assert c[k] == pytest.approx(expected, abs=1e-12)
    assert c[0].real == pytest.approx(0.0, abs=1e-12)


def test_relays_the_drive_cannot_switch_stay_in_their_rest_state_and_add_nothing():
    # a > H_m: ends down, as its demagnetised state (h_u > 0); b < -H_m: ends up, as its
    # (h_u < 0); neither: keeps it (Mayergoyz 2003, sec. 1.3). Measured from the
    # demagnetised state (the module docstring's convention), each adds 0
    c = relay_harmonics(np.array([2.0, 0.2, 3.0]), np.array([0.5, -2.0, -3.0]), 1.0, 3)
    assert np.all(c == 0)
    # a relay that switches: its mean less its rest state. At +-H_m/2 (h_u = 0, rest 0)
    # it is down for theta in [2 pi/3, 5 pi/3), half the period: mean 0. At (0.8, 0.2)
    # H_m (h_u = 0.5 > 0, rest -1) it is up for theta in [-arccos 0.8, arccos 0.2): mean
    # (arccos 0.8 + arccos 0.2)/pi - 1, plus 1
    c = relay_harmonics(np.array([0.5, 0.8]), np.array([-0.5, 0.2]), 1.0, 3)
    assert c[0, 0].real / 2 == pytest.approx(0.0, abs=1e-12)
    assert c[1, 0].real / 2 == pytest.approx(
        (math.acos(0.8) + math.acos(0.2)) / math.pi - 1.0 + 1.0)


def test_rate_factor_is_one_half_at_its_frequency_and_one_in_the_rate_independent_limit():
    v = {"rate_frequency_Hz": 100.0, "rate_exponent": 2.0}
    assert PreisachForm.rate_factor(v, 100.0) == pytest.approx(0.5)
    assert PreisachForm.rate_factor(v, 0.0) == 1.0
    assert PreisachForm.rate_factor({"rate_frequency_Hz": math.inf, "rate_exponent": 2.0},
                                    1e4) == 1.0


def test_bad_density_refused_by_name():
    good = PreisachForm.from_fit((4.0, 2.0) + (1.0,) * N_NODES, {"field_max": H_MAX})
    gmt.ModelVariant("rate_independent_hysteresis", good, "preisach")
    with pytest.raises(gmt.ParameterError, match="weights_A_per_m has 3 values"):
        gmt.ModelVariant("rate_independent_hysteresis", dict(good, weights_A_per_m=[1, 2, 3]),
                         "preisach")
    with pytest.raises(gmt.ParameterError, match=r"weights_A_per_m\[0\] = -1"):
        gmt.ModelVariant("rate_independent_hysteresis",
                         dict(good, weights_A_per_m=[-1.0] + [1.0] * (N_NODES - 1)),
                         "preisach")


def test_effective_dof_is_the_free_count_without_penalty_and_falls_with_it():
    # the trace of a ridge hat matrix: p for lambda = 0 (full column rank), decreasing in
    # lambda (Hastie et al. 2009, eq. 3.50 and sec. 7.6)
    rng = np.random.default_rng(3)
    jac = rng.normal(size=(300, N_NODES))
    pen = PreisachForm.smoothness()
    free = np.ones(N_NODES, bool)
    assert effective_dof(jac, pen, 0.0, free) == pytest.approx(N_NODES, rel=1e-6)
    dfs = [effective_dof(jac, pen, lam, free) for lam in (1e-2, 1.0, 1e2, 1e4)]
    assert all(x > y for x, y in zip(dfs, dfs[1:]))
    # a quadratic (plane) density is not penalised by second differences: df -> 3 ... plus
    # nothing else as lambda grows (the penalty's null space: constant and linear per axis)
    assert effective_dof(jac, pen, 1e9, free) == pytest.approx(
        N_NODES - np.linalg.matrix_rank(pen), abs=0.05)
    free[:10] = False
    assert effective_dof(jac, pen, 0.0, free) == pytest.approx(N_NODES - 10, rel=1e-6)
