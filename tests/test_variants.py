"""Model variants (issue #5, item 6): the extended model time-stepped in gmt.Transducer.

The stepped forms are checked against the periodic forms the diagnosis evaluates
(``smeha.diagnose._Evaluator.predict``, a separate code path: harmonic balance on a grid
with the ZOH frequency response of eq 27), after running long enough under a sinusoidal
current to reach the periodic steady state.
"""
from __future__ import annotations

import json
import math
import pickle
from types import SimpleNamespace

import numpy as np
import pytest

import gmt
from gmt import extensions as ext
from gmt.variants import FORMS, VARIANTS, ModalBank, ModelVariant, SectionBank
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

#: The forms other than a cause's first: (cause, form) -> the diagnosis' internal
#: parametrisation (smeha.diagnose.candidates(all_forms=True)); the SI parameters are
#: what smeha.diagnose.physical_parameters reports for it, derived keys included.
#: tau = 1 ms: the skin depth equals the half thickness (radius) at 318 Hz; the joint:
#: half of eq 27's mass on the output, 1 kHz, damping ratio 0.1.
FORM_CASES = {
    ("eddy_current_diffusion", "slab"): (math.log10(1e-3),),
    ("eddy_current_diffusion", "cylinder"): (math.log10(1e-3),),
    ("mechanical_resonance", "two_dof"): (0.5, math.log10(1000.0), 0.1),
}
#: Largest |Y_k(stepped) - Y_k(periodic)| / |Y_1|, k = 1..8, for y and B: the diffusion
#: forms hold each mode's mean over the step, (w h)^2 / 12 = 3.3e-6 at 100 Hz and 10 us
#: (3.2e-6 measured), plus the modal bank's error at 100-800 Hz (below 1e-8); the two masses
#: are the exact ZOH of the 4-state model, as the diagnosis' response (3e-13 measured).
FORM_TOLERANCE = {"slab": 1e-5, "cylinder": 1e-5, "two_dof": 1e-10}
#: Every (cause, form) with a step form.
ALL_FORMS = [(c, "") for c in ext.CAUSES] + list(FORM_CASES)


def si_parameters(cause, form=""):
    if not form:
        return CASES[cause][0]
    return diagnose.physical_parameters(cause, FORM_CASES[cause, form],
                                        {"params": P, "thresholds": tuple(THRESHOLDS)}, form)


def variant(cause, form=""):
    return ModelVariant(cause, si_parameters(cause, form), form)


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


LOSS = (P.hysteresis_coefficient, P.steinmetz_exponent, P.eddy_coefficient,
        P.excess_coefficient)
#: B_m at the operating point (Table 1 calibration, 100 Hz, 1 A)
BM = gmt.DEFAULT_CALIBRATION.flux_density_amplitude(F, 1.0)


def periodic(cause, extra, form=""):
    """The diagnosis' periodic Y_k, B_k (k = 1..8) at the operating point, Table 2 losses."""
    ev = diagnose._Evaluator(P, tuple(THRESHOLDS))
    rf = SimpleNamespace(frequency=F, angular_frequency=W, current_amplitude=1.0, step=H,
                         flux_density_amplitude=BM)
    y, b, _, _ = ev.predict(rf, LOSS, cause, extra, form=form)
    return y, b


def harmonics(x):
    return 2.0 * np.fft.rfft(x)[1:9] / x.size


# ------------------------------------------------------------------ the variant object


def test_every_form_of_the_diagnosis_has_a_step_form():
    # a cause or form the diagnosis can name but the product cannot run fails here: add
    # its StepForm to gmt.variants.FORMS (one class, one entry)
    expected = {(c, f) for c in ext.CAUSES for f in diagnose.FORMS.get(c, ("",))}
    assert set(FORMS) == expected
    assert {(c, f or diagnose.FORMS.get(c, ("",))[0]) for c, f in ALL_FORMS} == expected
    # the first form of each cause is the diagnosis' first (the default, named by the cause)
    for cause, forms in diagnose.FORMS.items():
        assert next(f for c, f in FORMS if c == cause) == forms[0]
    assert VARIANTS == ("paper", "rate_independent_hysteresis", "magnetization_saturation",
                        "eddy_current_diffusion", "eddy_current_diffusion:slab",
                        "eddy_current_diffusion:cylinder", "transport_delay",
                        "mechanical_resonance", "mechanical_resonance:two_dof",
                        "thermal_drift")
    assert set(CASES) == set(ext.CAUSES)


