"""The paper's own data: what its model gets wrong, and the held-out check of Figure 7."""
import pytest

from smeha.studies.paperdiag import HELDOUT, TRAIN, paper_data_diagnosis

# paper, Table 3 (uncompensated, I_m = 1 A): y at i = +1 A and i = -1 A above the loop
# minimum [um]; the text's peak-to-peak at 50 and 100 Hz
TABLE3 = {50: (42.0, 1.8), 70: (38.0, 3.0), 80: (36.0, 4.0), 100: (31.2, 4.6)}

#: The diagnosis of the paper's data fits every candidate extension (~5 s): integration.
pytestmark = pytest.mark.integration


@pytest.fixture(scope="module")
def result():
    return paper_data_diagnosis()


def test_measured_values_are_the_papers(result):
    for f, (yp, ym) in TABLE3.items():
        m = result["measured_um"][f"{f:g}"]
        assert m["y_plus1_um"] == pytest.approx(yp) and m["y_minus1_um"] == pytest.approx(ym)
    assert result["measured_um"]["50"]["pp_um"] == pytest.approx(46.0)
    assert result["measured_um"]["100"]["pp_um"] == pytest.approx(36.0)


def test_the_paper_model_lags_its_measurements_at_every_frequency(result):
    # what the model gets wrong: at i = +1 A the measured rod is higher, at i = -1 A lower,
    # above the loop minimum, than eq 30 predicts -- the model's loop lags the current too
    # much at both ends, by more than the 0.5 um reading uncertainty (Table 3)
    loops = result["paper_model"]["loops"]
    for f, (yp, ym) in TABLE3.items():
        model = loops[f"{f:g}"]
        assert yp - model["y_plus1_um"] > 1.0
        assert model["y_minus1_um"] - ym > 0.5
        # hence its dy (eq 40) is below the measured one
        assert model["y_plus1_um"] - model["y_minus1_um"] < yp - ym - 2.0


def test_fitted_on_identification_frequencies_judged_on_held_out(result):
    assert result["train"] == list(TRAIN) == [50.0, 100.0]
    assert result["heldout"] == list(HELDOUT) == [70.0, 80.0]
    assert result["cause"] in {"none", "unexplained"} | {c["cause"] for c in result["candidates"]}
    if result["cause"] != "none":
        best = next(c for c in result["candidates"] if c["cause"] == result["cause"])
        assert best["heldout_rms_um"] == pytest.approx(result["heldout_rms_um"]["extended"])
        assert result["heldout_rms_um"]["extended"] < result["heldout_rms_um"]["paper"]
        assert result["gain"] == pytest.approx(
            result["heldout_rms_um"]["paper"] / result["heldout_rms_um"]["extended"])
    # each candidate contains the paper's model up to its bounds (the smallest field lag
    # allowed, tau = 1 us, still adds a trace of lag), so none may fit the training values
    # worse than the paper by more than that trace: 0.01 um, far below the 0.5 um reading
    # uncertainty
    paper_train = result["paper_model"]["train_rms_um"]
    for c in result["candidates"]:
        assert c["train_rms_um"] <= paper_train + 0.01
