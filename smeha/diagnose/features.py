"""Step 1 of the diagnosis: each run reduced to what the models are compared on.

By linear least squares over the run's whole usable periods, the complex
harmonics k = 1 ... :data:`HARMONICS` of y and of B (from E, eq 21:
B_k = j E_k / (k w N_c A_c)), all referred to the phase of the current's
fundamental; the drift of y's offset and of its fundamental (a term linear in
time and a fundamental linear in time, in the same basis); B_m = |B_1| (eq 22).

The fit holds every harmonic the sampling resolves (:func:`fitted_harmonics`, up to
:data:`NOISE_HARMONICS`), of which the first :data:`HARMONICS` are the features. On
whole periods the harmonics are orthogonal to one another but not to the drift terms
(over whole periods the integral of tau cos(w t) cos(k w t) is zero only at particular
start phases): a harmonic left out of the fit leaks through them into the features, by
an amount that changes with the record's start phase. A hysteresis loop's corners give B
harmonics well above the 8th (labsim's Preisach density: B_2 moved by 3 % from run to run
at one amplitude, some 60 standard errors, and the drift terms carried chi^2 of 235-1665
on 48 features where the data have no drift).

**What is used.** A record may start in the transducer's transient (the
mechanics start at rest, an operator with memory starts demagnetised). Its
first period is compared with the periods after it (:func:`leading_transient`):
it is dropped only when it differs from them beyond noise, and then the next
one is checked in the same way, while a later period remains to compare it
with. So a run of 2 or 3 periods is used as it is when its start has settled,
and a run of 2 whose first period is transient gives its second. A run that
cannot be used (fewer than :data:`MIN_CYCLES` whole periods, no current) is
skipped with its reason (:class:`SkippedRun`).

**Noise** comes from the data alone: with a whole number of samples a period,
the scatter from period to period at the same phase after a straight line
over the period index at each phase (so a slow drift of offset or gain is not
noise); otherwise the scatter about a least-squares fit of many harmonics
(:data:`NOISE_HARMONICS` at most) and the drift terms. Interpolating the
samples onto a common phase grid, as a lab rate that is not a multiple of the
frequency would need, would average neighbouring samples and understate the
noise (by sqrt(2/3) for linear interpolation), so it is not done. A run with
fewer than 3 usable periods takes the median noise of the runs that have them
(one displacement sensor, one coil). Each feature's variance follows from the
noise and the least-squares design.

**Without a sense voltage** B_m comes from y's fundamental through eq 19 and
the continuous mechanics (:func:`smeha.identify.flux_density_from_displacement`),
and B is not a feature.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

import gmt

from ..identify import flux_density_from_displacement
from ..measured import Run

__all__ = ["HARMONICS", "MIN_CYCLES", "NOISE_HARMONICS", "TRANSIENT_Z", "SkippedRun",
           "fitted_harmonics",
           "RunFeatures", "current_fundamental", "noise_estimate", "leading_transient",
           "run_features", "extract"]

#: Harmonics of y and B in the features and the models.
HARMONICS = 8
#: Fewest whole periods a record needs: one to use, one more to tell whether the first is
#: still transient.
MIN_CYCLES = 2
#: Most harmonics of the features' fit (the first HARMONICS are kept) and of the noise
#: estimate's when the samples of a period are not a whole number (module docstring);
#: fewer when the sampling resolves fewer (a third of the samples a period).
NOISE_HARMONICS = 30
#: Mains pickup [Hz]: the 50 Hz and 60 Hz mains and their third harmonics, which a
#: ground loop or an unshielded lead puts on the displacement and sense-voltage lines
#: (Ott, Electromagnetic Compatibility Engineering, 2009, ch. 3). Each is fitted beside
#: the harmonics where the record tells it apart from them (:func:`mains_tones`): not
#: fitted, a tone between the drive's harmonics leaks into the drift terms, which then
#: carry a scatter no cause explains.
MAINS_TONES = (50.0, 150.0, 60.0, 180.0)
#: Least distance [resolution bins, 1 / T] of a fitted mains tone from the offset and each
#: harmonic. The fundamental's drift terms (tau cos, tau sin) spread it over a bin or two
#: either side: on a 50 Hz run of 6 periods a tone 1 bin off shares 27 % of its columns'
#: norm with them and widens the drift's standard error by a factor 1.58, room for a
#: further cause to take the scatter; 3 bins off, 2 % and 1.05.
MAINS_SEPARATION = 3.0
#: z-score of the first period's misfit to the later ones above which it is transient.
TRANSIENT_Z = 4.0


class SkippedRun(ValueError):
    """A run the diagnosis cannot use; ``reason`` says why (shown in the text and JSON)."""

    def __init__(self, run: str, reason: str):
        super().__init__(f"run {run!r}: {reason}")
        self.run = run
        self.reason = reason


@dataclass
class RunFeatures:
    """One run reduced to what the models are compared on (SI).

    Phasors X_k mean x(t) = Re(sum_k X_k e^{j k theta}), theta = w t + phi_i,
    the current's fundamental being I_m cos(theta).
    """

    name: str
    frequency: float
    current_amplitude: float
    current_phase: float
    step: float
    cycles: int  # whole periods used
    y: np.ndarray  # complex harmonics 1..K of y, [m]
    y_var: np.ndarray  # variance of each real component, [m^2]
    b: np.ndarray | None  # complex harmonics 1..K of B, [T]; None without a sense voltage
    b_var: np.ndarray | None
    offset_slope: float  # d(mean y)/dt, [m/s]
    offset_slope_var: float
    y1_slope: complex  # d Y_1 / dt, [m/s]
    y1_slope_var: float
    flux_density_amplitude: float  # B_m = |B_1|, [T]
    flux_density_stderr: float
    noise_y: float  # per-sample standard deviation of y, [m]
    noise_e: float | None  # per-sample standard deviation of E, [V]; None without E
    time: np.ndarray  # samples used (after the transient), [s]
    displacement: np.ndarray
    current: np.ndarray
    t_start: float  # first sample of the record, [s]
    t_mid: float
    y_prop_var: np.ndarray = field(default=None)  # B_m error carried into y, [m^2]
    #: where B_m comes from: "sense_voltage" (eq 22) or "displacement" (eq 19)
    flux_density_source: str = "sense_voltage"
    #: without B: M_1/H_m that y's fundamental gives through the paper's mechanics, [-]
    magnetization_ratio: complex | None = None
    #: whole periods dropped at the start as transient
    dropped_cycles: int = 0
    #: where the noise came from: "period scatter", "harmonic fit" or "pooled"
    noise_source: str = "period scatter"
    current_amplitude_var: float = 0.0  # variance of I_m, [A^2]
    current_phase_var: float = 0.0  # variance of phi, [rad^2]
    b_prop_var: np.ndarray = field(default=None)  # current's errors carried into B, [T^2]
    #: whether the first period used was compared with the later ones (module docstring)
    transient_checked: bool = True

    @property
    def has_b(self) -> bool:
        """True when B's harmonics are features (the run has a sense voltage)."""
        return self.b is not None

    @property
    def angular_frequency(self):
        return 2.0 * math.pi * self.frequency

    def phase(self, time):
        """theta at ``time``, [rad]."""
        return self.angular_frequency * np.asarray(time) + self.current_phase


