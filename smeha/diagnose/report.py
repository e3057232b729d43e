"""What the diagnosis reports: residual structure, evidence, text, JSON and figures."""
from __future__ import annotations

import math
import textwrap

import numpy as np

from gmt import extensions as ext

from .candidates import CAUSES, FORMS, Batch, Evaluator, label
from . import remainder
from .decision import leader
from .rules import (CONFUSABLE_WITHOUT_B, MIN_BIC_DROP, MIN_EXPLAINED, WITHIN_NOISE,
                    alike_at_levels, channels, explained, passes, shares_in_words, within_noise)

__all__ = ["SIGNALS", "SCALE_SPAN", "characterise", "cautions", "y_worse_caution",
           "scale_caution", "evidence",
           "remainder_report",
           "format_diagnosis", "sense_voltage_report", "as_dict", "write_report"]

#: What each cause changes, for the evidence text.
SIGNALS = {e.cause: e.signals for e in ext.EXTENSIONS}


def _synth(harm, theta):
    k = np.arange(1, len(harm) + 1)
    return np.real(np.exp(1j * np.outer(theta, k)) @ harm)


def characterise(ev: Evaluator, feats, base) -> dict:
    """Residual structure of the paper's model over all runs (module docstring, step 3)."""
    theta = 2.0 * np.pi * np.arange(128) / 128
    falling = theta < np.pi  # i = I_m cos(theta) falls on (0, pi)
    rows = []
    for rf in feats:
        one = Batch([rf])
        y, b, _, _ = ev.predict(one, base)
        y, b = y[0], b[0]
        ry = rf.y - y
        rb = rf.b - b if rf.has_b else None
        r = _synth(ry, theta)
        sy = math.sqrt(float(np.sum(rf.y_var)))  # noise of the periodic residual (RMS-ish)
        data = _synth(rf.y, theta)
        opening = float(_synth(rf.y, np.array([np.pi / 2]))[0]
                        - _synth(rf.y, np.array([3 * np.pi / 2]))[0])
        cy_y, cy_b, cy_d = (float(v[0]) for v in ev.parts(one, base))
        n_y, n_b, n_d = ev.n_features(rf)
        rows.append({
            "run": rf.name, "frequency_Hz": rf.frequency,
            "current_amplitude_A": rf.current_amplitude,
            "flux_density_source": rf.flux_density_source,
            "noise_um": rf.noise_y * 1e6,
            "noise_source": rf.noise_source,
            "cycles_used": rf.cycles,
            "transient_cycles_dropped": rf.dropped_cycles,
            "periodic_residual_rms_um": float(np.sqrt(np.mean(r * r))) * 1e6,
            "periodic_noise_rms_um": sy * 1e6,
            "falling_rms_um": float(np.sqrt(np.mean(r[falling] ** 2))) * 1e6,
            "rising_rms_um": float(np.sqrt(np.mean(r[~falling] ** 2))) * 1e6,
            "y_residual_harmonics_um": [float(abs(v)) * 1e6 for v in ry[:3]],
            "y_residual_phases_deg": [math.degrees(float(np.angle(v))) for v in ry[:3]],
            # the B entries are None for a run without a sense voltage
            "b_residual_harmonics_mT": ([float(abs(v)) * 1e3 for v in rb[:3]]
                                        if rf.has_b else None),
            "y_extra_lag_deg": math.degrees(float(np.angle(y[0] / rf.y[0]))),
            "y_gain_ratio": float(abs(rf.y[0]) / abs(y[0])),
            "b_extra_lag_deg": (math.degrees(float(np.angle(b[0] / rf.b[0])))
                                if rf.has_b else None),
            "y3_over_y1_pct": 100.0 * float(abs(rf.y[2]) / abs(rf.y[0])),
            "b3_over_b1_pct": (100.0 * float(abs(rf.b[2]) / abs(rf.b[0]))
                               if rf.has_b else None),
            "loop_opening_um": opening * 1e6,
            "loop_opening_rel": opening / float(np.ptp(data)),
            "offset_drift_um_per_s": rf.offset_slope * 1e6,
            "offset_drift_z": rf.offset_slope / math.sqrt(rf.offset_slope_var),
            "gain_drift_per_s": float((rf.y1_slope / rf.y[0]).real),
            "gain_drift_z": float((rf.y1_slope * np.conj(rf.y[0]) / abs(rf.y[0])).real
                                  / math.sqrt(rf.y1_slope_var)),
            "chi2_y": cy_y, "chi2_b": cy_b, "chi2_drift": cy_d,
            "n_y": n_y, "n_b": n_b, "n_drift": n_d,
        })
    # loop opening against f, at the largest amplitude
    amps = sorted({round(r["current_amplitude_A"], 2) for r in rows})
    top = [r for r in rows if round(r["current_amplitude_A"], 2) == amps[-1]]
    top.sort(key=lambda r: r["frequency_Hz"])
    f = np.array([r["frequency_Hz"] for r in top])
    o = np.array([r["loop_opening_rel"] for r in top])
    law = {}
    if f.size >= 3:
        for name, x in (("linear", f), ("sqrt", np.sqrt(f))):
            a = np.column_stack((np.ones_like(x), x))
            coef, *_ = np.linalg.lstsq(a, o, rcond=None)
            law[name] = {"intercept": float(coef[0]), "slope": float(coef[1]),
                         "rms": float(np.sqrt(np.mean((a @ coef - o) ** 2)))}
    # extra lag of y against f: through the origin (a delay) or not
    lag = np.array([math.radians(r["y_extra_lag_deg"]) for r in rows])
    fr = np.array([r["frequency_Hz"] for r in rows])
    tau = float((fr @ lag) / (2 * np.pi * (fr @ fr)))
    return {"runs": rows, "opening_vs_f": law,
            "opening_lowest_f_rel": float(o[0]) if o.size else None,
            "opening_highest_f_rel": float(o[-1]) if o.size else None,
            "y_lag_as_delay_s": tau,
            "y_lag_as_delay_rms_deg": math.degrees(float(np.sqrt(np.mean(
                (lag - 2 * np.pi * fr * tau) ** 2))))}


