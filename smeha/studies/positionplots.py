"""Figure of ``smeha position --plot``: the step in each drive mode (matplotlib, Agg).

Five panels sharing the time axis: command and position, the period-averaged piston
velocity, the drive amplitude (as a fraction of its limit), the valve stage of Figure 2,
and the cylinder's pressures. Colour = drive mode, as in every flow figure
(:data:`smeha.studies.flowplots.MODE_COLOURS`).
"""
from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .flowplots import MODE_COLOURS  # noqa: E402

__all__ = ["plot_steps", "stages"]


def stages(rows) -> np.ndarray:
    """Figure 2's stage (1-4) at each row: the direction and the valves' phase."""
    down = rows["direction"] > 0
    compressing = rows["valves_compressing"] > 0.5
    return np.where(down, np.where(compressing, 1, 2), np.where(compressing, 3, 4))


def _per_period(rows, periods, field):
    """Min, mean and max of a record field over each period but the last."""
    edges = np.searchsorted(rows["time"], periods["time"] - 1e-12)
    parts = [rows[field][a:b] for a, b in zip(edges[:-1], edges[1:])]
    return tuple(np.array([f(p) if p.size else np.nan for p in parts])
                 for f in (np.min, np.mean, np.max))


def plot_steps(path, results, settings) -> None:
    """Write the step runs (:class:`smeha.studies.position.PositionResult`, one a mode)."""
    fig, axes = plt.subplots(5, 1, figsize=(9.0, 11.0), sharex=True,
                             gridspec_kw={"height_ratios": [3, 2, 1.5, 1.2, 2]})
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
    ax_x.set_title(f"Position step {settings.target * 1e3:g} mm at {settings.frequency:g} Hz, "
                   f"{settings.circuit} circuit, {settings.load_force:g} N "
                   "(t = 0: the command starts)", fontsize=10)
    ax_v.set_ylabel("velocity [mm/s]\n(period mean)")
    ax_a.set_ylabel("amplitude\n/ limit")
    ax_a.set_ylim(-0.05, 1.1)
    ax_s.set_ylabel("valve stage\n(Figure 2)")
    ax_s.set_yticks([1, 2, 3, 4])
    ax_p.set_ylabel("pressure [MPa]\n(band: min-max)")
    ax_p.set_xlabel("time from the command [s]")
    for ax in axes:
        ax.grid(True, alpha=0.3)
    ax_x.legend(loc="lower right", fontsize=8)
    ax_p.legend(loc="upper right", fontsize=7, ncol=2)
    ax_v.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