def _basis(t, w, harmonics, t_mid, quadratic=False, tones=()):
    """Columns: offset, its drift, the harmonics' cos and sin, the ``tones`` [Hz] (cos
    and sin each), the fundamental's drift (cos, sin); with ``quadratic`` the second-order
    drift of offset and fundamental after them."""
    tau = t - t_mid
    cols = [np.ones_like(t), tau]
    for k in range(1, harmonics + 1):
        cols += [np.cos(k * w * t), np.sin(k * w * t)]
    for tone in tones:
        cols += [np.cos(2.0 * math.pi * tone * t), np.sin(2.0 * math.pi * tone * t)]
    cols += [tau * np.cos(w * t), tau * np.sin(w * t)]
    if quadratic:
        cols += [tau * tau, tau * tau * np.cos(w * t), tau * tau * np.sin(w * t)]
    return np.column_stack(cols)


def mains_tones(frequency, harmonics, duration, tones=MAINS_TONES):
    """The ``tones`` [Hz] a record of ``duration`` [s] at the drive ``frequency`` [Hz]
    tells apart from the offset, the harmonics 1 ... ``harmonics`` and the fundamental's
    drift: at least :data:`MAINS_SEPARATION` resolution bins (1 / duration) from each.

    >>> mains_tones(100.0, 8, 0.06)  # 60 and 180 Hz within 3 bins of 0, 100 and 200 Hz
    (50.0, 150.0)
    >>> mains_tones(50.0, 8, 0.12)  # 50, 150 Hz on harmonics 1, 3; 60, 180 Hz 1.2, 2.4 bins off
    ()
    """
    k = np.arange(harmonics + 1) * frequency
    least = MAINS_SEPARATION / duration * (1.0 - 1e-9)
    return tuple(tone for tone in tones if np.min(np.abs(tone - k)) >= least)