@pytest.mark.parametrize("cause, form", ALL_FORMS)
def test_parameters_are_the_diagnosis_si_parameters(cause, form):
    # the keys are those smeha diagnose --json reports for the candidate
    internal = CASES[cause][1] if not form else FORM_CASES[cause, form]
    context = {"params": P, "thresholds": tuple(THRESHOLDS)}
    reported = diagnose.physical_parameters(cause, internal, context, form)
    v = ModelVariant(cause, reported, form)
    assert set(v.parameters) == set(reported)
    assert ModelVariant.from_dict(v.as_dict()) == v
    assert ModelVariant.from_name(v.name, reported) == v
    assert pickle.loads(pickle.dumps(v)) == v and hash(v) == hash(
        ModelVariant(cause, reported, form))


@pytest.mark.parametrize("form, derived", [
    ("slab", ("skin_depth_equals_size_at_Hz",)),
    ("two_dof", ("joint_frequency_Hz", "joint_damping_ratio"))])
def test_derived_parameters_may_be_left_out_but_must_agree(form, derived):
    cause = "mechanical_resonance" if form == "two_dof" else "eddy_current_diffusion"
    full = si_parameters(cause, form)
    physical = {k: v for k, v in full.items() if k not in derived}
    assert set(ModelVariant(cause, physical, form).parameters) == set(physical)
    for key in derived:
        with pytest.raises(gmt.ParameterError, match=f"{key} = .* disagrees with"):
            ModelVariant(cause, dict(full, **{key: full[key] * 1.01}), form)
    with pytest.raises(gmt.ParameterError, match=r"missing .*expected exactly .*optionally"):
        ModelVariant(cause, {k: full[k] for k in derived}, form)


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
    assert ModelVariant("eddy_current_diffusion", lag["parameters"]) == v  # default form
    assert ModelVariant.from_name("eddy_current_diffusion", lag["parameters"]) == v
    # the winner's form, even when its score is not the cause's best
    won = ModelVariant.from_diagnosis(dict(d, form="slab", candidates=[lag, dict(
        slab, score=95.0)]))
    assert won == ModelVariant("eddy_current_diffusion", {"time_constant_s": 2e-3}, "slab")
    assert won.name == "eddy_current_diffusion:slab"
    # without the winner's form the best score wins
    assert ModelVariant.from_diagnosis({k: d[k] for k in ("cause", "candidates")}).form == "slab"
    # a named candidate and form
    assert ModelVariant.from_diagnosis(d, "eddy_current_diffusion", "slab").form == "slab"
    # a candidate without "form" is its cause's first form (diagnoses written before forms)
    old = {"cause": "eddy_current_diffusion", "form": "lag",
           "candidates": [{k: lag[k] for k in ("cause", "parameters")}, slab]}
    assert ModelVariant.from_diagnosis(old) == v
    # an unknown form, or a form with no candidate, is refused naming it and the forms
    with pytest.raises(gmt.ParameterError, match=r"form = 'sphere' is not a form of "
                                                 r"'eddy_current_diffusion': the allowed forms "
                                                 r"are \['lag', 'slab', 'cylinder'\]"):
        ModelVariant.from_diagnosis(dict(d, form="sphere"))
    with pytest.raises(gmt.ParameterError, match="no candidate of form 'cylinder'.*'lag', "
                                                 "'slab'"):
        ModelVariant.from_diagnosis(dict(d, form="cylinder"))
    with pytest.raises(gmt.ParameterError, match=r"form = 'sphere' .*\['lag', 'slab', "
                                                 r"'cylinder'\]"):
        ModelVariant.from_dict({"cause": "eddy_current_diffusion", "form": "sphere",
                                "parameters": {"time_constant_s": 1e-3}})
    with pytest.raises(gmt.ParameterError, match="one form"):
        ModelVariant("transport_delay", {"delay_s": 1e-3}, "fifo")
    # a small variant JSON may carry the form; without it, the cause's first
    small = '{"cause": "mechanical_resonance", "form": "two_dof", "parameters": %s}'
    two = si_parameters("mechanical_resonance", "two_dof")
    assert ModelVariant.from_json(small % json.dumps(two)) == variant("mechanical_resonance",
                                                                      "two_dof")
    with pytest.raises(gmt.ParameterError, match="unknown 'rod_mass_kg'"):
        ModelVariant.from_json(small.replace('"form": "two_dof", ', "") % json.dumps(two))