def _amplitudes(rows) -> list:
    """The runs' current amplitudes, rounded to 10 mA, sorted, [A]."""
    return sorted({round(r["current_amplitude_A"], 2) for r in rows})


def _data_lines(d) -> list[str]:
    """What was used of the data: runs skipped, transients dropped, B missing, the noise."""
    rows = d.characterisation["runs"]
    brows = [r for r in rows if r["b_residual_harmonics_mT"] is not None]  # runs with B
    without = d.runs_without_sense_voltage
    out = []
    if d.skipped:
        out.append("runs not used: " + "; ".join(f"{n} ({why})" for n, why in d.skipped))
    dropped = [(r["run"], r["transient_cycles_dropped"]) for r in rows
               if r["transient_cycles_dropped"]]
    if dropped:
        out.append("transient at the start of the record, dropped: " + ", ".join(
            f"{n} {k} period{'s' if k > 1 else ''}" for n, k in dropped))
    if without:
        magnetic = ", ".join(c for c in CAUSES if SIGNALS[c] == "B and y")
        pairs = "; ".join(f"{a} vs {b}" for a, b in CONFUSABLE_WITHOUT_B)
        out.append(f"no sense voltage in {len(without)} of {len(rows)} runs "
                   f"({', '.join(without)}): B_m of those from y's fundamental (eq 19, as "
                   "smeha.identify), and only y's harmonics and drift are compared. Without B "
                   f"the magnetic causes, which change B and y together ({magnetic}), are "
                   "told from those that change y only by the shape of y alone; hard to tell "
                   f"apart: {pairs}")
    e_noise = [d.context["features"][r["run"]].noise_e for r in brows]
    out.append(f"noise (scatter from period to period, or about a many-harmonic fit): y "
               f"{d.noise_um:.3g} um per "
               "sample (median over runs), sense voltage "
               + (f"{np.median(e_noise):.3g} V" if e_noise else "not measured"))
    return out


def _paper_lines(d) -> list[str]:
    """The paper's model against noise: chi^2 per signal, and which signals carry the misfit."""
    p, rows = d.paper, d.characterisation["runs"]
    out = []
    ny = sum(r["n_y"] for r in rows)
    nb = sum(r["n_b"] for r in rows)
    nd = sum(r["n_drift"] for r in rows)
    cy = sum(r["chi2_y"] for r in rows)
    cb = sum(r["chi2_b"] for r in rows)
    cd = sum(r["chi2_drift"] for r in rows)
    b_text = f"{cb / nb:.3g} on B harmonics" if nb else "no B harmonics (no sense voltage)"
    out.append(f"paper's model, all runs: chi^2/n = {cy / ny:.3g} on y harmonics, "
               f"{b_text}, {cd / nd:.3g} on the drift terms "
               f"(1 = within noise); training reduced chi^2 "
               f"{p.train_chi2 / max(p.train_n - 5, 1):.3g}, held-out "
               f"{p.heldout_chi2 / p.heldout_n:.3g} (predictive, with the fit's own "
               f"uncertainty, {p.heldout_predictive_chi2 / p.heldout_n:.3g}; threshold "
               f"{WITHIN_NOISE:g})")
    carriers = [name for name, v in (("y", cy / ny), ("B", cb / nb if nb else 0.0),
                                     ("drift of y", cd / nd))
                if v > WITHIN_NOISE]
    out.append("the discrepancy is carried by: " + (", ".join(carriers) if carriers
                                                     else "neither signal (within noise)"))
    return out