def _without_tones(t, x, coef, harmonics, tones):
    """``x`` less the ``tones`` of the fit ``coef`` (:func:`_basis`'s order): the noise is
    the scatter about the drive's periodic response, and a mains tone between its harmonics
    would otherwise count as noise (a 50 Hz tone on a 100 Hz run changes sign from one
    period to the next)."""
    out = np.array(x, float)
    for n, tone in enumerate(tones):
        a, b = coef[2 + 2 * harmonics + 2 * n], coef[3 + 2 * harmonics + 2 * n]
        out -= a * np.cos(2.0 * math.pi * tone * t) + b * np.sin(2.0 * math.pi * tone * t)
    return out


def _lstsq(basis, x):
    """Least-squares coefficients by the normal equations (well-conditioned trig bases)."""
    gram = basis.T @ basis
    return np.linalg.solve(gram, basis.T @ x), gram


def current_fundamental(time, current, frequency):
    """The current's fundamental i = I_m cos(w t + phi) by least squares over ``time``.

    Returns (I_m [A], phi [rad], var(I_m) [A^2], var(phi) [rad^2]): the variances
    from the fit's residual (offset, a drift line and the harmonics the sampling
    resolves, :func:`fitted_harmonics`, in the basis). Every feature is referred to phi
    and the model is driven by I_m, so their errors are carried into the features'
    variances (:func:`smeha.diagnose.workflow.propagate_errors`).
    """
    t = np.asarray(time, dtype=float)
    w = 2.0 * math.pi * frequency
    # the harmonics the sampling resolves, as for y and E (module docstring): a drive
    # with distortion would otherwise leak through the drift line into the fundamental
    fitted = fitted_harmonics(float(np.median(np.diff(t))), frequency)
    basis = _basis(t, w, fitted, float(t.mean()))[:, :2 + 2 * fitted]
    c, gram = _lstsq(basis, current)
    r = current - basis @ c
    sigma2 = float(r @ r) / max(t.size - basis.shape[1], 1)
    cov = sigma2 * np.linalg.inv(gram)[2:4, 2:4]
    i1 = complex(c[2], -c[3])
    im = abs(i1)
    # along the phasor: amplitude; across it: phase (i1 = a - j b, components (a, b))
    along = np.array([i1.real, -i1.imag]) / im if im > 0 else np.array([1.0, 0.0])
    across = np.array([along[1], -along[0]])
    return (im, math.atan2(i1.imag, i1.real), float(along @ cov @ along),
            float(across @ cov @ across) / max(im * im, 1e-300))


