"""Figures of the flow study: one co-simulation run, flow against frequency, load lines.

One meaning per colour in every figure: blue is the uncompensated mode, red the
compensated one (:data:`MODE_COLOURS`). What else differs -- the source of a flow
(co-simulation, eqs 40/41, the paper), the transducer model (the paper's or an
extended one), the pumping frequency of a load line -- is told by line style and
marker, each with its own legend.
"""
from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402
from matplotlib.patches import Patch  # noqa: E402

from ..outputs import save_figure  # noqa: E402

__all__ = ["MODE_COLOURS", "MARKERS", "drive_label", "run_figure", "plot_run", "flow_figure",
           "plot_flow"]

#: Colour of each drive mode, the same in every panel.
MODE_COLOURS = {"uncompensated": "tab:blue", "compensated": "tab:red"}
#: Markers for the curves a colour does not tell apart (frequencies of the load lines,
#: loads of a sweep), in order, cycled.
MARKERS = ("o", "s", "^", "D", "v", "P", "X", "*")
_SKIPPED = "first cycles, discarded by the flow check"


def _eq(mode):
    return "eq 41" if mode == "compensated" else "eq 40"


def run_figure(record, row, skip_cycles: int | None = None):
    """Rod displacement and control, pressures, valve phase and pumped volume of one run.

    The rod displacement is drawn as Table 3 measures it: zero at the rod's lowest
    point over the cycles the flow check averages (after ``skip_cycles``). The
    model's absolute y, from the unmagnetised and unloaded rod, includes the bias
    strain and the rod's compression by the chamber pressure; the offset is stated
    in the axis label.
    """
    if skip_cycles is None:
        from system_models.flowcheck import SKIP_CYCLES as skip_cycles
    t = record["time"] * 1e3
    period_ms = 1e3 / row["frequency_Hz"]
    steady = t >= skip_cycles * period_ms
    fig, axes = plt.subplots(4, 1, figsize=(9, 9.5), sharex=True,
                             gridspec_kw={"height_ratios": [3, 3, 1, 2]})
    twin = axes[0].twinx()
    for a in (twin, *axes[1:]):
        a.axvspan(0.0, min(skip_cycles * period_ms, t[-1]), color="0.92", zorder=0)
    for a in axes:
        a.grid(alpha=0.3)
    _rod_panel(axes[0], twin, t, record, steady)
    _pressure_panel(axes[1], t, record, row, steady)
    ax = axes[2]
    ax.step(t, record["valves_compressing"], where="post", color="black", lw=1.0)
    ax.set_yticks([0, 1], ["expanding", "compressing"], fontsize=7)
    ax.set_ylim(-0.2, 1.2)
    ax.set_ylabel("valves", fontsize=8)
    ax = axes[3]
    ax.plot(t, record["volume_into_big"] * 1e9, color="black", lw=1.2,
            label="net volume into the big cavity (V1 - V2)")
    ax.set_ylabel("volume [mm^3]")
    ax.set_xlabel("time [ms]")
    ax.legend(loc="best", fontsize=7)
    _run_title(fig, row)
    fig.tight_layout()
    return fig


def magnetics_label(row) -> str:
    """The transducer's magnetics of a row: "the paper's magnetics", "time-domain magnetics"."""
    magnetics = row.get("magnetics", "paper")
    return ("the paper's magnetics" if magnetics == "paper"
            else f"{magnetics.replace('_', '-')} magnetics")


def drive_label(row) -> str:
    """The transducer's magnetics and drive of a row: "time-domain magnetics, square drive"."""
    return f"{magnetics_label(row)}, {row.get('waveform', 'sine')} drive"


