"""``smeha paper``: structure, numbers re-derived from the paper's equations, data, exit codes.

Reference values are re-derived here from Table 2 with plain math (never taken
from the code under test); each names its source. Every test here runs the
command end to end (``smeha paper`` takes ~1 s, its figures ~4 s): integration.
"""
import json
import math

import numpy as np
import pytest

import gmt
from smeha import cli, paperdata
from smeha.studies import paper

pytestmark = pytest.mark.integration

# -- Table 2, SI (paper, Table 2: mm, kA/m and mm^2 converted) ------------------
D_ROD, L_ROD = 10e-3, 80e-3
MASS, DAMPING, STIFFNESS = 0.02, 2945.0, 1.963e7
M_B, N_TURNS, K_F = 250e3, 1300.0, 1.1
K_H, N_STEINMETZ, K_E, K_EX = 85805.0, 1.8092, 2753.39, 895.80
K_LAMBDA = 1.4694e-14
N_C, A_C = 150.0, 380e-6
MU_0 = 4e-7 * math.pi
V_ROD = math.pi * D_ROD ** 2 / 4 * L_ROD

ROW_KEYS = {"frequency_Hz", "current_amplitude_A", "Bm_T", "Bm_from_Em_T", "Bm_table_T",
            "mu_real", "mu_imag", "lag_deg", "pp_um", "dy_um", "P_hyst_W", "P_eddy_W",
            "P_excess_W", "pp_measured_um", "dy_measured_um", "role"}
COMPENSATED_KEYS = {"frequency_Hz", "control_amplitude_V", "dy_comp_um", "dy_comp_measured_um",
                    "dy_um", "flow_ratio", "max_dev_comp", "corr_comp", "max_dev_uncomp",
                    "corr_uncomp", "saturation_count"}


def run_cli(argv, capsys):
    status = cli.main(argv)
    out, err = capsys.readouterr()
    return status, out, err


@pytest.fixture(scope="module")
def report():
    """``smeha paper --json`` parsed (run once for the module)."""
    import contextlib
    import io

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        status = cli.main(["paper", "--json"])
    assert status == 0
    return json.loads(buf.getvalue())  # stdout is exactly one JSON object


def row_at(rows, f, im=1.0):
    (row,) = [r for r in rows if r["frequency_Hz"] == f and r["current_amplitude_A"] == im]
    return row


def hand_mu_imag(f, bm, im):
    """mu'' by eq 16 (eqs 7, 9, 11 over eq 14), Table 2; V cancels."""
    hm = N_TURNS * im / (K_F * L_ROD)  # eq 1
    loss_density = K_H * bm ** N_STEINMETZ * f + K_E * (bm * f) ** 2 + K_EX * (bm * f) ** 1.5
    return loss_density / (math.pi * f * MU_0 * hm ** 2)


def hand_steady_state(f, bm, im, samples=20000):
    """Steady state of eq 30 for i = I_m cos(wt), derived independently.

    M(t) from eq 5, whose H tan(wt) is the field's quadrature part: for
    i = I_m cos(wt), H tan(wt) = H_m cos(wt) tan(wt) = H_m sin(wt); lambda from eq 25,
    force K L lambda (eq 28 with E^H = K L / A_r), and each harmonic of the force
    through 1 / (K - m (k w)^2 + j c k w) (eq 27), harmonics taken by FFT.
    """
    hm = N_TURNS * im / (K_F * L_ROD)
    mu2 = hand_mu_imag(f, bm, im)
    mu1 = math.sqrt((bm / (MU_0 * hm)) ** 2 - mu2 ** 2)  # eq 20
    w = 2 * math.pi * f
    t = np.arange(samples) / (samples * f)
    m = hm * ((mu1 - 1) * np.cos(w * t) + mu2 * np.sin(w * t))
    force = STIFFNESS * L_ROD * K_LAMBDA * (M_B + m) ** 2
    spec = np.fft.rfft(force) / samples
    y = np.full(samples, spec[0].real / STIFFNESS)
    for k in (1, 2):
        g = 1.0 / (STIFFNESS - MASS * (k * w) ** 2 + 1j * DAMPING * k * w)
        y += 2 * np.real(spec[k] * g * np.exp(1j * k * w * t))
    return t, y


