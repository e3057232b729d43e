"""Model variants: the extended model time-stepped in gmt.Transducer.

The stepped forms are checked against the periodic forms the diagnosis evaluates
(:func:`gmt.extensions.steady.steady_state`, a separate code path: harmonic balance on a
grid), evaluated at the stepper's step (``step=H``: the ZOH frequency response of eq 27,
the steady state a held input reaches), after running long enough under a sinusoidal
current to reach the periodic steady state.
"""
from __future__ import annotations

import json
import math
import pickle

import numpy as np
import pytest

import gmt
from gmt import extensions as ext
from gmt.design_point import DriveMonitor
from gmt.extensions import FORMS, REGISTRY, VARIANTS, ModalBank, SectionBank
from gmt.extensions.preisach import COERCIVE_GRID, INTERACTION_GRID
from gmt.extensions.paperpart import mu_imag_from_losses
from gmt.extensions.steady import steady_state
from gmt.variants import ModelVariant

P = gmt.TransducerParameters()
F, H = 100.0, 1e-5  # operating point and step: 1000 samples a period
W = 2 * math.pi * F
N = int(round(1 / (F * H)))
#: H_m at 1 A with Table 2 (eq 1), [A/m]: the largest field amplitude, the plays' grid
FIELD_MAX = 14773.0
#: four Preisach nodes (coercive index, interaction index) flat: coercive nodes 1-3 at
#: h_u = 0 and node 4 at h_u = -H_max/3
_NU = INTERACTION_GRID[2]
PREISACH_NODES = tuple(i * _NU + j for i, j in
                       ((1, _NU // 2), (2, _NU // 2), (3, _NU // 2), (4, (_NU - 1) // 3)))

#: cause -> (SI parameters, the diagnosis' internal parametrisation of the same extension
#: (the extension's FitSpec, mapped to SI by its from_fit)).
CASES = {
    # SI from the internal unknowns (40 plays weighted by a gamma density; None: from_fit's)
    "rate_independent_hysteresis": (None, (0.25, -0.85, 1.0)),
    "magnetization_saturation": (
        {"saturation_magnetization_A_per_m": 4e5, "initial_slope": 1.1, "knee_exponent": 1.5,
         "tail_exponent": 2.0, "bias_shift": -0.2}, (250e3 / 4e5, 1.1, 1.5, 2.0, -0.2)),
    "eddy_current_diffusion": (
        {"time_constant_s": 1.6e-3, "order": 0.5}, (math.log10(1.6e-3), 0.5)),
    "transport_delay": ({"delay_s": 3.37e-4}, (0.337,)),
    "mechanical_resonance": (
        {"mass_kg": 4e-4, "damping_N_s_per_m": 58.9, "stiffness_N_per_m": 1.905e7},
        (0.02, 0.02, 1.905e7 / 1.963e7)),
    "thermal_drift": (
        {"offset_rate_m_per_A2s": 1e-4, "gain_rate_per_A2s": 0.5,
         "thermal_time_constant_s": math.inf, "start_current_A": 0.5},
        (100.0, 50.0, 30.0, 0.25, 0.0)),
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
#: parametrisation (the extension's FitSpec); the SI parameters are what its from_fit
#: reports for it (and smeha diagnose --json with it), derived keys included.
#: tau = 1 ms: the skin depth equals the half thickness (radius) at 318 Hz; the joint:
#: half of eq 27's mass on the output, 1 kHz, damping ratio 0.1.
FORM_CASES = {
    ("eddy_current_diffusion", "slab"): (math.log10(1e-3),),
    ("eddy_current_diffusion", "cylinder"): (math.log10(1e-3),),
    # the magnetisation lags, the coil sees 60 % of the vacuum flux unshielded
    ("eddy_current_diffusion", "slab_magnetization"): (math.log10(1e-3), 0.6),
    ("eddy_current_diffusion", "cylinder_magnetization"): (math.log10(1e-3), 0.6),
    ("mechanical_resonance", "two_dof"): (0.5, math.log10(1000.0), 0.1, 1.0),
    # a Preisach density of 3 kA/m at four nodes (a lognormal-like ridge at h_u = 0 and
    # one asymmetric node at h_u = -H_max/3), switching falling to half at 300 Hz
    ("rate_independent_hysteresis", "preisach"): (
        math.log10(300.0), 2.0, *[3000.0 if j in PREISACH_NODES else 0.0
                                  for j in range(COERCIVE_GRID[2] * INTERACTION_GRID[2])]),
}
#: Largest |Y_k(stepped) - Y_k(periodic)| / |Y_1|, k = 1..8, for y and B: the diffusion
#: forms hold each mode's mean over the step, (w h)^2 / 12 = 3.3e-6 at 100 Hz and 10 us
#: (3.2e-6 measured), plus the modal bank's error at 100-800 Hz (below 1e-8); the two masses
#: are the exact ZOH of the 4-state model, as the diagnosis' response (3e-13 measured).
FORM_TOLERANCE = {"slab": 1e-5, "cylinder": 1e-5, "two_dof": 1e-10, "preisach": 3e-4,
                  "slab_magnetization": 1e-5, "cylinder_magnetization": 1e-5}
#: The Preisach relays switch at the first sample past their field, late by up to one step
#: (w h = 6.3e-3 rad at 100 Hz, 10 us), against the periodic form's exact Fourier series of
#: the switched relays (24 harmonics): on the interaction grid out to +-H_max 1.2e-4
#: measured for y (2.0e-5 on the earlier +-0.6 H_max grid, whose nodes put these four
#: weights on other relays), while the density changes y's harmonics by up to 29 % of Y_1
#: (measured on the earlier grid):
#: the two forms agree three orders of magnitude below the effect.
#: Every (cause, form) with a step form.
ALL_FORMS = [(c, "") for c in ext.CAUSES] + list(FORM_CASES)


CONTEXT = {"params": P, "field_max": FIELD_MAX}


def reported(cause, internal, form=""):
    """The SI parameters the diagnosis reports for the internal unknowns."""
    return ext.lookup(cause, form).from_fit(internal, CONTEXT)


def si_parameters(cause, form=""):
    if not form:
        return CASES[cause][0] or reported(cause, CASES[cause][1])
    return reported(cause, FORM_CASES[cause, form], form)


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
    """The diagnosis' periodic Y_k, B_k (k = 1..8) at the operating point, Table 2 losses,
    at the stepper's step H."""
    comps = () if cause == "none" else ((ext.lookup(cause, form), reported(cause, extra,
                                                                            form)),)
    return steady_state(P, F, 1.0, BM, LOSS, comps, step=H)


def harmonics(x):
    return 2.0 * np.fft.rfft(x)[1:9] / x.size


# ------------------------------------------------------------------ the variant object


def test_every_extension_is_in_the_one_registry():
    # one class per (cause, form), with its periodic form, its time-stepped form (the
    # class itself) and its SI parameters; the diagnosis and the FMU read this registry
    expected = {(c, f) for c in ext.CAUSES for f in FORMS.get(c, ("",))}
    assert set(REGISTRY) == expected
    assert {(c, f or FORMS.get(c, ("",))[0]) for c, f in ALL_FORMS} == expected
    for (cause, form), cls in REGISTRY.items():
        assert issubclass(cls, ext.Extension) and cls.stage in ext.STAGES
        assert len(cls.fit.names) == len(cls.fit.lower) == len(cls.fit.upper)
        assert all(len(s) == len(cls.fit.names) for s in cls.fit.starts)
    assert VARIANTS == ("paper", "rate_independent_hysteresis",
                        "rate_independent_hysteresis:preisach", "magnetization_saturation",
                        "eddy_current_diffusion", "eddy_current_diffusion:slab",
                        "eddy_current_diffusion:cylinder",
                        "eddy_current_diffusion:slab_magnetization",
                        "eddy_current_diffusion:cylinder_magnetization", "transport_delay",
                        "mechanical_resonance", "mechanical_resonance:two_dof",
                        "thermal_drift")
    assert set(CASES) == set(ext.CAUSES)


@pytest.mark.parametrize("cause, form", ALL_FORMS)
def test_parameters_are_the_diagnosis_si_parameters(cause, form):
    # the keys are those smeha diagnose --json reports for the candidate
    internal = CASES[cause][1] if not form else FORM_CASES[cause, form]
    si = reported(cause, internal, form)
    v = ModelVariant(cause, si, form)
    assert set(v.parameters) == set(si) == {p.name for p in ext.lookup(cause, form).parameters}
    assert ModelVariant.from_dict(v.as_dict()) == v
    assert ModelVariant.from_name(v.name, si) == v
    assert pickle.loads(pickle.dumps(v)) == v and hash(v) == hash(
        ModelVariant(cause, si, form))


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


def test_small_variant_json_and_a_whole_diagnosis():
    small = '{"cause": "transport_delay", "parameters": {"delay_s": 0.000337}, "provenance": "x"}'
    assert ModelVariant.from_json(small) == variant("transport_delay")
    with pytest.raises(gmt.ParameterError, match="JSON"):
        ModelVariant.from_json("{cause: paper}")
    # a whole diagnosis is smeha's to read (smeha.diagnose.variant_from_diagnosis)
    with pytest.raises(gmt.ParameterError, match="variant_from_diagnosis"):
        ModelVariant.from_dict({"cause": "transport_delay", "candidates": []})
    assert ModelVariant.from_dict({"cause": "none"}).is_paper
    # a small variant JSON may carry the form; without it, the cause's first
    small = '{"cause": "mechanical_resonance", "form": "two_dof", "parameters": %s}'
    two = si_parameters("mechanical_resonance", "two_dof")
    assert ModelVariant.from_json(small % json.dumps(two)) == variant("mechanical_resonance",
                                                                      "two_dof")
    with pytest.raises(gmt.ParameterError, match="unknown 'rod_mass_kg'"):
        ModelVariant.from_json(small.replace('"form": "two_dof", ', "") % json.dumps(two))
    with pytest.raises(gmt.ParameterError, match=r"form = 'sphere' .*\['lag', 'slab', "
                                                 r"'cylinder', 'slab_magnetization', "
                                                 r"'cylinder_magnetization'\]"):
        ModelVariant.from_dict({"cause": "eddy_current_diffusion", "form": "sphere",
                                "parameters": {"time_constant_s": 1e-3}})
    with pytest.raises(gmt.ParameterError, match="one form"):
        ModelVariant("transport_delay", {"delay_s": 1e-3}, "fifo")


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
        assert len(tr.get_state()) == 7 + DriveMonitor.STATE_SIZE  # + the design-point monitor


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
    if form in ("slab", "cylinder"):
        # the mean strain carries the time average of the section's <M^2>,
        # |M_s|^2 <|g|^2> / 2: c (M_b^2 + |M_s|^2 <|g|^2> / 2) / K, with M_s the surface
        # magnetisation as the diagnosis computes it and <|g|^2> the closed form of
        # EddyCurrentDiffusion.mean_squares (the ZOH keeps the static gain 1/K)
        dif = ext.EddyCurrentDiffusion(10.0 ** FORM_CASES[cause, form][0], form)
        hm = P.field_per_ampere
        b_s = BM / abs(complex(dif.transfer(W)))
        mod = b_s / (gmt.constants.MU_0 * hm)
        mu_i = mu_imag_from_losses(LOSS, F, b_s, hm)
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
    # y, v, previous current and step, branch; saturation count, previous step; the
    # design-point monitor's; elapsed, sensed y; the rod's y_1, v_1
    assert len(tr.get_state()) == 11 + DriveMonitor.STATE_SIZE
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
    extra = (100.0, 50.0, math.log10(time_constant) if math.isfinite(time_constant) else 30.0,
             0.25, 0.0)
    v = ModelVariant("thermal_drift", parameters)
    y, _, _ = run(gmt.Transducer(P, gmt.Excitation(F, 1.0), variant=v), 10)
    t = H * np.arange(y.size)
    sel = t >= 1.0 / F
    yk = periodic("none", ()).displacement
    k = np.arange(1, yk.size + 1)
    model = np.real(np.exp(1j * np.outer(W * t[sel], k)) @ yk)
    model = ext.DriftForm.apply_samples(ext.DriftForm.from_fit(extra, CONTEXT), model, t[sel],
                                        1.0)
    model = model + np.mean(y[sel] - model)
    assert np.abs(y[sel] - model).max() <= 5e-4 * np.ptp(y[sel])
    # the drift is there: the offset o u(t) between the second and the last period, 8 um
    # (linear dose) and 0.95 um (t_th = 30 ms)
    dose = ext.LinearDrift(1e-4, 0.5, time_constant, 0.5).dose(np.array([1.5, 9.5]) / F, 1.0)
    shift = np.mean(y[-N:]) - np.mean(y[N:2 * N])
    assert shift == pytest.approx(1e-4 * (dose[1] - dose[0]), rel=0.02)


def test_the_drift_dose_runs_from_the_switch_on_periods_before_the_record():
    # gmt.extensions.drift, "Heating before the record": for a linear dose (t_th = inf,
    # I_s = 0) u = I_m^2 (t + n_p / f), so over a record of samples t the harmonics' gain
    # is 1 + g I_m^2 (n_p / f + mean t) and the slopes are o I_m^2 and g I_m^2 Y_1,
    # whatever n_p (arithmetic, to rounding)
    values = {"offset_rate_m_per_A2s": 2e-6, "gain_rate_per_A2s": -0.01,
              "thermal_time_constant_s": math.inf, "start_current_A": 0.0,
              "periods_before_record": 3.0}
    f, im, y1 = 5.0, 0.8, 30e-6
    t = np.arange(6000) / 5000.0
    gain, s_off, s_y1 = ext.DriftForm.feature_drift(values, t, t[0], t.mean(), im, y1, f)
    assert gain == pytest.approx(1.0 - 0.01 * im**2 * (3.0 / f + t.mean()), rel=1e-12)
    assert s_off == pytest.approx(2e-6 * im**2, rel=1e-9)
    assert s_y1 == pytest.approx(-0.01 * im**2 * y1, rel=1e-9)
    # without n_p (or without the run's frequency) the dose starts with the record
    gain0, _, _ = ext.DriftForm.feature_drift(dict(values, periods_before_record=0.0), t,
                                              t[0], t.mean(), im, y1, f)
    assert gain0 == pytest.approx(1.0 - 0.01 * im**2 * t.mean(), rel=1e-12)
    assert ext.DriftForm.feature_drift(values, t, t[0], t.mean(), im, y1)[0] == gain0


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


@pytest.mark.integration  # 15 cases, ~25 s
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
    assert (len(tr.get_state()) - DriveMonitor.STATE_SIZE) // 2 - 4 == pytest.approx(d, abs=2)


def test_reidentified_mechanics_rest_on_the_new_stiffness():
    tr = gmt.Transducer(P, variant=variant("mechanical_resonance"))
    force = P.rod_area * P.youngs_modulus * P.magnetostriction_coefficient * 250e3 ** 2
    assert tr.forward.displacement == pytest.approx(force / 1.905e7, rel=1e-14)


# ------------------------------------------------------------------ state


@pytest.mark.integration  # every form, both modes, ~12 s
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
    with pytest.raises(gmt.ParameterError, match=f"needs {7 + DriveMonitor.STATE_SIZE}"):
        gmt.Transducer().set_state(tr.get_state())


# ------------------------------------------------------------------ combinations
#: internal unknowns of the members of the combinations below (each extension's FitSpec)
COMBINED = {
    ("rate_independent_hysteresis", ""): (0.25, -0.85, 1.0),
    ("magnetization_saturation", ""): (0.625, 1.0, 2.0, 1.0, 0.0),
    ("eddy_current_diffusion", "lag"): (math.log10(1.6e-3), 0.5),
    ("eddy_current_diffusion", "slab"): (-3.0,),
    ("eddy_current_diffusion", "cylinder"): (-3.0,),
    ("eddy_current_diffusion", "cylinder_magnetization"): (-3.0, 0.6),
    ("rate_independent_hysteresis", "preisach"): FORM_CASES["rate_independent_hysteresis",
                                                            "preisach"],
    ("transport_delay", ""): (0.337,),
    ("mechanical_resonance", "one_dof"): (0.5, 0.3, 0.95),
    ("mechanical_resonance", "two_dof"): (0.5, 3.0, 0.1, 2.0),
}


def _single(cause, form=""):
    return ModelVariant(cause, reported(cause, COMBINED[cause, form], form), form)


def test_a_combination_is_one_variant_by_name_json_and_fmu_parameters():
    pair = gmt.ModelVariant.combine(_single("transport_delay"),
                                    _single("eddy_current_diffusion", "slab"))
    # stage order: the field in the rod first, the sensor last
    assert pair.name == "eddy_current_diffusion:slab+transport_delay"
    assert pair.causes == ("eddy_current_diffusion", "transport_delay")
    assert gmt.ModelVariant.from_dict(json.loads(json.dumps(pair.as_dict()))) == pair
    assert gmt.ModelVariant.from_name(pair.name, pair.variant_parameters()) == pair
    assert pickle.loads(pickle.dumps(pair)) == pair and hash(pair) == hash(
        gmt.ModelVariant.combine(_single("eddy_current_diffusion", "slab"),
                                 _single("transport_delay")))
    assert gmt.ModelVariant.combine(_single("transport_delay")) == _single("transport_delay")
    with pytest.raises(gmt.ParameterError, match="keyed by its members"):
        gmt.ModelVariant.from_name(pair.name, {"delay_s": 1e-3})
    with pytest.raises(gmt.ParameterError, match="one form of each cause"):
        gmt.ModelVariant.combine(_single("eddy_current_diffusion", "slab"),
                                 _single("eddy_current_diffusion", "lag"))
    with pytest.raises(gmt.ParameterError, match="is not one of"):
        gmt.ModelVariant.from_name("transport_delay+maxwell", {})


#: pairs of extensions at different stages, and the pair of the magnetisation stage;
#: tolerance as the larger of the members' in tests/test_variants.py (section banks 2e-4,
#: the plays 1e-4, the relays 3e-4, (w h)^2/12 of the held means 3.3e-6, the delay line
#: (w h)^2/8). Beside a field form the hysteresis switches on the section's mean field
#: (stepped: the modal bank's held mean; periodic: the closed-form relays at |<g>| H_m,
#: phase arg <g>), beside a magnetisation form on H.
PAIRS = [
    ((("eddy_current_diffusion", "slab"), ("rate_independent_hysteresis", "")), 1e-4),
    ((("eddy_current_diffusion", "cylinder"), ("rate_independent_hysteresis", "preisach")),
     3e-4),
    ((("eddy_current_diffusion", "cylinder_magnetization"),
      ("rate_independent_hysteresis", "preisach")), 3e-4),
    ((("transport_delay", ""), ("magnetization_saturation", "")), 1e-5),
    ((("rate_independent_hysteresis", ""), ("magnetization_saturation", "")), 1e-4),
    ((("eddy_current_diffusion", "lag"), ("mechanical_resonance", "two_dof")), 2e-4),
    ((("magnetization_saturation", ""), ("mechanical_resonance", "one_dof")), 1e-10),
]


@pytest.mark.integration  # time-stepped pairs to steady state, 1-3 s each
@pytest.mark.parametrize("members, tolerance", PAIRS)
def test_stepped_combination_reaches_its_periodic_form(members, tolerance):
    variant = gmt.ModelVariant.combine(*(_single(c, f) for c, f in members))
    periods = 8
    tr = gmt.Transducer(P, gmt.Excitation(F, 1.0), variant=variant)
    _, s, b = run(tr, periods)
    last = slice(N * (periods - 1), N * periods)
    yk, bk = steady_state(P, F, 1.0, BM, LOSS, variant.steady_components(), step=H)
    harm_y, harm_b = harmonics(s[last]), harmonics(b[last])
    assert np.abs(harm_y - yk).max() / abs(yk[0]) <= tolerance
    assert np.abs(harm_b - bk).max() / abs(bk[0]) <= tolerance
    # the pair is not either member alone
    for c, f in members:
        alone = steady_state(P, F, 1.0, BM, LOSS, _single(c, f).steady_components(), step=H)
        assert np.abs(alone.displacement - yk).max() / abs(yk[0]) > 1e-3
    # state save and restore replays bit for bit
    saved = tr.get_state()
    first = [tr.step(math.cos(W * k * H), H)[:3] for k in range(50)]
    tr.set_state(saved)
    assert [tr.step(math.cos(W * k * H), H)[:3] for k in range(50)] == first
