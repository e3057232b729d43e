"""``smeha position``: the cylinder's position in closed loop (:mod:`smeha.studies.position`).

Registered by :mod:`smeha.cli`; nothing heavy is imported before the command runs. The
numeric options' ranges, units, defaults and help come from their declarations
(:mod:`smeha.studies.positionoptions`), which the study enforces too.
"""
from __future__ import annotations

import csv
import json
import math
import sys

from gmt.errors import ParameterError

from ..cliargs import (UsageError, input_file, number_list, output_file, plot_file, say,
                       setting_type, warn)
from ..outputs import replacing
from ..settings import Setting
from . import positionoptions as options
from .flowcommands import CIRCUITS

__all__ = ["add_position"]

#: --mode's choices: each drive mode, or both (the default).
MODES = ("compensated", "uncompensated", "both")
#: A run estimated longer than this says so before it starts, [s].
LONG_RUN = 60.0


def _add(p, option: Setting, **kwargs):
    p.add_argument(option.flag, type=setting_type(option), default=option.default,
                   metavar=option.unit.upper(), help=option.help_text(), **kwargs)


def add_position(subparsers):
    p = subparsers.add_parser(
        "position", help="the cylinder's position in closed loop through the FMU",
        description="A position controller, designed with python-control on a linear model "
                    "identified from open-loop co-simulations (an integrator with a "
                    "velocity line per direction and the load's droop), sets the cylinder's "
                    "direction and the drive amplitude once a pump period. It runs a "
                    "position step (and with --bandwidth sine tracking, with --load-step a "
                    "load step) through the transducer FMU and the hydraulic circuit, and "
                    "prints the measured figures next to python-control's predictions. "
                    "With --envelope it maps the largest steady speed in each direction "
                    "against load instead, with the stall loads.")
    p.add_argument("--mode", choices=MODES, default="both",
                   help="drive mode: compensated (Figure 9), uncompensated, or both "
                        "(default)")
    _add(p, options.TARGET)
    _add(p, options.FREQUENCY)
    _add(p, options.LOAD)
    _add(p, options.DURATION)
    p.add_argument("--circuit", choices=CIRCUITS, default=None,
                   help="the hydraulic circuit (default realistic; with --envelope every "
                        "circuit)")
    p.add_argument("--variant", metavar="FILE", type=input_file,
                   help="the transducer with a model variant: FILE is 'smeha diagnose --json' "
                        "output or {\"cause\": ..., \"parameters\": {...}}")
    p.add_argument("--bandwidth", nargs="?", const="auto", metavar="HZ,HZ,...",
                   type=_sine_frequencies,
                   help=f"also track sines ({options.SINE_AMPLITUDE.default:g} mm) at these "
                        "frequencies (default: around the predicted bandwidth) and measure "
                        "the closed-loop -3 dB bandwidth")
    p.add_argument(options.LOAD_STEP.flag, type=setting_type(options.LOAD_STEP), nargs="?",
                   const=options.LOAD_STEP.default, metavar="N",
                   help=f"also step the load by N while holding the position: deflection, "
                        f"stiffness, recovery; [N] {options.LOAD_STEP.describe()}")
    _add(p, options.CONTROLLER_RATE)
    p.add_argument("--envelope", action="store_true",
                   help="map the speed-load envelope instead of a step: the largest steady "
                        "piston speed each way against load, the stall loads, beside the "
                        "flow table and the hand calculation from the pump's pressure limit")
    p.add_argument("--backend", choices=("fmu", "direct"), default="fmu",
                   help="the transducer: its FMU through fmpy (default) or gmt in-process")
    p.add_argument("--json", action="store_true", help="print only a JSON object")
    p.add_argument("--plot", metavar="FILE", type=plot_file,
                   help="write the step (command and position, velocity, amplitude, valve "
                        "stage, pressures; the sine and load-step results when run) or the "
                        "envelope (PNG)")
    p.add_argument("--csv", metavar="FILE", type=output_file,
                   help="write the step runs' records (one row a communication point)")
    p.set_defaults(run=_run_position)