def _samples_per_period(t, f):
    h = float(np.median(np.diff(t)))
    per = 1.0 / (f * h)
    n_per = int(round(per))
    uniform = float(np.max(np.abs(np.diff(t) - h))) <= 1e-6 * h
    whole = uniform and abs(per - n_per) < 1e-6 * per and n_per >= 8
    return h, per, (n_per if whole else None)


def fitted_harmonics(step, frequency, harmonics=HARMONICS):
    """Harmonics fitted beside the first ``harmonics`` when the samples ``step`` [s]
    apart resolve more at ``frequency`` [Hz] (:func:`_noise_harmonics`)."""
    return max(harmonics, _noise_harmonics(1.0 / (frequency * step)))


def _noise_harmonics(per):
    """Harmonics the noise fit may use when a period holds ``per`` samples (at least
    :data:`HARMONICS`: a run with at most 2 :data:`HARMONICS` samples a period, which does
    not resolve them, is skipped, :func:`run_features`)."""
    return int(max(HARMONICS, min(NOISE_HARMONICS, per // 3)))


def noise_estimate(t, x, f, t0, cycles):
    """(per-sample noise, source) of ``x`` over ``cycles`` whole periods from ``t0``.

    The period scatter about a line over the period index at each phase, with
    a whole number of samples a period and at least 3 periods; the scatter
    about a fit of many harmonics and the drift terms otherwise (module
    docstring). None when neither has 5 degrees of freedom.
    """
    span = 1.0 / f
    h, per, n_per = _samples_per_period(t, f)
    k0 = int(np.searchsorted(t, t0 - 1e-9 * span))
    if n_per is not None and cycles >= 3:
        rows = x[k0:k0 + cycles * n_per]
        if rows.size == cycles * n_per:
            mat = rows.reshape(cycles, n_per)
            c = np.arange(cycles, dtype=float)
            c -= c.mean()
            slope = (c @ mat) / (c @ c)
            res = mat - mat.mean(axis=0)[None, :] - c[:, None] * slope[None, :]
            dof = (cycles - 2) * n_per
            return math.sqrt(float((res * res).sum()) / dof), "period scatter"
    sel = (t >= t0 - 1e-9 * span) & (t < t0 + (cycles - 1e-9) * span)
    ts, xs = t[sel], x[sel]
    basis = _basis(ts, 2.0 * math.pi * f, _noise_harmonics(per), float(ts.mean()))
    dof = ts.size - basis.shape[1]
    if dof < 5:
        return None, "none"
    coef, _ = _lstsq(basis, xs)
    r = xs - basis @ coef
    return math.sqrt(float(r @ r) / dof), "harmonic fit"


def leading_transient(t, x, f, t_start, whole, noise=None) -> int:
    """Whole periods at the start of the record that are still transient (module docstring).

    Period c is compared with its prediction from the periods after it: with
    a whole number of samples a period, at each phase a polynomial in the
    period index through the later periods (a line, a parabola from 4 later
    periods on, so that a smooth drift is not taken for a transient) extrapolated
    to period c; otherwise a least-squares fit of the later periods (many
    harmonics, offset and fundamental drifting quadratically in time)
    extrapolated into it. The misfit chi^2 over its n samples, with the
    prediction's own variance, gives z = (chi^2 - n) / sqrt(2 n); above
    :data:`TRANSIENT_Z` the period is transient and the next one is checked,
    while a later period remains to compare it with. ``noise`` is the
    per-sample noise if known (else the later periods give it).

    Returns
    -------
    (int, bool)
        The periods dropped, and whether the first period kept was checked
        (False when the later periods were too few to give the noise and
        ``noise`` was not given).
    """
    span = 1.0 / f
    _, per, n_per = _samples_per_period(t, f)
    k0 = int(np.searchsorted(t, t_start - 1e-9 * span))
    mat = None
    if n_per is not None:
        rows = x[k0:k0 + whole * n_per]
        if rows.size == whole * n_per:
            mat = rows.reshape(whole, n_per)
    dropped = 0
    while whole - dropped >= 2:
        if mat is not None:
            z = _period_misfit(mat[dropped], mat[dropped + 1:], noise)
        else:
            z = _fit_misfit(t, x, f, t_start + dropped * span, whole - dropped, per, noise)
        if z is None:
            return dropped, False
        if z <= TRANSIENT_Z:
            break
        dropped += 1
    return dropped, True


def _period_misfit(first, later, noise):
    """z of ``first`` against the per-phase polynomial through the ``later`` periods."""
    n_later = later.shape[0]
    c = np.arange(1, n_later + 1, dtype=float)  # index of the later periods; first is 0
    degree = 2 if n_later >= 4 else (1 if n_later >= 2 else 0)
    design = np.vander(c, degree + 1, increasing=True)
    coef, *_ = np.linalg.lstsq(design, later, rcond=None)
    at0 = np.zeros(degree + 1)
    at0[0] = 1.0
    pred = at0 @ coef
    cov = np.linalg.pinv(design.T @ design)
    lev = float(at0 @ cov @ at0)
    dof = (n_later - degree - 1) * later.shape[1]
    if noise:
        sigma = noise
    elif dof >= 10:
        res = later - design @ coef
        sigma = math.sqrt(float((res * res).sum()) / dof)
    else:
        return None
    r = first - pred
    n = r.size
    chi2 = float(r @ r) / (sigma * sigma * (1.0 + lev))
    return (chi2 - n) / math.sqrt(2.0 * n)


def _fit_misfit(t, x, f, a, cycles, per, noise):
    """z of the period from ``a`` against a harmonic fit of the ``cycles - 1`` after it."""
    span = 1.0 / f
    w = 2.0 * math.pi * f
    b, end = a + span, a + cycles * span
    first = (t >= a - 1e-9 * span) & (t < b - 1e-9 * span)
    later = (t >= b - 1e-9 * span) & (t < end - 1e-9 * span)
    tl = t[later]
    quadratic = cycles - 1 >= 3
    basis = _basis(tl, w, _noise_harmonics(per), float(tl.mean()), quadratic)
    dof = tl.size - basis.shape[1]
    if dof < 10:
        return None
    coef, gram = _lstsq(basis, x[later])
    if noise:
        sigma = noise
    else:
        r_l = x[later] - basis @ coef
        sigma = math.sqrt(float(r_l @ r_l) / dof)
    if not sigma > 0:
        return None
    b1 = _basis(t[first], w, _noise_harmonics(per), float(tl.mean()), quadratic)
    lev = np.einsum("ij,ij->i", b1 @ np.linalg.inv(gram), b1)
    r1 = x[first] - b1 @ coef
    n = r1.size
    chi2 = float(np.sum(r1 * r1 / (sigma * sigma * (1.0 + lev))))
    return (chi2 - n) / math.sqrt(2.0 * n)


def _periods_used(run: Run, t, h, f, pooled_y, pooled_e):
    """Whole periods used, those dropped at the start as transient, and whether the first
    one used was checked (module docstring); SkippedRun for too few periods."""
    span = (t[-1] - t[0] + h) * f
    # a period short of less than one sample (a lab rate that is not a multiple of f) counts
    whole = int(math.floor(span + h * f + 1e-9))
    if whole < MIN_CYCLES:
        raise SkippedRun(run.name, f"{span:.3g} periods; a run needs at least {MIN_CYCLES} "
                                   "whole periods")
    t_start = float(t[0])
    dropped, checked = leading_transient(t, run.displacement, f, t_start, whole, pooled_y)
    if run.sense_voltage is not None:
        dropped_e, checked_e = leading_transient(t, run.sense_voltage, f, t_start, whole,
                                                 pooled_e)
        dropped, checked = max(dropped, dropped_e), checked and checked_e
    return whole - dropped, dropped, checked


def _noise(t, x, f, t0, cycles, pooled):
    """(per-sample noise, source) of ``x``: its own with 3 periods or more (or nothing
    pooled), else the pooled one (module docstring)."""
    if cycles >= 3 or pooled is None:
        return noise_estimate(t, x, f, t0, cycles)
    return pooled, "pooled"


def _phasors(coef, harmonics):
    """Complex harmonics a_k - j b_k of the fit's cos/sin coefficients (:func:`_basis`)."""
    return coef[2:2 + 2 * harmonics:2] - 1j * coef[3:3 + 2 * harmonics:2]


def _flux_density_from_y(run: Run, params, mask):
    """B_m [T] and its standard error from y's fundamental (eq 19), and M_1/H_m [-]
    (module docstring); SkippedRun when that B_m is not positive."""
    bm, se_b, mu_r, mu_i = flux_density_from_displacement(run, params, mask)
    bm, se_b = float(bm), float(se_b)
    if not (bm > 0 and math.isfinite(bm)):
        raise SkippedRun(run.name, f"B_m = {bm:g} T from the displacement's fundamental "
                                   "is not positive (no sense voltage)")
    return bm, se_b, complex(mu_r - 1.0, -mu_i)


def _check_resolved(name, per, f, harmonics) -> None:
    """SkippedRun where ``per`` samples a period at ``f`` [Hz] do not resolve the first
    ``harmonics`` harmonics (the k-th needs k < per / 2, Nyquist)."""
    if per <= 2 * harmonics:
        raise SkippedRun(name, f"{per:.3g} samples a period at {f:g} Hz resolve the "
                               f"harmonics up to the {math.ceil(per / 2) - 1}th; the "
                               f"features are the first {harmonics}: more than "
                               f"{2 * harmonics} samples a period are needed")


def run_features(run: Run, params: gmt.TransducerParameters | None = None,
                 harmonics: int = HARMONICS, pooled_noise=None) -> RunFeatures:
    """Reduce a run to its features (module docstring).

    Parameters
    ----------
    run : Run
    params : TransducerParameters, optional
        Table 2 by default (the sensing coil's N_c A_c, the mechanics for B_m
        from y).
    harmonics : int
    pooled_noise : (float or None, float or None), optional
        Per-sample noise of y [m] and of E [V] for runs with fewer than 3
        usable periods (the median of the other runs').

    Raises
    ------
    SkippedRun
        The run cannot be used (the reason says why).
    """
    params = params or gmt.TransducerParameters()
    f = float(run.frequency)
    w = 2.0 * math.pi * f
    t = np.asarray(run.time, dtype=float)
    h, per, _ = _samples_per_period(t, f)
    _check_resolved(run.name, per, f, harmonics)
    t_start = float(t[0])
    pooled_y, pooled_e = pooled_noise or (None, None)
    cycles, dropped, checked = _periods_used(run, t, h, f, pooled_y, pooled_e)
    t0 = t_start + dropped / f
    t1 = t0 + cycles / f
    mask = (t >= t0 - 1e-9 / f) & (t < t1 - 1e-9 / f)
    im, phi, im_var, phi_var = current_fundamental(t[mask], run.current[mask], f)
    if not im > 0:
        raise SkippedRun(run.name, f"the current has no fundamental at {f:g} Hz")
    ts, ys = t[mask], run.displacement[mask]
    t_mid = float(ts.mean())
    fitted = fitted_harmonics(h, f, harmonics)
    tones = mains_tones(f, fitted, cycles / f)
    basis = _basis(ts, w, fitted, t_mid, tones=tones)
    if ts.size < 2 * basis.shape[1]:
        raise SkippedRun(run.name, f"{ts.size} samples in {cycles} periods; the features need "
                                   f"at least {2 * basis.shape[1]}")
    gram_inv = np.linalg.pinv(basis.T @ basis)
    cy = gram_inv @ (basis.T @ ys)  # normal equations: near-orthogonal columns
    noise_y, source = _noise(t, _without_tones(t, run.displacement, cy, fitted, tones),
                             f, t0, cycles, pooled_y)
    if noise_y is None:
        raise SkippedRun(run.name, "too few samples to estimate the noise")
    k = np.arange(1, harmonics + 1)
    rot = np.exp(-1j * k * phi)
    yk = _phasors(cy, fitted)[:harmonics] * rot
    diag = np.diag(gram_inv)
    dvar = 0.5 * (diag[2:2 + 2 * harmonics:2] + diag[3:3 + 2 * harmonics:2])
    ratio = None
    if run.sense_voltage is not None:  # B_k = j E_k / (k w N_c A_c), eq 21
        ce = gram_inv @ (basis.T @ run.sense_voltage[mask])
        noise_e, _ = _noise(t, _without_tones(t, run.sense_voltage, ce, fitted, tones),
                            f, t0, cycles, pooled_e)
        ek = _phasors(ce, fitted)[:harmonics] * rot
        na = params.sense_turns * params.sense_area
        bk = 1j * ek / (k * w * na)
        b_var = noise_e ** 2 * dvar / (k * w * na) ** 2
        bm, se_b, b_source = float(abs(bk[0])), float(math.sqrt(b_var[0])), "sense_voltage"
    else:
        bk = b_var = noise_e = None
        bm, se_b, ratio = _flux_density_from_y(run, params, mask)
        b_source = "displacement"
    y1s = complex(cy[-2], -cy[-1]) * np.exp(-1j * phi)
    return RunFeatures(
        name=run.name, frequency=f, current_amplitude=im, current_phase=phi, step=h,
        cycles=cycles, y=yk, y_var=noise_y ** 2 * dvar, b=bk, b_var=b_var,
        offset_slope=float(cy[1]), offset_slope_var=noise_y ** 2 * float(diag[1]),
        y1_slope=y1s, y1_slope_var=noise_y ** 2 * 0.5 * float(diag[-1] + diag[-2]),
        flux_density_amplitude=bm, flux_density_stderr=se_b,
        noise_y=noise_y, noise_e=noise_e, time=ts, displacement=ys,
        current=run.current[mask], t_start=t_start, t_mid=t_mid,
        flux_density_source=b_source, magnetization_ratio=ratio, dropped_cycles=dropped,
        noise_source=source, current_amplitude_var=im_var, current_phase_var=phi_var,
        transient_checked=checked)


def extract(runs, params) -> tuple[dict, list]:
    """Features of every usable run and the skipped ones: ({name: RunFeatures}, [(name, reason)]).

    Runs with at least 3 usable periods are reduced first; their median noise
    is the pooled noise of the shorter ones, and of those whose start could not
    be checked without it (module docstring).
    """
    feats, skipped = {}, []
    for run in runs:
        try:
            feats[run.name] = run_features(run, params)
        except SkippedRun as exc:
            skipped.append((run.name, exc.reason))
    short = [r for r in runs if r.name in feats and (feats[r.name].cycles < 3
                                                     or not feats[r.name].transient_checked)]
    long_ = [rf for rf in feats.values() if rf.cycles >= 3 and rf.transient_checked]
    if short and long_:
        ny = float(np.median([rf.noise_y for rf in long_]))
        ne = [rf.noise_e for rf in long_ if rf.noise_e is not None]
        pooled = (ny, float(np.median(ne)) if ne else None)
        for run in short:
            try:
                feats[run.name] = run_features(run, params, pooled_noise=pooled)
            except SkippedRun as exc:
                del feats[run.name]
                skipped.append((run.name, exc.reason))
    order = {r.name: k for k, r in enumerate(runs)}
    return dict(sorted(feats.items(), key=lambda kv: order[kv[0]])), skipped