def _rod_panel(ax, twin, t, record, steady):
    """The rod's displacement (0 at its lowest averaged point) and the control signal."""
    y = record["rod_displacement"] * 1e6
    bottom = float(np.min(y[steady])) if steady.any() else float(np.min(y))
    rod, = ax.plot(t, y - bottom, color="tab:blue", lw=1.4, label="rod displacement y")
    ax.set_ylabel("rod displacement y [um]")
    ax.set_title(f"rod y: 0 at its lowest point after the first cycles, as Table 3 measures; "
                 f"there the model's y (from the free, unmagnetised rod) is {bottom:.1f} um",
                 fontsize=8, loc="left")
    control, = twin.plot(t, record["control"], color="0.45", lw=0.8,
                         label="control signal u (right axis)")
    twin.set_ylabel("control u [V]")
    low, high = float(np.min(record["control"])), float(np.max(record["control"]))
    twin.set_ylim(low - 0.05 * (high - low), high + 0.3 * (high - low))  # room for the legend
    shaded = Patch(color="0.92", label=_SKIPPED)
    # the axis spans the averaged cycles, with room above them for the legend; a start
    # beyond them (the drive switched on at its peak, the circuit settling) is said
    ys = (y - bottom)[steady] if steady.any() else y - bottom
    span = float(np.ptp(ys)) or 1.0
    top = float(np.max(ys)) + 0.45 * span
    ax.set_ylim(float(np.min(ys)) - 0.05 * span, top)
    if float(np.max(y - bottom)) > top:
        ax.set_title(ax.get_title(loc="left") + f"\nthe start is off scale (up to "
                     f"{float(np.max(y - bottom)):.0f} um: the drive switched on and the "
                     "circuit settling, within the discarded cycles)", fontsize=8, loc="left")
    ax.legend(handles=[rod, control, shaded], loc="upper right", fontsize=7, ncol=3,
              framealpha=0.9)
    ax.set_zorder(twin.get_zorder() + 1)  # the rod's line above the control trace
    ax.patch.set_visible(False)


def _pressure_panel(ax, t, record, row, steady):
    """The pressures of the cavities, the accumulator and the pump chamber."""
    # cavities underneath, wide and pale; the pump chamber on top, thin and dark: an open
    # valve ties the chamber to a cavity (V1: big, V3: small), and both stay visible
    ax.plot(t, record["p_big"] / 1e6, color="tab:orange", lw=3.5, alpha=0.45,
            label="big (cap) cavity B")
    ax.plot(t, record["p_small"] / 1e6, color="tab:green", lw=3.5, alpha=0.45,
            label="small (rod) cavity S")
    ax.plot(t, record["p_accumulator"] / 1e6, color="tab:purple", lw=1.0, ls="--",
            label="accumulator A")
    ax.plot(t, record["p_pump"] / 1e6, color="black", lw=0.9, label="pump chamber P")
    if row.get("cavitation"):  # below what oil holds (smeha.studies.flow.flag_row)
        ax.axhline(0.0, color="tab:red", lw=1.0, ls=":",
                   label="0 absolute: oil cavitates below ~1 kPa (not modelled)")
        low, high = ax.get_ylim()
        ax.set_ylim(low - 0.4 * (high - low), high)  # room for the legend below the traces
    pressures = np.concatenate([record[k][steady] if steady.any() else record[k]
                                for k in ("p_big", "p_small", "p_accumulator", "p_pump")]) / 1e6
    low, high = float(np.min(pressures)), float(np.max(pressures))
    span = (high - low) or 0.1
    if not row.get("cavitation"):  # the averaged cycles, room below for the legend
        ax.set_ylim(low - 0.45 * span, high + 0.05 * span)
    ax.set_ylabel("pressure [MPa]")
    ax.legend(loc="lower right", fontsize=7, ncol=4, framealpha=0.9)


def _run_title(fig, row):
    """The run's case (mode, frequency, circuit, load, magnetics, drive) and its flows."""
    flagged = []
    if row.get("flow_reversed"):
        flagged.append("flow reversed: " + ("the load past its stall point"
                                            if "stall" in row.get("note", "")
                                            else "the rod lags past a quarter period"))
    if row.get("cavitation"):
        flagged.append("cavitation: the oil held below what it can")
    mark = f"\n(!) {'; '.join(flagged)} (smeha simulate prints why)" if flagged else ""
    fig.suptitle(f"{row['mode']}, {row['frequency_Hz']:g} Hz, {row['circuit']} circuit, "
                 f"load {row['load_N']:g} N, {drive_label(row)}\n"
                 f"q = {row['flow_sim_m3_s']:.3e} m^3/s, "
                 f"f A_d dy ({_eq(row['mode'])}) = {row['flow_eq_m3_s']:.3e} m^3/s, "
                 f"dy = {row['dy_um']:.1f} um{mark}", fontsize=10,
                 color="tab:red" if flagged else "black")


