"""The diagnosis on data it was not built from: labsim, the independent generator.

labsim (tests/labsim, its README) implements the paper's model and six effects in its own
formulations, continuous in time, and records them as a lab does (one sample clock for
every channel, an anti-alias filter, ADC, noise 0.05 um); only its public API is used. Each
test hides an effect and requires it found, on seeds fixed before any result was seen
(101 and 102, outside the detection study's 0-19). The rates, rules and tolerances are the
detection targets: clean data -> "none"; one cause at strength 1 -> named, held-out gain
at least 2; two causes -> both named; nothing else ever named.
"""
from __future__ import annotations

import json
from dataclasses import replace

import labsim
import numpy as np
import pytest
from labsim_runs import runs, smeha_runs

from smeha import diagnose
from smeha.cli import main
from smeha.diagnose import rules
from smeha.diagnose.report import cautions

#: The required bound: the extended model at least halves the held-out misfit.
MIN_GAIN = 2.0
SEED = 101


#: Causes that change y alone and linearly: the report cautions that a sensor chain's
#: low-pass leaves the same signature (gmt.extensions._base.Y_LINEAR_LOOKALIKE).
Y_LINEAR = {("transport_delay", ""), ("mechanical_resonance", "one_dof")}


def _check(result, hidden):
    text = "\n".join(result.evidence)
    if not hidden:
        assert result.cause == "none", text
        assert result.gain == 1.0
        assert cautions(result) == []
        return
    assert set(result.causes) == set(hidden), text
    assert result.gain >= MIN_GAIN, text
    linear = [m for m in result.extended.candidate.members if (m.cause, m.form) in Y_LINEAR]
    assert (len(cautions(result)) > 0) == bool(linear), cautions(result)
    assert all("sensor" in c for c in cautions(result))


@pytest.mark.integration
@pytest.mark.parametrize("clock", [{"samples_per_cycle": 100}, {"sample_rate": 20000.0}],
                         ids=["100_per_cycle", "20kHz"])
def test_clean_data_is_none_at_any_sampling(clock):
    # the continuous physics: at 100 samples a period or at one lab rate for every frequency
    result = diagnose.diagnose(runs(None, seed=SEED, **clock))
    _check(result, ())
    # the noise it estimates is labsim's 0.05 um (its quantisation adds a trace)
    assert result.noise_um == pytest.approx(0.05, rel=0.1)


@pytest.mark.integration
@pytest.mark.parametrize("effect", labsim.EFFECTS)
def test_names_each_hidden_effect_with_gain(effect):
    result = diagnose.diagnose(runs({effect: 1.0}, seed=SEED, samples_per_cycle=100))
    _check(result, (effect,))


@pytest.mark.integration
def test_a_drift_heating_before_the_record_is_within_noise():
    # labsim switches the drive on and records after the transients, 2 to 3.3 periods
    # later (its record_start), heating the coil from the switch-on: dT = 10 K at the
    # switch-on towards 40 K I_m^2 with 30 s (labsim.effects.Thermal), so a warm start of
    # I_s = sqrt(10 / 40) = 0.5 A and a dose linear over the records. At the fixed 20 kHz
    # clock the 5 Hz runs' records weigh most; with the dose from the record's start the
    # drift form fits t_th = 0.7 s and leaves 27 % of the held-out excess
    d = diagnose.diagnose(runs({"thermal_drift": 1.0}, seed=0, noise_um=0.05,
                               sample_rate=20000.0))
    assert d.cause == "thermal_drift" and d.causes == ["thermal_drift"]
    assert rules.within_noise(d.extended), "\n".join(d.evidence)
    p = d.extended.parameters
    # one n_p for all runs between labsim's 2 and 3.3 periods; I_s within 10 % of 0.5 A
    # (n_p and I_s trade: both lower the early runs' gain)
    assert 2.0 <= p["periods_before_record"] <= 3.5
    assert p["start_current_A"] == pytest.approx(0.5, rel=0.1)
    assert p["thermal_time_constant_s"] >= 30.0  # linear over records of at most 1.2 s


