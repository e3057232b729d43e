"""The ``smeha`` command line.

Subcommands
-----------
``smeha paper [--json] [--plots DIR] [--branch-rule control|demand]``
    Reproduce the paper's model results and compare with its data
    (:mod:`smeha.studies.paper`); optionally write the figures (:mod:`smeha.studies.paperplots`).
``smeha simulate --frequency HZ --mode {uncompensated,compensated} [...]``
    One co-simulation of the EHA (transducer FMU + hydraulics) with the flow
    check of eqs 40/41 (:mod:`smeha.studies.flow`). ``simulate``, ``flow`` and
    ``sweep`` live in :mod:`smeha.studies.flowcommands`.
``smeha flow [--frequencies 50,70,80,100] [--ideal] [--variant FILE] [--json] [--plot FILE]``
    The flow study: both modes at each frequency, against eqs 40/41 and the
    paper's Table 3; ``--loads`` adds the load lines; ``--variant`` runs every
    case again with the extended model (a diagnosis or a small variant JSON)
    and prints both flows side by side.
``smeha sweep SPEC.toml [--scheduler ADDRESS] [--workers N] [--out FILE] [--json] [--plot FILE]``
    A grid of flow-study cases from a TOML spec on local processes or a
    Dask cluster, resumable, into one CSV table (:mod:`smeha.studies.sweep`).
``smeha identify DATA.csv [--json]``
    B_m, mu'' per measured run and the loss coefficients of eq 16
    (:mod:`smeha.identify`; file format in :mod:`smeha.measured`).
``smeha diagnose DATA.csv [--holdout RUN,...] [--json] [--report DIR]``
    What the paper's model gets wrong on measured runs, the cause, the
    extended model and its held-out gain (:mod:`smeha.diagnose`).
``smeha losses [MATERIAL|FILE] [--json] [--plot FILE] [--holdout]``
    The loss laws against measured core losses, MagNet's ferrites or a CSV file
    (:mod:`smeha.coreloss`; docs/LOSSES.md).
``smeha build [--fmi 2|3|both] [--out DIR] [--no-validate] [--cross-check DIR] [--system ...]``
    Build the FMU(s) (:mod:`smeha.fmu.build`) into the source tree's ``dist/``,
    where ``simulate``, ``flow`` and ``sweep`` look for the FMU; ``--system`` also
    builds the hydraulic plant's and the drive's FMUs and writes the EHA system of
    one case, ``SmehaEha.ssp``, ``SmehaEha/OspSystemStructure.xml`` and the container FMU
    ``SmehaEha.fmu`` (:mod:`smeha.fmu.ssp`).

Adding a subcommand: write ``_add_<name>(subparsers)`` (here, or
``add_<name>`` in a module of its own, as :mod:`smeha.studies.flowcommands`) that
registers its parser with ``set_defaults(run=<its run function>)``, and append
it to :data:`SUBCOMMANDS`. Build its options from the types of
:mod:`smeha.cliargs` (files, folders, numbers), so bad input is refused while
the command line is parsed; ``tests/test_cli_input.py`` drives every command
with bad input on that basis.

Exit status: 0 on success, 1 on a failure of the run (:class:`smeha.errors.RunError`,
a missing component or data file of the installation, failed sweep points), 2 on bad
input (:class:`smeha.errors.InputError`: the command line, :class:`gmt.ParameterError`,
bad files), 130 on Ctrl-C, printed on stderr on one line without a traceback. Any other
exception is a bug and shows its traceback.

Start-up: the heavy modules (numpy, scipy, python-control, fmpy, matplotlib)
are imported by the command that needs them, so ``smeha --help`` answers at
once (``benchmarks/cli_startup.py``).
"""
from __future__ import annotations

import json
import os
import signal
import sys

import gmt  # cheap: its names load on first use (gmt/__init__.py)

from . import __version__
from .errors import InputError, RunError
from .interrupt import fmu_safe_interrupts
from .cliargs import (Parser, UsageError, add_branch_rule, count, input_file,
                      join_negative_values, output_dir)
from .coreloss.commands import add_losses
from .studies.flowcommands import CIRCUITS, FREQUENCY, add_flow, add_simulate, add_sweep
from .studies.positioncommands import add_position
from .studies.timedomaincommands import add_timedomain

__all__ = ["SUBCOMMANDS", "build_parser", "main"]


def _add_paper(subparsers):
    p = subparsers.add_parser(
        "paper", help="reproduce the paper's results and compare with its data",
        description="Model results for every Table 1 case and the compensated runs of "
                    "Table 3, next to the paper's measured values.")
    p.add_argument("--json", action="store_true",
                   help="print only a JSON object {rows, compensated, diagnosis} on stdout")
    p.add_argument("--plots", metavar="DIR", type=output_dir,
                   help="write the figures (PNG) into DIR (created if missing, in a folder "
                        "that exists)")
    add_branch_rule(p)
    p.set_defaults(run=_run_paper)


