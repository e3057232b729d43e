"""``smeha losses``: the loss laws against measured core losses (docs/LOSSES.md).

Registered by :mod:`smeha.cli`; the study is :mod:`smeha.coreloss.study`.
Nothing heavy is imported before the command runs.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from ..cliargs import plot_file
from . import MATERIALS as _MATERIALS

__all__ = ["add_losses", "material_or_file"]


def material_or_file(text: str):
    """A MagNet material name, or a readable core-loss CSV file (argparse type)."""
    if text in _MATERIALS:
        return text
    path = Path(text)
    if path.is_file():
        return path
    raise argparse.ArgumentTypeError(
        f"{text!r} is neither a MagNet material ({', '.join(_MATERIALS)}) nor an existing file")


def add_losses(subparsers):
    p = subparsers.add_parser(
        "losses", help="the loss laws against measured core losses (MagNet or your CSV)",
        description="Calibrate the paper's loss separation, Steinmetz/iGSE and the extended "
                    "loss law (rate field, relaxation, a second hysteresis density and a break "
                    "of the hysteresis exponent; gmt.timedomain) on the "
                    "sinusoidal rows plus one duty setting per waveform family, predict every "
                    "row from its flux waveform, and score them per waveform family "
                    "(docs/LOSSES.md). Without MATERIAL: all ten MagNet ferrites.")
    p.add_argument("source", nargs="?", metavar="MATERIAL|FILE", type=material_or_file,
                   help=f"a MagNet material ({', '.join(_MATERIALS)}) or a core-loss CSV file "
                        "(format: docs/LOSSES.md); default: all ten materials")
    p.add_argument("--json", action="store_true",
                   help='print only {"materials": {NAME: {"sine": S, "triangle": S, '
                        '"trapezoid": S, "igse": {...}}}}, S = {rows, median_abs_error, '
                        'p95_abs_error}')
    p.add_argument("--plot", metavar="FILE", type=plot_file,
                   help="write the error maps (PNG): signed error of iGSE and of the extended "
                        "law over duty, frequency and flux density, per waveform")
    p.add_argument("--holdout", action="store_true",
                   help="also refit the extension without each waveform family and without "
                        "the upper frequency band, and score the held-out rows (text only)")
    p.set_defaults(run=_run_losses)


def _run_losses(args) -> int:
    from ..cliargs import UsageError
    from . import measurements, study

    if args.holdout and args.json:
        raise UsageError("--holdout prints tables; it has no JSON form (drop --json)")
    if args.source is None:
        data = [measurements.read_magnet(m) for m in _MATERIALS]
    elif isinstance(args.source, Path):
        data = [measurements.read_core_losses(args.source)]
    else:
        data = [measurements.read_magnet(args.source)]
    if args.plot and not any((d.family("triangle") | d.family("trapezoid")).any() for d in data):
        raise UsageError("--plot maps the errors on triangles and trapezoids (duty cycles); "
                         f"{data[0].name} has none")
    results = [study.run(d) for d in data]
    if args.plot:
        from .plots import plot_error_maps
        plot_error_maps(results, args.plot)
    if args.json:
        json.dump(study.summary(results), sys.stdout, allow_nan=False)
        sys.stdout.write("\n")
        return 0
    holdouts = [study.holdout(r) for r in results] if args.holdout else None
    print(study.format_results(results, holdouts))
    if args.plot:
        print(f"wrote {args.plot}")
    return 0