@pytest.mark.integration
@pytest.mark.parametrize("pair", [("eddy_current_diffusion", "rate_independent_hysteresis"),
                                  ("transport_delay", "magnetization_saturation")],
                         ids=["eddy+hysteresis", "delay+saturation"])
def test_names_both_causes_of_a_pair(pair):
    # the two required pairs; both named, in "causes", and the extended model the FMU
    # and the flow study run is the combination
    result = diagnose.diagnose(runs({e: 1.0 for e in pair}, seed=SEED, samples_per_cycle=100))
    _check(result, pair)
    out = result.as_dict()
    assert out["cause"] == out["causes"][0] and set(out["causes"]) == set(pair)
    # "causes" in the order forward selection added them (not the model chain's order):
    # first the single candidate that ranks best
    assert out["causes"][0] == min(result.fits, key=lambda f: f.total_score).cause
    variant = diagnose.variant_from_diagnosis(json.loads(json.dumps(out)))
    assert set(variant.causes) == set(pair) and "+" in variant.name


@pytest.mark.integration
def test_short_records_that_start_in_the_transient_are_used():
    # 3 periods below 10 Hz, every record from the drive's switch-on: the first period is
    # transient and dropped (the rest used), nothing refused
    ds = labsim.make_dataset({"magnetization_saturation": 1.0}, seed=SEED,
                             samples_per_cycle=100, low_frequency_cycles=3,
                             start_in_transient=True)
    result = diagnose.diagnose(smeha_runs(ds))
    _check(result, ("magnetization_saturation",))
    assert result.skipped == []
    rows = {r["run"]: r for r in result.characterisation["runs"]}
    assert rows["5Hz_1A"]["cycles_used"] == 2 and rows["5Hz_1A"]["transient_cycles_dropped"] == 1


def test_a_record_from_the_steady_state_keeps_every_period():
    # records that start after the transient: no period is dropped, 3 periods give 3
    ds = labsim.make_dataset(None, seed=SEED, frequencies=(5.0,), amplitudes=(1.0,),
                             samples_per_cycle=200, low_frequency_cycles=3)
    rf = diagnose.run_features(smeha_runs(ds)[0])
    assert (rf.cycles, rf.dropped_cycles) == (3, 0)


def _butterworth4(x):
    """H(j x) of the 4th-order Butterworth low-pass, x = f / f_c (its tabulated polynomial:
    s^4 + 2.6131 s^3 + 3.4142 s^2 + 2.6131 s + 1; e.g. Williams & Taylor, Electronic
    Filter Design Handbook, table 11-2)."""
    s = 1j * np.asarray(x)
    return 1.0 / (s ** 4 + 2.6131259 * s ** 3 + 3.4142136 * s ** 2 + 2.6131259 * s + 1.0)


def test_the_features_do_not_depend_on_the_sampling():
    # the same measurement at 50, 100, 800 or 4000 samples a period gives the same
    # features (noise-free: labsim's noise off, a 24-bit ADC). What remains is labsim's own
    # anti-alias filter (order 4, cut-off at 0.2 x the sample rate, on every channel, its
    # README): referred to the current's phase, its delay cancels and leaves the k-th
    # harmonic rotated by arg H(k x) - k arg H(x), x = f / f_c; the features agree to that
    # (and to 2e-6 of the fundamental: the 24-bit ADC, the fit's rounding and, for B, the
    # aliasing of the harmonics the filter lets through: B comes from E = -N_c A_c dB/dt,
    # which weights the k-th harmonic by k, so at 50 samples a period the hysteresis' high
    # harmonics alias onto the low ones above that, and B is compared from 100 on)
    feats = {}
    for spc in (50, 100, 800, 4000):
        ds = labsim.make_dataset({"rate_independent_hysteresis": 1.0}, seed=SEED,
                                 frequencies=(70.0,), amplitudes=(1.0,), samples_per_cycle=spc,
                                 noise_um=0.0, noise_current_A=0.0, noise_voltage_V=0.0,
                                 adc_bits=24)
        feats[spc] = diagnose.run_features(smeha_runs(ds)[0])
    k = np.arange(1, diagnose.HARMONICS + 1)
    ref = feats[4000]
    for spc in (50, 100, 800):
        x = 1.0 / (0.2 * spc)
        h = _butterworth4(k * x) / _butterworth4(x) ** k
        filtered = np.abs(h / np.abs(h) - 1.0)  # the rotation the filter leaves
        pairs = [(feats[spc].y, ref.y)] + ([(feats[spc].b, ref.b)] if spc >= 100 else [])
        for a, b in pairs:
            bound = 1.5 * filtered * np.abs(b) + 2e-6 * abs(b[0])
            assert np.all(np.abs(a - b) <= bound), (spc, np.abs(a - b) / bound)


