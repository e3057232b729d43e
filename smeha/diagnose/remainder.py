"""What each named cause explains, and what remains unexplained (its signature).

The paper's model leaves a held-out excess chi^2, E_0 = chi^2 - n over the
held-out features (:attr:`smeha.diagnose.fit.Fit.heldout_excess`). Forward
selection adds causes one by one (:mod:`smeha.diagnose.decision`); the model
with the first j causes leaves E_j, so cause j **explains** (E_{j-1} - E_j)/E_0
of it, and (E_k)/E_0 **remains**, both floored at 0 (an excess below zero is
noise). E_k is the named model's (at most E_0); for j < k the model with the first j
causes is the one of those fitted that predicts the held-out runs best, in whichever
forms, and E_j is held between E_k and E_{j-1}, so that the shares and the remainder add
up to 1. A cause's form in the named model may differ from the form it was first named
in: read off the fit of the named model's form alone, a mechanics whose two-mass form
alone predicts the held-out runs worse than the paper's model would explain 0 and the
cause beside it more than all (pinned by tests/test_decision.py::
test_each_named_cause_is_credited_with_the_best_form_of_the_model_before_it). A remainder counts
as unexplained only while the chosen model is outside noise
(:func:`smeha.diagnose.rules.within_noise`).

The remainder's **signature** is read from the chosen model's residual over
every run (training and held-out): the share of its chi^2 in y, in B and in
the drift terms; in y's and B's fundamental, even and odd (>= 3) harmonics;
the residual on the falling against the rising current (branch asymmetry); and
its growth with frequency and with the current's amplitude, each as the
exponent of a power law fitted in logs (a least-squares line of ln RMS against
ln f, or the ratio between the largest and the smallest amplitude).
"""
from __future__ import annotations

import math

import numpy as np

from .candidates import Batch
from .fit import drive_levels

__all__ = ["contributions", "signature", "describe", "summary"]


def _excess(fit) -> float:
    return max(fit.heldout_excess, 0.0)


def _sub_fit(d, causes):
    """Among the diagnosis' fits of the model with ``causes`` (in any of their forms), the
    one with the least held-out excess, or None."""
    fits = [f for f in [d.paper] + d.fits + d.combinations + [d.extended]
            if set(f.causes) == set(causes)]
    return min(fits, key=_excess) if fits else None


def contributions(d) -> tuple:
    """({cause: explained fraction}, remaining fraction) of the paper's held-out excess
    (module docstring); ({}, 1.0) when nothing is named, ({}, 0.0) for "none"."""
    e0 = _excess(d.paper)
    if d.cause == "none" or e0 <= 0.0:
        return {}, 0.0
    if not d.causes:
        return {}, 1.0
    last = min(_excess(d.extended), e0)
    out, before = {}, e0
    for j, cause in enumerate(d.causes, start=1):
        if j == len(d.causes):
            after = last
        else:  # no fit of the first j causes (none seen): the cause is credited nothing
            fit = _sub_fit(d, d.causes[:j])
            after = before if fit is None else min(max(_excess(fit), last), before)
        out[cause] = (before - after) / e0
        before = after
    return out, last / e0


