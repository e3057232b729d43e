"""The flow-study commands of ``smeha``: ``simulate``, ``flow`` and ``sweep``.

One co-simulation, the flow study (both modes at each frequency, load lines, a model
variant next to the paper's model) and a grid of co-simulations, with
the rules their options share: the co-simulation options, the step's accuracy
warning, the cases built from the options (:class:`smeha.studies.flow.Case`), the FMU
used. Registered by :mod:`smeha.cli`; option types from :mod:`smeha.cliargs`.
Nothing heavy is imported before a command runs.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import gmt  # cheap: its names load on first use
from gmt.parameters import COMPENSATOR_PERIOD
from system_models.defaults import (DEFAULT_COUPLING, DEFAULT_CYCLES, DEFAULT_STEP,
                                    MINIMUM_CYCLES, REALISTIC_LOAD, SKIP_CYCLES)

from ..pool import default_workers
from ..cliargs import (UsageError, add_branch_rule, count, fmu_file, input_file, output_file,
                      plot_file, say, scheduler_address, setting_list, setting_type, warn)
from . import flowsettings as fs

__all__ = ["FREQUENCY", "CONVERGED_STEPS_PER_CYCLE", "CIRCUITS", "MODE_HELP", "add_simulate",
           "WORKERS_HELP", "add_flow", "FAST_RETIRED", "add_sweep", "default_sweep_table"]

#: Frequencies the study accepts (smeha.studies.flowsettings.FREQUENCY).
FREQUENCY = setting_type(fs.FREQUENCY)

#: Steps a pumping cycle at and above which the flow was measured to converge, per
#: coupling (benchmarks/README.md, convergence): the force port within 0.1 % at 100 steps a
#: cycle (100 us at 100 Hz); the displacement port within 0.5 % at 250 (40 us at 100 Hz).
CONVERGED_STEPS_PER_CYCLE = {"force": 100, "displacement": 250}
#: The named circuits (system_models.presets.CIRCUITS, typed here so that --help loads no
#: solver; tests/test_kernel.py checks the two agree).
CIRCUITS = ("realistic", "ideal", "differential")
#: --magnetics (gmt.transducer.MAGNETICS) and --waveform (smeha.studies.waveforms.WAVEFORMS),
#: typed here for --help; tests/test_timedomain_study.py checks they agree.
MAGNETICS = ("paper", "time_domain")
WAVEFORMS = ("sine", "square", "trapezoid")


def _check_step(command, step, frequency, coupling, sample_period=0.0) -> None:
    """Warn (stderr) when the communication step is coarser than any measured to converge.

    ``sample_period``: the digital compensator's T_c (0 uncompensated); the master cuts
    every step at its samples, so a step longer than T_c runs as T_c (no warning then)."""
    need = CONVERGED_STEPS_PER_CYCLE[coupling]
    if sample_period > 0.0:
        step = min(step, sample_period)
    per_cycle = 1.0 / (frequency * step)
    if per_cycle < need * (1.0 - 1e-9):
        warn(command, f"--step {step:g} s is {per_cycle:.0f} steps a cycle at {frequency:g} Hz; "
                      f"the flow was measured to converge from {need} steps a cycle "
                      f"(--step {1.0 / (need * frequency):.2g} s) on (benchmarks/README.md): "
                      "expect a larger error")


def _averaged(cycles=DEFAULT_CYCLES) -> float:
    """Whole cycles the flow check averages in a run of ``cycles``: its compression strokes
    start at the drive's minima, (k + 1/2) T, and the averaged cycles lie between the
    strokes after the skipped ones."""
    import math
    return max(math.ceil(cycles - 0.5) - SKIP_CYCLES - 1, 0)



def _add_cosim_options(p):
    p.add_argument("--circuit", choices=CIRCUITS,
                   help="realistic (default: 0.5 %% air in the oil, 0.2 ms valve dead time, "
                        f"differential cylinder, {REALISTIC_LOAD:g} N load); ideal: the limit "
                        "in which eqs "
                        "40/41 hold (the chamber pressure constant: equal-area cylinder, "
                        "stiff oil, instant valves, no load); differential: ideal oil and "
                        "valves on the differential cylinder, whose rebound adds stroke")
    p.add_argument("--ideal", action="store_true", help="the same as --circuit ideal")
    p.add_argument("--step", type=setting_type(fs.STEP), metavar="S",
                   help=f"communication step {fs.STEP.describe()}; a warning below "
                        f"{CONVERGED_STEPS_PER_CYCLE['force']} steps a cycle; steps are also "
                        "cut at the compensator's samples and the valve actions")
    p.add_argument("--coupling", choices=("force", "displacement"),
                   help="force (default): the FMU hands over the magnetostrictive force and "
                        "the plant integrates the rod with the pump chamber; displacement: "
                        "the FMU integrates the rod, the chamber force iterated through its "
                        "state save/restore (the cross-check; needs smaller steps)")
    p.add_argument("--cycles", type=setting_type(fs.CYCLES), metavar="N",
                   help=f"simulated pumping cycles, {fs.CYCLES.interval()}: the flow check "
                        f"discards the first {SKIP_CYCLES} compression strokes and averages "
                        f"the whole cycles between the strokes that follow ({_averaged():g} "
                        f"at the default {DEFAULT_CYCLES:g})")
    p.add_argument("--backend", choices=("fmu", "direct"),
                   help="transducer through the FMU and fmpy (default) or gmt in-process")
    p.add_argument("--fmu", metavar="FILE", type=fmu_file,
                   help="transducer FMU (default dist/SmehaGmt.fmu of the source tree, built "
                        "if missing or out of date; see 'smeha build')")
    add_branch_rule(p)
    p.add_argument("--magnetics", choices=MAGNETICS,
                   help="the transducer's magnetics: paper (default: the complex permeability "
                        "of eqs 3-20, defined for one sinusoid) or time_domain (the paper's loss "
                        "separation as a field separation, valid for any drive; compensated, "
                        "its own explicit inverse; docs/TIMEDOMAIN.md)")
    p.add_argument("--waveform", choices=WAVEFORMS,
                   help="shape of the control signal: sine (default, the paper's), square or "
                        "trapezoid (ramps of 0.15 of the period); uncompensated the coil "
                        "current's, compensated the demanded stroke's; the valves switch where "
                        "u starts to rise and to fall")
    p.add_argument("--compensator-period", type=setting_type(fs.COMPENSATOR_PERIOD_S),
                   metavar="S",
                   help=f"sample period of the digital compensator "
                        f"{fs.COMPENSATOR_PERIOD_S.describe()}: 10 kHz; its current is held "
                        f"between samples; 0: a sample every step")
    p.add_argument("--controller-period", type=setting_type(fs.CONTROLLER_PERIOD),
                   metavar="S",
                   help=f"sample period of the valve controller {fs.CONTROLLER_PERIOD.describe()}"
                        "; the valves act after their exact dead times, at communication "
                        "points")
    p.add_argument("--hydraulic-step", type=setting_type(fs.HYDRAULIC_STEP_S), metavar="S",
                   help=f"longest hydraulic substep {fs.HYDRAULIC_STEP_S.describe()}; after "
                        f"each valve action the substeps start at 1 us and grow fourfold")


def _add_load(p):
    p.add_argument("--load", type=setting_type(fs.LOAD), metavar="N",
                   help=f"load on the cylinder {fs.LOAD.describe()}: positive opposes the "
                        "pumped direction "
                        "(oil into the big cavity), negative assists it (default "
                        f"{REALISTIC_LOAD:g} "
                        "realistic, 0 ideal and differential)")


MODE_HELP = ("uncompensated: u = I_m/K_a cos(2 pi f t), the coil current i = I_m cos(2 pi f t), "
             "valves switching at i = -+I_m (eq 40); compensated: u = a + a cos(2 pi f t) "
             "through the inverse compensator (Figure 9), valves switching at u = 0 and 2a "
             "(eq 41)")


def add_simulate(subparsers):
    p = subparsers.add_parser(
        "simulate", help="one co-simulation of the EHA: transducer FMU + hydraulics",
        description="Co-simulate the transducer FMU with the pump chamber, valves V1-V4, "
                    "cylinder and accumulator, and check the cylinder flow against eq 40 "
                    "(uncompensated) or eq 41 (compensated).")
    p.add_argument("--frequency", type=FREQUENCY, required=True, metavar="HZ",
                   help=f"pumping frequency {fs.FREQUENCY.describe()}")
    p.add_argument("--mode", choices=("uncompensated", "compensated"), required=True,
                   help=MODE_HELP)
    p.add_argument("--duration", type=setting_type(fs.DURATION), metavar="S",
                   help=f"simulated time {fs.DURATION.describe()} and at least "
                        f"{MINIMUM_CYCLES} cycles (default: --cycles pumping cycles)")
    _add_load(p)
    _add_cosim_options(p)
    p.add_argument("--csv", metavar="FILE", type=output_file,
                   help="write the whole record as CSV, SI units in the column names "
                        "(time_s, rod_displacement_m, p_pump_Pa, ...); for a file 'smeha "
                        "identify' and 'smeha diagnose' read, use --measurement")
    p.add_argument("--variant", metavar="FILE", type=input_file,
                   help="the transducer with a model variant: FILE is 'smeha diagnose --json' "
                        "output or {\"cause\": ..., \"parameters\": {...}} (e.g. "
                        "data/paper_variant.json); with --measurement, a data set to diagnose")
    p.add_argument("--amplitude", type=setting_type(fs.AMPLITUDE), metavar="A",
                   help="the control signal's amplitude: uncompensated the coil current's "
                        "I_m [A] (default 1, the paper's; the model's operating point "
                        "follows it), compensated the demand's a [V] (default Figure 10's); "
                        f"{fs.AMPLITUDE.interval()}")
    p.add_argument("--measurement", metavar="FILE", type=output_file,
                   help="add the run to FILE in the measurement format (docs/MEASURED.md: "
                        "run, frequency_Hz, time_s, current_A, displacement_um, "
                        "sense_voltage_V, control_V), as run '<mode>_<f>Hz' ('_<a>A' with "
                        "--amplitude); a run of that name already there is replaced, others "
                        "kept, so runs at several frequencies and amplitudes make one data "
                        "set for 'smeha diagnose'. The transducer's own channels: its rod "
                        "free of the chamber's force, the sensing coil's voltage (eq 21), "
                        "sampled every --step, with sensor noise (--noise-um)")
    p.add_argument("--noise-um", type=setting_type(fs.NOISE_UM), metavar="UM",
                   help="with --measurement: the displacement sensor's noise, standard "
                        f"deviation {fs.NOISE_UM.describe()}, default 0.05; the sense "
                        "voltage's 0.5 mV scales with it; seeded by the run's name and --seed")
    p.add_argument("--seed", type=count(0), metavar="N",
                   help="with --measurement: the sensor noise's seed (default 0)")
    p.add_argument("--plot", metavar="FILE", type=plot_file,
                   help="write a plot of the run (PNG, PDF or SVG by the suffix)")
    p.add_argument("--json", action="store_true", help="print only a JSON object")
    p.set_defaults(run=_run_simulate)


def _case_from(args, frequency, mode, load=None, variant=None):
    from .flow import Case
    cycles = getattr(args, "cycles", None)
    if getattr(args, "duration", None):
        cycles = args.duration * frequency
    optional = {"cycles": cycles, "backend": args.backend, "coupling": args.coupling,
                "step": args.step, "circuit": "ideal" if args.ideal else args.circuit,
                "compensator_period": args.compensator_period,
                "controller_period": args.controller_period,
                "hydraulic_step": args.hydraulic_step, "magnetics": args.magnetics,
                "waveform": args.waveform, "amplitude": getattr(args, "amplitude", None)}
    return Case(frequency=frequency, mode=mode, load=load, branch_rule=args.branch_rule,
                variant=variant, **{k: v for k, v in optional.items() if v is not None})


def _check_circuit(args) -> None:
    if args.ideal and args.circuit not in (None, "ideal"):
        raise UsageError(f"--ideal is --circuit ideal; it contradicts --circuit {args.circuit}")
    if args.waveform not in (None, "sine") and args.magnetics in (None, "paper"):
        warn(args.command, f"--waveform {args.waveform} drives the paper's model, which is "
                           "defined for a sinusoid (its outside_design_point rises): "
                           "--magnetics time_domain holds for any drive")


def _fmu_for(args, cases):
    from . import flow
    if all(c.backend != "fmu" for c in cases):
        if args.fmu:
            raise UsageError(f"--fmu {args.fmu} has no use: every case runs gmt in-process "
                             "(backend 'direct'); drop --fmu or the direct backend")
        return None
    if args.fmu:
        return args.fmu
    return flow.ensure_fmu(quiet=getattr(args, "json", False), say=say)


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


def _check_simulate(args) -> None:
    """The cross-option rules of simulate, in the options' own terms (before any work)."""
    if args.duration is not None:
        if args.cycles is not None:
            raise UsageError(f"give --duration or --cycles, not both (--duration "
                             f"{args.duration:g} s is {args.duration * args.frequency:g} "
                             f"cycles at {args.frequency:g} Hz)")
        if args.duration * args.frequency < MINIMUM_CYCLES:
            raise UsageError(
                f"--duration {args.duration:g} s is {args.duration * args.frequency:.3g} "
                f"cycles at {args.frequency:g} Hz; the flow check discards the first "
                f"{SKIP_CYCLES} cycles "
                f"and averages at least {MINIMUM_CYCLES - SKIP_CYCLES} more: give --duration "
                f">= {MINIMUM_CYCLES / args.frequency:g} s")
    _check_circuit(args)
    if args.measurement is None and (args.noise_um is not None or args.seed is not None):
        raise UsageError("--noise-um and --seed set the noise of --measurement's file; "
                         "give --measurement FILE")
    if args.measurement is not None and (args.mode == "compensated"
                                         or args.waveform not in (None, "sine")):
        warn("simulate", "--measurement: the identification and the diagnosis model a "
                         "sinusoidal coil current (the paper's uncompensated drive); this "
                         "run's current is not one (the compensator's, or another waveform), "
                         "so the paper's model will not describe it (measured: 'unexplained' "
                         "for the paper's own model, compensated)")
    if args.measurement is not None and args.coupling == "displacement":
        raise UsageError("--measurement records the transducer's own rod, which the "
                         "displacement port loads with the chamber's force: use --coupling "
                         "force (the default)")
    compensated = args.mode == "compensated"
    period = (COMPENSATOR_PERIOD if args.compensator_period is None
              else args.compensator_period) if compensated else 0.0
    _check_step("simulate", args.step or DEFAULT_STEP, args.frequency,
                args.coupling or DEFAULT_COUPLING, period)