def test_from_diagnosis_of_the_diagnose_json_takes_the_winning_form():
    # the shape of smeha diagnose --json (Diagnosis.as_dict): top-level cause and form, every
    # form of every cause a candidate with its own form and SI parameters
    context = {"params": P, "thresholds": tuple(THRESHOLDS)}
    cands = []
    for cause, form in ALL_FORMS:
        internal = CASES[cause][1] if not form else FORM_CASES[cause, form]
        cands.append({"cause": cause, "form": form or diagnose.FORMS.get(cause, ("",))[0],
                      "score": 100.0, "parameters": diagnose.physical_parameters(
                          cause, internal, context, form)})
    for cand in cands:
        d = {"cause": cand["cause"], "form": cand["form"], "candidates": cands}
        v = ModelVariant.from_diagnosis(d)
        assert v == ModelVariant(cand["cause"], cand["parameters"], cand["form"])
        assert (v.cause, v.form) == (cand["cause"], cand["form"])


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


@pytest.mark.parametrize("cause, form", list(FORM_CASES))
def test_stepped_form_reaches_the_diagnosis_periodic_form(cause, form):
    # the diagnosis' periodic model of this very form (_Evaluator.predict with form=...)
    periods = 8  # slowest memory: the joint's ring-down 1/(zeta w_j) = 1.6 ms
    y, s, b = run(gmt.Transducer(P, gmt.Excitation(F, 1.0), variant=variant(cause, form)),
                  periods)
    last = slice(N * (periods - 1), N * periods)
    yk, bk = periodic(cause, FORM_CASES[cause, form], form)
    err_y = np.abs(harmonics(y[last]) - yk).max() / abs(yk[0])
    err_b = np.abs(harmonics(b[last]) - bk).max() / abs(bk[0])
    assert err_y <= FORM_TOLERANCE[form], err_y
    assert err_b <= FORM_TOLERANCE[form], err_b
    assert np.array_equal(s, y)  # the sensor reads the displacement (the output's, two_dof)
    y0, _ = periodic("none", ())
    assert np.abs(yk - y0).max() / abs(y0[0]) > 5e-3  # 0.22 slab, 0.25 cylinder, 0.010 joint
    if cause == "eddy_current_diffusion":
        # the mean strain carries the time average of the section's <M^2>,
        # |M_s|^2 <|g|^2> / 2: c (M_b^2 + |M_s|^2 <|g|^2> / 2) / K, with M_s the surface
        # magnetisation as the diagnosis computes it and <|g|^2> the closed form of
        # EddyCurrentDiffusion.mean_squares (the ZOH keeps the static gain 1/K)
        dif = ext.EddyCurrentDiffusion(10.0 ** FORM_CASES[cause, form][0], form)
        hm = P.field_per_ampere
        b_s = BM / abs(complex(dif.transfer(W)))
        mod = b_s / (gmt.constants.MU_0 * hm)
        mu_i = diagnose._mu_imag(LOSS, F, b_s, hm)
        m_s = abs(complex(math.sqrt(mod ** 2 - mu_i ** 2) - 1.0, -mu_i)) * hm
        c = P.rod_area * P.youngs_modulus * P.magnetostriction_coefficient
        mean = c * (P.bias_magnetization ** 2 + 0.5 * m_s ** 2 * float(
            dif.mean_squares(W)[1])) / P.stiffness
        assert abs(np.mean(y[last]) - mean) <= 1e-6 * abs(yk[0])  # 2e-7 measured
        # the section's spread matters: the strain of the mean magnetisation alone is off
        # by c |M_s|^2 (<|g|^2> - |<g>|^2) / (2 K): 2.7e-4 (slab), 6.4e-5 (cylinder) of |Y_1|
        naive = c * (P.bias_magnetization ** 2 + 0.5 * m_s ** 2 * abs(
            complex(dif.transfer(W))) ** 2) / P.stiffness
        assert abs(naive - mean) > 3e-5 * abs(yk[0])


