"""Figures of ``smeha paper --plots DIR`` (matplotlib, Agg backend, no display).

* ``loops.png`` -- displacement against current in steady state for every
  Table 1 case, with the measured Table 3 and stated points (Figures 6-7);
* ``losses.png`` -- P_h, P_eddy, P_ex and their sum against frequency at
  I_m = 1 A (Figure 8);
* ``linearity.png`` -- eq 38-normalised displacement against the normalised
  control signal, compensated and uncompensated (Figures 10-11).
"""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import gmt  # noqa: E402

from ..outputs import save_figure  # noqa: E402
from . import paper  # noqa: E402

__all__ = ["LOOPS_FILE", "LOSSES_FILE", "LINEARITY_FILE", "LOSS_FREQUENCIES", "loops_figure",
           "losses_figure", "linearity_figure", "write_all"]

LOOPS_FILE = "loops.png"
LOSSES_FILE = "losses.png"
LINEARITY_FILE = "linearity.png"

#: Frequencies of the loss figure, [Hz] (Figure 8 spans the same decade).
LOSS_FREQUENCIES = np.arange(5.0, 150.0 + 1e-9, 1.0)


def _closed(x):
    return np.append(x, x[:1])


def loops_figure(params: gmt.TransducerParameters, rows: list[dict], path) -> Path:
    """Steady-state displacement-current loops, one panel per Table 1 case.

    Parameters
    ----------
    params : TransducerParameters
    rows : list of dict
        :func:`smeha.studies.paper.paper_rows` (cases and measured values).
    path : path-like
        PNG to write.
    """
    fig, axes = plt.subplots(2, 3, figsize=(13, 7.5), sharey=True)
    for ax, row in zip(axes.flat, rows):
        f, im = row["frequency_Hz"], row["current_amplitude_A"]
        cyc = paper.uncompensated_cycle(params, f, im)
        y = (cyc["displacement"] - cyc["displacement"].min()) * 1e6
        ax.plot(_closed(cyc["current"]), _closed(y), color="C0", lw=1.8, label="model, eq 30")
        # direction of travel: the current falls over the first half cycle
        k = len(y) // 8
        ax.annotate("", xy=(cyc["current"][k + 1], y[k + 1]), xytext=(cyc["current"][k], y[k]),
                    arrowprops=dict(arrowstyle="-|>", color="C0", lw=1.5))
        if row["y_at_i_plus_measured_um"] is not None:
            ax.plot([im, -im], [row["y_at_i_plus_measured_um"], row["y_at_i_minus_measured_um"]],
                    "s", color="C3", ms=7, label="measured y(i=\u00b1I_m), Table 3")
        if row["pp_measured_um"] is not None:
            ax.axhline(row["pp_measured_um"], color="C2", ls="--", lw=1.2,
                       label="measured peak-to-peak (text)")
        ax.set_title(f"{f:g} Hz, I_m = {im:g} A ({row['role']})", fontsize=10)
        ax.grid(alpha=0.3)
        ax.set_xlabel("current i [A]")
    for ax in axes[:, 0]:
        ax.set_ylabel("displacement y - y_min [\u00b5m]")
    handles = {}
    for ax in axes.flat:
        for h, lab in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(lab, h)
    fig.legend(handles.values(), handles.keys(), loc="lower center", ncol=3, frameon=False)
    fig.suptitle("Displacement against current in steady state, i = I_m cos(2\u03c0ft) "
                 "(analogue of Figures 6-7)")
    fig.tight_layout(rect=(0, 0.05, 1, 1))
    path = Path(path)
    save_figure(fig, path, dpi=110)
    return path


