"""The flow study's tables for the terminal: the flow table, the load lines, a model
variant against the paper's model (the rows of :func:`smeha.studies.flow.run_case`).

The study runs and decides (:mod:`smeha.studies.flow`); this module only prints.
"""
from __future__ import annotations

import gmt

from .flow import MODES

__all__ = ["format_table", "format_load_lines", "format_comparison"]


def _mark(row) -> str:
    """The table's mark of a flagged row (:func:`flag_row`; its note follows the table)."""
    return "  (!)" if row.get("flow_reversed") or row.get("cavitation") else ""


def format_table(rows) -> str:
    """The flow table for the terminal."""
    head = (f"{'f [Hz]':>6}  {'mode':<13}  {'circuit':<9}  {'load [N]':>8}  {'q sim [m3/s]':>12}  "
            f"{'q eq40/41':>10}  {'sim/eq':>6}  {'dy [um]':>7}  {'q paper':>10}  "
            f"{'dy paper':>8}  {'dy free':>7}  {'q/q free':>8}  {'q [L/min]':>9}")
    lines = ["Cylinder flow: co-simulation against eqs 40/41 and the paper's Table 3",
             "(dy: the rod between the valve switching instants of this run; q paper: f A_d dy "
             "that the paper computes with eqs 40/41 from Table 3's measured dy (dy paper), not "
             "a measured flow; dy free: the transducer alone, no oil; q/q free: delivered flow "
             "over f A_d dy free, the flow eqs 40/41 give for the free transducer, as the paper "
             "computes them)", head]
    drives = sorted({(r.get("magnetics", "paper"), r.get("waveform", "sine")) for r in rows})
    if drives != [("paper", "sine")]:
        lines.insert(1, "transducer: " + "; ".join(f"{m} magnetics, {w} drive"
                                                   for m, w in drives))
    for r in rows:
        paper = "-" if r["flow_paper_m3_s"] is None else f"{r['flow_paper_m3_s']:.3e}"
        dyp = "-" if r["dy_paper_um"] is None else f"{r['dy_paper_um']:.1f}"
        lines.append(f"{r['frequency_Hz']:>6g}  {r['mode']:<13}  {r['circuit']:<9}  "
                     f"{r['load_N']:>8g}  {r['flow_sim_m3_s']:>12.3e}  {r['flow_eq_m3_s']:>10.3e}  "
                     f"{r['flow_ratio']:>6.3f}  {r['dy_um']:>7.2f}  {paper:>10}  {dyp:>8}  "
                     f"{r['dy_free_um']:>7.2f}  {r['delivered_fraction']:>8.3f}  "
                     f"{r['flow_sim_L_min']:>9.4f}{_mark(r)}")
    by = {(r["frequency_Hz"], r["mode"]): r for r in rows}
    gains = [f"{f:g} Hz: {by[(f, MODES[1])]['flow_sim_m3_s'] / q:.3f}"
             for f in sorted({r["frequency_Hz"] for r in rows})
             if (f, MODES[1]) in by and (f, MODES[0]) in by
             and (q := by[(f, MODES[0])]["flow_sim_m3_s"]) != 0]
    if gains:
        lines.append("compensated / uncompensated flow: " + ", ".join(gains))
    for r in rows:
        if r.get("note"):
            lines.append(f"(!) {r['frequency_Hz']:g} Hz {r['mode']}: {r['note']}")
    lines += _unsettled_note(rows)
    return "\n".join(lines)


def _unsettled_note(rows) -> list:
    """A line naming the rows whose cycles' flows still change (smeha.studies.flow.settled)."""
    loose = [r for r in rows if r.get("settled") is False]
    if not loose:
        return []
    worst = max(abs(r["flow_drift_per_cycle"]) for r in loose)
    names = ", ".join(f"{r['frequency_Hz']:g} Hz {r['mode']}" for r in loose)
    return [f"not settled ({names}): the cycles' flows still change, by up to "
            f"{100 * worst:.3f} % a cycle (the realistic circuit follows the piston: its "
            "cavities' volumes, the accumulator's charge); those means depend on the run's "
            "length (--cycles)"]


def format_load_lines(rows) -> str:
    """Flow against load pressure (p_B - p_S) for each frequency and mode."""
    lines = ["Load lines: mean cylinder flow against load pressure p_B - p_S",
             f"{'f [Hz]':>6}  {'mode':<13}  {'load [N]':>8}  {'p_B - p_S [MPa]':>15}  "
             f"{'q sim [m3/s]':>12}  {'q [L/min]':>9}"]
    for r in sorted(rows, key=lambda r: (r["frequency_Hz"], r["mode"], r["load_N"])):
        lines.append(f"{r['frequency_Hz']:>6g}  {r['mode']:<13}  {r['load_N']:>8g}  "
                     f"{r['load_pressure_Pa'] / 1e6:>15.3f}  {r['flow_sim_m3_s']:>12.4e}  "
                     f"{r['flow_sim_L_min']:>9.4f}{_mark(r)}")
    for r in rows:
        if r.get("note"):
            lines.append(f"(!) {r['frequency_Hz']:g} Hz {r['mode']}, {r['load_N']:g} N: "
                         f"{r['note']}")
    return "\n".join(lines)


def format_comparison(pairs, variant: gmt.ModelVariant, source: str = "") -> str:
    """The flow with the paper's model and with the variant, side by side."""
    where = f" (from {source})" if source else ""
    lines = [f"Cylinder flow: the paper's model against the variant {variant.describe()}"
             f"{where}",
             "(co-simulation, same circuit and drive; the compensator is the paper's inverse "
             "model in both; dy: the rod between the valve switching instants; dy free "
             "variant: the variant's transducer alone, no oil; (!): see the notes below)",
             f"{'f [Hz]':>6}  {'mode':<13}  {'circuit':<9}  {'load [N]':>8}  "
             f"{'q paper [m3/s]':>14}  {'q variant [m3/s]':>16}  {'variant/paper':>13}  "
             f"{'dy paper [um]':>13}  {'dy variant [um]':>15}  {'dy free variant':>15}"]
    for c in pairs:
        ratio = "-" if c["flow_ratio_variant_to_paper"] is None else \
            f"{c['flow_ratio_variant_to_paper']:.4f}"
        lines.append(f"{c['frequency_Hz']:>6g}  {c['mode']:<13}  {c['circuit']:<9}  "
                     f"{c['load_N']:>8g}  {c['flow_paper_model_m3_s']:>14.4e}  "
                     f"{c['flow_variant_m3_s']:>16.4e}  {ratio:>13}  "
                     f"{c['dy_paper_model_um']:>13.2f}  {c['dy_variant_um']:>15.2f}  "
                     f"{c['dy_free_variant_um']:>15.2f}"
                     f"{'  (!)' if c.get('variant_marks') or c.get('note') else ''}")
    lines += _comparison_notes(pairs)
    return "\n".join(lines)


def _comparison_notes(pairs) -> list[str]:
    """The reasons behind the comparison's (!) marks, each once with the rows it applies to:
    the variant's (smeha.studies.variantcheck), then the variant rows' own flags
    (:func:`smeha.studies.flow.flag_row`)."""
    grouped = {}
    for c in pairs:
        where = f"{c['frequency_Hz']:g} Hz {c['mode']}"
        for reason in c.get("variant_marks") or ():
            grouped.setdefault(f"variant: {reason}", []).append(where)
        if c.get("note"):
            grouped.setdefault(f"variant row: {c['note']}", []).append(where)
    return [f"(!) {', '.join(rows)}: {reason}" for reason, rows in grouped.items()]
