"""Why an identified value makes no physical sense: per run, and for the loss law.

Every quantity ``smeha identify`` reports has a physical range the paper's model
(eqs 13-20) presumes. A value outside it is reported as it is, and flagged with
the reason; it is never clipped.

Per run (:func:`run_flags`):

* **B_m** and **H_m** are amplitudes (eqs 1, 19, 22): positive. B_m = 0 means
  no flux was seen (an open sense coil, an empty column);
* **mu''** >= 0: the loss per unit volume and cycle is pi mu_0 mu'' H_m^2
  (eqs 13-14), and a passive rod cannot give back more energy over a cycle
  than it receives; mu'' < 0 makes the **loss density** of eq 13 negative;
* **mu'** real (eq 20): mu'' <= |mu| = B_m / (mu_0 H_m) (eq 19), else eq 20 has
  no real root;
* **mu'** >= 1: the rod's relative permeability, against vacuum's 1. The
  magnetisation the excitation adds in phase with H is (mu' - 1) H (eq 25,
  where it drives the strain); mu' < 1 makes it oppose the field, a
  diamagnet, which Terfenol-D is not (the paper: a GMM rod's relative
  permeability is between 1 and 10; Table 1's B_m give |mu| of 1.6 to 2.9).
  A measured B_m that is low for H_m, as eddy currents shielding the rod
  make it, shows up this way: the paper's model does not describe the run;
* the **lag** phi = arctan(mu''/mu') of eq 18 lies in [0, 90] deg for such a
  rod (mu'' >= 0, mu' > 0): B lags H by less than a quarter period.

The loss law (:func:`loss_law_flags`, beside
:func:`smeha.identify.physical_flags` for the coefficients' signs, their
uncertainties and the residual variance):

* **n** inside (not on the bound of) :data:`gmt.parameters.STEINMETZ_RANGE`,
  [1, 3]: 3 is the Rayleigh law of eq 6 (loss per cycle growing as H_m^3, so
  B_m^3, at low fields), 1 a loop of fixed coercive field whose area grows as
  B_m; the paper states 1.5 to 2.5 for the rod (after eq 7). The fit stops on
  the bound when the data ask for more;
* the **loss per cycle** eq 16 predicts with the fitted coefficients, at every
  run's f and B_m: never negative (each K is a loss per cycle, eqs 7, 9, 11,
  but a negative one may hide in a positive total, or not).
"""
from __future__ import annotations

import math

import numpy as np

from gmt.constants import MU_0
from gmt.parameters import STEINMETZ_RANGE

__all__ = ["run_flags", "loss_law_flags"]

#: Largest lag of B behind H of a passive, magnetisable rod, [deg] (eq 18).
MAX_LAG_DEG = 90.0


def run_flags(run) -> tuple:
    """Why a run's identified values make no physical sense (module docstring); () if they do.

    Parameters
    ----------
    run : RunIdentification
        Its ``flux_density_amplitude`` [T], ``field_amplitude`` [A/m],
        ``mu_imag``, ``mu_real`` [-] and ``lag`` [rad] are checked.

    Returns
    -------
    tuple of str
        One text a flag, naming the quantity, its value, the bound and the
        equation.
    """
    flags = []
    bm, hm, mu2, mu1 = (run.flux_density_amplitude, run.field_amplitude, run.mu_imag,
                        run.mu_real)
    if not bm > 0.0:
        flags.append(f"B_m = {bm:.4g} T is not positive: an amplitude (eqs 19, 22); no flux "
                     "was seen (an open sense coil or an empty column?)")
    if not hm > 0.0:
        flags.append(f"H_m = {hm:.4g} A/m is not positive: an amplitude (eq 1)")
    if mu2 < 0.0:
        flags.append(f"mu'' = {mu2:.4g} < 0: the loss per cycle pi mu_0 mu'' H_m^2 (eqs 13-14) "
                     "would be negative, a rod giving back more energy than it receives")
    if bm > 0.0 and hm > 0.0 and not math.isfinite(mu1):
        flags.append(f"mu' is not real: mu'' = {mu2:.4g} exceeds |mu| = B_m/(mu_0 H_m) = "
                     f"{bm / (MU_0 * hm):.4g} (eqs 19, 20)")
    elif mu1 < 1.0:
        flags.append(f"mu' = {mu1:.4g} < 1 (eq 20): a relative permeability below vacuum's; "
                     "the in-phase magnetisation (mu' - 1) H_m (eq 25) would oppose the field. "
                     "B_m is low for H_m (eddy currents shielding the rod, or a sense coil "
                     "missing flux): the paper's model does not describe this run")
    lag = math.degrees(run.lag)
    if not 0.0 <= lag <= MAX_LAG_DEG:
        flags.append(f"lag = {lag:.4g} deg is outside [0, {MAX_LAG_DEG:g}] deg: eq 18's "
                     "arctan(mu''/mu') of a passive (mu'' >= 0), magnetisable (mu' > 0) rod")
    return tuple(flags)


def loss_law_flags(values, runs, volume: float, terms) -> tuple:
    """Why the fitted loss law makes no physical sense at the runs (module docstring).

    Parameters
    ----------
    values : sequence of float
        (K_h, n, K_e, K_ex).
    runs : sequence of RunIdentification
        Their ``frequency`` [Hz], ``flux_density_amplitude`` [T] and
        ``field_amplitude`` [A/m] are where eq 16 is evaluated.
    volume : float
        Rod volume V, [m^3] (cancels in eq 16).
    terms : callable
        ``terms(n, f, B_m, H_m, V)``: mu'' per unit K_h, K_e, K_ex (eq 16's three
        terms), arrays.
    """
    flags = []
    kh, n, ke, kex = values
    lo, hi = STEINMETZ_RANGE
    span = hi - lo
    if not lo + 1e-6 * span < n < hi - 1e-6 * span:
        where = "outside" if not lo <= n <= hi else "on the bound of"
        flags.append(f"n = {n:.4g} is {where} its physical range [{lo:g}, {hi:g}] (3: the "
                     "Rayleigh law of eq 6; 1: a loop of fixed coercive field): the data ask "
                     "for a loss law eq 7 cannot give")
    if runs:
        f = np.array([r.frequency for r in runs])
        bm = np.array([r.flux_density_amplitude for r in runs])
        hm = np.array([r.field_amplitude for r in runs])
        ph, pe, px = terms(n, f, bm, hm, volume)
        mu = kh * ph + ke * pe + kex * px
        bad = np.flatnonzero(mu < 0.0)
        if bad.size:
            k = int(bad[np.argmin(mu[bad])])
            flags.append(f"eq 16 with these coefficients gives a negative loss per cycle at "
                         f"{bad.size} run(s), down to mu'' = {mu[k]:.3g} at {runs[k].run!r} "
                         f"(f = {f[k]:g} Hz, B_m = {bm[k]:.4g} T)")
    return tuple(flags)
