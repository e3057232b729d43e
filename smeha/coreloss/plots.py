"""Error maps of the loss laws: where over duty, frequency and flux density they miss.

One figure, two rows (iGSE, the extended law), three maps each: triangles over
duty x frequency, triangles over duty x flux density, trapezoids over flat
duty x frequency. A cell is the median signed error P_model/P_measured - 1 of
its rows (all materials given pooled), in %.
"""
from __future__ import annotations

import numpy as np

from ..outputs import save_figure

__all__ = ["plot_error_maps"]

_F_EDGES = np.array([45e3, 80e3, 120e3, 180e3, 260e3, 380e3, 510e3])  # [Hz]
_B_EDGES = np.array([0.0, 0.02, 0.04, 0.07, 0.11, 0.17, 0.4])  # [T]


def _grid(x_values, y_values, y_edges, error):
    """(x levels, median error per (y band, x level))."""
    xs = np.unique(x_values)
    grid = np.full((len(y_edges) - 1, len(xs)), np.nan)
    for i in range(len(y_edges) - 1):
        band = (y_values >= y_edges[i]) & (y_values < y_edges[i + 1])
        for j, x in enumerate(xs):
            m = band & (x_values == x)
            if m.sum() >= 5:
                grid[i, j] = np.median(error[m])
    return xs, grid


def plot_error_maps(results, path) -> None:
    """Write the error maps of ``results`` (list of MaterialResult) to ``path`` (PNG)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cols = {k: np.concatenate([getattr(r.data, k) for r in results])
            for k in ("frequency", "flux_density", "waveform", "loss")}
    duty = np.concatenate([r.data.duty for r in results])
    fam = {w: np.concatenate([r.data.family(w) for r in results])
           for w in ("triangle", "trapezoid")}
    laws = {"iGSE (Steinmetz fitted on sinusoids)": "predicted_igse",
            "extended law (fitted on cal. rows)": "predicted_extended"}
    fig, axes = plt.subplots(2, 3, figsize=(14, 7.5), constrained_layout=True)
    names = ", ".join(r.data.name for r in results)
    fig.suptitle(f"Median signed error P_model/P_measured - 1 [%] ({names})")
    image = None
    for row, (title, attr) in enumerate(laws.items()):
        err = 100.0 * (np.concatenate([getattr(r, attr) for r in results]) / cols["loss"] - 1.0)
        maps = (
            ("triangles", fam["triangle"], duty[:, 0], "rising duty (duty_1)",
             cols["frequency"], _F_EDGES, "frequency [kHz]", 1e-3),
            ("triangles", fam["triangle"], duty[:, 0], "rising duty (duty_1)",
             cols["flux_density"], _B_EDGES, "peak flux density [mT]", 1e3),
            ("trapezoids", fam["trapezoid"], duty[:, 1], "flat duty (duty_2 = duty_4)",
             cols["frequency"], _F_EDGES, "frequency [kHz]", 1e-3),
        )
        for col, (label, m, x, xlabel, y, edges, ylabel, unit) in enumerate(maps):
            ax = axes[row, col]
            if not m.any():
                ax.set_axis_off()
                continue
            xs, grid = _grid(x[m], y[m], edges, err[m])
            image = ax.imshow(grid, origin="lower", aspect="auto", cmap="RdBu_r", vmin=-40,
                              vmax=40, extent=(-0.5, len(xs) - 0.5, -0.5, len(edges) - 1.5))
            for i in range(grid.shape[0]):
                for j in range(grid.shape[1]):
                    if np.isfinite(grid[i, j]):
                        ax.text(j, i, f"{grid[i, j]:.0f}", ha="center", va="center", fontsize=7)
            ax.set_xticks(range(len(xs)), [f"{v:.1f}" for v in xs])
            ax.set_yticks(np.arange(len(edges)) - 0.5, [f"{v * unit:.0f}" for v in edges])
            ax.set_xlabel(xlabel)
            ax.set_ylabel(ylabel)
            ax.set_title(f"{title}: {label}", fontsize=10)
    if image is not None:
        fig.colorbar(image, ax=axes, shrink=0.6, label="median error [%]")
    save_figure(fig, path, dpi=110)
