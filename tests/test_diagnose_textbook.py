"""The diagnosis on the paper's own effects in textbook forms outside its candidates'.

The data come from labsim (tests/labsim, its README), written apart from the candidates:
the classical Preisach model with general relay densities over (coercive, interaction)
field (Mayergoyz 2003), eddy currents diffusing into laminations or a solid rod *acting on
the magnetisation* (Stoll 1974), and effects outside the six causes (a joint's backlash).
The candidates (gmt.extensions) were not shaped on these data: the seeds here (201-209)
were fixed before any result was seen. The rules are the detection targets: each single
cause named; a pair named with both and nothing else; a known cause with an outside effect
named, with the remainder reported; no extra cause without a sense voltage.
"""
from __future__ import annotations

import pytest
from labsim_runs import runs

from smeha import diagnose

#: 400 samples a period, as the outside lab files; 6 periods; 5-200 Hz at 0.6 and 1 A.
CLOCK = {"samples_per_cycle": 400}


def _diagnose(effects, formulations=None, seed=201, **kw):
    return diagnose.diagnose(runs(effects, seed=seed, formulations=formulations,
                                  **dict(CLOCK, **kw)))


@pytest.mark.integration
@pytest.mark.parametrize("formulation, seed", [("general_preisach", 201),
                                               ("preisach_bimodal", 202),
                                               ("preisach_correlated", 203)])
def test_preisach_hysteresis_is_named(formulation, seed):
    d = _diagnose({"rate_independent_hysteresis": 1.0},
                  {"rate_independent_hysteresis": formulation}, seed=seed)
    assert d.causes == ["rate_independent_hysteresis"], "\n".join(d.evidence)
    assert d.gain >= 2.0


@pytest.mark.integration
@pytest.mark.parametrize("formulation, seed", [("slab_magnetization", 204),
                                               ("solid_rod_magnetization", 205)])
def test_eddy_diffusion_on_the_magnetisation_is_named(formulation, seed):
    d = _diagnose({"eddy_current_diffusion": 1.0}, {"eddy_current_diffusion": formulation},
                  seed=seed)
    assert d.causes == ["eddy_current_diffusion"], "\n".join(d.evidence)
    assert d.gain >= 2.0


@pytest.mark.integration
@pytest.mark.parametrize("effect, formulation, seed", [
    ("rate_independent_hysteresis", "general_preisach", 206),
    ("eddy_current_diffusion", "solid_rod_magnetization", 207)])
def test_each_with_a_delay_gives_both(effect, formulation, seed):
    # the miss to guard against: "eddy + delay answered as mechanical_resonance + eddy"
    d = _diagnose({effect: 1.0, "transport_delay": 1.0}, {effect: formulation}, seed=seed)
    assert set(d.causes) == {effect, "transport_delay"}, "\n".join(d.evidence)
    out = d.as_dict()
    assert set(out["explained_fraction"]) == set(d.causes)
    assert 0.0 <= out["unexplained_fraction"] <= 1.0


@pytest.mark.integration
def test_a_known_cause_with_an_outside_effect_is_named_with_the_remainder():
    d = _diagnose({"transport_delay": 1.0, "joint_backlash": 1.0}, seed=208)
    assert d.causes == ["transport_delay"], "\n".join(d.evidence)
    out = d.as_dict()
    assert out["explained_fraction"]["transport_delay"] > 0.0
    assert "transport_delay explains" in out["remainder"]["summary"]


@pytest.mark.integration
def test_a_magnetic_cause_beside_an_effect_on_y_alone_is_judged_in_b():
    # the detection study's case (eddy diffusion + a joint's backlash at labsim's 20 kHz
    # clock, seed 0): the slab form on the magnetisation removes 85 % of B's held-out
    # excess and 47 % of the whole, the backlash holding y, and no pair passes: judged on
    # the whole the answer is unexplained, so a magnetic cause is judged in B first
    # (smeha.diagnose.decision._magnetic_first). The rest of the excess is reported
    # unexplained, as the backlash's
    d = diagnose.diagnose(runs({"eddy_current_diffusion": 1.0, "joint_backlash": 1.0},
                               seed=0, noise_um=0.05, sample_rate=20e3,
                               formulations={"eddy_current_diffusion": "diffusion_random"}))
    assert d.causes == ["eddy_current_diffusion"], "\n".join(d.evidence)
    out = d.as_dict()
    assert out["first_judged_in"] == ["B"]
    assert any(e.startswith("judged in B:") for e in d.evidence)
    assert out["unexplained_fraction"] > 0.3


