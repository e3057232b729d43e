"""The terminal report of ``smeha position``: the identified lines, the design, one table of
the step measured beside python-control's prediction, the sine and load-step results, and
the notes (each kind once per drive mode)."""
from __future__ import annotations

import math

__all__ = ["format_report", "merged_flags", "VELOCITY_TOLERANCE"]

#: The largest departure of the step's top speed from the flow table's, as a fraction:
#: the position study reproduces the flow study's pumping within this.
VELOCITY_TOLERANCE = 0.15


def _pct(x):
    return "-" if x is None or not math.isfinite(x) else f"{100 * x:.1f} %"


def _num(x, fmt, missing="-"):
    return missing if x is None or not math.isfinite(x) else format(x, fmt)


def merged_flags(results) -> list:
    """The flags of a mode's scenarios, each kind (the words before its first colon) once:
    the first scenario's text, naming the other scenarios that raised it too."""
    kinds, order = {}, []
    for res in results:
        for flag in res.flags:
            kind = flag.split(":")[0]
            if kind not in kinds:
                kinds[kind] = [res.scenario, flag, []]
                order.append(kind)
            elif res.scenario != kinds[kind][0] and res.scenario not in kinds[kind][2]:
                kinds[kind][2].append(res.scenario)
    out = []
    for kind in order:
        scenario, flag, also = kinds[kind]
        more = f" (also in the {', '.join(also)} run{'s' if len(also) > 1 else ''})" if also \
            else ""
        out.append(f"{scenario}: {flag}{more}")
    return out


def _design_lines(mode, study, settings) -> list:
    m, d = study["model"], study["design"]
    settle = _num(d.predicted_settling_time_s, ".3f", "not within the prediction")
    return [
        f"{mode}: identified v = v0 + g a (a: amplitude / limit, period means): "
        f"down v0 {m.v0_down * 1e3:+.2f} mm/s, g {m.g_down * 1e3:.2f} mm/s; up v0 "
        f"{m.v0_up * 1e3:+.2f} mm/s, g {m.g_up * 1e3:.2f} mm/s; droop dv/dF "
        f"{m.droop_down * 1e6:.1f} (down) / {m.droop_up * 1e6:.1f} (up) um/s per N",
        f"  design (python-control): K_p {d.kp:.1f} 1/s, K_i {d.ki:.1f} 1/s^2 (T = "
        f"{d.period * 1e3:g} ms); phase margin {d.phase_margin_deg:.0f} deg, gain margin "
        f"{d.gain_margin:.2f}, crossover {d.crossover_Hz:.2f} Hz, closed-loop bandwidth "
        f"{d.bandwidth_Hz:.2f} Hz; step {settings.target * 1e3:g} mm with the velocity "
        f"limits: rise {_num(d.predicted_rise_time_s, '.3f')} s, settling {settle} s, "
        f"overshoot {_pct(d.predicted_overshoot)}"]


_HEAD = (f"{'mode':<13}  {'rise [s]':>8}  {'(pred)':>7}  {'overshoot':>9}  {'settle [s]':>12}"
         f"  {'(pred)':>7}  {'final err [um]':>14}  {'v max [mm/s]':>12}  "
         f"{'flow/A_B':>8}  {'wall [s]':>8}  {'CPU [s]':>7}  {'sim [s]':>7}  "
         f"{'x real time (CPU)':>17}")


def _step_row(mode, study) -> str:
    step = study["results"][0].figures
    qa = study["flow_velocity_m_s"]
    settle = _num(step["settling_time_s"], ".3f", "not settled")
    return (f"{mode:<13}  {_num(step['rise_time_s'], '.3f', 'not reached'):>8}  "
            f"{_num(step['predicted_rise_time_s'], '.3f'):>7}  "
            f"{_pct(step['overshoot_fraction']):>9}  {settle:>12}  "
            f"{_num(step['predicted_settling_time_s'], '.3f'):>7}  "
            f"{step['final_error_m'] * 1e6:>14.1f}  {step['max_velocity_m_s'] * 1e3:>12.2f}  "
            f"{qa * 1e3:>8.2f}  {step['wall_s']:>8.2f}  {step['cpu_s']:>7.2f}  "
            f"{step['simulated_s']:>7.2f}  {step['simulated_s'] / step['wall_s']:>8.2f} "
            f"({step['simulated_s'] / step['cpu_s']:.2f})")