def _settings(args, mode):
    from . import position
    from .flowcommands import _read_variant
    if args.target_mm == 0.0:
        raise UsageError("--target-mm 0: a step needs a distance")
    variant = _read_variant(args.variant)[0] if args.variant else None
    try:
        return position.PositionSettings(
            mode=mode, target=args.target_mm * options.TARGET.si, frequency=args.frequency,
            load=args.load, duration=args.duration, circuit=args.circuit or "realistic",
            variant=variant, backend=args.backend,
            load_step=args.load_step if args.load_step is not None else position.LOAD_STEP,
            controller_rate=args.controller_rate)
    except ParameterError as exc:  # in the option's words
        raise UsageError(_in_option_words(str(exc))) from None


def _in_option_words(message: str) -> str:
    """A settings field's message with the command line's option name."""
    for option in options.OPTIONS.values():
        if message.startswith(f"{option.name} = "):
            return f"{option.flag} " + message[len(option.name) + 3:]
    return message


def _sine_frequencies(text):
    """--bandwidth's value: "auto" (the default frequencies) or a list of them, [Hz]."""
    return text if text == "auto" else number_list(0.0, 1000.0, unit="Hz")(text)


_sine_frequencies.numeric = True


def _check_before_work(args, settings, scenarios) -> bool:
    """Every mode's load against the hand calculation (exit 2 before any run), and a note
    when the run is estimated over :data:`LONG_RUN`; True if it said so."""
    from . import position
    # the identification alone first: at a low frequency the hand calculation's free
    # stroke is itself a long run of the transducer
    quick = sum(position.identification_time(s) for s in settings.values())
    if quick > LONG_RUN:
        _say_long(quick, args, settings, scenarios)
    total = 0.0
    for s in settings.values():
        limits = position.check_load(s)
        total += position.estimate_wall_time(s, scenarios, limits)
    if total > LONG_RUN and quick <= LONG_RUN:
        _say_long(total, args, settings, scenarios)
    return total > LONG_RUN


def _say_long(seconds, args, settings, scenarios) -> None:
    warn("position", f"this run is estimated at over {max(seconds / 60.0, 1.0):.0f} min of "
                     f"wall time ({len(settings)} mode(s) at {args.frequency:g} Hz: "
                     "identification, the flow table's point and "
                     f"{', '.join(scenarios)}); Ctrl-C stops it")


def _run_position(args) -> int:
    modes = ("compensated", "uncompensated") if args.mode == "both" else (args.mode,)
    if args.envelope:
        return _run_envelope(args, modes)
    frequencies = None if args.bandwidth in (None, "auto") else args.bandwidth
    settings = {m: _settings(args, m) for m in modes}
    scenarios = ["step"] + (["sine"] if args.bandwidth else []) + (
        ["load"] if args.load_step is not None else [])
    said = [_check_before_work(args, settings, scenarios)]

    def on_design(seconds):  # the step's length known from the design: said once, if long
        if seconds > LONG_RUN and not said[0]:
            said[0] = True
            _say_long(seconds, args, settings, scenarios)
    from . import flow, position
    fmu = flow.ensure_fmu(quiet=args.json, say=say) if args.backend == "fmu" else None
    out = {}
    for mode in modes:
        if not args.json:
            print(f"{mode}: identifying, designing, running {', '.join(scenarios)} ...",
                  file=sys.stderr, flush=True)
        study = position.run_study(settings[mode], scenarios, frequencies, fmu, on_design)
        study["flow_velocity_m_s"] = position.flow_table_velocity(settings[mode], fmu)
        out[mode] = study
    first = next(iter(settings.values()))
    if args.plot:
        from .positionplots import plot_study
        plot_study(args.plot, out, first)
    if args.csv:
        _write_csv(args.csv, out)
    if args.json:
        json.dump(_json(out), sys.stdout, indent=2, allow_nan=False)
        sys.stdout.write("\n")
        return 0
    from .positionreport import format_report
    print(format_report(out, first))
    for path in (args.plot, args.csv):
        if path:
            print(f"wrote {path}")
    return 0