def _run_paper(args) -> int:
    from .studies import paper

    params = gmt.TransducerParameters()
    runs = paper.compensated_runs(params, args.branch_rule)
    report = paper.paper_report(params, args.branch_rule, runs)
    written = []
    if args.plots:
        from .studies import paperplots

        written = paperplots.write_all(args.plots, params, report, runs)
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
        "build", help="build the transducer FMU(s) into dist/ of the source tree",
        description="Build and validate the transducer FMU(s) (smeha.fmu.build; "
                    "'python build_fmu.py' is the same command). By default they go into "
                    "dist/ of the smeha source tree, where simulate, flow and sweep look for "
                    "dist/SmehaGmt.fmu (and build it when it is missing or older than its "
                    "sources). --system adds the EHA as an FMI system: the plant's and the "
                    "drive's FMUs, SmehaEha.ssp, SmehaEha/OspSystemStructure.xml and "
                    "SmehaEha.fmu.")
    p.add_argument("--fmi", choices=("2", "3", "both"), default="2",
                   help="FMI version: 2 (pythonfmu, default), 3 (pythonfmu3) or both")
    p.add_argument("--out", metavar="DIR", type=output_dir,
                   help="output folder (default: dist/ of the source tree; created if "
                        "missing, in a folder that exists)")
    p.add_argument("--no-validate", action="store_true",
                   help="skip fmpy's validation of the built FMU")
    p.add_argument("--cross-check", metavar="DIR", type=output_dir,
                   help="also write each transducer FMU built with the files of the FMI "
                        "Cross-Check (input, reference result, options, README) under "
                        "DIR/fmus/... (docs/FMU.md)")
    p.add_argument("--system", action="store_true",
                   help="also build the hydraulic plant's and the drive's FMUs and write the "
                        "EHA as an FMI system: SmehaEha.ssp (SSP 1.0: fmpy), "
                        "SmehaEha/OspSystemStructure.xml (libcosim) and SmehaEha.fmu (the "
                        "three as one FMU), for the case below (docs/FMU.md)")
    p.add_argument("--frequency", type=FREQUENCY, default=100.0, metavar="HZ",
                   help="with --system: pumping frequency [Hz], in (0, 1000] (default 100)")
    p.add_argument("--mode", choices=("uncompensated", "compensated"), default="compensated",
                   help="with --system: drive mode (default compensated)")
    p.add_argument("--circuit", choices=CIRCUITS, default="realistic",
                   help="with --system: the hydraulic circuit (default realistic)")
    p.set_defaults(run=_run_build)


def _run_build(args) -> int:
    from .fmu import build as fmu_build

    out = args.out or fmu_build.DIST
    if args.out:  # the folder named, in one that exists (smeha.cliargs.output_dir)
        args.out.mkdir(exist_ok=True)
    status = fmu_build.build_all(args.fmi, out, validate=not args.no_validate)
    if args.cross_check and status == 0:
        from .fmu import crosscheck
        iface = fmu_build.iface
        names = {"2": (iface.MODEL_NAME_FMI2,), "3": (iface.MODEL_NAME_FMI3,),
                 "both": (iface.MODEL_NAME_FMI2, iface.MODEL_NAME_FMI3)}
        for folder in crosscheck.write(args.cross_check,
                                       [out / f"{n}.fmu" for n in names[args.fmi]]):
            print(f"FMI Cross-Check files: {folder}")
    if not args.system:
        return status
    from .fmu import ssp
    transducer = out / f"{fmu_build.iface.MODEL_NAME_FMI2}.fmu"
    built = {"transducer": transducer} if status == 0 and args.fmi != "3" else {}
    try:
        written = ssp.build_system(out, args.frequency, args.mode, args.circuit,
                                   validate=not args.no_validate, built=built)
    except fmu_build.BuildError as exc:
        print(f"smeha build: error: {exc}", file=sys.stderr)
        return 1
    for path in written:
        print(f"EHA system ({args.mode}, {args.frequency:g} Hz, {args.circuit} circuit): {path}")
    return status


def _add_identify(subparsers):
    p = subparsers.add_parser(
        "identify", help="identify B_m, mu'' and the loss coefficients from measured runs",
        description="Read a measurement file (docs/MEASURED.md), get B_m of each run from its "
                    "sense voltage (eq 22) or its displacement, fit mu'' of each run to the "
                    "measured loop with eq 30, and fit K_h, n, K_e, K_ex to the set of "
                    "eqs 16 with standard uncertainties.")
    p.add_argument("data", metavar="DATA.csv", type=input_file,
                   help="measurement file (CSV, long form)")
    p.add_argument("--json", action="store_true",
                   help="print only a JSON object {runs, loss_coefficients, correlation, ...}")
    p.set_defaults(run=_run_identify)


def _run_identify(args) -> int:
    from . import identify, measured

    runs = measured.read_measurements(args.data)  # DataError (a ValueError): exit 2
    result = identify.identify(runs)
    if args.json:
        report = {"file": str(args.data), **result.as_dict()}
        json.dump(report, sys.stdout, indent=2, allow_nan=False)
        sys.stdout.write("\n")
    else:
        print(identify.format_identification(result, str(args.data)))
    return 0


