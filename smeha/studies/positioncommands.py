"""``smeha position``: the cylinder's position in closed loop (:mod:`smeha.studies.position`).

Registered by :mod:`smeha.cli`; nothing heavy is imported before the command runs.
"""
from __future__ import annotations

import csv
import json
import math
import sys

from ..cliargs import UsageError, input_file, number, number_list, output_file
from system_models.defaults import REALISTIC_LOAD

from .flowcommands import CIRCUITS, FREQUENCY

__all__ = ["add_position"]

#: --mode's choices: each drive mode, or both (the default).
MODES = ("compensated", "uncompensated", "both")
#: The study's defaults (plain numbers, read by --help and by smeha.studies.position):
#: the step's distance [mm], the pump frequency [Hz], the load step [N].
TARGET_MM = 5.0
FREQUENCY_HZ = 100.0
LOAD_STEP_N = 50.0
TARGET_LIMIT_MM = 20.0
DURATION_LIMIT = 60.0


def add_position(subparsers):
    p = subparsers.add_parser(
        "position", help="the cylinder's position in closed loop through the FMU",
        description="A position controller, designed with python-control on a linear model "
                    "identified from open-loop co-simulations (an integrator with a "
                    "velocity line per direction and the load's droop), sets the cylinder's "
                    "direction and the drive amplitude once a pump period. It runs a "
                    "position step (and with --bandwidth sine tracking, with --load-step a "
                    "load step) through the transducer FMU and the hydraulic circuit, and "
                    "prints the measured figures next to python-control's predictions.")
    p.add_argument("--mode", choices=MODES, default="both",
                   help="drive mode: compensated (Figure 9), uncompensated, or both "
                        "(default)")
    p.add_argument("--target-mm", type=number(-TARGET_LIMIT_MM, TARGET_LIMIT_MM, unit="mm"),
                   default=TARGET_MM, metavar="MM",
                   help=f"the step, [mm] in [-{TARGET_LIMIT_MM:g}, {TARGET_LIMIT_MM:g}], not 0; "
                        f"> 0 moves down (oil into the big cavity) (default {TARGET_MM:g})")
    p.add_argument("--frequency", type=FREQUENCY, default=FREQUENCY_HZ, metavar="HZ",
                   help=f"pump frequency [Hz], in (0, 1000] (default {FREQUENCY_HZ:g})")
    p.add_argument("--load", type=number(-1e4, 1e4, unit="N"), metavar="N",
                   help="load on the cylinder, opposing down, [N] in (-1e4, 1e4) (default: "
                        f"the circuit's, {REALISTIC_LOAD:g} N realistic, 0 otherwise)")
    p.add_argument("--duration", type=number(0.0, DURATION_LIMIT, high_open=False, unit="s"),
                   metavar="S",
                   help=f"simulated time of the step [s], in (0, {DURATION_LIMIT:g}] (default: "
                        "twice the predicted settling time, at least 0.3 s)")
    p.add_argument("--circuit", choices=CIRCUITS, default="realistic",
                   help="the hydraulic circuit (default realistic)")
    p.add_argument("--variant", metavar="FILE", type=input_file,
                   help="the transducer with a model variant: FILE is 'smeha diagnose --json' "
                        "output or {\"cause\": ..., \"parameters\": {...}}")
    p.add_argument("--bandwidth", nargs="?", const="auto", metavar="HZ,HZ,...",
                   type=_sine_frequencies,
                   help="also track sines (0.1 mm) at these frequencies (default: around the "
                        "predicted bandwidth) and measure the closed-loop -3 dB bandwidth")
    p.add_argument("--load-step", type=number(-1e4, 1e4, unit="N"), nargs="?",
                   const=LOAD_STEP_N, metavar="N",
                   help=f"also step the load by N (default {LOAD_STEP_N:g}) while holding "
                        "the position: deflection, stiffness, recovery")
    p.add_argument("--controller-rate", type=number(0.0, 1000.0, unit="Hz"), metavar="HZ",
                   help="the position controller's sample rate [Hz]: the pump frequency over "
                        "a whole number N (default: the pump frequency, a decision a period). "
                        "The drive changes at a pump period's start, so a decision holds N "
                        "periods; the design's sample-and-hold is N/f")
    p.add_argument("--backend", choices=("fmu", "direct"), default="fmu",
                   help="the transducer: its FMU through fmpy (default) or gmt in-process")
    p.add_argument("--json", action="store_true", help="print only a JSON object")
    p.add_argument("--plot", metavar="FILE", type=output_file,
                   help="write the step: command and position, velocity, amplitude, valve "
                        "stage, pressures (PNG)")
    p.add_argument("--csv", metavar="FILE", type=output_file,
                   help="write the step runs' records (one row a communication point)")
    p.set_defaults(run=_run_position)