def _residual_lines(d) -> list[str]:
    """The shape of the paper's residual: by run, branch, harmonic, amplitude, loop opening."""
    c = d.characterisation
    rows = c["runs"]
    out = []
    res = np.array([r["periodic_residual_rms_um"] for r in rows])
    nse = np.array([r["periodic_noise_rms_um"] for r in rows])
    out.append(f"periodic residual RMS of y per run: {res.min():.3g} to {res.max():.3g} um "
               f"against a noise level of the averaged period of {nse.min():.2g} to "
               f"{nse.max():.2g} um")
    fall = np.array([r["falling_rms_um"] for r in rows])
    rise = np.array([r["rising_rms_um"] for r in rows])
    out.append(f"by branch: residual RMS falling current {np.mean(fall):.3g} um, rising "
               f"{np.mean(rise):.3g} um (mean over runs)")
    lo, hi = min(rows, key=lambda r: r["frequency_Hz"]), max(rows,
                                                              key=lambda r: r["frequency_Hz"])
    def bres(r):
        v = r["b_residual_harmonics_mT"]
        return "/".join(f"{x:.3g}" for x in v) if v is not None else "not measured"
    out.append(
        f"by harmonic (y residual, um, k = 1..3): {lo['run']} "
        + "/".join(f"{v:.3g}" for v in lo["y_residual_harmonics_um"])
        + f"; {hi['run']} " + "/".join(f"{v:.3g}" for v in hi["y_residual_harmonics_um"])
        + f"; B residual (mT): {bres(lo)} and {bres(hi)}")
    amps = _amplitudes(rows)
    if len(amps) >= 2:
        def mean3(a, key):
            v = [r[key] for r in rows
                 if round(r["current_amplitude_A"], 2) == a and r[key] is not None]
            return float(np.mean(v)) if v else None

        b_lo, b_hi = mean3(amps[0], "b3_over_b1_pct"), mean3(amps[-1], "b3_over_b1_pct")
        b_part = (f"third harmonic of B: {b_lo:.3g} % of the fundamental at {amps[0]:g} A, "
                  f"{b_hi:.3g} % at {amps[-1]:g} A; " if b_lo is not None and b_hi is not None
                  else "third harmonic of B: not measured (no sense voltage); ")
        out.append(b_part + f"of y: {mean3(amps[0], 'y3_over_y1_pct'):.3g} % at {amps[0]:g} "
                   f"A and {mean3(amps[-1], 'y3_over_y1_pct'):.3g} % at {amps[-1]:g} A")
    law = c["opening_vs_f"]
    if law:
        better = min(law, key=lambda k: law[k]["rms"])
        out.append(f"loop opening (y at i = 0, falling minus rising, over peak-to-peak) at the "
                   f"largest amplitude: {c['opening_lowest_f_rel']:.3g} at the lowest f, "
                   f"{c['opening_highest_f_rel']:.3g} at the highest; best law {better} in f "
                   f"with intercept {law[better]['intercept']:.3g} at f -> 0")
    return out


def _by_frequency(rows, key, fmt, amplitude) -> str:
    """``rows``' ``key`` per frequency at the current amplitude ``amplitude`` [A]:
    "5Hz:+0.12 20Hz:+0.30 ..."."""
    return " ".join(f"{r['frequency_Hz']:g}Hz:{r[key]:{fmt}}" for r in rows
                    if round(r["current_amplitude_A"], 2) == amplitude)