def _announce_long(command, cases, workers=1) -> None:
    """Warn (stderr) before a run whose estimate exceeds a minute, with the estimate and
    what sets it (smeha.studies.flowsettings.estimated_wall)."""
    walls = [fs.estimated_wall(c.cycles / c.frequency, c.step) for c in cases]
    total = sum(walls) / max(1, min(workers, len(cases)))
    if total <= fs.LONG_RUN:
        return
    longest = cases[walls.index(max(walls))]
    steps = longest.cycles / longest.frequency / longest.step
    warn(command, f"this run is estimated at up to about {total / 60:.0f} min: "
                  f"{longest.cycles:g} cycles at {longest.frequency:g} Hz are "
                  f"{longest.cycles / longest.frequency:g} s of simulated time, {steps:,.0f} "
                  f"steps of {longest.step:g} s (Ctrl-C stops it)")


def _run_failures() -> tuple:
    """The errors of a run that stopped (the integration, the displacement port's
    interface): said in one line with exit status 1, not as a traceback."""
    from system_models.displacementport import CouplingError
    from system_models.implicit import IntegrationError
    return IntegrationError, CouplingError


def _failed(command, exc) -> int:
    print(f"smeha {command}: error: the run stopped: {exc}", file=sys.stderr)
    return 1


def _write_record_csv(record, path) -> None:
    """The co-simulation record as CSV, each column named with its SI unit (p_pump_Pa)."""
    import numpy as np
    from system_models.cosim import RESULT_UNITS

    from ..outputs import replacing

    names = [f"{n}_{RESULT_UNITS[n]}" if RESULT_UNITS[n] else n for n in record.dtype.names]
    with replacing(path) as tmp:
        np.savetxt(tmp, np.column_stack([record[n] for n in record.dtype.names]),
                   delimiter=",", header=",".join(names), comments="")