@pytest.mark.integration
def test_a_joints_backlash_beside_eddy_diffusion_is_not_read_as_a_mechanics():
    # the detection study's case (eddy diffusion + a joint's backlash, seed 3 at 800 samples
    # a period): beside the eddy form a one-mass mechanics removes 50.2 % of y's held-out
    # excess, 39.7 % at 0.6 A and 63.1 % at 1 A, enough on the sum. A linear filter on
    # y acts alike at every amplitude (rules.alike_at_levels); the backlash's dead band
    # takes a larger share of a smaller stroke
    d = diagnose.diagnose(runs({"eddy_current_diffusion": 1.0, "joint_backlash": 1.0},
                               seed=3, noise_um=0.05, samples_per_cycle=800,
                               formulations={"eddy_current_diffusion": "diffusion_random"}))
    assert d.causes == ["eddy_current_diffusion"], "\n".join(d.evidence)
    assert "acts alike at every drive amplitude" in d.stopped
    assert d.as_dict()["unexplained_fraction"] > 0.2


@pytest.mark.integration
def test_a_joints_backlash_beside_a_drift_is_not_read_as_a_delay():
    # the detection study's case (thermal drift + a joint's backlash, seed 11 at 100
    # samples a period): a delay alone removes 50.0 % of the paper's held-out excess, but
    # 37.2 % of y's at 0.6 A and 61.9 % at 1 A, so it is not named first
    # (rules.passes_first)
    d = diagnose.diagnose(runs({"thermal_drift": 1.0, "joint_backlash": 1.0}, seed=11,
                               noise_um=0.05, samples_per_cycle=100))
    assert d.causes == ["thermal_drift"], "\n".join(d.evidence)


@pytest.mark.integration
def test_no_extra_cause_without_a_sense_voltage():
    # saturation alone without B, not saturation + mechanical_resonance
    # (+ thermal_drift)
    d = _diagnose({"magnetization_saturation": 1.0}, seed=209, sense_coil=False)
    assert d.causes == ["magnetization_saturation"], "\n".join(d.evidence)


@pytest.mark.integration
def test_two_effects_that_neither_explains_alone_are_named_together():
    # the detection study's case (benchmarks/diagnose_detection.py: seed 1, 800 samples a
    # period, diffusion_random): labsim's eddy diffusion with its two-mass resonance.
    # Alone the one-mass resonance removes 31 % of the paper's held-out excess, in y, and
    # makes B worse; the eddy form takes B's and leaves y's; neither passes the rule (50 %),
    # so forward selection names nothing and the pair is tried at once
    # (smeha.diagnose.decision._pair_first)
    d = _eddy_and_resonance(seed=1)
    assert set(d.causes) == {"eddy_current_diffusion", "mechanical_resonance"}, \
        "\n".join(d.evidence)
    assert any(line.startswith("named together") for line in d.evidence)
    assert d.gain >= 2.0


def _eddy_and_resonance(seed):
    return diagnose.diagnose(runs({"eddy_current_diffusion": 1.0, "mechanical_resonance": 1.0},
                                  seed=seed, noise_um=0.05, samples_per_cycle=800,
                                  formulations={"eddy_current_diffusion": "diffusion_random"}))


@pytest.mark.integration
def test_a_pair_named_at_once_takes_the_lookalike_that_predicts_better():
    # the detection study's case (seed 12, 100 samples a period, diffusion_random): labsim's
    # eddy diffusion + delay. No single cause passes; the pairs of the three best-ranked
    # causes hold the one-mass mechanics (its masses and stiffness on bounds alone), not the
    # delay ranked behind it, and give eddy + one-mass mechanics (held out 227.3).
    # The exchange step after the pair (smeha.diagnose.decision.select) puts the delay in
    # its place: held out 218.1, ranked better too
    d = _eddy_and_delay(seed=12, samples_per_cycle=100)
    assert set(d.causes) == {"eddy_current_diffusion", "transport_delay"}, \
        "\n".join(d.evidence)


def _eddy_and_delay(seed, samples_per_cycle):
    return diagnose.diagnose(runs({"eddy_current_diffusion": 1.0, "transport_delay": 1.0},
                                  seed=seed, noise_um=0.05, samples_per_cycle=samples_per_cycle,
                                  formulations={"eddy_current_diffusion": "diffusion_random"}))


@pytest.mark.integration
def test_a_cause_in_its_other_form_takes_no_extra_cause():
    # the detection study's case (seed 4, 800 a period, diffusion_random): the two-mass
    # resonance is fitted first by the one-mass form (it ranks first alone), and beside
    # the eddy form a delay makes up for that form, an extra cause, unless the exchange
    # step tries each member's other form (smeha.diagnose.decision)
    d = _eddy_and_resonance(seed=4)
    assert set(d.causes) == {"eddy_current_diffusion", "mechanical_resonance"}, \
        "\n".join(d.evidence)