def _fundamental_lines(d) -> list[str]:
    """The fundamentals' extra lag and gain against f, and the drift within runs."""
    c = d.characterisation
    rows = c["runs"]
    brows = [r for r in rows if r["b_residual_harmonics_mT"] is not None]  # runs with B
    amps = _amplitudes(rows)
    out = []
    lag = _by_frequency(rows, "y_extra_lag_deg", "+.2f", amps[-1])
    out.append(f"extra lag of y's fundamental behind the model (deg): {lag}; as a delay "
               f"{c['y_lag_as_delay_s'] * 1e3:.3g} ms leaves {c['y_lag_as_delay_rms_deg']:.2g} "
               "deg RMS")
    bl = _by_frequency(brows, "b_extra_lag_deg", "+.2f", amps[-1])
    out.append("extra lag of B's fundamental behind the model (deg): "
               + (bl or "not measured (no sense voltage)"))
    gains = _by_frequency(rows, "y_gain_ratio", ".3f", amps[-1])
    out.append(f"gain of y's fundamental, measured over model: {gains}")
    zo = max(rows, key=lambda r: abs(r["offset_drift_z"]))
    zg = max(rows, key=lambda r: abs(r["gain_drift_z"]))
    out.append(f"drift within runs: largest offset drift {zo['offset_drift_um_per_s']:.3g} um/s "
               f"(z = {zo['offset_drift_z']:.3g}, {zo['run']}), largest gain drift "
               f"{zg['gain_drift_per_s'] * 100:.3g} %/s (z = {zg['gain_drift_z']:.3g}, "
               f"{zg['run']})")
    return out


def _verdict_lines(d) -> list[str]:
    """The candidates' held-out misfits, then why the answer is what it is."""
    p = d.paper
    out = []
    ranked = sorted(d.fits, key=lambda f: f.score)
    listed = (", ".join(f"{f.label} {f.heldout_misfit * 1e6:.4g} um (score {f.score:.4g})"
                        for f in ranked) if ranked else
              "not fitted (within noise, no candidate can be named)")
    out.append(f"held-out misfit of y (the model against y's harmonics and drift, the "
               f"noise's share removed): paper {p.heldout_misfit * 1e6:.4g} um; candidates "
               + listed + f"; paper's score {p.score:.4g}")
    if d.cause in CAUSES:
        out += _named_lines(d)
    elif d.cause == "none":
        out.append("none: the paper's model is within noise on training and held-out runs")
    else:
        out.append("unexplained: the paper's model is outside noise and no candidate removes "
                   f"at least {100 * MIN_EXPLAINED:g} % of its held-out excess with a BIC drop "
                   f"above {MIN_BIC_DROP:g}" + _unalike_filters(d))
    return out


def cautions(d) -> list[str]:
    """What else leaves the named causes' signature (each extension's ``lookalike``), an
    extended model that predicts the held-out y worse than the paper's
    (:func:`y_worse_caution`), and a strain scale fitted without a sense voltage outside
    :data:`SCALE_SPAN` (:func:`scale_caution`)."""
    members = d.extended.candidate.members if d.extended.causes else ()
    out = list(dict.fromkeys(f"{label(m)}: {m.lookalike}" for m in members if m.lookalike))
    worse = members and y_worse_caution(d.paper.heldout_misfit, d.extended.heldout_misfit,
                                        sense=d.sense)
    scale = scale_caution(d.extended.strain_scale, not d.sense)
    return out + ([worse] if worse else []) + ([scale] if scale else [])


#: Strain scale s (K_lambda over Table 2's) that a fit without a sense voltage may reach
#: before the report cautions: a rod's magnetostriction coefficient moves with its
#: temperature and prestress (Engdahl (ed.), *Handbook of Giant Magnetostrictive
#: Materials*, 2000, ch. 2); +-10 % is this project's assumed span of a lab's conditions.
SCALE_SPAN = (0.9, 1.1)


def scale_caution(strain_scale: float, without_b: bool) -> str | None:
    """The caution for a strain scale outside :data:`SCALE_SPAN` fitted with no sense
    voltage (``without_b``), else None.

    Without B each run's B_m follows y's fundamental and s shows only in y's harmonics
    against it (eq 25's square law), which hysteresis and saturation change too: outside
    lab C without its sense voltage the paper's model took s = 1.82 and the Preisach
    density 1.73 (with B: 0.99 and 1.00)."""
    lo, hi = SCALE_SPAN
    if not without_b or lo <= strain_scale <= hi:
        return None
    return (f"strain scale s = {strain_scale:.3g} (K_lambda over Table 2's) fitted without a "
            "sense voltage, outside the span of a lab's temperature and prestress "
            f"({lo:g}-{hi:g}): from y alone s is seen only in the harmonics' ratio to the "
            "fundamental, which a magnetic nonlinearity also sets; a sense voltage would "
            "pin it")