def _add_measurement(record, case, args) -> None:
    """The run as a measurement of the transducer (smeha.studies.simmeasure), added to the
    measurement file."""
    from .. import measured
    from . import simmeasure
    path = args.measurement
    name = simmeasure.run_name(case.mode, case.frequency, case.amplitude)
    scale = 1.0 if args.noise_um is None else args.noise_um * 1e-6 / simmeasure.DISPLACEMENT_NOISE
    run = simmeasure.measurement_run(
        record, name, case.frequency, case.step, simmeasure.DISPLACEMENT_NOISE * scale,
        simmeasure.VOLTAGE_NOISE * scale, args.seed or 0, case.held_force_mechanics(),
        simmeasure.variant_sensor(case.variant))
    uneven = simmeasure.uneven_steps(record, case.step)
    if uneven:
        warn("simulate", f"--measurement: {uneven} valve actions fell between the "
                         f"{case.step:g} s steps, so the transducer stepped unevenly there and "
                         "its quadrature is less accurate (0.34 deg of B at 150 Hz, 50 us: "
                         "the diagnosis sees it); a --step and --controller-period that "
                         "divide half the period and the valves' dead time avoid it (150 Hz: "
                         "both 6.6667e-05 s)")
    runs = measured.read_measurements(path) if Path(path).is_file() else []
    measured.write_measurements(path, [r for r in runs if r.name != name] + [run])


