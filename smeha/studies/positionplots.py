"""Figures of ``smeha position --plot`` (matplotlib, Agg).

The study (:func:`plot_study`): five panels sharing the time axis for the step in each
drive mode -- command and position, the period-averaged piston velocity, the drive
amplitude (as a fraction of its limit), the valve stage of Figure 2, the cylinder's
pressures -- and, when they were run, the sine tracking's gain against frequency (with
python-control's predicted bandwidth) and the load step's deflection. The envelope
(:func:`plot_envelope`): the largest steady speed each way against load. Colour = drive
mode, as in every flow figure (:data:`smeha.studies.flowplots.MODE_COLOURS`).
"""
from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.ticker import ScalarFormatter  # noqa: E402

from ..outputs import save_figure  # noqa: E402
from .flowplots import MODE_COLOURS  # noqa: E402
from .positionloop import TIME_TOLERANCE  # noqa: E402

__all__ = ["plot_study", "plot_envelope", "stages", "describe"]


def stages(rows) -> np.ndarray:
    """Figure 2's stage (1-4) at each row: the direction and the valves' phase."""
    down = rows["direction"] > 0
    compressing = rows["valves_compressing"] > 0.5
    return np.where(down, np.where(compressing, 1, 2), np.where(compressing, 3, 4))


def _per_period(rows, periods, field):
    """Min, mean and max of a record field over each period but the last."""
    edges = np.searchsorted(rows["time"], periods["time"] - TIME_TOLERANCE)
    parts = [rows[field][a:b] for a, b in zip(edges[:-1], edges[1:])]
    return tuple(np.array([f(p) if p.size else np.nan for p in parts])
                 for f in (np.min, np.mean, np.max))


def describe(settings) -> str:
    """What a figure shows: the model, the drive, the circuit and the load."""
    return (f"the paper's magnetics, sinusoidal drive at {settings.frequency:g} Hz, "
            f"{settings.circuit} circuit, {settings.load_force:g} N load (opposing down)")


def _step_panels(axes, results, settings) -> None:
    """The step runs (:class:`smeha.studies.position.PositionResult`, one a mode)."""
    ax_x, ax_v, ax_a, ax_s, ax_p = axes
    for res in results:
        rec, colour = res.record, MODE_COLOURS[res.mode]
        rows, per = rec.rows, rec.periods
        start = per["time"][np.isfinite(per["command"])][0]
        origin = per["position"][per["time"] >= start][0]
        t = rows["time"] - start
        ax_x.plot(t, (rows["piston_position"] - origin) * 1e3, color=colour, lw=1.2,
                  label=f"{res.mode}: position")
        ax_x.step(per["time"] - start, (per["command"] - origin) * 1e3, where="post",
                  color=colour, lw=0.8, ls="--", label=f"{res.mode}: command")
        tp = per["time"][:-1] - start
        v = np.diff(per["position"]) * rec.frequency * 1e3
        shown = tp >= 0.0
        ax_v.step(tp[shown], v[shown], where="post", color=colour, lw=1.0, label=res.mode)
        limit = settings.amplitude_limit if res.mode == "compensated" else 1.0
        ax_a.step(per["time"] - start, per["amplitude"] / limit, where="post", color=colour,
                  lw=1.0, label=res.mode)
        ax_s.plot(t, stages(rows), color=colour, lw=0.5, alpha=0.7, drawstyle="steps-post")
        for field, style, name in (("p_big", "-", "big cavity"), ("p_small", ":", "small cavity")):
            low, mean, high = _per_period(rows, per, field)
            ax_p.plot(tp, mean / 1e6, color=colour, lw=1.2, ls=style,
                      drawstyle="steps-post", label=f"{res.mode}: {name} (period mean)")
            ax_p.fill_between(tp, low / 1e6, high / 1e6, step="post", color=colour,
                              alpha=0.12, lw=0)
    ax_x.set_ylabel("x - x(0) [mm]")
    ax_x.set_title(f"Position step {settings.target * 1e3:g} mm: {describe(settings)}\n"
                   "(t = 0: the command starts)", fontsize=9)
    ax_v.set_ylabel("velocity [mm/s]\n(period mean)")
    ax_a.set_ylabel("amplitude\n/ limit")
    ax_a.set_ylim(-0.05, 1.1)
    ax_s.set_ylabel("valve stage\n(Figure 2)")
    ax_s.set_yticks([1, 2, 3, 4])
    ax_p.set_ylabel("pressure [MPa]\n(band: min-max)")
    ax_p.set_xlabel("time from the command [s]")
    ax_x.legend(loc="lower right", fontsize=8)
    ax_p.legend(loc="upper right", fontsize=7, ncol=2)
    ax_v.legend(loc="upper right", fontsize=8)