# -- structure ---------------------------------------------------------------
def test_json_structure(report):
    assert set(report) == {"rows", "compensated", "diagnosis"}
    assert len(report["rows"]) == 6  # paper, Table 1
    for row in report["rows"]:
        assert ROW_KEYS <= set(row)
    assert [r["frequency_Hz"] for r in report["compensated"]] == [50, 70, 80, 100]  # Table 3
    for row in report["compensated"]:
        assert COMPENSATED_KEYS <= set(row)
        assert row["branch_rule"] == gmt.parameters.BRANCH_RULE  # the default rule


def test_roles(report):
    # paper, Figures 6 (identification: 5 Hz at 0.5 and 0.7 A, 50 and 100 Hz) and 7
    # (held out: 70 and 80 Hz)
    roles = {(r["frequency_Hz"], r["current_amplitude_A"]): r["role"] for r in report["rows"]}
    assert roles == {(5, 0.5): "identification", (5, 0.7): "identification",
                     (50, 1.0): "identification", (70, 1.0): "held-out",
                     (80, 1.0): "held-out", (100, 1.0): "identification"}


# -- numbers re-derived from the equations ----------------------------------------
def test_mu_imag_50hz_by_hand(report):
    # paper eq 16, Table 2, Table 1 (50 Hz, 1 A, B_m = 0.0637 T)
    row = row_at(report["rows"], 50)
    assert row["mu_imag"] == pytest.approx(hand_mu_imag(50.0, 0.0637, 1.0), rel=1e-6)


@pytest.mark.parametrize("f, im, bm", [(5, 0.5, 0.0300), (5, 0.7, 0.0530), (50, 1.0, 0.0637),
                                       (70, 1.0, 0.0590), (80, 1.0, 0.0570),
                                       (100, 1.0, 0.0531)])
def test_permeability_and_losses_by_hand(report, f, im, bm):
    # paper, Table 1 (B_m) and Table 2; eqs 1, 7, 9, 11, 16, 18, 20
    row = row_at(report["rows"], f, im)
    hm = N_TURNS * im / (K_F * L_ROD)
    mu2 = hand_mu_imag(f, bm, im)
    mu1 = math.sqrt((bm / (MU_0 * hm)) ** 2 - mu2 ** 2)
    assert row["Bm_T"] == pytest.approx(bm, rel=1e-12)
    assert row["mu_imag"] == pytest.approx(mu2, rel=1e-6)
    assert row["mu_real"] == pytest.approx(mu1, rel=1e-6)
    assert row["lag_deg"] == pytest.approx(math.degrees(math.atan(mu2 / mu1)), rel=1e-6)
    assert row["P_hyst_W"] == pytest.approx(K_H * bm ** N_STEINMETZ * f * V_ROD, rel=1e-6)
    assert row["P_eddy_W"] == pytest.approx(K_E * (bm * f) ** 2 * V_ROD, rel=1e-6)
    assert row["P_excess_W"] == pytest.approx(K_EX * (bm * f) ** 1.5 * V_ROD, rel=1e-6)


@pytest.mark.parametrize("f, im, bm", [(5, 0.5, 0.0300), (50, 1.0, 0.0637), (100, 1.0, 0.0531)])
def test_loop_by_hand(report, f, im, bm):
    # eq 30 steady state built by hand (see hand_steady_state); dy is eq 40's window
    row = row_at(report["rows"], f, im)
    t, y = hand_steady_state(f, bm, im)
    half = len(t) // 2  # i = -I_m at t = T/2
    assert row["dy_um"] == pytest.approx((y[0] - y[half]) * 1e6, rel=1e-6)
    # pp: both sides take max - min of a sampled cycle (4096 vs 20000 samples), so
    # they differ by the sampling of the peak, ~ (pi/4096)^2 / 2 relative
    assert row["pp_um"] == pytest.approx((y.max() - y.min()) * 1e6, rel=1e-5)
    assert row["y_at_i_plus_um"] == pytest.approx((y[0] - y.min()) * 1e6, rel=1e-5)


def test_bm_from_em_eq22(report):
    # eq 22, B_m = E_m / (w N_c A_c), with Table 1's E_m; Table 1 rounds to ~2 %
    for row, (f, im, em, bm) in zip(report["rows"], gmt.TABLE_1):
        assert row["Bm_from_Em_T"] == pytest.approx(em / (2 * math.pi * f * N_C * A_C), rel=1e-9)
        assert row["Bm_from_Em_T"] == pytest.approx(bm, rel=0.02)


