"""The time-domain magnetics' studies: where the two models part, the drive
waveforms, and the compensation re-judged.

* :func:`compare_rows` -- both models under a sinusoidal current at Table 1's points
  (the flow table's 50-100 Hz at 1 A are among them): B_m, mu', mu'', lag, loss per
  cycle and the free rod's strokes, beside Table 1's measured B_m
  (:func:`gmt.timedomain.steady.compare_with_paper`).
* :func:`waveform_rows` -- which drive waveform pumps the most flow, 50-200 Hz, at equal
  peak and at equal RMS coil current, with and without the inverse, on the time-domain
  magnetics (the only model a square or trapezoid is inside).
* :func:`gain_rows` -- the compensation gain (compensated over uncompensated flow) of the
  paper's model, of the time-domain model behind the paper's inverse and behind its own,
  against the paper's measured 1.14-1.32 (Table 3 through eqs 40/41).
"""
from __future__ import annotations

import math

import numpy as np

import gmt

from . import flow, waveforms

__all__ = ["compare_rows", "format_compare", "drive_amplitude", "waveform_rows",
           "format_waveforms", "gain_rows", "format_gains", "measured_gain", "waveform_cases"]

#: The study's reference coil current: the paper's sinusoid of 1 A peak (RMS 0.707 A).
PEAK_CURRENT = 1.0
RMS_CURRENT = PEAK_CURRENT / math.sqrt(2.0)


# -- where the two models part ----------------------------------------------------------------
def compare_rows(points=None, samples: int = 2000) -> list[dict]:
    """Both models at each (f, I_m) (default: Table 1's six points), one dict a point."""
    from gmt.timedomain.steady import compare_with_paper

    points = points or [(f, i) for f, i, _, _ in gmt.TABLE_1]
    rows = []
    for f, i in points:
        c = compare_with_paper(frequency=f, current_amplitude=i, samples=samples)
        rows.append({"frequency_Hz": f, "current_amplitude_A": i,
                     "measured_flux_density_T": c.measured_flux_density,
                     "paper": c.paper, "time_domain": c.time_domain,
                     "difference": c.differences()})
    return rows


def format_compare(rows) -> str:
    """The side-by-side table (SI, the lag in degrees, strokes in um)."""
    head = (f"{'f':>4} {'I_m':>4} | {'B_m meas':>8} | {'B_m':>13} {'mu_re':>11} "
            f"{'mu_im':>11} {'lag [deg]':>11} {'loss [J/m3]':>13} {'dy [um]':>11} | "
            f"{'dB_m':>6} {'dloss':>6} {'dlag':>5} {'ddy':>6}")
    lines = ["Both models under i = I_m cos(w t): paper / time-domain (differences: "
             "time-domain against paper)", head]
    for r in rows:
        p, t, d = r["paper"], r["time_domain"], r["difference"]
        meas = r["measured_flux_density_T"]
        lines.append(
            f"{r['frequency_Hz']:>4g} {r['current_amplitude_A']:>4g} | "
            f"{'-' if meas is None else f'{meas:.4f}':>8} | "
            f"{p['flux_density_amplitude']:.4f}/{t['flux_density_amplitude']:.4f} "
            f"{p['mu_real']:5.2f}/{t['mu_real']:5.2f} {p['mu_imag']:5.2f}/{t['mu_imag']:5.2f} "
            f"{math.degrees(p['lag']):5.1f}/{math.degrees(t['lag']):5.1f} "
            f"{p['loss_per_cycle']:6.0f}/{t['loss_per_cycle']:6.0f} "
            f"{p['dy'] * 1e6:5.1f}/{t['dy'] * 1e6:5.1f} | "
            f"{100 * d['flux_density_amplitude']:+5.1f}% {100 * d['loss_per_cycle']:+5.1f}% "
            f"{d['lag']:+5.1f} {100 * d['dy']:+5.1f}%")
    return "\n".join(lines)