def _run_simulate(args) -> int:
    from . import flow
    _check_simulate(args)
    variant = _read_variant(args.variant)[0] if args.variant else None
    case = _case_from(args, args.frequency, args.mode, args.load,
                      None if variant is None or variant.is_paper else variant)
    _announce_long("simulate", [case])
    fmu = _fmu_for(args, [case])
    from system_models import kernel
    kernel.ensure_compiled(None if args.json else say)
    n = int(round(case.cycles / case.frequency / case.step))
    bar, update = _progress_bar(n, f"{case.mode} {case.frequency:g} Hz", args.json)
    try:
        record, check, row = flow.run_case(case, fmu, progress=update)
    except _run_failures() as exc:
        bar.close()
        return _failed("simulate", exc)
    bar.close()
    if args.csv:
        _write_record_csv(record, args.csv)
    if args.measurement:
        _add_measurement(record, case, args)
    if args.plot:
        from .flowplots import plot_run
        plot_run(record, row, args.plot)
    if args.json:
        print(json.dumps(row.as_dict()))
        return 0
    print(f"{row['mode']} at {row['frequency_Hz']:g} Hz, {row['circuit']} circuit, load "
          f"{row['load_N']:g} N, step {row['step_s']:g} s, backend {row['backend']}, "
          f"{row['magnetics']} magnetics, {row['waveform']} drive")
    eq = "eq 41" if case.mode == "compensated" else "eq 40"
    print(f"  mean cylinder flow   {row['flow_sim_m3_s']:.3e} m^3/s "
          f"({row['flow_sim_L_min']:.4f} L/min)")
    print(f"  {eq} flow f A_d dy   {row['flow_eq_m3_s']:.3e} m^3/s (ratio {row['flow_ratio']:.3f})")
    print(f"  dy                   {row['dy_um']:.3f} um between the valve switching instants")
    if row["flow_paper_m3_s"] is not None:
        print(f"  paper, Table 3       {row['flow_paper_m3_s']:.3e} m^3/s, f A_d dy computed "
              f"from its measured dy {row['dy_paper_um']:g} um (eqs 40/41)")
    print(f"  volume balance       {row['volume_imbalance_m3']:.2e} m^3 of "
          f"{row['volume_pumped_m3']:.2e} m^3 pumped; wall {row['wall_s']:.1f} s")
    if not row["settled"]:
        print(f"  not settled          the cycles' flows change by "
              f"{100 * row['flow_drift_per_cycle']:+.3f} % a cycle (the circuit follows the "
              f"piston: cavities, accumulator); the mean depends on the run's length")
    if row.get("note"):  # a reversed flow, cavitation (smeha.studies.flow.flag_row)
        print(f"  (!) {row['note']}")
    for path in (args.csv, args.measurement, args.plot):
        if path:
            print(f"wrote {path}")
    return 0