def _sine_panel(ax, out) -> None:
    """Gain of the tracked sines against frequency, each mode, with the predicted -3 dB."""
    for mode, study in out.items():
        res = next(r for r in study["results"] if r.scenario == "sine")
        rows, colour = res.figures["tracking"], MODE_COLOURS[mode]
        ax.semilogx([r["frequency_Hz"] for r in rows],
                    [20 * np.log10(r["gain"]) for r in rows], "o-", color=colour, lw=1.0,
                    label=f"{mode}: measured")
        ax.axvline(res.figures["predicted_bandwidth_Hz"], color=colour, ls=":", lw=1.0,
                   label=f"{mode}: python-control's -3 dB")
    ax.axhline(-3.0, color="0.5", lw=0.6)
    ax.xaxis.set_major_formatter(ScalarFormatter())
    ax.xaxis.set_minor_formatter(ScalarFormatter())
    ax.tick_params(axis="x", which="minor", labelsize=7)
    ax.set_xlabel("command frequency [Hz]")
    ax.set_ylabel("gain [dB]")
    ax.set_title("Sine tracking (position / command)", fontsize=9)
    ax.legend(fontsize=7)


def _load_panel(ax, out) -> None:
    """Deflection after the load step, each mode."""
    for mode, study in out.items():
        res = next(r for r in study["results"] if r.scenario == "load")
        rec, colour = res.record, MODE_COLOURS[mode]
        at = res.figures["load_step_at_s"]
        rows = rec.rows
        late = rows["time"] >= at - 0.02
        origin = res.figures["origin_m"]
        ax.plot(rows["time"][late] - at, (rows["piston_position"][late] - origin) * 1e6,
                color=colour, lw=1.0, label=f"{mode}: {res.figures['load_step_N']:+g} N")
    ax.axvline(0.0, color="0.5", lw=0.6)
    ax.set_xlabel("time from the load step [s]")
    ax.set_ylabel("deflection [um]")
    ax.set_title("Load step while holding", fontsize=9)
    ax.legend(fontsize=7)


def plot_study(path, out, settings) -> None:
    """Write the study (``out``: mode -> :func:`smeha.studies.position.run_study`'s result):
    the step panels, and the sine and load-step panels of the scenarios that were run."""
    extra = [s for s in ("sine", "load")
             if all(any(r.scenario == s for r in st["results"]) for st in out.values())]
    heights = [3, 2, 1.5, 1.2, 2] + [2.5] * len(extra)
    fig, axes = plt.subplots(len(heights), 1, figsize=(9.0, 11.0 + 2.5 * len(extra)),
                             gridspec_kw={"height_ratios": heights})
    for ax in axes[1:5]:
        ax.sharex(axes[0])
    _step_panels(axes[:5], [st["results"][0] for st in out.values()], settings)
    for ax, scenario in zip(axes[5:], extra):
        (_sine_panel if scenario == "sine" else _load_panel)(ax, out)
    for ax in axes:
        ax.grid(True, alpha=0.3)
    fig.tight_layout()
    save_figure(fig, path, dpi=110)


def plot_envelope(path, curves) -> None:
    """Write the speed-load envelope (:class:`smeha.studies.positionenvelope.Envelope`s): one
    panel a circuit, the full-drive speed each way against load; solid: co-simulation,
    dashed: the hand calculation, squares: the flow table (down), ticks: stall loads."""
    circuits = list(dict.fromkeys(c.circuit for c in curves))
    fig, axes = plt.subplots(1, len(circuits), figsize=(5.5 * len(circuits), 4.8),
                             squeeze=False)
    for ax, circuit in zip(axes[0], circuits):
        for c in (c for c in curves if c.circuit == circuit):
            colour = MODE_COLOURS[c.mode]
            for direction, marker in (("down", "o"), ("up", "v")):
                pts = [p for p in c.points if p.direction == direction]
                loads = [p.load for p in pts]
                ax.plot(loads, [p.velocity * 1e3 for p in pts], marker=marker, color=colour,
                        lw=1.2, label=f"{c.mode}, {direction}: co-simulation")
                ax.plot(loads, [p.hand_velocity * 1e3 for p in pts], color=colour, lw=0.8,
                        ls="--", label=f"{c.mode}, {direction}: hand calculation")
                if direction == "down":
                    ax.plot(loads, [p.flow_table_velocity * 1e3 for p in pts], "s",
                            mfc="none", color=colour, ms=7, label=f"{c.mode}: flow table")
            for stall in (c.stall_load_down, c.stall_load_up):
                if np.isfinite(stall):
                    ax.axvline(stall, color=colour, lw=0.6, alpha=0.6)
        ax.axhline(0.0, color="0.4", lw=0.6)
        freq = curves[0].frequency
        ax.set_title(f"{circuit} circuit, {freq:g} Hz, the paper's magnetics, sinusoidal drive"
                     "\n(vertical lines: stall loads, co-simulation)", fontsize=9)
        ax.set_xlabel("load, opposing down [N]")
        ax.set_ylabel("piston velocity at full drive [mm/s] (+ down)")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=6)
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
