"""The ``smeha`` command line.

Subcommands
-----------
``smeha paper [--json] [--plots DIR] [--branch-rule control|demand]``
    Reproduce the paper's model results and compare with its data
    (:mod:`smeha.paper`); optionally write the figures (:mod:`smeha.plots`).
``smeha simulate --frequency HZ --mode {uncompensated,compensated} [...]``
    One co-simulation of the EHA (transducer FMU + hydraulics) with the flow
    check of eqs 40/41 (:mod:`smeha.flowstudy`).
``smeha flow [--frequencies 50,70,80,100] [--ideal] [--variant FILE] [--fast] [--json] [--plot FILE]``
    The flow study: both modes at each frequency, against eqs 40/41 and the
    paper's Table 3; ``--loads`` adds the load lines; ``--variant`` runs every
    case again with the extended model (a diagnosis or a small variant JSON)
    and prints both flows side by side.
``smeha sweep SPEC.toml [--scheduler ADDRESS] [--workers N] [--out FILE] [--json] [--plot FILE]``
    A grid of flow-study cases from a TOML spec on local processes or a
    Dask cluster, resumable, into one CSV table (:mod:`smeha.sweep`).
``smeha identify DATA.csv [--json]``
    Identification from measured runs (:mod:`smeha.identify`).
``smeha diagnose DATA.csv [--holdout RUN,...] [--json] [--report DIR]``
    What the paper's model gets wrong on measured runs, the cause, the
    extended model and its held-out gain (:mod:`smeha.diagnose`).
``smeha build [...]``
    Build the FMU(s); arguments go unchanged to :func:`smeha.fmu_build.main`.
``smeha identify DATA.csv [--oversample K] [--json]``
    B_m, mu'' per measured run and the loss coefficients of eq 16
    (:mod:`smeha.identify`; file format in :mod:`smeha.measured`).

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

import numpy as np

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


def _output_directory(option: str, path: str) -> Path:
    """Create an output directory named on the command line; bad ones are usage errors."""
    try:
        Path(path).mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UsageError(f"{option} {path}: cannot create the directory "
                         f"({exc.strerror or exc})") from None
    return Path(path)


def _run_paper(args) -> int:
    from . import paper

    if args.plots:
        _output_directory("--plots", args.plots)
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


def _positive_float(text):
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (value > 0 and value < float("inf")):
        raise argparse.ArgumentTypeError(f"{text!r} must be a positive finite number")
    return value


def _frequencies(text):
    try:
        values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a comma-separated list of "
                                         "frequencies in Hz") from None
    if not values or any(not (0 < v <= 1000) for v in values):
        raise argparse.ArgumentTypeError(f"{text!r}: frequencies must lie in (0, 1000] Hz")
    return values


def _add_cosim_options(p):
    p.add_argument("--ideal", action="store_true",
                   help="ideal limit: stiff oil, fast wide valves, no load (eqs 40/41 hold)")
    p.add_argument("--step", type=_positive_float, default=20e-6,
                   help="communication step [s] (default 2e-05)")
    p.add_argument("--cycles", type=_positive_float, default=8.0,
                   help="simulated pumping cycles, at least 4 (default 8; the first 2 are discarded)")
    p.add_argument("--backend", choices=("fmu", "direct"), default="fmu",
                   help="transducer through the FMU and fmpy (default) or gmt in-process")
    p.add_argument("--fmu", metavar="FILE", help="transducer FMU (default dist/SmehaGmt.fmu, "
                                                 "built if missing or out of date)")
    p.add_argument("--branch-rule", choices=gmt.parameters.BRANCH_RULES, default="control",
                   help="compensator root rule (default 'control', Figure 9)")
    p.add_argument("--controller-period", type=_positive_float, metavar="S",
                   help="sample the valve controller every S seconds, act after the valves' "
                        "exact dead times and put a communication point at each valve action "
                        "(e.g. 1e-5; default: valves switch on the communication grid)")
    p.add_argument("--hydraulic-step", type=_positive_float, metavar="S",
                   help="longest hydraulic substep [s] (e.g. 1e-5; default one per step)")


def _add_simulate(subparsers):
    p = subparsers.add_parser(
        "simulate", help="one co-simulation of the EHA: transducer FMU + hydraulics",
        description="Co-simulate the transducer FMU with the pump chamber, valves V1-V4, "
                    "cylinder and accumulator, and check the cylinder flow against eq 40 "
                    "(uncompensated) or eq 41 (compensated).")
    p.add_argument("--frequency", type=_positive_float, required=True, help="pumping frequency [Hz]")
    p.add_argument("--mode", choices=("uncompensated", "compensated"), required=True)
    p.add_argument("--duration", type=_positive_float,
                   help="simulated time [s] (default: --cycles pumping cycles)")
    p.add_argument("--load", type=float, help="load on the cylinder, opposing 'down' [N] "
                                               "(default 150 realistic, 0 ideal)")
    _add_cosim_options(p)
    p.add_argument("--csv", metavar="FILE", help="write the time series (SI) as CSV")
    p.add_argument("--plot", metavar="FILE", help="write a PNG of the run")
    p.add_argument("--json", action="store_true", help="print only a JSON object")
    p.set_defaults(run=_run_simulate)


def _case_from(args, frequency, mode, load=None, variant=None):
    from .flowstudy import Case
    cycles = args.cycles
    if getattr(args, "duration", None):
        cycles = args.duration * frequency
    return Case(frequency=frequency, mode=mode, ideal=args.ideal, load=load, step=args.step,
                cycles=cycles, backend=args.backend, branch_rule=args.branch_rule,
                variant=variant, controller_period=args.controller_period,
                hydraulic_step=args.hydraulic_step)


def _fmu_for(args):
    from . import flowstudy
    if args.backend != "fmu":
        return None
    if args.fmu:
        if not Path(args.fmu).is_file():
            raise FileNotFoundError(f"--fmu {args.fmu}: no such file")
        return Path(args.fmu)
    return flowstudy.ensure_fmu(quiet=getattr(args, "json", False))


def _progress_bar(total_steps, label, quiet):
    from tqdm import tqdm
    bar = tqdm(total=total_steps, desc=label, unit="step", disable=quiet, leave=False,
               file=sys.stderr, mininterval=0.5)

    def update(done, n):
        bar.n = done
        bar.refresh() if done == n else None
        if done % 200 == 0:
            bar.update(0)
    return bar, update


def _run_simulate(args) -> int:
    from . import flowstudy
    case = _case_from(args, args.frequency, args.mode, args.load)
    fmu = _fmu_for(args)
    n = int(round(case.cycles / case.frequency / case.step))
    bar, update = _progress_bar(n, f"{case.mode} {case.frequency:g} Hz", args.json)
    try:
        record, check, row = flowstudy.run_case(case, fmu, progress=update)
    finally:
        bar.close()
    if args.csv:
        np.savetxt(args.csv, np.column_stack([record[n] for n in record.dtype.names]),
                   delimiter=",", header=",".join(record.dtype.names), comments="")
    if args.plot:
        from .flowplots import plot_run
        plot_run(record, row, args.plot)
    if args.json:
        print(json.dumps(row))
        return 0
    print(f"{row['mode']} at {row['frequency_Hz']:g} Hz, {row['circuit']} circuit, load "
          f"{row['load_N']:g} N, step {row['step_s']:g} s, backend {row['backend']}")
    eq = "eq 41" if case.mode == "compensated" else "eq 40"
    print(f"  mean cylinder flow   {row['flow_sim_m3_s']:.4e} m^3/s ({row['flow_sim_L_min']:.4f} L/min)")
    print(f"  {eq} flow f A_d dy   {row['flow_eq_m3_s']:.4e} m^3/s (ratio {row['flow_ratio']:.4f})")
    print(f"  dy                   {row['dy_um']:.3f} um between the valve switching instants")
    if row["flow_paper_m3_s"] is not None:
        print(f"  paper, Table 3       {row['flow_paper_m3_s']:.4e} m^3/s (dy {row['dy_paper_um']:g} um)")
    print(f"  volume balance       {row['volume_imbalance_m3']:.2e} m^3 of "
          f"{row['volume_pumped_m3']:.2e} m^3 pumped; wall {row['wall_s']:.1f} s")
    return 0


def _add_flow(subparsers):
    p = subparsers.add_parser(
        "flow", help="cylinder flow against frequency, both modes (the flow study)",
        description="Co-simulate both modes at each frequency and compare the mean "
                    "cylinder flow with eqs 40/41 and the paper's Table 3.")
    p.add_argument("--frequencies", type=_frequencies, default=[50.0, 70.0, 80.0, 100.0],
                   help="comma-separated frequencies [Hz] (default 50,70,80,100)")
    p.add_argument("--load", type=float, help="load on the cylinder [N] "
                                               "(default 150 realistic, 0 ideal)")
    p.add_argument("--loads", metavar="N,N,...",
                   help="also trace the load line: flow against load at each frequency")
    p.add_argument("--workers", type=int, default=min(2, os.cpu_count() or 1),
                   help="worker processes (default 2)")
    _add_cosim_options(p)
    p.add_argument("--variant", metavar="FILE",
                   help="also run every case with the extended transducer model: FILE is the "
                        "output of 'smeha diagnose --json' (its winning extension) or "
                        "{\"cause\": ..., \"parameters\": {...}} (e.g. data/paper_variant.json); "
                        "prints the flow of both models side by side")
    p.add_argument("--fast", action="store_true",
                   help="solve each case's periodic steady state directly (smeha.fastpath: "
                        "the paper's model, gmt in-process; ~0.1 s a case) instead of "
                        "time-stepping the co-simulation")
    p.add_argument("--json", action="store_true",
                   help="print only a JSON object {rows: [...]} (with --variant also "
                        "{variant, comparison})")
    p.add_argument("--plot", metavar="FILE", help="write flow against frequency (PNG; the "
                                                   "paper's model)")
    p.set_defaults(run=_run_flow)


def _read_variant(path):
    """The gmt.ModelVariant of a diagnosis or variant JSON file (--variant FILE)."""
    try:
        text = Path(path).read_text()
    except FileNotFoundError:
        raise FileNotFoundError(f"--variant {path}: no such file") from None
    except OSError as exc:
        raise FileNotFoundError(f"--variant {path}: cannot read it ({exc.strerror or exc})"
                                ) from None
    try:
        return gmt.ModelVariant.from_json(text)
    except gmt.ParameterError as exc:
        raise UsageError(f"--variant {path}: {exc}") from None


def _run_fast_flow(args) -> int:
    from . import fastpath, flowstudy
    if args.variant:
        raise UsageError("--fast solves the paper's model only; drop --fast to run --variant")
    if args.controller_period or args.hydraulic_step:
        raise UsageError("--fast solves the study's default discretisation (valves on the step "
                         "grid, one hydraulic substep); drop --controller-period/--hydraulic-step")
    loads = [args.load]
    if args.loads:
        try:
            loads += [float(v) for v in args.loads.split(",") if v.strip()]
        except ValueError:
            raise UsageError(f"--loads {args.loads!r} is not a comma-separated list") from None
    rows = fastpath.flow_table(args.frequencies, flowstudy.MODES, ideal=args.ideal,
                               load=loads if len(loads) > 1 else args.load, step=args.step,
                               branch_rule=args.branch_rule)
    if args.plot:
        from .flowplots import plot_flow
        plot_flow(rows, args.plot)
    if args.json:
        print(json.dumps({"rows": rows}))
        return 0
    first = rows[0]["load_N"]
    print(flowstudy.format_table([r for r in rows if r["load_N"] == first]))
    if args.loads:
        print()
        print(flowstudy.format_load_lines(rows))
    print(f"\n(periodic-steady-state fast path, {sum(r['wall_s'] for r in rows):.2f} s)")
    return 0


def _run_flow(args) -> int:
    from . import flowstudy
    if args.fast:
        return _run_fast_flow(args)
    variant = _read_variant(args.variant) if args.variant else None
    if variant is not None and variant.is_paper:
        print(f"smeha flow: --variant {args.variant} is the paper's model (the diagnosis named "
              "no extension): running the paper's model only", file=sys.stderr)
        variant = None
    fmu = _fmu_for(args)
    models = [None] if variant is None else [None, variant]
    cases = [_case_from(args, f, m, args.load, v) for v in models for f in args.frequencies
             for m in flowstudy.MODES]
    if args.loads:
        try:
            loads = [float(v) for v in args.loads.split(",") if v.strip()]
        except ValueError:
            raise UsageError(f"--loads {args.loads!r} is not a comma-separated list") from None
        cases += [_case_from(args, f, m, load, v) for v in models for f in args.frequencies
                  for m in flowstudy.MODES for load in loads]
    rows = flowstudy.run_cases(cases, fmu, workers=max(1, args.workers), quiet=args.json)
    paper_rows = [r for r in rows if r["model"] == "paper"]
    table = [r for r in paper_rows if r["load_N"] == cases[0].load_force]
    pairs = flowstudy.compare_variant(rows) if variant is not None else None
    if args.plot:
        from .flowplots import plot_flow
        plot_flow(paper_rows, args.plot)
    if args.json:
        out = {"rows": rows}
        if variant is not None:
            out["variant"] = {**variant.as_dict(), "source": str(args.variant)}
            out["comparison"] = pairs
        print(json.dumps(out))
        return 0
    print(flowstudy.format_table(table))
    if args.loads:
        print()
        print(flowstudy.format_load_lines(paper_rows))
    if variant is not None:
        print()
        print(flowstudy.format_comparison(pairs, variant, str(args.variant)))
    return 0


def _add_sweep(subparsers):
    p = subparsers.add_parser(
        "sweep", help="a grid of co-simulations from a TOML spec, locally or on Dask",
        description="Run every point of the spec's grid (docs/SWEEP.md) as a flow-study "
                    "co-simulation on local worker processes or a Dask distributed cluster, "
                    "into one CSV table; a rerun runs only the points missing or failed there.")
    p.add_argument("spec", metavar="SPEC", help="sweep spec (TOML: [grid], [settings])")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="Dask scheduler, e.g. tcp://host:8786 (default: local processes)")
    p.add_argument("--workers", type=int, default=min(2, os.cpu_count() or 1),
                   help="local worker processes (default 2; ignored with --scheduler)")
    p.add_argument("--out", metavar="FILE", help="result table (CSV; default sweep.csv beside "
                                                  "SPEC)")
    p.add_argument("--fmu", metavar="FILE", help="transducer FMU (default dist/SmehaGmt.fmu, "
                                                 "built if missing or out of date)")
    p.add_argument("--json", action="store_true",
                   help="print only a JSON object {rows, skipped, failed, ran}")
    p.add_argument("--plot", metavar="FILE", help="write flow against frequency (PNG)")
    p.set_defaults(run=_run_sweep)


def _run_sweep(args) -> int:
    from . import flowstudy, sweep

    points = sweep.read_spec(args.spec)  # SpecError (a ValueError): exit 2
    if args.workers < 1:
        raise UsageError(f"--workers {args.workers} is outside the allowed range [1, inf)")
    out = Path(args.out) if args.out else Path(args.spec).parent / "sweep.csv"
    fmu = None
    if any(p.backend == "fmu" for p in points):
        if args.fmu:
            if not Path(args.fmu).is_file():
                raise FileNotFoundError(f"--fmu {args.fmu}: no such file")
            fmu = Path(args.fmu)
        else:
            fmu = flowstudy.ensure_fmu(quiet=args.json)
    try:
        result = sweep.run_sweep(points, out, fmu, workers=args.workers,
                                 scheduler=args.scheduler, quiet=args.json)
    except sweep.SweepError as exc:
        print(f"smeha sweep: error: {exc}", file=sys.stderr)
        return 1
    if args.plot:
        sweep.plot_sweep(result.rows, args.plot)
    if args.json:
        print(json.dumps(result.as_dict()))
    else:
        print(sweep.format_summary(result, out))
        if args.plot:
            print(f"wrote {args.plot}")
    return 1 if result.failed else 0


def _add_identify(subparsers):
    p = subparsers.add_parser(
        "identify", help="identify B_m, mu'' and the loss coefficients from measured runs",
        description="Read a measurement file (docs/MEASURED.md), get B_m of each run from its "
                    "sense voltage (eq 22) or its displacement, fit mu'' of each run to the "
                    "measured loop with eq 30, and fit K_h, n, K_e, K_ex to the set of "
                    "eqs 16 with standard uncertainties.")
    p.add_argument("data", metavar="DATA.csv", help="measurement file (CSV, long form)")
    p.add_argument("--oversample", type=int, default=1, metavar="K",
                   help="run the model on a K times finer step than the data (cubic-spline "
                        "current); K >= 16 removes the half-step hold delay for data from "
                        "the physical transducer (default 1: the data's step)")
    p.add_argument("--json", action="store_true",
                   help="print only a JSON object {runs, loss_coefficients, correlation, ...}")
    p.set_defaults(run=_run_identify)


def _run_identify(args) -> int:
    from . import identify, measured

    if not Path(args.data).is_file():
        raise FileNotFoundError(f"{args.data}: no such file")
    if not 1 <= args.oversample <= 1000:
        raise UsageError(f"--oversample {args.oversample} is outside the allowed range [1, 1000]")
    runs = measured.read_measurements(args.data)  # DataError (a ValueError): exit 2
    result = identify.identify(runs, oversample=args.oversample)
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
    p.add_argument("data", metavar="DATA.csv",
                   help="measurement file (CSV, long form; docs/MEASURED.md); sense_voltage_V "
                        "optional but it separates magnetic from mechanical causes")
    p.add_argument("--holdout", metavar="RUN,...",
                   help="comma-separated names of the held-out runs (default: all runs at the "
                        "middle and the second-highest frequency)")
    p.add_argument("--json", action="store_true",
                   help="print only a JSON object {cause, evidence, heldout_runs, "
                        "heldout_rms_um, gain, candidates, ...}")
    p.add_argument("--report", metavar="DIR",
                   help="write PNG figures per run into DIR (loops, residual by branch, "
                        "paper vs extended)")
    p.set_defaults(run=_run_diagnose)


def _run_diagnose(args) -> int:
    from . import diagnose, measured

    if not Path(args.data).is_file():
        raise FileNotFoundError(f"{args.data}: no such file")
    holdout = None
    if args.holdout is not None:
        holdout = [h.strip() for h in args.holdout.split(",") if h.strip()]
        if not holdout:
            raise UsageError(f"--holdout {args.holdout!r} names no run")
    if args.report:
        _output_directory("--report", args.report)
    runs = measured.read_measurements(args.data)  # DataError (a ValueError): exit 2
    result = diagnose.diagnose(runs, holdout=holdout)
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
SUBCOMMANDS = (_add_paper, _add_simulate, _add_flow, _add_build, _add_identify,
               _add_diagnose, _add_sweep)


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
    except (gmt.ParameterError, UsageError, ValueError) as exc:
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