def plot_run(record, row, path):
    """:func:`run_figure` as an image (PNG, PDF or SVG by the suffix), written whole."""
    save_figure(run_figure(record, row), path, dpi=110, bbox_inches="tight")


def flow_figure(rows):
    """Flow against frequency for both modes, with eqs 40/41 and Table 3 (Figure 12 analogue).

    Rows of a model variant (``row["model"] != "paper"``) are drawn next to the
    paper's model. With several loads in ``rows``, a second panel draws the
    load lines of each model. The title states the circuit, the load, the magnetics and
    the drive; the legend names only what is drawn.
    """
    paper = [r for r in rows if r.get("model", "paper") == "paper"]
    variants = [r for r in rows if r.get("model", "paper") != "paper"]
    loads = sorted({r["load_N"] for r in paper})
    base = paper[0]["load_N"]
    ncols = 2 if len(loads) > 1 else 1
    fig, axes = plt.subplots(1, ncols, figsize=(6.8 * ncols, 6.0), squeeze=False)
    ax = axes[0, 0]
    simulated = "co-simulation"
    drawn = _flow_curves(ax, paper, variants, base)
    styles = [Line2D([], [], color="k", marker="o", ls="-",
                     label=f"{simulated}, {magnetics_label(paper[0])}"),
              Line2D([], [], color="k", marker="s", ls="--", mfc="none",
                     label="f A_d dy of this run (eqs 40/41)")]
    if drawn["paper"]:
        styles.append(Line2D([], [], color="k", marker="^", ls=":", alpha=0.7,
                             label="paper: f A_d dy from Table 3's measured dy\n(eqs 40/41; "
                                   "computed, not a measured flow)"))
    if drawn["variant"]:
        styles.append(Line2D([], [], color="k", marker="D", ls="-.", mfc="white",
                             label=f"{simulated}, extended model\n{variants[0]['model']}"))
    _mark_flagged(ax, [r for r in rows if r["load_N"] == base], styles)
    _mark_variant(ax, [r for r in variants if r["load_N"] == base], styles)
    _finish_flow_axes(ax, styles, 2, "pumping frequency f [Hz]",
                      f"Flow against frequency ({paper[0]['circuit']} circuit, load {base:g} N)"
                      f"\n{drive_label(paper[0])}")
    if ncols == 2:
        _load_lines(axes[0, 1], paper, variants, simulated)
    fig.tight_layout()
    return fig


def _flow_curves(ax, paper, variants, base) -> dict:
    """Each mode's co-simulated flow, eqs 40/41 and, where the case is one of Table 3's,
    the paper's; the variant's flow. Returns which optional curves were drawn."""
    drawn = {"paper": False, "variant": False}
    for mode, colour in MODE_COLOURS.items():
        rs = sorted((r for r in paper if r["mode"] == mode and r["load_N"] == base),
                    key=lambda r: r["frequency_Hz"])
        if not rs:
            continue
        f = [r["frequency_Hz"] for r in rs]
        ax.plot(f, [r["flow_sim_m3_s"] * 1e6 for r in rs], "o-", color=colour)
        ax.plot(f, [r["flow_eq_m3_s"] * 1e6 for r in rs], "s--", color=colour, mfc="none")
        pf = [(r["frequency_Hz"], r["flow_paper_m3_s"] * 1e6) for r in rs
              if r["flow_paper_m3_s"]]
        if pf:
            ax.plot(*zip(*pf), "^:", color=colour, alpha=0.7)
            drawn["paper"] = True
        vs = sorted((r for r in variants if r["mode"] == mode and r["load_N"] == base),
                    key=lambda r: r["frequency_Hz"])
        if vs:
            ax.plot([r["frequency_Hz"] for r in vs], [r["flow_sim_m3_s"] * 1e6 for r in vs],
                    "D-.", color=colour, mfc="white", lw=1.6)
            drawn["variant"] = True
    return drawn