#: --workers of flow and sweep: how the local workers start and what that costs
#: (docs/SWEEP.md, Workers; benchmarks/README.md, Sweeps).
WORKERS_HELP = ("local worker processes, at least 1 (default 2 on Linux, 1 on Windows and "
                "macOS: smeha.pool.default_workers); on Linux they are forked from "
                "this process once it has loaded the kernel and the FMU, and cost about the "
                "CPU time of one; on Windows and macOS each starts a new interpreter (~1.5-2 s "
                "of CPU): there 1 is faster for grids of a few short runs")


def add_flow(subparsers):
    p = subparsers.add_parser(
        "flow", help="cylinder flow against frequency, both modes (the flow study)",
        description="Co-simulate both modes at each frequency and compare the mean "
                    "cylinder flow with eqs 40/41 and the paper's Table 3.")
    p.add_argument("--frequencies", type=setting_list(fs.FREQUENCY),
                   default=[50.0, 70.0, 80.0, 100.0], metavar="HZ,HZ,...",
                   help=f"comma-separated frequencies {fs.FREQUENCY.describe()} each "
                        "(default 50,70,80,100)")
    _add_load(p)
    p.add_argument("--loads", metavar="N,N,...", type=setting_list(fs.LOAD),
                   help="also trace the load line: flow against load at each frequency "
                        f"(negative loads assist), each {fs.LOAD.describe()}")
    p.add_argument("--workers", type=count(1), metavar="N", help=WORKERS_HELP)
    _add_cosim_options(p)
    p.add_argument("--variant", metavar="FILE", type=input_file,
                   help="also run every case with the extended transducer model: FILE is the "
                        "output of 'smeha diagnose --json' (its winning extension) or "
                        "{\"cause\": ..., \"parameters\": {...}} (e.g. data/paper_variant.json); "
                        "prints the flow of both models side by side, and marks (!) with "
                        "the reason a variant that is not physical in the pump (a weak "
                        "finding, a circuit mode it moves onto the pumping frequency, a "
                        "rebound it magnifies)")
    # retired (FAST_RETIRED); kept out of --help, refused with the reason
    p.add_argument("--fast", action="store_true", help=argparse.SUPPRESS)
    p.add_argument("--json", action="store_true",
                   help="print only a JSON object {rows: [...]} (with --variant also "
                        "{variant, comparison})")
    p.add_argument("--plot", metavar="FILE", type=plot_file,
                   help="write flow against frequency (PNG; with --variant both models, "
                        "with --loads the load lines)")
    p.set_defaults(run=_run_flow)