def y_worse_caution(paper_misfit: float, extended_misfit: float,
                    sense: bool = True) -> str | None:
    """The caution for a named model whose held-out misfit of y [m] is larger than the
    paper's model's (a gain below 1), else None; ``sense``: the runs have a sense voltage.

    The rule names a model by its held-out score over y, B and the drift together, each
    feature over its error, so a model can be named for what it removes in B while it
    predicts y worse (labsim's Preisach hysteresis with eddy diffusion: 85 % of the
    held-out excess explained, gain 0.68; tests/test_decision.py::
    test_a_named_model_that_predicts_y_worse_is_cautioned), or, without B, for
    what it removes in y's harmonics, whose errors are small, while it misses y's
    fundamental by more microns (outside lab C without its sense voltage: 98 % explained,
    gain 0.89; over the held-out runs y's third harmonic 2.02 -> 0.20 um, its fundamental
    0.79 -> 2.75 um); y is what the flow study and the FMU use."""
    if not extended_misfit > paper_misfit:
        return None
    where = ("in B or the drift" if sense else
             "in y's harmonics and drift, weighted by their errors, more than in y's "
             "fundamental")
    return (f"the extended model predicts the held-out runs' y worse than the paper's model "
            f"(misfit {paper_misfit * 1e6:.4g} -> {extended_misfit * 1e6:.4g} um, gain "
            f"{paper_misfit / extended_misfit:.3g}x): what it explains is {where}; "
            "for y, the displacement and the flow, the paper's model is the better one")


def _unalike_filters(d) -> str:
    """The linear filters on y that pass the rule against the paper on the sum of the drive
    levels but not at each (:func:`smeha.diagnose.rules.passes_first`), as a clause, or ""."""
    p = d.paper
    parts = []
    for f in sorted(d.fits, key=lambda f: f.score):
        member = f.candidate.members[0]
        if passes(p, f) and alike_at_levels(p, f, member):
            parts.append(f"{f.label} {shares_in_words(p, f, member)} of the excess in y and "
                         "the drift")
    return ("; where a linear filter on y, at every drive level (it acts alike at every "
            "amplitude): " + "; ".join(parts)) if parts else ""


def _named_lines(d) -> list[str]:
    """Why the named cause(s): BIC and explained share, forward selection, parameters."""
    p, e = d.paper, d.extended
    without = d.runs_without_sense_voltage
    out = []
    # the named model itself where it holds the first cause alone (a refit of the single
    # may have replaced it: the table's row and the headline are of that fit)
    first = (e if e.causes == (d.cause,) else
             leader([f for f in d.fits if f.causes == (d.cause,)]))
    out.append(f"named {first.label} (acts on {SIGNALS[d.cause]}): held-out BIC lower by "
               f"{p.score - first.score:.4g} (threshold {MIN_BIC_DROP:g}), "
               f"{100 * explained(p, first):.3g} % of the paper's excess chi^2 removed; "
               f"held-out misfit {p.heldout_misfit * 1e6:.4g} -> "
               f"{first.heldout_misfit * 1e6:.4g} um")
    if d.first_in:
        chans = tuple(d.first_in)
        out.append(f"judged in {', '.join(chans)}: {first.label} removes "
                   f"{100 * explained(p, first, chans):.3g} % of the paper's held-out excess "
                   f"there (held-out chi^2 lower by "
                   f"{p.heldout_excess_in(chans) - first.heldout_excess_in(chans):.4g}), "
                   f"less than {100 * MIN_EXPLAINED:g} % of the whole; "
                   + ("the drift terms are its own evidence, which no periodic form produces"
                      if chans == ("drift",) else
                      "B is the magnetic causes' own channel, which the effects on y alone "
                      "leave as the paper predicts: what remains in y is another effect's"))
    elif len(e.causes) > 1 and not passes(p, first):
        out.append(f"named together: neither {d.causes[0]} nor {d.causes[1]} alone removes "
                   f"{100 * MIN_EXPLAINED:g} % of the paper's excess; the two fitted together "
                   "do, and each passes the rule of a later cause against the other alone")
    if len(e.causes) > 1:
        out.append(f"forward selection: {_contribution_label(d)} together lower the "
                   f"held-out BIC by "
                   f"{first.score - e.score:.4g} beyond {first.label} alone; the model "
                   f"with all {len(e.causes)} gives held-out misfit "
                   f"{e.heldout_misfit * 1e6:.4g} um, gain {d.gain:.3g}x")
    elif d.combinations:
        best = min(d.combinations, key=lambda f: f.score)
        added = [m for m in best.candidate.members if m not in first.candidate.members]
        chans = channels(added[0]) if added else None
        where = "" if chans is None else f" in {', '.join(first.measured_of(chans))}"
        out.append(f"forward selection: of the models with a further cause, {best.label} "
                   f"predicts the held-out runs best (held-out BIC lower by "
                   f"{first.score - best.score:.4g}, "
                   f"{100 * explained(first, best, chans):.3g} % of the remaining "
                   f"excess{where} removed); no further cause is named"
                   + (" (the rule each model tried failed: next line)" if d.stopped
                      else ""))
    if d.stopped:
        out.append(f"no further cause named: {d.stopped}")
    if d.screened:
        out.append("screened beside the density and not fitted in full (each fitted the "
                   "training runs worse than those that were): "
                   + ", ".join(f"{f.label} (training chi^2 {f.train_chi2:.4g})"
                               for f in d.screened))
    out.append(f"parameters of the extended model: {_fmt_params(e.parameters)}")
    out += [f"caution, {c}" for c in cautions(d)]
    if e.weak:
        plural = "s" if len(e.at_bounds) > 1 else ""
        out.append(f"weak finding: {', '.join(e.at_bounds)} on the bound{plural} "
                   "of the fit; the extended model predicts the held-out runs better, but "
                   "these parameters are not a physical result (the effect may be another "
                   "one, or the data do not fix it)")
    if d.also_consistent:
        out.append("also consistent: " + ", ".join(
            f"{f.label} (score {f.score - first.score:+.3g} from the named one, held-out "
            f"misfit {f.heldout_misfit * 1e6:.4g} um)" for f in d.also_consistent)
            + f"; the data prefer {first.label} by less than the BIC margin "
            f"({MIN_BIC_DROP:g}), so they do not separate these causes"
            + (" (without B, see above)" if without else ""))
    return out


