"""Figure of the waveform study (:mod:`smeha.studies.timedomain`).

Flow against frequency for each drive waveform; one panel per basis (equal peak, equal
RMS coil current). As in :mod:`smeha.studies.flowplots`, blue is the uncompensated mode
and red the compensated one; the waveform is told by line style and marker.
"""
from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402

from ..outputs import save_figure  # noqa: E402
from .flowplots import MODE_COLOURS  # noqa: E402

__all__ = ["STYLES", "BASES", "plot_waveforms"]

#: Line style and marker of each waveform.
STYLES = {"sine": ("-", "o"), "square": ("--", "s"), "trapezoid": (":", "^")}
BASES = {"peak": "equal peak current (1 A)", "rms": "equal RMS current (0.707 A)"}


def plot_waveforms(rows, path) -> None:
    """Write the waveform study's figure (PNG) to ``path``."""
    bases = [b for b in BASES if any(r["basis"] == b for r in rows)]
    fig, axes = plt.subplots(1, len(bases), figsize=(6.2 * len(bases), 4.6), squeeze=False,
                             sharey=True)
    for ax, basis in zip(axes[0], bases):
        for mode, colour in MODE_COLOURS.items():
            for shape, (line, marker) in STYLES.items():
                pts = sorted((r["frequency_Hz"], r["flow_sim_L_min"]) for r in rows
                             if (r["basis"], r["mode"], r["waveform"]) == (basis, mode, shape))
                if pts:
                    f, q = zip(*pts)
                    ax.plot(f, q, line, marker=marker, color=colour)
        ax.axhline(0.0, color="0.5", lw=0.8)
        ax.set_title(BASES[basis])
        ax.set_xlabel("pumping frequency [Hz]")
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel("mean cylinder flow [L/min] (below 0: reversed)")
    handles = ([Line2D([], [], color=c, lw=2, label=m) for m, c in MODE_COLOURS.items()]
               + [Line2D([], [], color="k", ls=ls, marker=mk, label=w)
                  for w, (ls, mk) in STYLES.items()])
    axes[0][-1].legend(handles=handles, loc="best", fontsize=8)
    fig.suptitle("Which drive waveform pumps most: time-domain magnetics, realistic circuit, "
                 "150 N load", fontsize=10)
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