def _add_diagnose(subparsers):
    p = subparsers.add_parser(
        "diagnose", help="name the effect the paper's model misses in measured runs",
        description="Fit the paper's model (eq 30, loss coefficients of eq 16) on the training "
                    "runs, characterise its residuals (by branch, harmonic, frequency, drift), "
                    "fit each candidate extension (gmt.extensions) and compare them on the "
                    "held-out runs; print the cause (or 'none' / 'unexplained'), the evidence "
                    "and the held-out gain (smeha.diagnose; docs/DIAGNOSE.md).")
    p.add_argument("data", metavar="DATA.csv", type=input_file,
                   help="measurement file (CSV, long form; docs/MEASURED.md); sense_voltage_V "
                        "optional but it separates magnetic from mechanical causes")
    p.add_argument("--holdout", metavar="RUN,...",
                   help="comma-separated names of the held-out runs (default: all runs at the "
                        "middle and the second-highest frequency)")
    p.add_argument("--json", action="store_true",
                   help="print only a JSON object {cause, evidence, heldout_runs, "
                        "heldout_rms_um, gain, candidates, ...}")
    p.add_argument("--report", metavar="DIR", type=output_dir,
                   help="write PNG figures per run into DIR (loops, residual by branch, "
                        "paper vs extended; created if missing)")
    p.add_argument("--workers", type=count(1), metavar="N",
                   help="processes that fit the candidates side by side, at least 1 (default "
                        "2 on Linux, 1 on Windows and macOS: smeha.pool.default_workers); "
                        "the answer does not depend on it")
    p.set_defaults(run=_run_diagnose)


def _run_diagnose(args) -> int:
    from . import diagnose, measured

    holdout = None
    if args.holdout is not None:
        holdout = [h.strip() for h in args.holdout.split(",") if h.strip()]
        if not holdout:
            raise UsageError(f"--holdout {args.holdout!r} names no run")
    runs = measured.read_measurements(args.data)  # DataError (a ValueError): exit 2
    with diagnose.progress.shown():  # a bar with the current step once it takes > 5 s
        result = diagnose.diagnose(runs, holdout=holdout, workers=args.workers)
    written = diagnose.write_report(result, args.report) if args.report else []
    if args.json:
        report = {"file": str(args.data), **result.as_dict()}
        json.dump(report, sys.stdout, indent=2, allow_nan=False)
        sys.stdout.write("\n")
    else:
        print(diagnose.format_diagnosis(result, str(args.data)))
        for path in written:
            print(f"wrote {path}")
    return 0


#: Registration functions of the subcommands, in the order ``--help`` lists them.
SUBCOMMANDS = (_add_paper, add_simulate, add_flow, add_sweep, add_position, add_timedomain,
               _add_identify, _add_diagnose, add_losses, _add_build)


def build_parser() -> Parser:
    """The top-level parser with every subcommand registered."""
    parser = Parser(
        prog="smeha",
        description="Giant magnetostrictive transducer of a smart-material "
                    "electrohydrostatic actuator: the paper's model, the transducer FMU, the "
                    "actuator's flow by co-simulation, identification and diagnosis from "
                    "measured data. Each command has --help.")
    parser.add_argument("--version", action="version", version=f"smeha {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for add in SUBCOMMANDS:
        add(subparsers)
    for sub in subparsers.choices.values():  # main() reports stray arguments as the command's
        sub.set_defaults(parser=sub)
    return parser


def main(argv=None) -> int:
    """Run the command line; return the exit status.

    Parameters
    ----------
    argv : list of str, optional
        Arguments without the program name; ``sys.argv[1:]`` if None.
    """
    program = argv is None
    argv = sys.argv[1:] if argv is None else list(argv)
    try:
        with fmu_safe_interrupts():
            status = _main(argv)
    except KeyboardInterrupt:  # Ctrl-C: one line, the shell's 128 + SIGINT
        command = " ".join(["smeha", *[a for a in argv if not a.startswith("-")][:1]])
        print(f"\n{command}: interrupted", file=sys.stderr)
        status = 130
    if program:  # the work is done or stopped: a Ctrl-C while Python shuts down changes nothing
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    return status


def _main(argv) -> int:
    parser = build_parser()
    try:
        args, extra = parser.parse_known_args(join_negative_values(argv))
        if extra:
            args.parser.error(f"unrecognized arguments: {' '.join(extra)}")
    except SystemExit as exc:  # argparse: --help, --version (0) or a usage error (2)
        return exc.code if isinstance(exc.code, int) else 2
    try:
        return args.run(args)
    except InputError as exc:  # UsageError, gmt.ParameterError, a bad data file or spec
        print(f"smeha {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except RunError as exc:  # an integration, a coupling, a sweep that stopped
        print(f"smeha {args.command}: error: the run stopped: {exc}", file=sys.stderr)
        return 1
    except FileNotFoundError as exc:  # a file of the installation (the paper's data)
        print(f"smeha {args.command}: error: {exc}", file=sys.stderr)
        return 1
    except BrokenPipeError:  # stdout closed early, e.g. `smeha paper --json | head`
        sys.stdout = open(os.devnull, "w")
        return 1


if __name__ == "__main__":
    sys.exit(main())
