"""The ``smeha`` command line.

Subcommands
-----------
``smeha paper [--json] [--plots DIR] [--branch-rule control|demand]``
    Reproduce the paper's model results and compare with its data
    (:mod:`smeha.paper`); optionally write the figures (:mod:`smeha.plots`).
``smeha build [...]``
    Build the FMU(s); arguments go unchanged to :func:`smeha.fmu_build.main`.

Adding a subcommand: write ``_add_<name>(subparsers)`` that registers its
parser with ``set_defaults(run=_run_<name>)``, and append it to
:data:`SUBCOMMANDS`. A subcommand whose parser sets ``passthrough=True``
receives the arguments it does not know in ``args.extra``.

Exit status: 0 on success, 1 on a failure of the run (missing component or
data), 2 on bad input (argparse errors and :class:`gmt.ParameterError`),
printed on stderr without a traceback.
"""
from __future__ import annotations

import argparse
import importlib
import json
import os
import sys
from pathlib import Path

import gmt

from . import __version__


class UsageError(ValueError):
    """Bad input to a subcommand that argparse cannot check (exit status 2)."""


def _add_paper(subparsers):
    p = subparsers.add_parser(
        "paper", help="reproduce the paper's results and compare with its data",
        description="Model results for every Table 1 case and the compensated runs of "
                    "Table 3, next to the paper's measured values.")
    p.add_argument("--json", action="store_true",
                   help="print only a JSON object {rows, compensated} on stdout")
    p.add_argument("--plots", metavar="DIR",
                   help="write the figures (PNG) into DIR (created if missing)")
    p.add_argument("--branch-rule", choices=gmt.parameters.BRANCH_RULES, default="control",
                   help="compensator root rule: 'control' (Figure 9, default) or 'demand'")
    p.set_defaults(run=_run_paper)


def _run_paper(args) -> int:
    from . import paper

    if args.plots:
        try:
            Path(args.plots).mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise UsageError(f"--plots {args.plots}: cannot create the directory "
                             f"({exc.strerror or exc})") from None
    params = gmt.TransducerParameters()
    runs = paper.compensated_runs(params, args.branch_rule)
    report = paper.paper_report(params, args.branch_rule, runs)
    written = []
    if args.plots:
        from . import plots

        written = plots.write_all(args.plots, params, report, runs)
    if args.json:
        json.dump(report, sys.stdout, indent=2, allow_nan=False)
        sys.stdout.write("\n")
    else:
        print(paper.format_report(report))
        for path in written:
            print(f"wrote {path}")
    return 0


def _add_build(subparsers):
    p = subparsers.add_parser(
        "build", add_help=False,
        help="build the FMU(s) (arguments are passed to smeha.fmu_build)")
    p.set_defaults(run=_run_build, passthrough=True)


def _run_build(args) -> int:
    try:
        fmu_build = importlib.import_module("smeha.fmu_build")
    except ModuleNotFoundError as exc:
        if exc.name not in ("smeha.fmu_build",):
            raise
        print("smeha build: the FMU builder (smeha.fmu_build) is not available in this "
              "installation", file=sys.stderr)
        return 1
    try:
        status = fmu_build.main(list(args.extra))
    except SystemExit as exc:
        status = exc.code
    if status is None:
        return 0
    return status if isinstance(status, int) else 1


#: Registration functions of the subcommands, in the order ``--help`` lists them.
SUBCOMMANDS = (_add_paper, _add_build)


def build_parser() -> argparse.ArgumentParser:
    """The top-level parser with every subcommand registered."""
    parser = argparse.ArgumentParser(
        prog="smeha",
        description="Giant magnetostrictive transducer of a smart-material "
                    "electrohydrostatic actuator: paper reproduction, FMU build.")
    parser.add_argument("--version", action="version", version=f"smeha {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for add in SUBCOMMANDS:
        add(subparsers)
    return parser


def main(argv=None) -> int:
    """Run the command line; return the exit status.

    Parameters
    ----------
    argv : list of str, optional
        Arguments without the program name; ``sys.argv[1:]`` if None.
    """
    parser = build_parser()
    try:
        args, extra = parser.parse_known_args(argv)
        if extra and not getattr(args, "passthrough", False):
            parser.error(f"unrecognized arguments: {' '.join(extra)}")
    except SystemExit as exc:  # argparse: --help, --version (0) or a usage error (2)
        return exc.code if isinstance(exc.code, int) else 2
    args.extra = extra
    try:
        return args.run(args)
    except (gmt.ParameterError, UsageError) as exc:
        print(f"smeha {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except FileNotFoundError as exc:
        print(f"smeha {args.command}: error: {exc}", file=sys.stderr)
        return 1
    except BrokenPipeError:  # stdout closed early, e.g. `smeha paper --json | head`
        sys.stdout = open(os.devnull, "w")
        return 1


if __name__ == "__main__":
    sys.exit(main())