# -- measured values ---------------------------------------------------------
def test_measured_values_appear(report):
    rows = report["rows"]
    # paper text (discussion of Figures 6-7): 46 um at 50 Hz, 36 um at 100 Hz, I_m = 1 A
    assert row_at(rows, 50)["pp_measured_um"] == pytest.approx(46.0)
    assert row_at(rows, 100)["pp_measured_um"] == pytest.approx(36.0)
    assert row_at(rows, 70)["pp_measured_um"] is None
    assert row_at(rows, 5, 0.5)["pp_measured_um"] is None
    # paper, Table 3: y(i=1) - y(i=-1)
    for f, dy in [(50, 42 - 1.8), (70, 38 - 3), (80, 36 - 4), (100, 31.2 - 4.6)]:
        assert row_at(rows, f)["dy_measured_um"] == pytest.approx(dy, rel=1e-12)
    assert row_at(rows, 5, 0.7)["dy_measured_um"] is None


def test_compensated_measured_and_ratios(report):
    # paper, Table 3: y(u=u_m) - y(u=0) and control amplitudes a (text, Figure 10)
    expected = {50: (46.0, 2.2), 70: (42.0, 1.9), 80: (40.0, 1.7), 100: (35.2, 1.5)}
    for row in report["compensated"]:
        dy_meas, a = expected[row["frequency_Hz"]]
        assert row["dy_comp_measured_um"] == pytest.approx(dy_meas, rel=1e-12)
        assert row["control_amplitude_V"] == pytest.approx(a)
        assert row["flow_ratio"] == pytest.approx(row["dy_comp_um"] / row["dy_um"], rel=1e-12)
        assert row["dy_um"] == pytest.approx(row_at(report["rows"], row["frequency_Hz"])["dy_um"])
        # the paper's claim (Figures 10-11): the compensator improves linearity
        assert row["corr_comp"] > row["corr_uncomp"]
        assert row["max_dev_comp"] < row["max_dev_uncomp"]
        # the demand y_d = 10 u spans 20 a um; the model cannot exceed its stroke
        assert 0 < row["dy_comp_um"] <= 20 * a * 1.01


def hand_saturated_time(f):
    """Time per cycle the compensator's demand lies below the stroke's bottom, [s].

    Table 3 measures the compensated stroke from its lowest point, so u = 0 asks
    for exactly the bottom y_b of the stroke the current amplitude allows. Eq 34
    inverts eq 27: the demanded force over K is y_d + (c/K) y_d' + (m/K) y_d''.
    With u = a + a cos(wt) and wt = pi + theta, y_d - y_b = 10 a (1 - cos theta) um,
    so the demand is out of reach, F/K < y_b, where
    g(theta) = 1 - cos(theta) + (c/K) w sin(theta) + (m/K) w^2 cos(theta) < 0,
    an interval just before u's minimum whose length is ~2 sqrt((c/K)^2 - 2 m/K)
    (0.286 ms with Table 2), whatever f and a. Its roots by bisection.
    """
    w = 2 * math.pi * f

    def g(theta):
        return (1 - math.cos(theta) + DAMPING / STIFFNESS * w * math.sin(theta)
                + MASS / STIFFNESS * w * w * math.cos(theta))

    def root(lo, hi):  # g changes sign once in [lo, hi]
        for _ in range(100):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if (g(lo) < 0) == (g(mid) < 0) else (lo, mid)
        return 0.5 * (lo + hi)
    deepest = -DAMPING / STIFFNESS * w
    return (root(deepest, 1.0) - root(-1.0, deepest)) / w