# -- the waveform study -------------------------------------------------------------------------
def _free_current(frequency, mode, waveform, amplitude, magnetics="time_domain", inverse=None,
                  cycles=4, per_cycle=200):
    """The free transducer's coil current over its last two cycles [A], and how many
    compensator samples saturated there (the start, from rest, is not counted)."""
    drive = gmt.DriveParameters(compensated=mode == "compensated")
    unit = gmt.Transducer(gmt.TransducerParameters(),
                          gmt.Excitation(frequency, flow.CURRENT_AMPLITUDE), drive,
                          magnetics=magnetics, inverse=inverse)
    control, _ = flow.control_signal(mode, frequency, amplitude, waveform)
    period = unit.sample_period
    h = 1.0 / (frequency * per_cycle)
    if period > 0.0:
        h = period / math.ceil(period / h - 1e-9)
    n = int(math.ceil(cycles / (frequency * h)))
    last = n - int(round(2 / (frequency * h)))  # the last two cycles
    current = np.empty(n)
    for k in range(n):
        if k == last:
            before = unit.saturation_count
        current[k] = unit.step(control(k * h), h).current
    return current[last:], unit.saturation_count - before


def drive_amplitude(frequency, mode, waveform, basis, magnetics="time_domain",
                    inverse=None) -> float:
    """The control amplitude a [V] whose coil current has the reference peak or RMS.

    Uncompensated the current is K_a u: a = 1 A / K_a for equal peak, and
    0.707 A / (K_a RMS of the shape) for equal RMS (coil heating). Compensated
    the current is what the inverse asks for the demanded stroke: a is found by
    bisection on the free transducer (its current does not depend on the load).
    """
    if basis not in ("peak", "rms"):
        raise gmt.ParameterError(f"basis = {basis!r} is not one of ('peak', 'rms')")
    gain = gmt.DriveParameters().amplifier_gain
    if mode == "uncompensated":
        target = PEAK_CURRENT if basis == "peak" else RMS_CURRENT / waveforms.rms_factor(waveform)
        return target / gain
    target = PEAK_CURRENT if basis == "peak" else RMS_CURRENT

    def measure(a):
        i, _ = _free_current(frequency, mode, waveform, a, magnetics, inverse)
        return float(np.max(np.abs(i))) if basis == "peak" else float(np.sqrt(np.mean(i * i)))

    lo, hi = 0.0, 4.0
    while measure(hi) < target and hi < 100.0:
        hi *= 2.0
    for _ in range(24):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if measure(mid) < target else (lo, mid)
    return 0.5 * (lo + hi)


def waveform_cases(frequencies=(50.0, 100.0, 150.0, 200.0), bases=("peak", "rms"),
                   backend="direct", magnetics="time_domain") -> list:
    """(basis, amplitude, Case) of the waveform study, realistic circuit."""
    out = []
    for basis in bases:
        for f in frequencies:
            for mode in flow.MODES:
                for w in waveforms.WAVEFORMS:
                    a = drive_amplitude(f, mode, w, basis, magnetics)
                    out.append((basis, a, flow.Case(frequency=f, mode=mode, waveform=w,
                                                    amplitude=a, magnetics=magnetics,
                                                    backend=backend)))
    return out


def waveform_rows(frequencies=(50.0, 100.0, 150.0, 200.0), bases=("peak", "rms"),
                  backend="direct", workers=1, quiet=True) -> list[dict]:
    """The waveform study's co-simulations: one row a (basis, f, mode, waveform)."""
    cases = waveform_cases(frequencies, bases, backend)
    flows = flow.run_cases([c for _, _, c in cases], workers=workers, quiet=quiet)
    rows = []
    for (basis, a, case), row in zip(cases, flows):
        current, saturated = _free_current(case.frequency, case.mode, case.waveform, a)
        rows.append(dict(row, basis=basis, control_amplitude_V=a,
                         current_peak_A=float(np.max(np.abs(current))),
                         current_rms_A=float(np.sqrt(np.mean(current * current))),
                         saturated_samples=saturated))
    return rows