def _power_law(x, y) -> float | None:
    """Exponent p of y ~ x^p by least squares in logs (None for fewer than 2 distinct x)."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    ok = (x > 0) & (y > 0)
    if len(set(np.round(x[ok], 9))) < 2:
        return None
    return float(np.polyfit(np.log(x[ok]), np.log(y[ok]), 1)[0])


def signature(ev, feats, fit) -> dict:
    """The residual's signature for the fitted model ``fit`` (module docstring)."""
    theta = 2.0 * np.pi * np.arange(128) / 128
    falling = theta < np.pi
    chi = {"y": 0.0, "B": 0.0, "drift": 0.0}
    harm = {"y": np.zeros(3), "B": np.zeros(3)}  # fundamental, even, odd >= 3
    rows = []
    for rf in feats:
        one = Batch([rf])
        y, b, _, _ = ev.predict(one, fit.base, fit.candidate, fit.x)
        cy, cb, cd = (float(v[0]) for v in ev.parts(one, fit.base, fit.candidate, fit.x))
        chi["y"] += cy
        chi["B"] += cb
        chi["drift"] += cd
        k = np.arange(1, y.shape[1] + 1)
        for key, model, data, sd in (("y", y[0], rf.y, one.y_sd[0]),
                                     ("B", b[0], rf.b, one.b_sd[0])):
            if key == "B" and not rf.has_b:
                continue
            z = np.abs((model - data) / sd) ** 2
            harm[key] += (z[k == 1].sum(), z[(k % 2 == 0)].sum(), z[(k % 2 == 1) & (k > 1)].sum())
        r = np.real(np.exp(1j * np.outer(theta, k)) @ (rf.y - y[0]))
        rows.append((rf.frequency, rf.current_amplitude, float(np.sqrt(np.mean(r * r))),
                     float(np.sqrt(np.mean(r[falling] ** 2))),
                     float(np.sqrt(np.mean(r[~falling] ** 2)))))
    total = sum(chi.values()) or 1.0
    f, a, rms, fall, rise = (np.array(c) for c in zip(*rows))
    levels = drive_levels(a)
    amp_law = None
    if len(levels) > 1:
        (a_lo, runs_lo), (a_hi, runs_hi) = levels[0], levels[-1]
        lo, hi = rms[runs_lo].mean(), rms[runs_hi].mean()
        amp_law = float(math.log(hi / lo) / math.log(a_hi / a_lo)) if lo > 0 else None
    harmonics = {}
    for key, v in harm.items():
        s = v.sum()
        if s > 0:
            harmonics[key] = dict(zip(("fundamental", "even", "odd"), (float(x / s) for x in v)))
    return {
        "chi2_share": {k: v / total for k, v in chi.items()},
        "harmonic_share": harmonics,
        "branch_asymmetry": float(np.mean(np.abs(fall - rise)) / max(np.mean(rms), 1e-30)),
        "frequency_exponent": _power_law(f, rms),
        "amplitude_exponent": amp_law,
        "residual_rms_um": float(np.sqrt(np.mean(rms * rms))) * 1e6,
    }


def describe(sig) -> str:
    """The signature in words (for the text report's one line)."""
    words = []
    chans = [k for k in ("y", "B") if sig["chi2_share"].get(k, 0.0) >= 0.2]
    for part, name in (("odd", "odd harmonics"), ("even", "even harmonics"),
                       ("fundamental", "the fundamental")):
        where = [k for k in chans if sig["harmonic_share"].get(k, {}).get(part, 0.0) >= 0.3]
        if where:
            words.append(f"{name} of {' and '.join(where)}")
    if sig["chi2_share"].get("drift", 0.0) >= 0.2:
        words.append("drift within runs")
    if sig["branch_asymmetry"] >= 0.3:
        words.append("falling and rising branches differ")
    p = sig["frequency_exponent"]
    if p is not None and abs(p) >= 0.5:
        words.append(f"{'growing' if p > 0 else 'falling'} with frequency as f^{p:.1f}")
    q = sig["amplitude_exponent"]
    if q is not None and abs(q - 1.0) >= 0.5:
        words.append(f"amplitude-dependent (residual ~ I_m^{q:.1f})")
    return ", ".join(words) or "no dominant pattern"


def _percent(fraction) -> str:
    """A share in per cent: whole per cents from 1 % up, two significant digits below (a
    remainder of 0.02 % outside noise is not "0 %")."""
    p = 100.0 * fraction
    return f"{p:.0f} %" if abs(p) >= 1.0 or p == 0.0 else f"{p:.2g} %"


def summary(fractions, remaining, sig, outside_noise) -> str:
    """The one line of the text report (module docstring)."""
    names = list(fractions)
    shares = [_percent(v) for v in fractions.values()]
    if len(names) == 1:
        named = f"{names[0]} explains {shares[0]} of the held-out excess"
    elif names:
        named = (f"{', '.join(names[:-1])} and {names[-1]} explain "
                 f"{', '.join(shares[:-1])} and {shares[-1]} of the held-out excess")
    else:
        named = ""
    if not outside_noise:
        rest = "the rest is within noise"
    else:
        rest = f"{_percent(remaining)} remains unexplained ({describe(sig)})"
    return f"{named}; {rest}" if named else f"no candidate qualifies; {rest}"
