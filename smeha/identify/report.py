"""The plain-text report of an identification (``smeha identify``)."""
from __future__ import annotations

import math

from .results import LOSS_COEFFICIENTS, Identification

__all__ = ["format_identification"]


def _pm(value, err, digits=4):
    if err is None or not math.isfinite(err):
        return f"{value:.{digits}g}"
    return f"{value:.{digits}g} +- {err:.2g}"


def format_identification(ident: Identification, path: str = "") -> str:
    """Plain-text report: a table per run and the loss coefficients."""
    lines = []
    if path:
        lines.append(f"identification from {path} ({len(ident.runs)} runs)")
    head = (f"{'run':<14} {'f [Hz]':>8} {'I_m [A]':>8} {'B_m [T]':>9} {'B_m source':<14} "
            f"{'mu_imag':>20} {'mu_real':>8} {'lag [deg]':>9} {'RMS [um]':>9}")
    lines += [head, "-" * len(head)]
    short = {"sense_voltage": "sense voltage", "displacement": "displacement"}
    for r in ident.runs:
        mark = "*" if r.mu_imag_at_bound else ""
        lines.append(
            f"{r.run:<14.14} {r.frequency:>8.4g} {r.current_amplitude:>8.4f} "
            f"{r.flux_density_amplitude:>9.5f} {short[r.flux_density_source]:<14} "
            f"{_pm(r.mu_imag, r.mu_imag_stderr, 6) + mark:>20} {r.mu_real:>8.4f} "
            f"{math.degrees(r.lag):>9.2f} {r.rms_residual * 1e6:>9.4f}"
            f"{'  (!)' if r.flags else ''}")
    lines.append("B_m: sense voltage = eq 22; displacement = fundamental of y (eqs 19, 25, 29)")
    flagged = [r for r in ident.runs if r.flags]
    if flagged:
        lines.append("(!) values that make no physical sense:")
        lines += [f"  - {r.run}: {flag}" for r in flagged for flag in r.flags]
    lines.append("")
    fit = ident.loss_fit
    if fit is None:
        lines.append(ident.note)
        return "\n".join(lines + _extended_lines(ident))
    rv = "" if fit.residual_variance is None else \
        f", residual variance {fit.residual_variance:.3g}"
    lines.append(f"loss coefficients (set of eqs 16, weighted least squares over "
                 f"{fit.runs} runs{rv}):")
    for k, (name, _, unit) in enumerate(LOSS_COEFFICIENTS):
        err = None if fit.stderrs is None else fit.stderrs[k]
        lines.append(f"  {name:<5} = {_pm(fit.values[k], err, 6):<26} [{unit}]")
    if fit.correlation is not None:
        lines.append("correlation:")
        lines.append("        " + "".join(f"{n:>8}" for n in fit.names))
        for name, row in zip(fit.names, fit.correlation):
            lines.append(f"  {name:<5} " + "".join(f"{v:>8.3f}" for v in row))
    if fit.flags:
        lines.append("these coefficients make no physical sense:")
        lines += [f"  - {flag}" for flag in fit.flags]
        where = f" {path}" if path else ""
        lines.append(f"the paper's model does not describe these runs; run `smeha diagnose"
                     f"{where}` to see what it misses")
    elif fit.note or ident.note:
        lines.append("note: " + "; ".join(x for x in (fit.note, ident.note) if x))
    return "\n".join(lines + _extended_lines(ident))


def _extended_lines(ident) -> list:
    """The extended loss law's parameters, or why it was not fitted (docs/LOSSES.md)."""
    law = ident.extended_law
    if law is None:
        return [ident.extended_note] if ident.extended_note else []
    return ["extended loss law (gmt.timedomain.dynamic; docs/LOSSES.md):",
            "  " + ", ".join(f"{k} = {v:.4g}" for k, v in law.items())]
