"""What identification gives: per run (:class:`RunIdentification`), the loss
coefficients (:class:`LossFit`) and both together (:class:`Identification`)."""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import gmt
from gmt.constants import MU_0

__all__ = ["LOSS_COEFFICIENTS", "RunIdentification", "LossFit", "Identification"]

#: Names, symbols and units of the loss coefficients (eqs 7, 9, 11).
LOSS_COEFFICIENTS = (
    ("K_h", "hysteresis_coefficient", "W s/(m^3 T^n)"),
    ("n", "steinmetz_exponent", "-"),
    ("K_e", "eddy_coefficient", "W s^2/(m^3 T^2)"),
    ("K_ex", "excess_coefficient", "W s^1.5/(m^3 T^1.5)"),
)


@dataclass(frozen=True)
class RunIdentification:
    """What one run gives: B_m, the complex permeability and the fit quality.

    Attributes
    ----------
    run : str
        Run label.
    frequency : float
        f, [Hz].
    current_amplitude : float
        I_m of the current's fundamental, [A].
    field_amplitude : float
        H_m = N I_m / (k_f L), [A/m] (eq 1).
    flux_density_amplitude, flux_density_stderr : float
        B_m and its standard error, [T].
    flux_density_source : {"sense_voltage", "displacement"}
        Where B_m came from (:mod:`smeha.identify`, step 1).
    mu_imag, mu_imag_stderr : float
        mu'' minimising the eq 30 error, and its standard error including the
        propagated uncertainty of B_m, [-].
    mu_imag_fit_stderr : float
        Standard error of mu'' from the loop fit alone (B_m held), [-].
    mu_imag_flux_sensitivity : float
        d mu''/d B_m of the loop fit (B_m held at a shifted value), [1/T];
        with ``flux_density_stderr`` it carries B_m's error into the loss fit.
    mu_imag_at_bound : bool
        True when mu'' ended on a bound of the scan (the minimum may lie
        outside it).
    scan_upper : float
        Upper bound of the scan, min(10, |mu|) just below |mu|, [-].
    mu_real : float
        mu' from eq 20, [-].
    lag : float
        Lag of B behind H, arctan(mu''/mu'), [rad] (eq 18).
    rms_residual : float
        RMS of measured minus model displacement over the fitted samples, [m].
    offset : float
        Fitted constant added to the model's displacement, [m].
    samples : int
        Samples in the fit (after the discarded transient).
    discarded_time : float
        Time discarded at the start of the run as transient, [s].
    """

    run: str
    frequency: float
    current_amplitude: float
    field_amplitude: float
    flux_density_amplitude: float
    flux_density_stderr: float
    flux_density_source: str
    mu_imag: float
    mu_imag_stderr: float
    mu_imag_fit_stderr: float
    mu_imag_flux_sensitivity: float
    mu_imag_at_bound: bool
    scan_upper: float
    mu_real: float
    lag: float
    rms_residual: float
    offset: float
    samples: int
    discarded_time: float

    @property
    def flags(self) -> tuple:
        """Why this run's values make no physical sense (:func:`smeha.identify.flags.run_flags`:
        B_m, H_m, mu'', mu', the lag); empty when they do."""
        from .flags import run_flags
        return run_flags(self)

    @property
    def physical(self) -> bool:
        """True when no flag was raised (:attr:`flags`)."""
        return not self.flags

    @property
    def loss_density(self) -> float:
        """P/V = pi f mu_0 mu'' H_m^2, [W/m^3] (eq 13)."""
        return math.pi * self.frequency * MU_0 * self.mu_imag * self.field_amplitude ** 2

    def as_dict(self) -> dict:
        """JSON-able dict: SI fields plus ``lag_deg``, ``rms_residual_um``,
        ``loss_density_W_m3``, ``physical`` and ``flags`` (:attr:`flags`)."""
        d = {k: (None if isinstance(v, float) and not math.isfinite(v) else v)
             for k, v in asdict(self).items()}
        d["lag_deg"] = math.degrees(self.lag)
        d["rms_residual_um"] = self.rms_residual * 1e6
        d["loss_density_W_m3"] = self.loss_density
        d["physical"], d["flags"] = self.physical, list(self.flags)
        return d


