"""Model variants (issue #5, item 6): the extended model time-stepped in gmt.Transducer.

The stepped forms are checked against the periodic forms the diagnosis evaluates
(``smeha.diagnose._Evaluator.predict``, a separate code path: harmonic balance on a grid
with the ZOH frequency response of eq 27), after running long enough under a sinusoidal
current to reach the periodic steady state.
"""
from __future__ import annotations

import math
import pickle
from types import SimpleNamespace

import numpy as np
import pytest

import gmt
from gmt import extensions as ext
from gmt.variants import FORMS, VARIANTS, ModelVariant, SectionBank
from smeha import diagnose

P = gmt.TransducerParameters()
F, H = 100.0, 1e-5  # operating point and step: 1000 samples a period
W = 2 * math.pi * F
N = int(round(1 / (F * H)))
#: H_m at 1 A with Table 2 (eq 1): 14773 A/m; play thresholds at 0.2 ... 0.8 of it
THRESHOLDS = [2954.5, 5909.1, 8863.6, 11818.2]

#: cause -> (SI parameters, the diagnosis' internal parametrisation of the same extension
#: (smeha.diagnose.candidates / physical_parameters)).
CASES = {
    "rate_independent_hysteresis": (
        {"thresholds_A_per_m": THRESHOLDS, "weights": [0.3, 0.2, 0.1, 0.05]}, (3, 2, 1, 0.5)),
    "magnetization_saturation": (
        {"saturation_magnetization_A_per_m": 4e5}, (250e3 / 4e5,)),
    "eddy_current_diffusion": (
        {"time_constant_s": 1.6e-3, "order": 0.5}, (math.log10(1.6e-3), 0.5)),
    "transport_delay": ({"delay_s": 3.37e-4}, (0.337,)),
    "mechanical_resonance": (
        {"mass_kg": 4e-4, "damping_N_s_per_m": 58.9, "stiffness_N_per_m": 1.905e7},
        (0.02, 0.02, 1.905e7 / 1.963e7)),
    "thermal_drift": (
        {"offset_rate_m_per_A2s": 1e-4, "gain_rate_per_A2s": 0.5,
         "thermal_time_constant_s": math.inf}, (100.0, 50.0, 30.0)),
}

#: Largest |Y_k(stepped) - Y_k(periodic)| / |Y_1|, k = 1..8, for y and B. Why each:
#: saturation and mechanics are exact per sample (round-off; the diagnosis takes the
#: fundamental on 128 points, gmt on 4096, the tanh's harmonics beyond 127 are nil);
#: hysteresis: the plays on samples miss the peak by (w h)^2 and the diagnosis' 128-point
#: remainder aliases harmonics ~127 (~1e-5 measured); eddy: the section bank's fit error
#: (2.5e-4 at most, 5e-5 measured here) plus (w h)^2 / 12 = 3.3e-6 of the step mean;
#: delay: linear interpolation between samples, (w h)^2 / 8 at most.
TOLERANCE = {"rate_independent_hysteresis": 1e-4, "magnetization_saturation": 1e-10,
             "eddy_current_diffusion": 2e-4, "transport_delay": 1e-5,
             "mechanical_resonance": 1e-10}


def variant(cause):
    return ModelVariant(cause, CASES[cause][0])


def run(tr, periods):
    """Step ``tr`` with i = cos(w t_k) A: y and sensed y at t_k (before step k), B over step k."""
    n = N * periods
    y, s, b = np.empty(n), np.empty(n), np.empty(n)
    y_prev, s_prev = tr.forward.displacement, tr.sensed_displacement
    for k in range(n):
        out = tr.step(math.cos(W * k * H), H)
        y[k], s[k], b[k] = y_prev, s_prev, out.magnetics.flux_density
        y_prev, s_prev = out.displacement, out.sensed_displacement
    return y, s, b