def _mark_flagged(ax, rows, styles):
    """Mark a reversed flow and cavitation (smeha.studies.flow.flag_row) with the reason."""
    flagged = [r for r in rows if r.get("flow_reversed")]
    if flagged:
        ax.axhline(0.0, color="k", lw=0.6)
        for r in flagged:
            q = r["flow_sim_m3_s"] * 1e6
            ax.plot(r["frequency_Hz"], q, "X", color="k", ms=11, mfc="none", mew=1.5)
            reason = ("the rod lags the valve switches\nby more than a quarter period"
                      if r["dy_um"] < 0.0 else "the load is past\nthe pump's stall point")
            first = r["frequency_Hz"] <= min(x["frequency_Hz"] for x in flagged)
            ax.annotate(f"reversed: {reason}", (r["frequency_Hz"], q),
                        xytext=(30, 0) if first and len(flagged) > 1 else (-30, 0),
                        textcoords="offset points",
                        ha="left" if first and len(flagged) > 1 else "right", va="center",
                        fontsize=7,
                        arrowprops={"arrowstyle": "-", "color": "0.4", "lw": 0.6})
        styles.append(Line2D([], [], color="k", marker="X", ls="none", mfc="none", ms=9,
                             label="flow reversed (the table's note says why)"))
    tension = [r for r in rows if r.get("cavitation")]
    for r in tension:  # oil held below what it can
        ax.plot(r["frequency_Hz"], r["flow_sim_m3_s"] * 1e6, "o", color="k", ms=15,
                mfc="none", mew=1.5)
    if tension:
        styles.append(Line2D([], [], color="k", marker="o", ls="none", mfc="none", ms=10,
                             label="cavitation: a pressure below 1 kPa absolute,\n"
                                   "which no oil holds (the table's note)"))


def _mark_variant(ax, rows, styles):
    """Ring the variant's rows that smeha.studies.variantcheck marks (a weak finding, a circuit mode
    it moves onto the pumping frequency) and name the reasons in the legend."""
    marked = [r for r in rows if r.get("variant_marks")]
    if not marked:
        return
    for r in marked:
        ax.plot(r["frequency_Hz"], r["flow_sim_m3_s"] * 1e6, "s", color="tab:red", ms=14,
                mfc="none", mew=1.4)
    kinds = sorted({m.split(":")[0] for r in marked for m in r["variant_marks"]})
    styles.append(Line2D([], [], color="tab:red", marker="s", ls="none", mfc="none", ms=10,
                         label="extended model not physical here:\n" + ";\n".join(kinds)
                               + "\n(the table's notes say why)"))


def _load_lines(ax, paper, variants, simulated):
    """Flow against load pressure: colour = mode, marker = frequency, dash-dot = variant."""
    frequencies = sorted({r["frequency_Hz"] for r in paper})
    marker = {f: MARKERS[k % len(MARKERS)]
              for k, f in enumerate(frequencies)}
    for rows, style in ((paper, "-"), (variants, "-.")):
        for f in frequencies:
            for mode, colour in MODE_COLOURS.items():
                rs = sorted((r for r in rows if r["frequency_Hz"] == f and r["mode"] == mode),
                            key=lambda r: r["load_N"])
                if len(rs) < 2:
                    continue
                ax.plot([r["load_pressure_Pa"] / 1e6 for r in rs],
                        [r["flow_sim_m3_s"] * 1e6 for r in rs], ls=style, color=colour,
                        marker=marker[f], mfc="white" if style == "-." else colour)
    ax.axhline(0.0, color="k", lw=0.6)
    freqs = [Line2D([], [], color="0.3", marker=marker[f], ls="none", label=f"{f:g} Hz")
             for f in frequencies]
    if variants:
        freqs.append(Line2D([], [], color="0.3", ls="-.", mfc="white", marker="o",
                            label=f"extended model {variants[0]['model']}"))
    _finish_flow_axes(ax, freqs, 3, "load pressure p_B - p_S [MPa]", f"Load lines: {simulated}")


def _finish_flow_axes(ax, handles, ncol, xlabel, title):
    """Labels, grid and a legend below the panel: the modes' colours, then ``handles``."""
    modes = [Line2D([], [], color=c, lw=2, label=m) for m, c in MODE_COLOURS.items()]
    ax.legend(handles=modes + handles, loc="upper center", bbox_to_anchor=(0.5, -0.13),
              fontsize=7, ncol=ncol, frameon=False)
    ax.set_xlabel(xlabel)
    ax.set_ylabel("mean cylinder flow [cm^3/s]")
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3)


def plot_flow(rows, path):
    """:func:`flow_figure` as an image, written whole (the legends below the panels
    included)."""
    save_figure(flow_figure(rows), path, dpi=110, bbox_inches="tight")