def evidence(d) -> list[str]:
    """The evidence lines of the text report (and ``evidence`` in the JSON)."""
    return (_data_lines(d) + _paper_lines(d) + _residual_lines(d) + _fundamental_lines(d)
            + _verdict_lines(d))


def _fmt_params(p: dict) -> str:
    def f(v):
        if isinstance(v, (list, tuple)):
            return "[" + ", ".join(f"{x:.3g}" for x in v) + "]"
        if isinstance(v, dict):
            return "{" + _fmt_params(v) + "}"
        return f"{v:.4g}"
    return ", ".join(f"{k} = {f(v)}" for k, v in p.items())


def _contribution_label(d) -> str:
    """The named model's members in the order forward selection added them."""
    return " + ".join(label(m) for c in d.causes for m in d.extended.candidate.members
                      if m.cause == c)


def remainder_report(d) -> dict | None:
    """What each named cause explains and what remains (:mod:`smeha.diagnose.remainder`);
    None for "none"."""
    if d.cause == "none" or d.context is None:
        return None
    fractions, remaining = remainder.contributions(d)
    feats = list(d.context["features"].values())
    sig = remainder.signature(d.context["evaluator"], feats, d.extended)
    outside = not within_noise(d.extended)
    return {"explained_fraction": fractions,
            "unexplained_fraction": remaining if outside else 0.0,
            "signature": sig,
            "summary": remainder.summary(fractions, remaining, sig, outside)}


def format_diagnosis(d, path: str = "") -> str:
    """Plain-text report."""
    lines = []
    if path:
        lines.append(f"diagnosis of {path}")
    if d.cause in CAUSES:
        lines.append(f"cause: {d.cause}" + (f" (model: {d.form})"
                                             if d.cause in FORMS and d.form else "")
                     + (" [weak: parameters on bounds]" if d.weak else ""))
        if len(d.causes) > 1:
            lines.append(f"causes (in order of contribution): {_contribution_label(d)}")
    else:
        lines.append(f"cause: {d.cause}")
    rem = remainder_report(d)
    if rem is not None:
        lines.append(rem["summary"])
    if d.also_consistent:
        lines.append("also consistent: " + ", ".join(f.label for f in d.also_consistent))
    lines += [f"caution, {c}" for c in cautions(d)]
    without = d.runs_without_sense_voltage
    if without:
        lines.append(f"no sense voltage: {', '.join(without)} (B_m from the displacement; "
                     "y's features only)")
    if d.skipped:
        lines.append("runs not used: " + "; ".join(f"{n} ({why})" for n, why in d.skipped))
    lines.append(f"held-out runs: {', '.join(d.heldout_runs)}")
    lines.append(f"held-out misfit of y (the noise's share removed): paper "
                 f"{d.paper.heldout_misfit * 1e6:.4g} um, extended "
                 f"{d.extended.heldout_misfit * 1e6:.4g} um, gain {d.gain:.3g}x (the "
                 f"noise's share: {d.paper.heldout_noise_misfit * 1e6:.3g} um)")
    lines.append(f"held-out RMS of y over the samples (noise included): paper "
                 f"{d.paper.heldout_rms * 1e6:.4g} um, extended "
                 f"{d.extended.heldout_rms * 1e6:.4g} um")
    lines.append("")
    lines += candidate_table(d)
    lines.append("")
    lines.append("evidence:")
    lines += [f"  - {e}" for e in d.evidence]
    return "\n".join(lines)


