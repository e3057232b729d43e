"""The loss laws against measured core losses: calibrate, predict, score, hold out.

Per material (or file), on every row read (MagNet's copy keeps |outlier factor| < 5 %):

1. **Calibration rows** (:func:`calibration_mask`, fixed before any error was
   looked at): every sinusoidal row, plus one duty setting per other waveform
   family: triangles with ``duty_1 = 0.5``, and trapezoids with ``duty_1 =
   duty_3`` (flat parts truly flat) and the largest ``duty_2`` present. When
   these exceed :data:`CALIBRATION_SHARE` of the non-sinusoidal rows, every
   k-th of them (file order) is kept.
2. **Before**: the paper's separation fitted on the sinusoids and run through
   the time-domain magnetics (:class:`smeha.coreloss.models.SeparationLaw`), and
   Steinmetz's law fitted on the sinusoids with iGSE for the other waveforms
   (:class:`~smeha.coreloss.models.SteinmetzLaw`), on the same rows.
3. **After**: the extended law (:class:`~smeha.coreloss.models.ExtendedLaw`)
   fitted on the calibration rows, predicting every row.
4. Scores: median and 95th percentile of |P_model / P_measured - 1| per
   waveform family over every row (calibration rows counted; :func:`score`).
5. **Held out** (:func:`holdout`): the extension refitted without one waveform
   family's calibration rows, scored on that family; and refitted on the
   rows below :data:`BAND_SPLIT` only, scored above it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .measurements import WAVEFORMS, CoreLossData, DataError
from .models import (ExtendedLaw, SeparationLaw, SteinmetzLaw, fit_extended, fit_separation,
                     fit_steinmetz)

__all__ = ["CALIBRATION_SHARE", "BAND_SPLIT", "calibration_mask", "score", "MaterialResult",
           "run", "holdout", "summary", "format_results"]

#: Largest share of the non-sinusoidal rows used for calibration.
CALIBRATION_SHARE = 0.10
#: Frequency that splits the band hold-out: fit below, score at and above, [Hz].
BAND_SPLIT = 250e3


def calibration_mask(data: CoreLossData) -> np.ndarray:
    """The calibration rows (module docstring, step 1)."""
    sine = data.family("sine")
    d1, d2, d3 = data.duty[:, 0], data.duty[:, 1], data.duty[:, 2]
    tri = data.family("triangle") & (np.abs(d1 - 0.5) < 1e-9)
    trap = data.family("trapezoid")
    if trap.any():
        symmetric = trap & (np.abs(d1 - d3) < 1e-9)
        trap = symmetric & (d2 == d2[symmetric].max()) if symmetric.any() else symmetric
    chosen = tri | trap
    limit = math.floor(CALIBRATION_SHARE * int((~sine).sum()))
    if chosen.sum() > limit:
        idx = np.flatnonzero(chosen)
        keep = idx[::math.ceil(len(idx) / max(limit, 1))][:limit]
        chosen = np.zeros(len(data), bool)
        chosen[keep] = True
    return sine | chosen


def score(predicted, measured, mask) -> dict:
    """{rows, median_abs_error, p95_abs_error} of |predicted/measured - 1| over ``mask``."""
    err = np.abs(predicted[mask] / measured[mask] - 1.0)
    if not len(err):
        return {"rows": 0, "median_abs_error": None, "p95_abs_error": None}
    return {"rows": int(len(err)), "median_abs_error": float(np.median(err)),
            "p95_abs_error": float(np.percentile(err, 95))}


@dataclass(frozen=True)
class MaterialResult:
    """One material's fits and per-row predictions [W/m^3]."""

    data: CoreLossData
    calibration: np.ndarray  #: mask of the calibration rows
    separation: SeparationLaw
    steinmetz: SteinmetzLaw
    extended: ExtendedLaw
    predicted_separation: np.ndarray
    predicted_igse: np.ndarray
    predicted_extended: np.ndarray

    def families(self):
        """Waveform families present, in table order."""
        return [w for w in WAVEFORMS if self.data.family(w).any()]

    def scores(self, which: str = "extended", rows: str = "all") -> dict:
        """{family: score} of one law; ``rows``: "all", "calibration" or "predicted"."""
        pred = getattr(self, f"predicted_{which}")
        sel = {"all": np.ones(len(self.data), bool), "calibration": self.calibration,
               "predicted": ~self.calibration}[rows]
        return {w: score(pred, self.data.loss, self.data.family(w) & sel)
                for w in self.families()}


def run(data: CoreLossData) -> MaterialResult:
    """Calibrate the three laws on ``data`` and predict every row (module docstring)."""
    sine = data.family("sine")
    if not sine.any():
        raise DataError(f"{data.name}: no sinusoidal rows to calibrate on (duty_1 = -1)")
    cal = calibration_mask(data)
    sep = fit_separation(data.subset(sine))
    st = fit_steinmetz(data)
    ext = fit_extended(data.subset(cal), sep)
    return MaterialResult(data, cal, sep, st, ext, sep.predict(data), st.predict(data),
                          ext.predict(data))