@dataclass(frozen=True)
class LossFit:
    """K_h, n, K_e, K_ex from the set of eqs 16 (weighted least squares).

    Attributes
    ----------
    values : tuple of float
        (K_h, n, K_e, K_ex) in the units of :data:`LOSS_COEFFICIENTS`.
    stderrs : tuple of float or None
        Standard uncertainties; None when not determined (``note`` says why).
    correlation : tuple of tuple of float, or None
        Correlation matrix of the four, in the same order.
    runs : int
        Runs in the fit.
    residual_variance : float or None
        Sum of squared weighted residuals over the degrees of freedom
        (about 1 when the per-run standard errors are right); None without
        degrees of freedom.
    note : str
        What limits the result, or "".
    flags : tuple of str
        Why the coefficients are not a physical result, when they are not
        (:func:`~smeha.identify.physical_flags`): a negative loss coefficient, an uncertainty
        larger than the value, a residual variance the per-run errors cannot
        explain; and (:func:`smeha.identify.flags.loss_law_flags`) n on or
        outside its physical range, a negative loss per cycle predicted at a
        run. Empty for a fit that makes physical sense.
    """

    values: tuple
    stderrs: tuple | None
    correlation: tuple | None
    runs: int
    residual_variance: float | None
    note: str = ""
    flags: tuple = ()

    @property
    def physical(self) -> bool:
        """True when no flag was raised (:attr:`flags`)."""
        return not self.flags

    @property
    def names(self) -> tuple[str, ...]:
        """("K_h", "n", "K_e", "K_ex")."""
        return tuple(n for n, _, _ in LOSS_COEFFICIENTS)

    def parameters(self, params: gmt.TransducerParameters | None = None):
        """A :class:`gmt.TransducerParameters` with these coefficients (others from ``params``)."""
        params = params or gmt.TransducerParameters()
        return params.replace(**{attr: v for (_, attr, _), v in
                                 zip(LOSS_COEFFICIENTS, self.values)})

    def as_dict(self) -> dict:
        """``{name: {"value", "stderr", "unit"}}``, JSON-able."""
        out = {}
        for k, (name, _, unit) in enumerate(LOSS_COEFFICIENTS):
            out[name] = {"value": self.values[k],
                         "stderr": None if self.stderrs is None else self.stderrs[k],
                         "unit": unit}
        return out


@dataclass(frozen=True)
class Identification:
    """Result of :func:`~smeha.identify.identify`: every run and the loss coefficients.

    Attributes
    ----------
    runs : tuple of RunIdentification
    loss_fit : LossFit or None
        None when there are fewer than four runs (``note`` says so).
    note : str
    extended_law : dict or None
        The extended loss law's parameters (:func:`smeha.identify.losses.fit_extended_losses`,
        field names of gmt.TransducerParameters and gmt.TimeDomainParameters), or None.
    extended_note : str
        Why the extended law was not fitted.
    """

    runs: tuple
    loss_fit: LossFit | None
    note: str = ""
    extended_law: dict | None = None
    extended_note: str = ""

    @property
    def flags(self) -> tuple:
        """Every flag of the runs (``"run: flag"``) and of the loss fit, in that order."""
        out = tuple(f"{r.run}: {flag}" for r in self.runs for flag in r.flags)
        return out + (self.loss_fit.flags if self.loss_fit is not None else ())

    @property
    def physical(self) -> bool:
        """True when neither a run nor the loss fit raised a flag."""
        return not self.flags

    def as_dict(self) -> dict:
        """``{"runs": [...], "loss_coefficients": {...} | None, "correlation": ...,
        "loss_fit": ..., "physical", "flags"}``."""
        lf = self.loss_fit
        return {
            "physical": self.physical,
            "flags": list(self.flags),
            "runs": [r.as_dict() for r in self.runs],
            "loss_coefficients": None if lf is None else lf.as_dict(),
            "correlation": None if lf is None or lf.correlation is None else
            {"names": list(lf.names), "matrix": [list(row) for row in lf.correlation]},
            "loss_fit": None if lf is None else
            {"runs": lf.runs, "residual_variance": lf.residual_variance, "note": lf.note,
             "physical": lf.physical, "flags": list(lf.flags),
             "method": "weighted least squares on the set of eqs 16 (weights 1/stderr(mu''))"},
            "note": self.note,
            "extended_loss_law": {"parameters": self.extended_law, "note": self.extended_note},
        }