def display_label(fit) -> str:
    """The model's name in the report: its label, or "paper (none)"."""
    return fit.label if fit.candidate.members else "paper (none)"


def candidate_table(d) -> list[str]:
    """The table of the text report: the named model first (its row is the headline's
    figures), then the other models tried, each once (the best-scored fit of a model
    fitted more than once), best held-out score first; labels whole; a note on k."""
    rows, seen = [d.extended], {display_label(d.extended)}
    for f in sorted([d.paper] + list(d.fits) + list(d.combinations), key=lambda f: f.score):
        name = display_label(f)
        if name not in seen:
            seen.add(name)
            rows.append(f)
    named = d.cause not in ("none", "unexplained")
    marks = ["named"] + [""] * (len(rows) - 1) if named else [""] * len(rows)
    width = max(len(display_label(f)) for f in rows) + 2
    head = (f"{'model':<{width}} {'':<6} {'misfit [um]':>12} {'RMS [um]':>10} "
            f"{'chi2/n':>10} {'score':>12} {'k':>6}")
    out = [head, "-" * len(head)]
    for f, mark in zip(rows, marks):
        out.append(f"{display_label(f):<{width}} {mark:<6} {f.heldout_misfit * 1e6:>12.4g} "
                   f"{f.heldout_rms * 1e6:>10.4g} {f.heldout_chi2 / f.heldout_n:>10.4g} "
                   f"{f.score:>12.5g} {f.k:>6.3g}")
    out += textwrap.wrap(
        "misfit, RMS, chi2/n and score on the held-out runs (score: held-out chi^2 + k ln n, "
        "lower is better); k: the parameters the score charges, counted as effective degrees "
        "of freedom where a model holds the Preisach density (its penalised nonnegative "
        "weights count by the trace of the fit's hat matrix, so k need not be whole)",
        width=len(head))
    return out


def _fit_dict(fit) -> dict:
    return {"cause": fit.cause, "form": fit.form, "causes": list(fit.causes),
            "label": fit.label, "heldout_rms_um": fit.heldout_rms * 1e6,
            "heldout_misfit_um": fit.heldout_misfit * 1e6,
            "score": fit.score, "heldout_chi2": fit.heldout_chi2,
            "heldout_predictive_chi2": fit.heldout_predictive_chi2, "heldout_n": fit.heldout_n,
            "heldout_chi2_y": fit.heldout_chi2_y, "heldout_chi2_b": fit.heldout_chi2_b,
            "heldout_chi2_drift": fit.heldout_chi2_drift,
            "heldout_chi2_higher_harmonics": fit.heldout_chi2_higher,
            "heldout_n_higher_harmonics": fit.heldout_n_higher,
            "train_chi2": fit.train_chi2, "train_n": fit.train_n,
            "added_parameters": fit.n_params, "effective_parameters": fit.k,
            "parameters": fit.parameters,
            "at_bounds": list(fit.at_bounds),
            "loss_coefficients": dict(zip(("K_h", "n", "K_e", "K_ex"), fit.loss)),
            "strain_scale": fit.strain_scale}


def sense_voltage_report(d) -> dict:
    """What the missing sense voltage leaves undetermined (``sense_voltage`` in JSON)."""
    without = d.runs_without_sense_voltage
    return {"runs_without": without,
            "flux_density_source": {name: rf.flux_density_source
                                    for name, rf in d.context["features"].items()},
            "hard_to_separate": [list(p) for p in CONFUSABLE_WITHOUT_B] if without else []}