def periodic(cause, extra):
    """The diagnosis' periodic Y_k, B_k (k = 1..8) at the operating point, Table 2 losses."""
    ev = diagnose._Evaluator(P, tuple(THRESHOLDS))
    rf = SimpleNamespace(frequency=F, angular_frequency=W, current_amplitude=1.0, step=H,
                         flux_density_amplitude=gmt.DEFAULT_CALIBRATION.flux_density_amplitude(
                             F, 1.0))
    loss = (P.hysteresis_coefficient, P.steinmetz_exponent, P.eddy_coefficient,
            P.excess_coefficient)
    y, b, _, _ = ev.predict(rf, loss, cause, extra)
    return y, b


def harmonics(x):
    return 2.0 * np.fft.rfft(x)[1:9] / x.size


# ------------------------------------------------------------------ the variant object


def test_every_cause_of_the_diagnosis_has_a_step_form():
    # a cause the diagnosis can name but the product cannot run fails here: add its
    # StepForm to gmt.variants.FORMS (one class, one entry)
    assert {c for c, _ in FORMS} == set(ext.CAUSES)
    assert VARIANTS == ("paper",) + ext.CAUSES  # one (default) form each so far
    assert set(CASES) == set(ext.CAUSES)


@pytest.mark.parametrize("cause", ext.CAUSES)
def test_parameters_are_the_diagnosis_si_parameters(cause):
    # the keys are those smeha diagnose --json reports for the candidate
    internal = CASES[cause][1]
    context = {"params": P, "thresholds": tuple(THRESHOLDS)}
    reported = diagnose.physical_parameters(cause, internal, context)
    v = ModelVariant(cause, reported)
    assert set(v.parameters) == set(reported)
    assert ModelVariant.from_dict(v.as_dict()) == v
    assert pickle.loads(pickle.dumps(v)) == v and hash(v) == hash(ModelVariant(cause, reported))


def test_default_is_the_paper():
    assert ModelVariant().is_paper and ModelVariant() == ModelVariant("paper", {})
    assert gmt.Transducer().variant.is_paper


@pytest.mark.parametrize("cause, parameters, words", [
    ("maxwell", {}, ["cause", "maxwell", "transport_delay"]),
    ("transport_delay", {}, ["missing", "delay_s"]),
    ("transport_delay", {"delay_s": 1e-3, "tau": 1.0}, ["unknown", "tau"]),
    ("paper", {"delay_s": 1e-3}, ["unknown", "delay_s"]),
    ("transport_delay", {"delay_s": -1e-3}, ["delay_s = -0.001 s", "[0, 0.1] s"]),
    ("transport_delay", {"delay_s": "1 ms"}, ["delay_s", "not a number"]),
    ("eddy_current_diffusion", {"time_constant_s": 1e-3, "order": 1.5}, ["order = 1.5",
                                                                         "(0, 1]"]),
    ("mechanical_resonance", {"mass_kg": 0.0, "damping_N_s_per_m": 1.0,
                              "stiffness_N_per_m": 1.0}, ["mass_kg = 0 kg", "(0, inf)"]),
    ("rate_independent_hysteresis", {"thresholds_A_per_m": [1.0, 2.0], "weights": [1.0]},
     ["equal length"]),
    ("rate_independent_hysteresis", {"thresholds_A_per_m": 1.0, "weights": [1.0]},
     ["thresholds_A_per_m", "list"]),
    ("thermal_drift", {"offset_rate_m_per_A2s": math.nan, "gain_rate_per_A2s": 0.0,
                       "thermal_time_constant_s": 1.0}, ["offset_rate_m_per_A2s = nan"]),
])
def test_bad_variants_are_refused_naming_the_parameter(cause, parameters, words):
    with pytest.raises(gmt.ParameterError) as err:
        ModelVariant(cause, parameters)
    for word in words:
        assert word in str(err.value)


def test_saturation_below_the_bias_is_refused_with_the_range():
    v = ModelVariant("magnetization_saturation", {"saturation_magnetization_A_per_m": 2e5})
    with pytest.raises(gmt.ParameterError, match=r"saturation_magnetization_A_per_m = 200000 "
                                                 r"A/m .*bias_magnetization = 250000"):
        gmt.Transducer(variant=v)