def holdout(result: MaterialResult) -> dict:
    """Gains on held-out rows: by waveform family and by frequency band (module docstring).

    Returns
    -------
    dict
        ``{"waveform": {family: {"igse": S, "extended": S}}, "band": {family: ...}}``,
        S as :func:`score`, each extended law refitted without the rows it is scored on.
    """
    data, cal = result.data, result.calibration
    sine = data.family("sine")
    out = {"waveform": {}, "band": {}}
    for fam in ("triangle", "trapezoid"):
        m = data.family(fam)
        if not m.any():
            continue
        law = fit_extended(data.subset(cal & ~m), result.separation)
        out["waveform"][fam] = {"igse": score(result.predicted_igse, data.loss, m),
                                "extended": score(law.predict(data), data.loss, m)}
    low = data.frequency < BAND_SPLIT
    if (sine & low).any() and (~low).any():
        sub = data.subset(low)
        st = fit_steinmetz(sub)
        law = fit_extended(data.subset(cal & low), fit_separation(sub.subset(sub.family("sine"))))
        for fam in result.families():
            m = data.family(fam) & ~low
            out["band"][fam] = {"igse": score(st.predict(data), data.loss, m),
                                "extended": score(law.predict(data), data.loss, m)}
    return out


def summary(results) -> dict:
    """The JSON of ``smeha losses --json``: {"materials": {name: {...}}}."""
    out = {}
    for r in results:
        ext, igse = r.scores("extended"), r.scores("igse")
        entry = {fam: ext[fam] for fam in ("sine", "triangle", "trapezoid") if fam in ext}
        entry.update({fam: ext[fam] for fam in ext if fam not in entry})
        entry["igse"] = {fam: igse[fam] for fam in igse if fam != "sine"}
        out[r.data.name] = entry
    return {"materials": out}


def _pct(s) -> str:
    if not s or s["rows"] == 0:
        return "      -      "
    return f"{100 * s['median_abs_error']:5.1f} /{100 * s['p95_abs_error']:5.1f}"


def format_results(results, holdouts=None) -> str:
    """Plain-text tables: before and after per family, calibration rows apart, fits."""
    lines = ["median / 95th percentile of |P_model/P_measured - 1|, %, every row "
             "(calibration rows included)", ""]
    head = f"{'material':9s} {'family':10s} {'rows':>6s} {'cal':>5s}  {'separation':>13s}  " \
           f"{'iGSE':>13s}  {'extended':>13s}  {'ext, predicted rows':>19s}"
    lines += [head, "-" * len(head)]
    for r in results:
        sep, igse, ext = r.scores("separation"), r.scores("igse"), r.scores("extended")
        pred = r.scores("extended", "predicted")
        for fam in r.families():
            ncal = int((r.calibration & r.data.family(fam)).sum())
            lines.append(f"{r.data.name:9s} {fam:10s} {ext[fam]['rows']:6d} {ncal:5d}  "
                         f"{_pct(sep[fam])}  {_pct(igse[fam])}  {_pct(ext[fam])}  "
                         f"{_pct(pred[fam]):>19s}")
    lines += ["", "extended law per material (SI; gmt.TransducerParameters / "
              "gmt.TimeDomainParameters names):"]
    for r in results:
        e = r.extended
        lines.append(f"  {r.data.name}: K_h {e.hysteresis_coefficient:.4g}, n "
                     f"{e.steinmetz_exponent:.3f}, K_e {e.eddy_coefficient:.3g}, K_ex "
                     f"{e.excess_coefficient:.3g}, k_w {e.rate_coefficient:.4g}, q "
                     f"{e.rate_exponent:.3f}, beta {e.swing_exponent:.3f}, k_r "
                     f"{e.relaxation_coefficient:.4g}, tau {e.relaxation_time:.3g} s, K_h2 "
                     f"{e.second_hysteresis_coefficient:.4g}, n2 "
                     f"{e.second_steinmetz_exponent:.3f}, r_b {e.steinmetz_break:.3g} T, m "
                     f"{e.steinmetz_exponent_high:.3f}")
    if holdouts:
        lines += ["", "held out (extension refitted without the scored rows): iGSE -> extended",
                  f"{'material':9s} {'by':9s} {'family':10s} {'rows':>6s}  {'iGSE':>13s}  "
                  f"{'extended':>13s}"]
        for r, h in zip(results, holdouts):
            for by in ("waveform", "band"):
                for fam, s in h[by].items():
                    lines.append(f"{r.data.name:9s} {by:9s} {fam:10s} {s['extended']['rows']:6d}"
                                 f"  {_pct(s['igse'])}  {_pct(s['extended'])}")
    return "\n".join(lines)