def _settings(args, mode):
    from . import position
    from .flowcommands import _read_variant
    if args.target_mm == 0.0:
        raise UsageError("--target-mm 0: a step needs a distance")
    variant = _read_variant(args.variant)[0] if args.variant else None
    return position.PositionSettings(
        mode=mode, target=args.target_mm * 1e-3, frequency=args.frequency, load=args.load,
        duration=args.duration, circuit=args.circuit, variant=variant, backend=args.backend,
        load_step=args.load_step if args.load_step is not None else position.LOAD_STEP,
        controller_rate=args.controller_rate)


def _sine_frequencies(text):
    """--bandwidth's value: "auto" (the default frequencies) or a list of them, [Hz]."""
    return text if text == "auto" else number_list(0.0, 1000.0, unit="Hz")(text)


_sine_frequencies.numeric = True


def _run_position(args) -> int:
    modes = ("compensated", "uncompensated") if args.mode == "both" else (args.mode,)
    frequencies = None if args.bandwidth in (None, "auto") else args.bandwidth
    settings = {m: _settings(args, m) for m in modes}
    from . import flow, position
    fmu = flow.ensure_fmu(quiet=args.json) if args.backend == "fmu" else None
    scenarios = ["step"] + (["sine"] if args.bandwidth else []) + (
        ["load"] if args.load_step is not None else [])
    out = {}
    for mode in modes:
        if not args.json:
            print(f"{mode}: identifying, designing, running {', '.join(scenarios)} ...",
                  file=sys.stderr, flush=True)
        study = position.run_study(settings[mode], scenarios, frequencies, fmu)
        study["flow_velocity_m_s"] = position.flow_table_velocity(settings[mode], fmu)
        out[mode] = study
    if args.plot:
        from .positionplots import plot_steps
        plot_steps(args.plot, [s["results"][0] for s in out.values()],
                   next(iter(settings.values())))
    if args.csv:
        _write_csv(args.csv, out)
    if args.json:
        json.dump(_json(out), sys.stdout, indent=2, allow_nan=False)
        sys.stdout.write("\n")
        return 0
    print(position.format_report(out, next(iter(settings.values()))))
    for path in (args.plot, args.csv):
        if path:
            print(f"wrote {path}")
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
             "design": study["design"].as_dict(),
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
    from .positionplots import stages
    fields = ("mode", "time_s", "command_m", "piston_position_m", "piston_velocity_m_s",
              "amplitude", "direction", "stage", "p_pump_Pa", "p_big_Pa", "p_small_Pa",
              "rod_displacement_m", "current_A", "load_N")
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(fields)
        for mode, study in out.items():
            rec = study["results"][0].record
            rows, per = rec.rows, rec.periods
            k = (rows["time"][:, None] >= per["time"][None, :] - 1e-12).sum(axis=1) - 1
            command = per["command"][k]
            for i, r in enumerate(rows):
                w.writerow([mode, f"{r['time']:.7g}", f"{command[i]:.9g}",
                            f"{r['piston_position']:.9g}", f"{r['piston_velocity']:.6g}",
                            f"{r['amplitude']:.6g}", "down" if r["direction"] > 0 else "up",
                            int(stages(rows[i:i + 1])[0]), f"{r['p_pump']:.6g}",
                            f"{r['p_big']:.6g}", f"{r['p_small']:.6g}",
                            f"{r['rod_displacement']:.9g}", f"{r['current']:.6g}",
                            f"{r['load']:.6g}"])