@pytest.mark.parametrize("geometry", ["slab", "cylinder"])
@pytest.mark.parametrize("time_constant", [1e-6, 1e-3, 0.05])
def test_modal_bank_gives_the_section_mean_and_mean_square(geometry, time_constant):
    # <g>, <g^2> (max_relative_error) and <|g|^2> of the modes against the closed forms of
    # EddyCurrentDiffusion (Parseval: the mean of the square is the weighted sum of squares)
    dif = ext.EddyCurrentDiffusion(time_constant, geometry)
    bank = ModalBank(dif)
    assert bank.max_relative_error <= 2.5e-4  # 0 to 100 kHz (module docstring)
    assert bank.size <= 257 and np.all(bank.weights > 0) and np.all(bank.time_constants > 0)
    assert bank.weights.sum() == pytest.approx(1.0, abs=1e-12)  # static gain
    w = 2 * math.pi * np.array([0.0, 1.0, 50.0, 1e3, 2e4, 1e5])
    assert np.abs(bank.mean_squares(w)[1] / dif.mean_squares(w)[1] - 1).max() <= 2.5e-4
    assert np.abs(bank.mean_squares(w)[0] / dif.mean_squares(w)[0] - 1).max() <= 2.5e-4


def test_modal_bank_for_a_slow_diffusion_is_accurate_in_the_operating_band():
    # tau = 1 s (skin depth equal to the size at 0.3 Hz): 256 modes follow 0-1 kHz to 3.2e-6
    dif = ext.EddyCurrentDiffusion(1.0, "slab")
    bank = ModalBank(dif)
    w = 2 * math.pi * np.logspace(-2, 3, 200)
    assert bank.mode_count == 256
    assert np.abs(bank.transfer(w) / dif.transfer(w) - 1).max() <= 5e-6
    assert np.abs(bank.mean_squares(w)[0] / dif.mean_squares(w)[0] - 1).max() <= 5e-6


def test_modal_bank_steps_the_modes_as_eddy_current_diffusion_step():
    # the kept modes' states are the numbers EddyCurrentDiffusion.step gives
    dif = ext.EddyCurrentDiffusion(1e-3, "cylinder")
    bank = ModalBank(dif)
    state = np.zeros((2, bank.size))
    x = np.zeros(bank.mode_count)
    for k in range(50):
        u = math.cos(0.3 * k)
        _, state = bank.step((u, 0.0), state, 2e-5)
        _, x = dif.step(u, x, 2e-5, bank.mode_count)
        assert np.array_equal(state[0, :bank.mode_count], x)


@pytest.mark.parametrize("geometry", ["slab", "cylinder"])
def test_mode_profiles_are_the_diffusion_profile_and_orthogonal(geometry):
    # the module docstring's profiles: w_n = 2 (-1)^(n+1) cos(p_n x)/p_n (slab) or
    # 2 J_0(p_n r)/(p_n J_1(p_n)) (cylinder), tau_n = tau/p_n^2: with the lags they rebuild
    # EddyCurrentDiffusion.profile, and <w_n w_k> = r_n delta_nk (the weights of modes())
    from scipy.special import j0, j1, jn_zeros

    dif = ext.EddyCurrentDiffusion(1e-3, geometry)
    count = 2000
    n = np.arange(1, count + 1)
    p = (n - 0.5) * np.pi if geometry == "slab" else jn_zeros(0, count)

    def w(x):
        if geometry == "slab":
            return 2 * (-1.0) ** (n + 1) * np.cos(np.outer(x, p)) / p
        return 2 * j0(np.outer(x, p)) / (p * j1(p))

    x = np.linspace(0.0, 1.0, 6)
    lags = 1 / (1 + 1j * W * 1e-3 / p ** 2)
    # the static part sums to 1; the rest converges fast (terms ~ p^-3)
    assert np.abs(1 + w(x) @ (lags - 1) - dif.profile(x, W)).max() <= 1e-8
    # mean over the section (weight 1 or 2 r) by Gauss-Legendre on [0, 1]
    u, g = np.polynomial.legendre.leggauss(200)
    u, g = (u + 1) / 2, g / 2
    if geometry == "cylinder":
        g = 2 * u * g
    wk = w(u)[:, :5]
    gram = wk.T @ (g[:, None] * wk)
    _, r = dif.modes(5)
    assert np.allclose(gram, np.diag(r[:-1]), rtol=0, atol=1e-12)
    assert np.allclose(g @ wk, r[:-1], rtol=1e-12)