def _sine_lines(mode, f) -> list:
    lines = ["", f"{mode}: sine tracking, {f['sine_amplitude_m'] * 1e3:g} mm (gain and phase of "
             "the position's fundamental against the command)"]
    lines += [f"  {r['frequency_Hz']:>7.2f} Hz  gain {r['gain']:.3f} "
              f"({20 * math.log10(r['gain']):+.1f} dB)  phase {r['phase_deg']:+.0f} deg"
              for r in f["tracking"]]
    bw = _num(f["bandwidth_Hz"], ".2f", "above the frequencies run")
    lines.append(f"  -3 dB bandwidth {bw} Hz (predicted {f['predicted_bandwidth_Hz']:.2f} Hz)")
    return lines


def _load_lines(mode, f) -> list:
    back = (f"back within a tenth of it after {f['recovery_time_s']:.3f} s"
            if math.isfinite(f["recovery_time_s"]) else "not back within a tenth of it in the run")
    return ["", f"{mode}: load step {f['load_step_N']:+g} N while holding: peak deflection "
            f"{f['peak_deflection_m'] * 1e6:+.1f} um (droop alone, predicted: "
            f"{f['predicted_peak_deflection_m'] * 1e6:+.1f} um; the oil and the rod's "
            f"compliance add to it), stiffness {f['stiffness_N_per_m'] / 1e6:.2f} N/um, "
            f"{back}, error at the end {f['final_error_m'] * 1e6:.1f} um"]


def format_report(out: dict, settings) -> str:
    """The report of ``smeha position`` (``out``: mode -> :func:`run_study`'s result with
    ``flow_velocity_m_s``; ``settings``: one mode's
    :class:`~smeha.studies.position.PositionSettings`)."""
    lines = [f"Position control through the transducer FMU (the paper's magnetics, sinusoidal "
             f"drive): {settings.frequency:g} Hz pump, {settings.circuit} circuit, "
             f"{settings.load_force:g} N load (opposing down)"]
    for mode, study in out.items():
        lines += _design_lines(mode, study, settings)
    lines += ["", f"Position step {settings.target * 1e3:g} mm (v max: the fastest period mean; "
              "flow/A_B: smeha flow's flow at this point over the big cavity's area; real "
              "time: simulated over wall time, and over the process's CPU time, the FMU "
              "running in-process)", _HEAD]
    notes = []
    for mode, study in out.items():
        lines.append(_step_row(mode, study))
        step, qa = study["results"][0].figures, study["flow_velocity_m_s"]
        if abs(step["max_velocity_m_s"] / abs(qa) - 1.0) > VELOCITY_TOLERANCE:
            notes.append(f"{mode}: the top speed departs from the flow table's by more than "
                         f"{100 * VELOCITY_TOLERANCE:g} %")
        notes += [f"{mode} {f}" for f in merged_flags(study["results"])]
    if len(out) == 2:
        rise = {m: s["results"][0].figures["rise_time_s"] for m, s in out.items()}
        if all(math.isfinite(r) for r in rise.values()):
            lines.append(f"compensation: the step rises "
                         f"{rise['uncompensated'] / rise['compensated']:.2f}x faster "
                         "compensated")
    for mode, study in out.items():
        for res in study["results"][1:]:
            lines += (_sine_lines if res.scenario == "sine" else _load_lines)(mode, res.figures)
    if notes:
        lines += ["", "(!) " + "\n(!) ".join(notes)]
    return "\n".join(lines)