def as_dict(d) -> dict:
    """JSON-able report (the ``--json`` output)."""
    named = d.cause in CAUSES
    rem = remainder_report(d)
    return {
        "cause": d.cause,
        "form": d.form,
        "causes": d.causes,
        "explained_fraction": rem["explained_fraction"] if rem else {},
        "unexplained_fraction": rem["unexplained_fraction"] if rem else 0.0,
        "remainder": rem,
        "weak": d.weak,
        "model": d.variant().as_dict() if named else {"cause": d.cause},
        "evidence": list(d.evidence),
        "heldout_runs": list(d.heldout_runs),
        "training_runs": list(d.training_runs),
        "skipped_runs": [{"run": n, "reason": why} for n, why in d.skipped],
        "noise_um": d.noise_um,
        "heldout_rms_um": {"paper": d.paper.heldout_rms * 1e6,
                           "extended": d.extended.heldout_rms * 1e6},
        "heldout_misfit_um": {"paper": d.paper.heldout_misfit * 1e6,
                              "extended": d.extended.heldout_misfit * 1e6,
                              "noise_share": d.paper.heldout_noise_misfit * 1e6},
        "gain": d.gain,
        "extended": _fit_dict(d.extended),
        "selection_stopped": d.stopped,
        "first_judged_in": list(d.first_in),
        "screened_only": [{"label": f.label, "causes": list(f.causes),
                           "train_chi2": f.train_chi2} for f in d.screened],
        "also_consistent": [{"cause": f.cause, "form": f.form, "score": f.score,
                             "score_above_named": f.score - d.extended.score,
                             "heldout_rms_um": f.heldout_rms * 1e6}
                            for f in d.also_consistent],
        "cautions": cautions(d),
        "sense_voltage": sense_voltage_report(d),
        "candidates": [_fit_dict(f) for f in d.fits],
        "combinations": [_fit_dict(f) for f in d.combinations],
        "paper": _fit_dict(d.paper),
        "characterisation": d.characterisation,
        "decision_rule": {"within_noise_reduced_chi2": WITHIN_NOISE,
                          "min_bic_drop": MIN_BIC_DROP,
                          "min_explained_excess": MIN_EXPLAINED,
                          "forward_selection": "add the best candidate that passes the same "
                                               "rule against the model before it"},
    }


def write_report(d, directory) -> list:
    """PNG figures: per run, the loop (measured, paper, extended) and the residual
    against phase by branch, before (paper) and after (extended). Returns the paths."""
    from pathlib import Path

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    ev = d.context["evaluator"]
    paths = []
    for name, rf in d.context["features"].items():
        yp = ev.samples(rf, d.paper.base)
        ye = ev.samples(rf, d.extended.base, d.extended.candidate, d.extended.x)
        th = np.mod(rf.phase(rf.time), 2 * np.pi)
        falling = th < np.pi
        fig, axes = plt.subplots(1, 3, figsize=(14, 4))
        ax = axes[0]
        # three colours that stay apart in print and for colour-blind readers
        ax.plot(rf.current, rf.displacement * 1e6, ".", ms=2.0, color="0.45",
                label="measured")
        order = np.argsort(rf.time)
        ax.plot(rf.current[order], yp[order] * 1e6, "-", lw=1.0, color="tab:blue",
                label="paper (eq 30)")
        if d.extended.cause != "none":
            ax.plot(rf.current[order], ye[order] * 1e6, "--", lw=1.0, color="tab:red",
                    label="extended")
        ax.set_xlabel("current i [A]")
        ax.set_ylabel("displacement y [um]")
        tag = " (held out)" if name in d.heldout_runs else " (training)"
        ax.set_title(f"{name}{tag}: loop")
        ax.legend(fontsize=7, loc="upper left")
        answer = (f"{d.extended.label}: held-out gain {d.gain:.3g}x"
                  + (" (weak: parameters on bounds)" if d.weak else "")
                  if d.cause in CAUSES else d.cause)
        fig.suptitle(f"diagnosis: {answer}", fontsize=10)
        for ax, model, which in ((axes[1], yp, "paper"), (axes[2], ye, "extended")):
            r = (rf.displacement - model) * 1e6
            ax.plot(th[falling], r[falling], ".", ms=1.5, color="tab:purple",
                    label="falling current")
            ax.plot(th[~falling], r[~falling], ".", ms=1.5, color="tab:green",
                    label="rising current")
            ax.axhline(0.0, color="k", lw=0.5)
            ax.set_xlabel("phase of the current [rad]")
            ax.set_ylabel("measured - model [um]")
            ax.set_title(f"residual, {which} (RMS {np.sqrt(np.mean(r * r)):.3g} um)")
            ax.legend(fontsize=7)
        fig.tight_layout()
        path = out / f"diagnose_{name}.png"
        fig.savefig(path, dpi=90)
        plt.close(fig)
        paths.append(path)
    return paths