def test_from_diagnosis_takes_the_winner_none_and_a_named_candidate():
    cands = [{"cause": c, "parameters": diagnose.physical_parameters(
        c, CASES[c][1], {"params": P, "thresholds": tuple(THRESHOLDS)})} for c in ext.CAUSES]
    d = {"cause": "transport_delay", "candidates": cands, "gain": 3.0}
    assert ModelVariant.from_diagnosis(d) == variant("transport_delay")
    assert ModelVariant.from_dict(d) == variant("transport_delay")
    assert ModelVariant.from_diagnosis(d, cause="mechanical_resonance") == variant(
        "mechanical_resonance")
    assert ModelVariant.from_diagnosis(dict(d, cause="none")).is_paper
    with pytest.raises(gmt.ParameterError, match="unexplained.*explicitly"):
        ModelVariant.from_diagnosis(dict(d, cause="unexplained"))
    assert ModelVariant.from_diagnosis(dict(d, cause="unexplained"),
                                       cause="thermal_drift").cause == "thermal_drift"
    small = '{"cause": "transport_delay", "parameters": {"delay_s": 0.000337}, "provenance": "x"}'
    assert ModelVariant.from_json(small) == variant("transport_delay")
    with pytest.raises(gmt.ParameterError, match="JSON"):
        ModelVariant.from_json("{cause: paper}")


def test_a_cause_with_several_formulations_takes_the_named_or_best_one():
    # smeha diagnose may fit a cause in several forms (e.g. the eddy currents as a lag or as
    # diffusion into a slab); the winner's "form" picks the candidate, else the best score
    lag = {"cause": "eddy_current_diffusion", "form": "lag", "score": 90.0,
           "parameters": {"time_constant_s": 1e-3, "order": 0.5}}
    slab = {"cause": "eddy_current_diffusion", "form": "slab", "score": 80.0,
            "parameters": {"time_constant_s": 2e-3}}
    d = {"cause": "eddy_current_diffusion", "form": "lag", "candidates": [slab, lag]}
    v = ModelVariant.from_diagnosis(d)
    assert (v.form, v.parameters["order"]) == ("lag", 0.5) and v.name == "eddy_current_diffusion"
    # without the winner's form the best score wins: a form with no step form is refused,
    # naming it
    with pytest.raises(gmt.ParameterError, match="form = 'slab'.*no step form"):
        ModelVariant.from_diagnosis({k: d[k] for k in ("cause", "candidates")})
    assert ModelVariant("eddy_current_diffusion", lag["parameters"]) == v  # default form
    assert ModelVariant.from_name("eddy_current_diffusion", lag["parameters"]) == v


# ------------------------------------------------------------------ the default is unchanged


def test_paper_variant_steps_bit_identically_to_the_default_and_to_simulate():
    point = gmt.operating_point(P, gmt.Excitation(F, 1.0))
    i = np.cos(W * H * np.arange(3 * N))
    ref = gmt.simulate(P, point, i, H)
    for tr in (gmt.Transducer(P, gmt.Excitation(F, 1.0)),
               gmt.Transducer(P, gmt.Excitation(F, 1.0), variant=ModelVariant("paper"))):
        assert type(tr.forward) is gmt.ForwardStepper
        y = [tr.forward.displacement] + [tr.step(float(u), H).displacement for u in i[:-1]]
        assert np.array_equal(np.array(y), ref["displacement"])
        assert len(tr.get_state()) == 7


# ------------------------------------------------------------------ stepped = periodic


@pytest.mark.parametrize("cause", [c for c in ext.CAUSES if c != "thermal_drift"])
def test_stepped_variant_reaches_the_diagnosis_periodic_form(cause):
    periods = 8  # the slowest memory here is the lag's 1.6 ms: settled after two periods
    y, s, b = run(gmt.Transducer(P, gmt.Excitation(F, 1.0), variant=variant(cause)), periods)
    last = slice(N * (periods - 1), N * periods)
    yk, bk = periodic(cause, CASES[cause][1])
    seen = s if cause == "transport_delay" else y  # the delay acts on the sensed y
    err_y = np.abs(harmonics(seen[last]) - yk).max() / abs(yk[0])
    err_b = np.abs(harmonics(b[last]) - bk).max() / abs(bk[0])
    assert err_y <= TOLERANCE[cause], err_y
    assert err_b <= TOLERANCE[cause], err_b
    # and the variant does change the loop (against the paper's periodic form)
    y0, b0 = periodic("none", ())
    assert np.abs(yk - y0).max() / abs(y0[0]) > 1e-3


