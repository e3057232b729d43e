"""Real-time factor of the EHA co-simulation at the step that keeps the flow within 0.5 %.

1. A converged reference: the mean cylinder flow at a 2.5 us communication
   step with 1.25 us hydraulic substeps (gmt coupled directly; the FMU gives
   the same numbers bit for bit, ``tests/test_fmu_cosim.py``). Halving both
   again moves it by ~0.05 %: the phase of the piston's ringing at the valve
   switches.
2. The flow at each candidate step and its difference from the reference;
   the largest step within ``--tolerance`` (0.5 %) is the benchmark's step.
3. Wall time of ``--duration`` simulated seconds at that step, through the FMU
   with fmpy and with gmt coupled directly in one process, ``--repeats`` times
   each (median): the real-time factor (simulated s per wall s), the FMI
   overhead (FMU / direct) and the cost per communication step.

The valve controller samples at 10 us and the hydraulics take substeps of at
most 10 us whatever the communication step (``CosimSettings.controller_period``
and ``hydraulic_step``), so the step only sets how often the transducer and
the circuit exchange force and motion -- and, compensated, how often the
compensator samples u: its rate terms are backward differences of those
samples (Figure 9), a first-order error in h of the compensator itself.

Usage: python benchmarks/cosim_realtime.py [--frequency 100] [--mode compensated]
       [--branch-rule demand] [--steps 10e-6,20e-6,...] [--duration 1] [--repeats 3] [--json]
"""
from __future__ import annotations

import argparse
import json
import resource
import statistics
import time

import gmt
from smeha import flowstudy
from system_models import presets
from system_models.cosim import CosimSettings, DirectTransducer, FmuTransducer, cosimulate
from system_models.flowcheck import flow_check

CONTROLLER_PERIOD = 10e-6
HYDRAULIC_STEP = 10e-6


def run(args, step, duration, backend, fmu=None, hydraulic_step=None):
    """(flow [m^3/s] or None, wall [s], communication steps) of one co-simulation."""
    compensated = args.mode == "compensated"
    control, _ = flowstudy.control_signal(args.mode, args.frequency)
    if backend == "fmu":
        trans = FmuTransducer(fmu, {"frequency": args.frequency, "current_amplitude": 1.0,
                                    "compensated": compensated,
                                    "branch_rule": args.branch_rule})
    else:
        trans = DirectTransducer(gmt.TransducerParameters(), gmt.Excitation(args.frequency, 1.0),
                                 gmt.DriveParameters(compensated=compensated,
                                                     branch_rule=args.branch_rule))
    settings = CosimSettings(duration=duration, step=step, load_force=presets.REALISTIC_LOAD,
                             controller_period=CONTROLLER_PERIOD,
                             hydraulic_step=hydraulic_step or HYDRAULIC_STEP)
    wall = time.perf_counter()
    try:
        rec = cosimulate(trans, control, presets.realistic_circuit(), settings)
    finally:
        trans.close()
    wall = time.perf_counter() - wall
    try:
        q = flow_check(rec, args.frequency, presets.realistic_circuit().chamber.piston_area).flow_sim
    except ValueError:
        q = None
    return q, wall, len(rec) - 1


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frequency", type=float, default=100.0)
    ap.add_argument("--mode", choices=flowstudy.MODES, default="compensated")
    ap.add_argument("--branch-rule", choices=("control", "demand"), default="demand")
    ap.add_argument("--reference-step", type=float, default=2.5e-6,
                    help="communication step of the reference [s]; its hydraulic substeps "
                         "are half of it")
    ap.add_argument("--steps", default="10e-6,20e-6,25e-6,40e-6,50e-6,80e-6,100e-6,160e-6")
    ap.add_argument("--cycles", type=float, default=6.0, help="cycles of the accuracy runs")
    ap.add_argument("--tolerance", type=float, default=0.005)
    ap.add_argument("--duration", type=float, default=1.0, help="simulated s of the timed runs")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    say = (lambda *a: None) if args.json else (lambda *a: print(*a, flush=True))
    accuracy_time = args.cycles / args.frequency
    q_ref, _, _ = run(args, args.reference_step, accuracy_time, "direct",
                      hydraulic_step=args.reference_step / 2)
    say(f"{args.mode} ({args.branch_rule} rule) {args.frequency:g} Hz, realistic circuit: "
        f"reference flow {q_ref:.6e} m^3/s at h = {args.reference_step * 1e6:g} us")
    table = []
    for h in (float(s) for s in args.steps.split(",")):
        q, _, _ = run(args, h, accuracy_time, "direct")
        err = None if q is None else (q - q_ref) / q_ref
        table.append({"step_s": h, "flow_m3_s": q, "relative_error": err})
        say(f"  h = {h * 1e6:6.1f} us  q = {q:.6e}  error {100 * err:+.3f} %")
    within = [r["step_s"] for r in table
              if r["relative_error"] is not None and abs(r["relative_error"]) <= args.tolerance]
    # the largest step such that it and every smaller candidate are within tolerance
    chosen = None
    for r in table:
        if r["relative_error"] is None or abs(r["relative_error"]) > args.tolerance:
            break
        chosen = r["step_s"]
    if chosen is None:
        chosen = min(within) if within else args.reference_step
    say(f"step within {100 * args.tolerance:g} %: {chosen * 1e6:g} us")
    fmu = flowstudy.ensure_fmu(quiet=True)
    walls = {"fmu": [], "direct": []}
    steps_taken = {}
    for _ in range(args.repeats):
        for backend in ("fmu", "direct"):
            _, wall, n = run(args, chosen, args.duration, backend, fmu)
            walls[backend].append(wall)
            steps_taken[backend] = n
    med = {k: statistics.median(v) for k, v in walls.items()}
    result = {
        "case": {"frequency_Hz": args.frequency, "mode": args.mode,
                 "branch_rule": args.branch_rule, "circuit": "realistic",
                 "load_N": presets.REALISTIC_LOAD, "controller_period_s": CONTROLLER_PERIOD,
                 "hydraulic_step_s": HYDRAULIC_STEP},
        "reference": {"step_s": args.reference_step,
                      "hydraulic_step_s": args.reference_step / 2, "flow_m3_s": q_ref},
        "accuracy": table, "tolerance": args.tolerance, "chosen_step_s": chosen,
        "simulated_s": args.duration, "wall_s": walls, "median_wall_s": med,
        "real_time_factor": {k: args.duration / v for k, v in med.items()},
        "fmi_overhead_ratio": med["fmu"] / med["direct"],
        "us_per_step": {k: med[k] / steps_taken[k] * 1e6 for k in med},
        "peak_rss_MB": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
    }
    if args.json:
        print(json.dumps(result))
        return
    for k in ("fmu", "direct"):
        print(f"  {k:<6} {args.duration:g} s simulated in {med[k]:.2f} s (median of "
              f"{args.repeats}): real-time factor {result['real_time_factor'][k]:.3f}, "
              f"{result['us_per_step'][k]:.1f} us per communication step")
    print(f"  FMI overhead (fmu / direct, same process): {result['fmi_overhead_ratio']:.3f}")
    print(f"  peak RSS: {result['peak_rss_MB']:.0f} MB")


if __name__ == "__main__":
    main()