def format_waveforms(rows) -> str:
    """Flow [L/min] by waveform, per basis, frequency and mode; the best marked."""
    lines = ["Cylinder flow [L/min] by drive waveform (time-domain magnetics, realistic "
             "circuit, 150 N); equal peak: 1 A, equal RMS: 0.707 A of coil current"]
    shapes = waveforms.WAVEFORMS
    lines.append(f"{'basis':<5} {'f [Hz]':>6}  {'mode':<13}  "
                 + "  ".join(f"{w:>16}" for w in shapes) + "  best")
    keys = sorted({(r["basis"], r["frequency_Hz"], r["mode"]) for r in rows},
                  key=lambda k: (k[0] != "peak", k[1], k[2] != "uncompensated"))
    for basis, f, mode in keys:
        by = {r["waveform"]: r for r in rows
              if (r["basis"], r["frequency_Hz"], r["mode"]) == (basis, f, mode)}
        cells = [f"{by[w]['flow_sim_L_min']:7.4f} ({by[w]['current_peak_A']:.2f} A)"
                 for w in shapes]
        best = max(shapes, key=lambda w: by[w]["flow_sim_m3_s"])
        lines.append(f"{basis:<5} {f:>6g}  {mode:<13}  " + "  ".join(f"{c:>16}" for c in cells)
                     + f"  {best}")
    lines.append("(in brackets: the coil current's peak)")
    return "\n".join(lines)


# -- the compensation gain re-judged --------------------------------------------------------
def measured_gain(frequency: float) -> float | None:
    """Paper, Table 3 through eqs 40/41: (y(u_m) - y(u=0)) / (y(i=1) - y(i=-1))."""
    comp = flow.paper_dy(frequency, "compensated")
    unc = flow.paper_dy(frequency, "uncompensated")
    return None if comp is None or unc is None else comp / unc


#: The models of the gain table: (label, magnetics, the compensator's inverse).
GAIN_MODELS = (("paper model, paper inverse", "paper", "paper"),
               ("time-domain model, paper inverse", "time_domain", "paper"),
               ("time-domain model, time-domain inverse", "time_domain", "time_domain"))


def gain_rows(frequencies=(50.0, 70.0, 80.0, 100.0), backend="direct", workers=1,
              quiet=True) -> list[dict]:
    """Compensation gains, free transducer (eqs 40/41) and realistic circuit, per model."""
    cases, keys = [], []
    for label, magnetics, inverse in GAIN_MODELS:
        for f in frequencies:
            for mode in flow.MODES:
                cases.append(flow.Case(frequency=f, mode=mode, magnetics=magnetics,
                                       inverse=inverse if mode == "compensated" else None,
                                       backend=backend))
                keys.append((label, f, mode))
    flows = dict(zip(keys, flow.run_cases(cases, workers=workers, quiet=quiet)))
    rows = []
    for label, _, _ in GAIN_MODELS:
        for f in frequencies:
            unc, comp = flows[(label, f, "uncompensated")], flows[(label, f, "compensated")]
            rows.append({"model": label, "frequency_Hz": f, "measured_gain": measured_gain(f),
                         "free_gain": comp["dy_free_um"] / unc["dy_free_um"],
                         "flow_gain": comp["flow_sim_m3_s"] / unc["flow_sim_m3_s"],
                         "dy_free_uncompensated_um": unc["dy_free_um"],
                         "dy_free_compensated_um": comp["dy_free_um"],
                         "flow_uncompensated_m3_s": unc["flow_sim_m3_s"],
                         "flow_compensated_m3_s": comp["flow_sim_m3_s"]})
    return rows


def format_gains(rows) -> str:
    """The gain table: free transducer (Figure 12's basis) and realistic circuit."""
    lines = ["Compensation gain, compensated / uncompensated: the free transducer's dy "
             "(eqs 40/41, Figure 12's basis) and the realistic circuit's flow",
             f"{'model':<40} {'f [Hz]':>6}  {'measured':>8}  {'free':>6}  {'circuit':>7}  "
             f"{'dy free unc/comp [um]':>22}"]
    for r in rows:
        m = "-" if r["measured_gain"] is None else f"{r['measured_gain']:.3f}"
        lines.append(f"{r['model']:<40} {r['frequency_Hz']:>6g}  {m:>8}  "
                     f"{r['free_gain']:>6.3f}  {r['flow_gain']:>7.3f}  "
                     f"{r['dy_free_uncompensated_um']:>10.2f}/{r['dy_free_compensated_um']:<10.2f}")
    return "\n".join(lines)