def _run_envelope(args, modes) -> int:
    """--envelope: each mode and circuit (every circuit unless --circuit names one)."""
    for given, name in ((args.csv, "--csv"), (args.bandwidth, "--bandwidth"),
                        (args.load_step is not None, "--load-step"),
                        (args.load is not None, "--load"), (args.duration, "--duration"),
                        (args.controller_rate, "--controller-rate"),
                        (args.variant, "--variant")):
        if given:
            raise UsageError(f"{name} belongs to the step; --envelope runs no step (its "
                             "loads span the pump's stall loads)")
    from . import flow
    from .positionenvelope import estimate_wall_time, format_envelope, run_envelope
    circuits = (args.circuit,) if args.circuit else CIRCUITS
    seconds = estimate_wall_time(args.frequency, len(circuits) * len(modes))
    if seconds > LONG_RUN:
        warn("position", f"this envelope is estimated at about {seconds / 60.0:.0f} min of "
                         f"wall time ({len(circuits) * len(modes)} curves at "
                         f"{args.frequency:g} Hz); Ctrl-C stops it")
    fmu = flow.ensure_fmu(quiet=args.json, say=say) if args.backend == "fmu" else None
    curves = []
    for circuit in circuits:
        for mode in modes:
            if not args.json:
                print(f"{circuit}, {mode}: full drive each way at each load ...",
                      file=sys.stderr, flush=True)
            curves.append(run_envelope(mode, circuit, args.frequency, args.backend, fmu))
    if args.plot:
        from .positionplots import plot_envelope
        plot_envelope(args.plot, curves)
    if args.json:
        json.dump(_clean({"envelope": [c.as_dict() for c in curves]}), sys.stdout, indent=2,
                  allow_nan=False)
        sys.stdout.write("\n")
        return 0
    print(format_envelope(curves))
    if args.plot:
        print(f"wrote {args.plot}")
    return 0


def _clean(obj):
    """NaN and infinities as null (JSON has neither)."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_clean(v) for v in obj]
    return obj


def _json(out) -> dict:
    """One mode: the step's figures at the top, the rest beside them; both: one per mode."""
    def entry(mode, study):
        d = {"mode": mode, "model": study["model"].as_dict(),
             "design": study["design"].as_dict(), "limits": study["limits"].as_dict(),
             "flow_velocity_m_s": study["flow_velocity_m_s"]}
        for res in study["results"]:
            fig = res.as_dict()
            if res.scenario == "step":
                d.update({k: v for k, v in fig.items() if k != "scenario"})
            elif res.scenario == "sine":
                d.update(bandwidth_Hz=fig["bandwidth_Hz"],
                         predicted_bandwidth_Hz=fig["predicted_bandwidth_Hz"], sine=fig)
            else:
                d["load_step"] = fig
        return d
    entries = {m: entry(m, s) for m, s in out.items()}
    return _clean(next(iter(entries.values())) if len(entries) == 1 else entries)


def _write_csv(path, out) -> None:
    from .positionloop import TIME_TOLERANCE
    from .positionplots import stages
    fields = ("mode", "time_s", "command_m", "piston_position_m", "piston_velocity_m_s",
              "amplitude", "direction", "stage", "p_pump_Pa", "p_big_Pa", "p_small_Pa",
              "rod_displacement_m", "current_A", "load_N")
    with replacing(path) as tmp, open(tmp, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(fields)
        for mode, study in out.items():
            rec = study["results"][0].record
            rows, per = rec.rows, rec.periods
            k = (rows["time"][:, None] >= per["time"][None, :] - TIME_TOLERANCE).sum(axis=1) - 1
            command = per["command"][k]
            for i, r in enumerate(rows):
                w.writerow([mode, f"{r['time']:.7g}", f"{command[i]:.9g}",
                            f"{r['piston_position']:.9g}", f"{r['piston_velocity']:.6g}",
                            f"{r['amplitude']:.6g}", "down" if r["direction"] > 0 else "up",
                            int(stages(rows[i:i + 1])[0]), f"{r['p_pump']:.6g}",
                            f"{r['p_big']:.6g}", f"{r['p_small']:.6g}",
                            f"{r['rod_displacement']:.9g}", f"{r['current']:.6g}",
                            f"{r['load']:.6g}"])