def test_two_masses_carry_the_load_on_the_output():
    # statically y_1 = (F - F_ext)/K and y_2 = y_1 - F_ext/k_j (the joint yields under the
    # load): the pump chamber pushes on the output, where the sensor is (module docstring)
    v = variant("mechanical_resonance", "two_dof")
    kj = v.parameters["joint_stiffness_N_per_m"]
    ends = []
    for load in (0.0, 50.0):
        tr = gmt.Transducer(P, gmt.Excitation(F, 1.0), variant=v)
        rest = P.rod_area * P.youngs_modulus * P.magnetostriction_coefficient * (
            P.bias_magnetization ** 2) / P.stiffness
        assert tr.forward.displacement == tr.forward.rod_displacement == pytest.approx(
            rest, rel=1e-14)
        for _ in range(3000):  # 30 ms: the joint rings down at 1/(zeta w_j) = 1.6 ms
            out = tr.step(0.3, H, load)
        assert out.sensed_displacement == out.displacement
        ends.append((tr.forward.rod_displacement, out.displacement))
    assert ends[1][0] - ends[0][0] == pytest.approx(-50.0 / P.stiffness, rel=1e-6)
    assert ends[1][1] - ends[0][1] == pytest.approx(-50.0 * (1 / P.stiffness + 1 / kj),
                                                    rel=1e-6)
    # y, v, previous current and step, branch; saturation count, previous step; elapsed,
    # sensed y; the rod's y_1, v_1
    assert len(tr.get_state()) == 11
    # the force column of the two-input ZOH is TwoMassMechanics.zoh_matrices'
    ad, bd = tr.forward.form.zoh(H)
    ad0, bd0 = tr.forward.form.system.zoh_matrices(H)
    assert np.allclose(ad, ad0, rtol=1e-12, atol=0) and np.allclose(bd[:, 0], bd0, rtol=1e-12,
                                                                    atol=0)


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
@pytest.mark.parametrize("cause, form", ALL_FORMS)
def test_state_save_restore_replays_bit_identically(cause, form, compensated):
    drive = gmt.DriveParameters(compensated=compensated)
    tr = gmt.Transducer(P, gmt.Excitation(F, 1.0), drive, variant=variant(cause, form))
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
    other = gmt.Transducer(P, gmt.Excitation(F, 1.0), drive, variant=variant(cause, form))
    other.set_state(saved)
    assert [tuple(other.step(u(k), steps[k], forces[k])[:3]) + (
        other.sensed_displacement,) for k in range(600, 900)] == first


def test_a_state_of_the_wrong_size_is_refused():
    tr = gmt.Transducer(variant=variant("rate_independent_hysteresis"))
    with pytest.raises(gmt.ParameterError, match="state"):
        tr.set_state(tr.get_state()[:-1])
    for cause, form in FORM_CASES:
        tr = gmt.Transducer(variant=variant(cause, form))
        good = tr.get_state()
        with pytest.raises(gmt.ParameterError, match="state"):
            tr.set_state(good[:-1] if form != "two_dof" else good[:-2])
        assert tr.get_state() == good  # nothing restored in part
    with pytest.raises(gmt.ParameterError, match="needs 7"):
        gmt.Transducer().set_state(tr.get_state())