@pytest.mark.parametrize("time_constant", [math.inf, 0.03])
def test_stepped_drift_matches_the_diagnosis_drift_form(time_constant):
    # the diagnosis applies the drift to y's samples about its mean (LinearDrift.apply);
    # the stepped form drifts the strain, so the rod lags the drift by the mechanics'
    # time constant (c/K ~ 0.15 ms): 3e-5 (linear dose) and 2e-4 (t_th = 30 ms, the dose
    # rising fastest) of the peak-to-peak measured over 10 periods
    parameters = dict(CASES["thermal_drift"][0], thermal_time_constant_s=time_constant)
    extra = (100.0, 50.0, math.log10(time_constant) if math.isfinite(time_constant) else 30.0)
    v = ModelVariant("thermal_drift", parameters)
    y, _, _ = run(gmt.Transducer(P, gmt.Excitation(F, 1.0), variant=v), 10)
    t = H * np.arange(y.size)
    sel = t >= 1.0 / F
    ev = diagnose._Evaluator(P, (1.0,))
    rf = SimpleNamespace(frequency=F, angular_frequency=W, current_amplitude=1.0, step=H,
                         flux_density_amplitude=gmt.DEFAULT_CALIBRATION.flux_density_amplitude(
                             F, 1.0), time=t[sel], t_start=0.0, t_mid=float(t[sel].mean()),
                         displacement=y[sel], phase=lambda tt: W * np.asarray(tt))
    model = ev.samples(rf, (P.hysteresis_coefficient, P.steinmetz_exponent,
                            P.eddy_coefficient, P.excess_coefficient), "thermal_drift", extra)
    assert np.abs(y[sel] - model).max() <= 5e-4 * np.ptp(y[sel])
    # the drift is there: the offset o u(t) between the second and the last period, 8 um
    # (linear dose) and 0.95 um (t_th = 30 ms)
    dose = ext.LinearDrift(1e-4, 0.5, time_constant).dose(np.array([1.5, 9.5]) / F, 1.0)
    shift = np.mean(y[-N:]) - np.mean(y[N:2 * N])
    assert shift == pytest.approx(1e-4 * (dose[1] - dose[0]), rel=0.02)


def test_first_order_eddy_lag_is_second_order_in_the_step():
    # alpha = 1: one section, stepped by EddyCurrentLag.step; the held field (the step's
    # mean) equals the continuous lag at t_k to (w h)^2 / 12 = 3.3e-6 at 100 Hz, 10 us
    v = ModelVariant("eddy_current_diffusion", {"time_constant_s": 1.6e-3, "order": 1.0})
    y, _, b = run(gmt.Transducer(P, gmt.Excitation(F, 1.0), variant=v), 8)
    last = slice(7 * N, 8 * N)
    yk, bk = periodic("eddy_current_diffusion", (math.log10(1.6e-3), 1.0))
    assert np.abs(harmonics(y[last]) - yk).max() / abs(yk[0]) <= 1e-5
    assert np.abs(harmonics(b[last]) - bk).max() / abs(bk[0]) <= 1e-5
    # the coil still sees the operating point's B_m (mu' re-solved, eq 20 with |g|)
    bm = gmt.DEFAULT_CALIBRATION.flux_density_amplitude(F, 1.0)
    assert abs(harmonics(b[last])[0]) == pytest.approx(bm, rel=1e-5)


@pytest.mark.parametrize("order", [0.3, 0.5, 0.7, 0.9, 0.99])
@pytest.mark.parametrize("time_constant", [1e-6, 1e-3, 0.1])
def test_section_bank_approximates_the_fractional_lag(order, time_constant):
    lag = ext.EddyCurrentLag(time_constant, order)
    bank = SectionBank(lag)
    assert bank.max_relative_error <= 2.5e-4
    assert bank.size <= 37 and np.all(bank.weights > 0) and bank.direct >= 0
    assert bank.weights.sum() + bank.direct == pytest.approx(1.0, abs=1e-12)  # DC gain
    w = 2 * math.pi * np.array([0.0, 1.0, 50.0, 1e3, 2e4, 1e5])
    assert np.abs(bank.transfer(w) / lag.transfer(w) - 1).max() <= 2.5e-4