def test_saturation_is_the_inverted_damping_at_the_stroke_bottom(report):
    # The compensated runs saturate only where eq 27's inversion asks for less than the
    # stroke's bottom (hand_saturated_time). The top is out of the question: Table 3's
    # amplitudes demand 20 a um (44 um at 50 Hz), within the static stroke
    # 4 K_lambda L M_b |mu - 1| H_m (eqs 5, 25; 44.5 um at 50 Hz, 36.2 um at 100 Hz).
    # The count is of samples, 1/(samples_per_cycle f) apart: +-1 at each end of the
    # interval, the compensator's backward differences (a sample's lag) included.
    for row in report["compensated"]:
        f = row["frequency_Hz"]
        hm = N_TURNS * 1.0 / (K_F * L_ROD)  # eq 1
        bm = dict((r[0], r[3]) for r in gmt.TABLE_1 if r[1] == 1.0)[f]
        mu2 = hand_mu_imag(f, bm, 1.0)
        mu1 = math.sqrt((bm / (MU_0 * hm)) ** 2 - mu2 ** 2)  # eq 20
        static_stroke_um = 4 * K_LAMBDA * L_ROD * M_B * hm * math.hypot(mu1 - 1, mu2) * 1e6
        assert 20 * row["control_amplitude_V"] < static_stroke_um
        expected = hand_saturated_time(f) * row["samples_per_cycle"] * f
        assert row["saturated_last_cycle"] == pytest.approx(expected, abs=2.0), f


def test_data_files_match_paper():
    # paper, Table 1 (f, I_m, E_m, B_m) as shipped in data/ and as gmt embeds it
    t1 = paperdata.table1()
    assert np.array_equal(t1["frequency"], [5, 5, 50, 70, 80, 100])
    table = np.array(gmt.TABLE_1)
    for k, key in enumerate(("frequency", "current_amplitude", "sense_voltage_amplitude",
                             "flux_density_amplitude")):
        np.testing.assert_allclose(t1[key], table[:, k], rtol=0, atol=0)
    t3 = paperdata.table3()
    np.testing.assert_allclose(t3["displacement_at_current_max"], [42e-6, 38e-6, 36e-6, 31.2e-6])
    np.testing.assert_allclose(t3["control_amplitude"], [2.2, 1.9, 1.7, 1.5])
    st = paperdata.stated()
    np.testing.assert_allclose(st["peak_to_peak"], [46e-6, 36e-6])


def test_normalise_eq38():
    # eq 38: X = (x - x_min) / (x_max - x_min)
    assert paper.normalise([3.0, 5.0, 4.0]).tolist() == [0.0, 1.0, 0.5]
    dev, corr = paper.linearity([0.0, 1.0, 2.0], [10.0, 20.0, 30.0])
    assert dev == 0.0 and corr == pytest.approx(1.0)


# -- terminal output, plots, exit codes ----------------------------------------------------
def test_terminal_table(capsys):
    status, out, err = run_cli(["paper"], capsys)
    assert status == 0
    assert "f [Hz]" in out and "mu''" in out and "q'/q" in out and "P_eddy [W]" in out
    assert err == ""


def test_plots_written(tmp_path, capsys):
    status, out, _ = run_cli(["paper", "--json", "--plots", str(tmp_path / "figs")], capsys)
    assert status == 0
    json.loads(out)  # --json still prints only the JSON object
    for name in ("loops.png", "losses.png", "linearity.png"):
        path = tmp_path / "figs" / name
        assert path.is_file() and path.stat().st_size > 10_000
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("argv", [["paper", "--branch-rule", "sideways"], ["paper", "--bogus"],
                                  [], ["nosuchcommand"], ["paper", "extra"]])
def test_bad_arguments_exit_2(argv, capsys):
    status, out, err = run_cli(argv, capsys)
    assert status == 2
    assert "Traceback" not in err and err


def test_parameter_error_exit_2(monkeypatch, capsys):
    def broken(*args, **kwargs):
        raise gmt.ParameterError("frequency = -1 Hz is outside the allowed range (0, 1000] Hz")

    monkeypatch.setattr(paper, "compensated_runs", broken)
    status, out, err = run_cli(["paper"], capsys)
    assert status == 2
    assert "frequency = -1 Hz" in err and "Traceback" not in err and out == ""


def test_plots_dir_not_creatable_exit_2(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    status, _, err = run_cli(["paper", "--plots", str(blocker / "sub")], capsys)
    assert status == 2 and "--plots" in err


def test_missing_data_exit_1(monkeypatch, tmp_path, capsys):
    monkeypatch.setenv(paperdata.DATA_DIR_ENV, str(tmp_path / "nowhere"))
    with pytest.raises(paperdata.DataNotFoundError, match="SMEHA_DATA_DIR"):
        paperdata.table1()
    status, _, err = run_cli(["paper"], capsys)
    assert status == 1 and "not found" in err