def losses_figure(params: gmt.TransducerParameters, rows: list[dict], path,
                  frequencies=LOSS_FREQUENCIES) -> Path:
    """Separated losses against frequency at I_m = 1 A, B_m from the default calibration.

    Parameters
    ----------
    params : TransducerParameters
    rows : list of dict
        :func:`smeha.studies.paper.paper_rows`; the Table 1 cases at 1 A are marked.
    path : path-like
        PNG to write.
    frequencies : array
        f [Hz] of the curves.
    """
    losses = np.array([
        [lb.hysteresis, lb.eddy, lb.excess, lb.total]
        for lb in (gmt.operating_point(params, gmt.Excitation(float(f), 1.0)).losses
                   for f in frequencies)])
    fig, ax = plt.subplots(figsize=(8, 5.5))
    names = ("P_h, hysteresis (eq 7)", "P_eddy, eddy current (eq 9)",
             "P_ex, excess (eq 11)", "total (eq 12)")
    keys = ("P_hyst_W", "P_eddy_W", "P_excess_W", "P_total_W")
    table = [r for r in rows if r["current_amplitude_A"] == 1.0]
    for k, (name, key) in enumerate(zip(names, keys)):
        ax.plot(frequencies, losses[:, k], color=f"C{k}", lw=2 if k == 3 else 1.5,
                ls="-" if k < 3 else "--", label=name)
        ax.plot([r["frequency_Hz"] for r in table], [r[key] for r in table], "o",
                color=f"C{k}", ms=6)
    for r in table:
        ax.axvline(r["frequency_Hz"], color="0.6", lw=0.8, ls=":")
    ax.plot([], [], "o", color="0.3", label="Table 1 points at 1 A (measured B_m)")
    ax.set_xlabel("frequency f [Hz]")
    ax.set_ylabel("power loss in the rod [W]")
    ax.set_xlim(frequencies[0], frequencies[-1])
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax.legend(loc="upper left")
    ax.set_title("Losses against frequency, I_m = 1 A (analogue of Figure 8)\n"
                 "B_m between and beyond the Table 1 points from gmt's calibration",
                 fontsize=11)
    fig.tight_layout()
    path = Path(path)
    save_figure(fig, path, dpi=110)
    return path


def linearity_figure(params: gmt.TransducerParameters, runs, path) -> Path:
    """Normalised displacement against normalised control signal (eq 38), 2x2 panels.

    Parameters
    ----------
    params : TransducerParameters
    runs : list of smeha.studies.paper.CompensatedRun
        One per Table 3 frequency (four).
    path : path-like
        PNG to write.
    """
    fig, axes = plt.subplots(2, 2, figsize=(10, 9), sharex=True, sharey=True)
    for ax, run in zip(axes.flat, runs):
        cyc = paper.uncompensated_cycle(params, run.frequency)
        ax.plot(_closed(paper.normalise(cyc["current"])),
                _closed(paper.normalise(cyc["displacement"])),
                color="C0", lw=1.5, label="uncompensated, U from i = I_m cos(2\u03c0ft)")
        ax.plot(_closed(paper.normalise(run.control)), _closed(paper.normalise(run.displacement)),
                color="C3", lw=3.5, alpha=0.55,
                label=f"compensated (Figure 9, rule '{run.branch_rule}'), U from u")
        ax.plot([0, 1], [0, 1], color="k", lw=1, ls=":", label="ideal, Y = U")  # above it
        dev_c, corr_c = paper.linearity(run.control, run.displacement)
        dev_u, corr_u = paper.linearity(cyc["current"], cyc["displacement"])
        ax.text(0.97, 0.03, f"max|Y-U|, r\ncompensated:    {dev_c:.3f}, {corr_c:.4f}\n"
                f"uncompensated: {dev_u:.3f}, {corr_u:.4f}", transform=ax.transAxes,
                ha="right", va="bottom", fontsize=8,
                bbox=dict(boxstyle="round", fc="white", ec="0.7"))
        ax.set_title(f"{run.frequency:g} Hz, u = {run.control_amplitude:g}"
                     f" + {run.control_amplitude:g} cos(2\u03c0ft) V", fontsize=10)
        ax.set_aspect("equal")
        ax.grid(alpha=0.3)
    for ax in axes[1, :]:
        ax.set_xlabel("normalised control signal U [-]")
    for ax in axes[:, 0]:
        ax.set_ylabel("normalised displacement Y [-]")
    handles, labels = axes.flat[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=2, frameon=False)
    fig.suptitle("Linearity, eq 38 normalisation: compensated against uncompensated\n"
                 "(analogue of Figures 10-11; model, steady state)")
    fig.tight_layout(rect=(0, 0.06, 1, 1))
    path = Path(path)
    save_figure(fig, path, dpi=110)
    return path


def write_all(directory, params: gmt.TransducerParameters, report: dict, runs) -> list[Path]:
    """Write the three figures into ``directory`` (created if missing).

    Parameters
    ----------
    directory : path-like
    params : TransducerParameters
    report : dict
        :func:`smeha.studies.paper.paper_report`.
    runs : list of smeha.studies.paper.CompensatedRun

    Returns
    -------
    list of Path
        The files written.
    """
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    return [loops_figure(params, report["rows"], out / LOOPS_FILE),
            losses_figure(params, report["rows"], out / LOSSES_FILE),
            linearity_figure(params, runs, out / LINEARITY_FILE)]