def test_first_order_bank_is_eddy_current_lag_step():
    lag = ext.EddyCurrentLag(1e-3, 1.0)
    bank = SectionBank(lag)
    assert bank.size == 1 and bank.direct == 0.0
    state = np.zeros((2, 1))
    x = 0.0
    for k in range(50):
        u = math.cos(0.3 * k)
        _, state = bank.step((u, 0.0), state, 2e-5)
        x = lag.step(u, x, 2e-5)
        assert state[0, 0] == x


def test_sensor_delay_moves_only_the_reading_by_the_fifo_of_delay_samples():
    tau = CASES["transport_delay"][0]["delay_s"]
    tr = gmt.Transducer(P, gmt.Excitation(F, 1.0), variant=variant("transport_delay"))
    y, s, _ = run(tr, 2)
    y_paper, _, _ = run(gmt.Transducer(P, gmt.Excitation(F, 1.0)), 2)
    assert np.array_equal(y, y_paper)  # the rod (and so the flow) is the paper's
    # at a fixed step: a FIFO of TransportDelay.delay_samples(h) samples, fraction interpolated
    d = ext.TransportDelay(tau).delay_samples(H)
    n, frac = int(d), d - int(d)
    k = np.arange(n + 1, y.size)
    fifo = (1 - frac) * y[k - n] + frac * y[k - n - 1]
    assert np.abs(s[k] - fifo).max() <= 1e-12 * np.ptp(y)
    assert np.all(s[:n] == y[0])  # before t = tau: the rest reading
    # the delay line holds about tau / h samples
    assert len(tr.get_state()) // 2 - 4 == pytest.approx(d, abs=2)


def test_reidentified_mechanics_rest_on_the_new_stiffness():
    tr = gmt.Transducer(P, variant=variant("mechanical_resonance"))
    force = P.rod_area * P.youngs_modulus * P.magnetostriction_coefficient * 250e3 ** 2
    assert tr.forward.displacement == pytest.approx(force / 1.905e7, rel=1e-14)


# ------------------------------------------------------------------ state


@pytest.mark.parametrize("compensated", [False, True])
@pytest.mark.parametrize("cause", ext.CAUSES)
def test_state_save_restore_replays_bit_identically(cause, compensated):
    drive = gmt.DriveParameters(compensated=compensated)
    tr = gmt.Transducer(P, gmt.Excitation(F, 1.0), drive, variant=variant(cause))
    rng = np.random.default_rng(5)
    # variable steps from a few values (each new step costs a ZOH discretisation)
    steps = rng.choice([4e-6, 1e-5, 2.5e-5, 3.7e-5], 900)
    forces = rng.uniform(-20.0, 20.0, 900)
    t = np.concatenate(([0.0], np.cumsum(steps)))

    def u(k):
        return (1.5 + 1.5 * math.cos(W * t[k])) if compensated else math.cos(W * t[k])

    for k in range(600):
        tr.step(u(k), steps[k], forces[k])
    saved = tr.get_state()
    first = [tuple(tr.step(u(k), steps[k], forces[k])[:3]) + (
        tr.sensed_displacement,) for k in range(600, 900)]
    tr.set_state(saved)
    again = [tuple(tr.step(u(k), steps[k], forces[k])[:3]) + (
        tr.sensed_displacement,) for k in range(600, 900)]
    assert again == first
    other = gmt.Transducer(P, gmt.Excitation(F, 1.0), drive, variant=variant(cause))
    other.set_state(saved)
    assert [tuple(other.step(u(k), steps[k], forces[k])[:3]) + (
        other.sensed_displacement,) for k in range(600, 900)] == first


def test_a_state_of_the_wrong_size_is_refused():
    tr = gmt.Transducer(variant=variant("rate_independent_hysteresis"))
    with pytest.raises(gmt.ParameterError, match="state"):
        tr.set_state(tr.get_state()[:-1])
    with pytest.raises(gmt.ParameterError, match="needs 7"):
        gmt.Transducer().set_state(tr.get_state())