def _read_variant(path):
    """The gmt.ModelVariant of a diagnosis or variant JSON file (--variant FILE), and the
    file's JSON object (what it states about the variant, e.g. ``weak``)."""
    try:
        text = Path(path).read_text()
    except (OSError, UnicodeDecodeError) as exc:
        raise UsageError(f"--variant {path}: cannot read it ({getattr(exc, 'strerror', exc)})"
                         ) from None
    from ..diagnose import read_variant_json

    try:
        return read_variant_json(text), json.loads(text)
    except gmt.ParameterError as exc:
        raise UsageError(f"--variant {path}: {exc}") from None


#: Why ``smeha flow --fast`` is refused (exit status 2): the periodic-steady-state fast path
#: is gone. The time-stepped table on the force port is faster than it was (0.4 s against
#: 0.67 s in-process, one run each) and keeps the exact valve timing it missed by up to
#: 2.5 % (benchmarks/README.md, "The fast path, retired").
FAST_RETIRED = ("--fast is retired: the default co-simulation replaced the periodic-steady-state "
                "fast path and is faster (the whole table in ~0.4 s in-process: "
                "--backend direct); drop --fast")


def _workers(args) -> int:
    return args.workers if args.workers is not None else default_workers()


def _run_flow(args) -> int:
    from . import flow
    if args.fast:
        raise UsageError(FAST_RETIRED)
    variant, declared = _read_variant(args.variant) if args.variant else (None, None)
    no_extension = variant is not None and variant.is_paper
    if no_extension:
        note = (f"--variant {args.variant} names no extension (the diagnosis found nothing "
                "the paper's model misses: cause 'none'), so there is no extended model to "
                "compare: running the paper's model only")
        warn("flow", note)
        variant = None
    _check_circuit(args)
    _check_step("flow", args.step or DEFAULT_STEP, max(args.frequencies),
                args.coupling or DEFAULT_COUPLING)
    models = [None] if variant is None else [None, variant]
    cases = [_case_from(args, f, m, args.load, v) for v in models for f in args.frequencies
             for m in flow.MODES]
    cases += [_case_from(args, f, m, load, v) for v in models for f in args.frequencies
              for m in flow.MODES for load in (args.loads or [])]
    check = None
    if variant is not None:  # a weak finding or a circuit mode it moves: said in every output
        from .variantcheck import check_variant
        check = check_variant(variant, cases[0].circuit, declared, cases[0].frequency)
    _announce_long("flow", cases, _workers(args))
    fmu = _fmu_for(args, cases)
    try:
        rows = flow.run_cases(cases, fmu, workers=_workers(args), quiet=args.json, say=say)
    except _run_failures() as exc:
        return _failed("flow", exc)
    if check is not None:
        from .variantcheck import mark_rows
        rows = mark_rows(rows, check)
    paper_rows = [r for r in rows if r["model"] == "paper"]
    table = [r for r in paper_rows if r["load_N"] == cases[0].load_force]
    pairs = flow.compare_variant(rows) if variant is not None else None
    if args.plot:
        from .flowplots import plot_flow
        plot_flow(rows, args.plot)
    if args.json:
        out = {"rows": [r.as_dict() for r in rows]}
        if variant is not None:
            out["variant"] = {**variant.as_dict(), "source": str(args.variant),
                              "check": check.as_dict(args.frequencies)}
            out["comparison"] = pairs
        elif no_extension:
            out["variant"] = {"cause": "none", "source": str(args.variant), "note": note}
            out["comparison"] = []
        print(json.dumps(out))
        return 0
    from . import flowtables
    print(flowtables.format_table(table))
    if args.loads:
        print()
        print(flowtables.format_load_lines(paper_rows))
    if variant is not None:
        print()
        print(flowtables.format_comparison(pairs, variant, str(args.variant)))
    if no_extension:
        print(f"\n{note}")
    if args.plot:
        print(f"wrote {args.plot}")
    return 0