@pytest.mark.integration
def test_a_density_that_changes_the_fundamentals_alone_is_not_a_third_cause():
    # the detection study's case (seed 15, 800 a period, diffusion_random): beside the
    # eddy and two-mass forms the Preisach density takes 0.01 % of the paper's excess,
    # through y's and B's fundamentals, leaving their harmonics from the third up as they
    # are (held-out chi^2 130 -> 154), no signature of its own
    # (smeha.diagnose.rules.shows_signature). The rule is asked of the density's single
    # against the paper too (decision.showing), and this density, which shows no loop
    # there either, is not tried beside the others: the further cause the stop names is
    # another
    d = _eddy_and_resonance(seed=15)
    assert set(d.causes) == {"eddy_current_diffusion", "mechanical_resonance"}, \
        "\n".join(d.evidence)
    assert "rate_independent_hysteresis" not in d.stopped


@pytest.mark.integration
def test_saturation_and_drift_end_in_their_joint_steps():
    # the detection study's case (seed 5, 800 a period): a Preisach density combination's
    # joint step, its bounded subproblem conditioned at 1.5e15 by a node whose relays barely
    # switch, loops for good in scipy's trf line search unscaled (scipy issue #18908; no
    # end in 13 min). Scaled by the damped column norms it ends (smeha.diagnose.
    # linearfit._joint) and the two causes labsim hid are named
    d = diagnose.diagnose(runs({"magnetization_saturation": 1.0, "thermal_drift": 1.0},
                               seed=5, noise_um=0.05, samples_per_cycle=800))
    assert set(d.causes) == {"magnetization_saturation", "thermal_drift"}, \
        "\n".join(d.evidence)


@pytest.mark.integration
def test_a_lookalike_takes_the_place_of_the_first_cause_beside_a_second():
    # the detection study's case (seed 11, 800 a period, diffusion_random): the one-mass
    # mechanics ranks first alone; the delay, taking half of what the eddy form leaves,
    # passes no rule alone, so an exchange step that tried only passing causes would answer
    # mechanical_resonance + eddy (the miss test_each_with_a_delay_gives_both guards
    # against). The exchange step tries a member's lookalikes
    d = _eddy_and_delay(seed=11, samples_per_cycle=800)
    assert set(d.causes) == {"eddy_current_diffusion", "transport_delay"}, \
        "\n".join(d.evidence)


@pytest.mark.integration
def test_hysteresis_beside_eddy_currents_that_shield_the_field_gives_both():
    # the detection study's case (seed 1, 800 a period, preisach_random + diffusion_random:
    # eddy diffusion in a solid rod acting on the field, tau 1.6 ms): labsim's relays switch
    # on the shielded field, the candidates' switched on the applied one, and the density
    # with the true eddy form would miss B by a held-out chi^2 of 3.8e9 (1.7e8 at its
    # fitted time constant), leaving hysteresis alone, gain 1.8. Beside a form that
    # shields the field the relays switch on the section's mean field
    # (gmt.extensions.Extension.switching_gain; the same density and true form: 3.0e5), and
    # the combination starts from the form's own starts (smeha.diagnose.linearfit.
    # _screened_members)
    d = diagnose.diagnose(runs({"rate_independent_hysteresis": 1.0,
                                "eddy_current_diffusion": 1.0},
                               seed=1, noise_um=0.05, samples_per_cycle=800,
                               formulations={"rate_independent_hysteresis": "preisach_random",
                                             "eddy_current_diffusion": "diffusion_random"}))
    assert set(d.causes) == {"rate_independent_hysteresis", "eddy_current_diffusion"}, \
        "\n".join(d.evidence)
    assert d.gain >= 2.0


@pytest.mark.integration
@pytest.mark.parametrize("seed", [4, 1])
def test_eddy_and_resonance_at_a_20_khz_clock_give_both_and_nothing_else(seed):
    # the detection study's cases at labsim's 20 kHz clock. Seed 4: the paper's held-out
    # harmonics from the third up are within noise (145.7 for 144 features) and the
    # Preisach density alone raises them to 1809, removing 57 % of the excess through the
    # fundamentals, no signature against the paper, so it is not named first
    # (smeha.diagnose.rules.shows_signature against the paper: decision.showing). Seed 1:
    # eddy, the one-mass mechanics, then a delay for what the one-mass form leaves (1.5 %
    # of the paper's excess); once the exchange step puts the two-mass form in, the delay
    # is asked again against the model without it (smeha.diagnose.exchange.pruned)
    d = diagnose.diagnose(runs({"eddy_current_diffusion": 1.0, "mechanical_resonance": 1.0},
                               seed=seed, noise_um=0.05, sample_rate=20e3,
                               formulations={"eddy_current_diffusion": "diffusion_random"}))
    assert set(d.causes) == {"eddy_current_diffusion", "mechanical_resonance"}, \
        "\n".join(d.evidence)
