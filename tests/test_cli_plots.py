"""The figures of ``smeha flow --plot`` and ``smeha simulate --plot`` say what they show.

Built from small hand-made rows and records (no co-simulation), and checked through the
matplotlib artists: what a reader must be able to tell apart is drawn, each colour keeps
one meaning across panels, and the rod displacement has a stated reference.
The PNGs themselves were looked at; these tests keep what was fixed from coming back.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from smeha.studies import flowplots
from system_models.cosim import RESULT_FIELDS

MODES = ("uncompensated", "compensated")


def _row(f, mode, load, model="paper", backend="direct"):
    flow = (2.0 if mode == "compensated" else 1.5) * f / 100 - load * 1e-3 \
        + (0.3 if model != "paper" else 0.0)
    return {"frequency_Hz": f, "mode": mode, "model": model, "load_N": load,
            "circuit": "realistic", "flow_sim_m3_s": flow * 1e-6, "flow_eq_m3_s": flow * 1.01e-6,
            "flow_paper_m3_s": (2.5e-6 if f == 50.0 else None), "load_pressure_Pa": load * 1e3,
            "backend": backend}


def _rows(models=("paper",), loads=(150.0,)):
    return [_row(f, m, ld, model) for model in models for f in (50.0, 100.0) for m in MODES
            for ld in loads]


def _mode_of(colour):
    (mode,) = [m for m, c in flowplots.MODE_COLOURS.items()
               if np.allclose(matplotlib_rgba(c), matplotlib_rgba(colour))]
    return mode


def matplotlib_rgba(colour):
    from matplotlib.colors import to_rgba
    return to_rgba(colour)


def _data_lines(ax):
    return [ln for ln in ax.get_lines() if len(ln.get_xdata()) > 1
            and ln.get_color() not in ("k", "black")]


def test_one_colour_per_mode_in_both_panels():
    # blue and red meant modes in one panel and frequency/mode pairs in the other
    fig = flowplots.flow_figure(_rows(loads=(150.0, 0.0, 300.0)))
    left, right = fig.axes
    for ax in (left, right):
        for line in _data_lines(ax):
            mode = _mode_of(line.get_color())
            flows = np.asarray(line.get_ydata())
            rows = [r for r in _rows(loads=(150.0, 0.0, 300.0)) if r["mode"] == mode]
            candidates = {round(r["flow_sim_m3_s"] * 1e6, 9) for r in rows} | \
                {round(r["flow_eq_m3_s"] * 1e6, 9) for r in rows} | {2.5}
            assert {round(v, 9) for v in flows} <= candidates, (mode, flows)
    # the load lines: one per frequency and mode, told apart by marker, coloured by mode
    markers = {(ln.get_marker(), _mode_of(ln.get_color())) for ln in _data_lines(right)}
    assert markers == {(flowplots.MARKERS[k], m) for k in (0, 1) for m in MODES}


def test_variant_is_drawn_next_to_the_paper_model():
    # flow --variant FILE --plot drew only the paper's model
    rows = _rows(models=("paper", "mechanical_resonance"))
    fig = flowplots.flow_figure(rows)
    (ax,) = fig.axes
    drawn = {tuple(np.round(ln.get_ydata(), 9)) for ln in ax.get_lines()}
    for mode in MODES:
        variant = [r["flow_sim_m3_s"] * 1e6 for r in rows
                   if r["model"] != "paper" and r["mode"] == mode]
        assert tuple(np.round(variant, 9)) in drawn
    labels = " ".join(t.get_text() for t in ax.get_legend().get_texts())
    assert "extended model" in labels and "mechanical_resonance" in labels


def test_paper_flow_is_labelled_as_computed_from_table_3():
    fig = flowplots.flow_figure(_rows())
    labels = " ".join(t.get_text() for t in fig.axes[0].get_legend().get_texts())
    assert "Table 3" in labels and "eqs 40/41" in labels and "not a measured flow" in labels


def _record(frequency=100.0, cycles=4, n_cycle=200):
    """A run's record: y = bias + compression + a 30 um stroke; pump chamber equal to the big
    cavity while compressing (V1 open), to the small one while expanding (V3 open)."""
    n = cycles * n_cycle + 1
    rec = np.zeros(n, dtype=[(name, float) for name in RESULT_FIELDS])
    t = np.arange(n) / (frequency * n_cycle)
    phase = 2 * math.pi * frequency * t
    rec["time"] = t
    rec["control"] = 1.5 + 1.5 * np.cos(phase)
    rec["rod_displacement"] = -40e-6 + 15e-6 * (1 - np.cos(phase))
    compressing = (np.sin(phase) < 0).astype(float)
    rec["valves_compressing"] = compressing
    rec["p_big"] = 1.6e6 + 0.1e6 * np.sin(phase)
    rec["p_small"] = rec["p_accumulator"] = 1.5e6
    rec["p_pump"] = np.where(compressing == 1, rec["p_big"], rec["p_small"])
    rec["volume_into_big"] = 1e-9 * t * frequency
    return rec


ROW = {"mode": "compensated", "frequency_Hz": 100.0, "circuit": "realistic", "load_N": 150.0,
       "flow_sim_m3_s": 3.1e-6, "flow_eq_m3_s": 3.2e-6, "dy_um": 25.0}


def test_run_figure_names_the_control_trace_and_states_the_rod_reference():
    fig = flowplots.run_figure(_record(), ROW, skip_cycles=2)
    rod_axis = fig.axes[0]
    labels = [t.get_text() for t in rod_axis.get_legend().get_texts()]
    assert any("control signal u" in label for label in labels)
    (rod,) = [ln for ln in rod_axis.get_lines() if ln.get_label() == "rod displacement y"]
    # Table 3's reference: zero at the lowest point of the cycles the flow check averages
    assert min(rod.get_ydata()) == pytest.approx(0.0, abs=1e-9)
    reference = rod_axis.get_title(loc="left")
    assert "0 at its lowest point" in reference
    assert "-40.0 um" in reference  # where that zero sits in the model's y


def test_pump_chamber_pressure_is_drawn_on_top():
    # the pump chamber hid under the cavity traces it equals while a valve is open
    fig = flowplots.run_figure(_record(), ROW, skip_cycles=2)
    pressure = fig.axes[1] if "pressure" in fig.axes[1].get_ylabel() else None
    assert pressure is not None
    lines = {ln.get_label(): ln for ln in pressure.get_lines()}
    pump = lines["pump chamber P"]
    for name in ("big (cap) cavity B", "small (rod) cavity S"):
        cavity = lines[name]
        # drawn after (above) the cavities, narrower than them: both stay visible
        assert pressure.get_lines().index(pump) > pressure.get_lines().index(cavity)
        assert pump.get_linewidth() < cavity.get_linewidth()


@pytest.mark.integration  # rendering two PNGs takes ~2 s
def test_plots_write_png(tmp_path):
    flowplots.plot_flow(_rows(loads=(150.0, 0.0)), tmp_path / "flow.png")
    flowplots.plot_run(_record(), ROW, tmp_path / "run.png")
    for name in ("flow.png", "run.png"):
        assert (tmp_path / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def _legend_texts(ax):
    return [t.get_text() for t in ax.get_legend().get_texts()]


def test_no_legend_entry_without_points():
    # flow --magnetics time_domain --waveform square --plot: the legend listed Table 3's
    # points (measured with the sinusoidal drive only, so not drawn) and "the paper's model"
    rows = [dict(r, magnetics="time_domain", waveform="square", flow_paper_m3_s=None)
            for r in _rows()]
    fig = flowplots.flow_figure(rows)
    ax = fig.axes[0]
    labels = " ".join(_legend_texts(ax))
    assert "Table 3" not in labels and "the paper's" not in labels
    assert "time-domain magnetics" in labels
    assert not any(ln.get_marker() == "^" for ln in ax.get_lines())  # nothing to list
    title = ax.get_title()
    assert all(w in title for w in ("realistic circuit", "load 150 N", "time-domain magnetics",
                                    "square drive"))
    # at the paper's sine drive its Table 3 points are drawn and listed
    ax = flowplots.flow_figure(_rows()).axes[0]
    assert any(ln.get_marker() == "^" for ln in ax.get_lines())
    assert "Table 3" in " ".join(_legend_texts(ax))
    assert "the paper's magnetics, sine drive" in ax.get_title()


def test_run_title_states_magnetics_waveform_circuit_and_load():
    # simulate --plot's title omitted the magnetics and the waveform
    row = dict(ROW, magnetics="time_domain", waveform="trapezoid")
    title = flowplots.run_figure(_record(), row, skip_cycles=2)._suptitle.get_text()
    for words in ("compensated", "100 Hz", "realistic circuit", "load 150 N",
                  "time-domain magnetics", "trapezoid drive"):
        assert words in title


def test_sweep_plot_states_the_drive(tmp_path, monkeypatch):
    # one drive: in the title; several: in each line's label
    import matplotlib.pyplot as plt

    from smeha.studies import sweep
    figures = []
    monkeypatch.setattr(sweep, "save_figure", lambda fig, path, **k: figures.append(fig))

    def row(f, mode, waveform):
        return {"status": "ok", "frequency": f, "mode": mode, "load_N": 150.0,
                "circuit": "realistic", "flow_sim_m3_s": 1e-6 * f / 50,
                "magnetics": "time_domain", "waveform": waveform}
    sweep.plot_sweep([row(f, m, "square") for f in (50.0, 100.0) for m in MODES],
                     tmp_path / "a.png")
    assert "time-domain magnetics, square drive" in figures[-1].axes[0].get_title()
    sweep.plot_sweep([row(f, "compensated", w) for f in (50.0, 100.0)
                      for w in ("sine", "square")], tmp_path / "b.png")
    labels = [t.get_text() for t in figures[-1].axes[0].get_legend().get_texts()]
    assert labels == ["compensated, 150 N, realistic, time-domain magnetics, sine drive",
                      "compensated, 150 N, realistic, time-domain magnetics, square drive"]
    plt.close("all")