def add_sweep(subparsers):
    p = subparsers.add_parser(
        "sweep", help="a grid of co-simulations from a TOML spec, locally or on Dask",
        description="Run every point of the spec's grid (docs/SWEEP.md) as a flow-study "
                    "co-simulation on local worker processes or a Dask distributed cluster, "
                    "into one CSV table; a rerun runs only the points missing or failed there.")
    p.add_argument("spec", metavar="SPEC", type=input_file,
                   help="sweep spec (TOML: [grid], [settings])")
    p.add_argument("--scheduler", metavar="ADDRESS", type=scheduler_address,
                   help="Dask scheduler, e.g. tcp://host:8786 (default: local processes)")
    p.add_argument("--workers", type=count(1), metavar="N",
                   help=WORKERS_HELP + "; not with --scheduler")
    p.add_argument("--out", metavar="FILE", type=output_file,
                   help="result table (CSV; default: the spec's name with .csv, beside it: "
                        "grid.toml -> grid.csv)")
    p.add_argument("--fmu", metavar="FILE", type=fmu_file,
                   help="transducer FMU (default dist/SmehaGmt.fmu of the source tree, built "
                        "if missing or out of date; see 'smeha build')")
    p.add_argument("--json", action="store_true",
                   help="print only a JSON object {rows, skipped, failed, ran}")
    p.add_argument("--plot", metavar="FILE", type=plot_file,
                   help="write flow against frequency (PNG)")
    p.set_defaults(run=_run_sweep)


def default_sweep_table(spec: Path) -> Path:
    """The sweep's table when --out is not given: the spec's name with .csv, beside it."""
    out = spec.with_suffix(".csv")
    return out if out != spec else spec.with_name(spec.name + ".csv")


def _run_sweep(args) -> int:
    from . import sweep

    if args.scheduler and args.workers is not None:
        raise UsageError("--workers sets local processes; with --scheduler the Dask "
                         "cluster's workers run the points: drop one of them")
    if args.scheduler and (missing := sweep.dask_missing()):
        raise UsageError(f"--scheduler needs Dask, and {missing!r} is not installed: "
                         f"{sweep.DASK_INSTALL}")
    points = sweep.read_spec(args.spec)  # SpecError (a ValueError): exit 2
    out = args.out
    if out is None:
        try:
            out = output_file(str(default_sweep_table(args.spec)))
        except argparse.ArgumentTypeError as exc:
            raise UsageError(f"the default table (--out) {exc}") from None
    highest = {}  # (step, coupling) -> the highest frequency swept with it
    for q in points:
        key = (q.step, q.coupling)
        highest[key] = max(highest.get(key, 0.0), q.frequency)
    for (step, coupling), frequency in highest.items():
        _check_step("sweep", step, frequency, coupling)
    if not args.scheduler:  # a cluster's speed is its own
        _announce_long("sweep", [q.case for q in points], _workers(args))
    fmu = _fmu_for(args, points)
    try:
        result = sweep.run_sweep(points, out, fmu, workers=_workers(args),
                                 scheduler=args.scheduler, quiet=args.json, say=say)
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
