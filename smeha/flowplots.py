"""Figures of the flow study: one co-simulation run, flow against frequency, load lines."""
from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def plot_run(record, row, path):
    """Rod displacement, pressures, valve phase and pumped volume of one run (PNG)."""
    t = record["time"] * 1e3
    fig, axes = plt.subplots(4, 1, figsize=(9, 9), sharex=True)
    axes[0].plot(t, record["rod_displacement"] * 1e6, label="rod y")
    axes[0].set_ylabel("rod displacement [um]")
    ax = axes[0].twinx()
    ax.plot(t, record["control"], color="tab:gray", lw=0.8, label="control u")
    ax.set_ylabel("control u [V]")
    for name, label in (("p_pump", "pump chamber"), ("p_big", "big cavity"),
                        ("p_small", "small cavity"), ("p_accumulator", "accumulator")):
        axes[1].plot(t, record[name] / 1e6, label=label)
    axes[1].set_ylabel("pressure [MPa]")
    axes[1].legend(loc="upper right", fontsize=8, ncol=2)
    axes[2].step(t, record["compressing"], where="post", color="tab:purple")
    axes[2].set_yticks([0, 1], ["expanding", "compressing"])
    axes[2].set_ylabel("pump phase")
    axes[3].plot(t, record["volume_into_big"] * 1e9, label="into the big cavity (V1 - V2)")
    axes[3].set_ylabel("volume [mm^3]")
    axes[3].set_xlabel("time [ms]")
    axes[3].legend(loc="upper left", fontsize=8)
    fig.suptitle(f"{row['mode']}, {row['frequency_Hz']:g} Hz, {row['circuit']} circuit, "
                 f"load {row['load_N']:g} N: q = {row['flow_sim_m3_s']:.3e} m^3/s, "
                 f"f A_d dy = {row['flow_eq_m3_s']:.3e} m^3/s")
    for a in axes:
        a.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_flow(rows, path):
    """Flow against frequency for both modes with eqs 40/41 and Table 3 (Figure 12 analogue).

    With several loads in ``rows``, a second panel draws the load lines.
    """
    loads = sorted({r["load_N"] for r in rows})
    base = min(loads, key=lambda v: abs(v - rows[0]["load_N"]))
    table = [r for r in rows if r["load_N"] == base]
    ncols = 2 if len(loads) > 1 else 1
    fig, axes = plt.subplots(1, ncols, figsize=(6.5 * ncols, 4.8), squeeze=False)
    ax = axes[0, 0]
    colours = {"uncompensated": "tab:blue", "compensated": "tab:red"}
    for mode, colour in colours.items():
        rs = sorted((r for r in table if r["mode"] == mode), key=lambda r: r["frequency_Hz"])
        if not rs:
            continue
        f = [r["frequency_Hz"] for r in rs]
        ax.plot(f, [r["flow_sim_m3_s"] * 1e6 for r in rs], "o-", color=colour,
                label=f"{mode}: co-simulation")
        ax.plot(f, [r["flow_eq_m3_s"] * 1e6 for r in rs], "s--", color=colour, mfc="none",
                label=f"{mode}: f A_d dy (eq {'41' if mode == 'compensated' else '40'})")
        pf = [(r["frequency_Hz"], r["flow_paper_m3_s"]) for r in rs if r["flow_paper_m3_s"]]
        if pf:
            ax.plot(*zip(*[(a, b * 1e6) for a, b in pf]), "^:", color=colour, alpha=0.6,
                    label=f"{mode}: paper, Table 3")
    ax.set_xlabel("pumping frequency f [Hz]")
    ax.set_ylabel("mean cylinder flow [cm^3/s]")
    ax.set_title(f"Flow against frequency ({table[0]['circuit']} circuit, load {base:g} N)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    if ncols == 2:
        ax = axes[0, 1]
        for (f, mode) in sorted({(r["frequency_Hz"], r["mode"]) for r in rows}):
            rs = sorted((r for r in rows if r["frequency_Hz"] == f and r["mode"] == mode),
                        key=lambda r: r["load_N"])
            ax.plot([r["load_pressure_Pa"] / 1e6 for r in rs],
                    [r["flow_sim_m3_s"] * 1e6 for r in rs], marker="o",
                    ls="-" if mode == "compensated" else "--",
                    label=f"{f:g} Hz {mode}")
        ax.axhline(0.0, color="k", lw=0.6)
        ax.set_xlabel("load pressure p_B - p_S [MPa]")
        ax.set_ylabel("mean cylinder flow [cm^3/s]")
        ax.set_title("Load lines")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