@pytest.mark.integration
def test_unit_mistakes_are_refused_naming_the_column(tmp_path, capsys):
    # metres under displacement_um, mA under current_A: exit 2 before any fit,
    # the message names the column and the unit the numbers look like
    from smeha.measured import write_measurements

    good = runs(None, seed=SEED, frequencies=(20.0, 50.0, 100.0), amplitudes=(0.6, 1.0),
                samples_per_cycle=100)
    cases = {"displacement_um": ("m", [replace(r, displacement=r.displacement * 1e-6)
                                      for r in good]),
             "current_A": ("mA", [replace(r, current=r.current * 1e3) for r in good])}
    for column, (unit, bad) in cases.items():
        path = tmp_path / f"{column}.csv"
        write_measurements(path, bad)
        for command in ("diagnose", "identify"):
            assert main([command, str(path)]) == 2
            err = capsys.readouterr().err
            assert column in err and f"look like {unit}" in err, err
            assert "Traceback" not in err


def test_identify_recovers_table_2_on_clean_lab_data_and_flags_a_misfit():
    # paper, Table 2: K_h 85805, n 1.8092, K_e 2753.39, K_ex 895.80 (labsim's clean model has
    # them); within 3 standard uncertainties, and nothing flagged
    from smeha.identify import format_identification, identify

    clean = identify(runs(None, seed=SEED, samples_per_cycle=200)).loss_fit
    for value, err, true in zip(clean.values, clean.stderrs, (85805.0, 1.8092, 2753.39, 895.80)):
        assert abs(value - true) < 3.0 * err, (value, err, true)
    assert clean.flags == () and clean.physical
    # with an effect the paper's model lacks, the loss law cannot hold: flagged, pointing to
    # smeha diagnose (a residual variance of hundreds must come with its note)
    result = identify(runs({"eddy_current_diffusion": 1.0}, seed=SEED, samples_per_cycle=200))
    assert not result.loss_fit.physical
    assert any("residual variance" in f for f in result.loss_fit.flags)
    text = format_identification(result, "lab.csv")
    assert "make no physical sense" in text and "smeha diagnose lab.csv" in text
    assert result.as_dict()["loss_fit"]["physical"] is False


@pytest.mark.integration
def test_a_sensor_chains_low_pass_is_answered_with_the_caution():
    # labsim's second formulation of the sensor: an order-2 Bessel chain (100 us group delay;
    # tests/labsim/README.md). y alone cannot tell it from a delay or from changed mechanics
    # (docs/DIAGNOSE-method.md, Limits): whichever of those the answer names, it must say so
    result = diagnose.diagnose(runs({"transport_delay": 1.0}, seed=SEED, sample_rate=20000.0,
                                    formulation="alt"))
    assert result.causes and set(result.causes) <= {"transport_delay", "mechanical_resonance"}
    assert any("sensor" in c for c in cautions(result))
    assert result.as_dict()["cautions"] == cautions(result)  # smeha diagnose --json
