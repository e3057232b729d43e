"""The extended model in the system study: ``smeha flow --variant`` and data/paper_variant.json."""
from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pytest

import gmt
from smeha import cli
from smeha.flowstudy import Case, compare_variant, ensure_fmu, run_case

ROOT = Path(__file__).resolve().parents[1]
PAPER_VARIANT = ROOT / "data" / "paper_variant.json"


def test_shipped_paper_variant_is_what_the_paper_diagnosis_picks():
    # data/paper_variant.json is regenerated from smeha.paperdiag, not typed in: the file
    # must still be that diagnosis' pick (the least-squares fit may move in the last digits)
    from smeha.paperdiag import paper_data_diagnosis

    shipped = json.loads(PAPER_VARIANT.read_text())
    assert "paper_data_diagnosis" in shipped["provenance"]
    v = gmt.ModelVariant.from_dict(shipped)
    fresh = gmt.ModelVariant.from_diagnosis(paper_data_diagnosis())
    assert (v.cause, v.form) == (fresh.cause, fresh.form) == ("mechanical_resonance",
                                                              "one_dof")
    for key, value in fresh.parameters.items():
        assert v.parameters[key] == pytest.approx(value, rel=1e-6), key


def test_case_keeps_the_paper_as_default():
    case = Case(100.0, "uncompensated")
    assert case.variant is None and case.model == "paper"
    assert Case(100.0, "uncompensated", variant=gmt.ModelVariant()).variant is None
    with pytest.raises(gmt.ParameterError, match="variant"):
        Case(100.0, "uncompensated", variant="transport_delay")


def test_bad_variant_file_is_a_usage_error(tmp_path, capsys):
    bad = tmp_path / "v.json"
    bad.write_text('{"cause": "transport_delay", "parameters": {"delay_s": -1}}')
    assert cli.main(["flow", "--variant", str(bad), "--backend", "direct"]) == 2
    assert "delay_s = -1 s" in capsys.readouterr().err
    assert cli.main(["flow", "--variant", str(tmp_path / "missing.json"),
                     "--backend", "direct"]) == 1


@pytest.mark.integration
def test_cli_flow_variant_json_pairs_the_models(tmp_path, capsys):
    # a diagnosis that names the sensor delay: the rod, hence the flow, is the paper's
    diagnosis = {"cause": "transport_delay", "gain": 2.0, "candidates": [
        {"cause": "transport_delay", "parameters": {"delay_s": 4e-4}, "score": 10.0},
        {"cause": "thermal_drift", "parameters": {"offset_rate_m_per_A2s": 0.0,
                                                  "gain_rate_per_A2s": 0.0,
                                                  "thermal_time_constant_s": 1.0}}]}
    path = tmp_path / "d.json"
    path.write_text(json.dumps(diagnosis))
    status = cli.main(["flow", "--frequencies", "100", "--ideal", "--cycles", "4",
                       "--backend", "direct", "--workers", "1", "--variant", str(path),
                       "--json"])
    out = json.loads(capsys.readouterr().out)
    assert status == 0
    assert out["variant"] == {"cause": "transport_delay", "parameters": {"delay_s": 4e-4},
                              "source": str(path)}
    assert sorted(r["model"] for r in out["rows"]) == ["paper", "paper", "transport_delay",
                                                       "transport_delay"]
    assert len(out["comparison"]) == 2
    for pair in out["comparison"]:
        assert pair["model"] == "transport_delay"
        # a pure sensor delay changes nothing in the cylinder flow, to the last bit
        assert pair["flow_variant_m3_s"] == pair["flow_paper_model_m3_s"]
        assert pair["flow_ratio_variant_to_paper"] == 1.0
        assert pair["dy_variant_um"] == pair["dy_paper_model_um"]


@pytest.mark.integration
def test_fmu_and_direct_backends_agree_with_the_paper_variant():
    # the FMU's model_variant/variant_parameters start values give gmt.Transducer(variant=..)
    variant = gmt.ModelVariant.from_json(PAPER_VARIANT.read_text())
    case = Case(100.0, "compensated", ideal=True, cycles=4, backend="direct", variant=variant)
    direct = run_case(case)[2]
    fmu = run_case(dataclasses.replace(case, backend="fmu"), ensure_fmu(quiet=True))[2]
    for key in ("flow_sim_m3_s", "dy_um", "load_pressure_Pa", "p_pump_max_Pa"):
        assert fmu[key] == direct[key], key
    assert fmu["model"] == direct["model"] == "mechanical_resonance"
    paper = run_case(dataclasses.replace(case, variant=None))[2]
    pairs = compare_variant([paper, direct])
    assert pairs[0]["flow_ratio_variant_to_paper"] == pytest.approx(
        direct["flow_sim_m3_s"] / paper["flow_sim_m3_s"], rel=1e-15)
    # the re-identified mechanics change the flow (by about 3 % here)
    assert abs(pairs[0]["flow_ratio_variant_to_paper"] - 1.0) > 0.005
