"""Implausible measurements caught before any fit: wrong units under a column's name.

A file whose numbers are in another unit than its header says (metres under
``displacement_um``, mA under ``current_A``, mV under ``sense_voltage_V``)
reads without error, and a fit then "explains" it with absurd parameters. So
:func:`check_plausible` compares each run's magnitudes with what the paper's
model of this transducer gives for the same run, before ``smeha identify`` or
``smeha diagnose`` fit anything, and refuses the file with a message that names
the column, the value and the unit the numbers most likely are in.

The checks, per run, in this order (each uses only what the ones before it
accepted):

1. **current**: the amplitude I_m of the current's fundamental must lie in
   [:data:`CURRENT_RANGE`] A. The coil has N = 1300 turns on an 80 mm rod
   (Table 2), so 1 A already drives H_m = 14.8 kA/m (eq 1), and Terfenol-D
   is near saturation at some 100-200 kA/m (Engdahl (ed.), *Handbook of Giant
   Magnetostrictive Materials*, Academic Press 2000, ch. 1): tens of amperes
   are not a measurement of this transducer;
2. **sense voltage** (when present): |mu| = B_m / (mu_0 H_m) (eqs 19, 22) must
   lie in [:data:`PERMEABILITY_RANGE`]; Terfenol-D's relative permeability is
   of order 2-10 (Table 1 gives |mu| = 1.6 to 2.9);
3. **displacement**: the amplitude of y's fundamental over the paper's model's
   at the same f, I_m and B_m (eq 30 in steady state, Table 2) must lie in
   [:data:`DISPLACEMENT_RATIO_RANGE`]. Any effect the diagnosis looks for
   changes that ratio by far less than the factor 1000 between metres,
   millimetres, micrometres and nanometres.

A value outside its range raises :class:`~smeha.measured.DataError` naming the
file, the run and the column, and, when a power of 1000 brings the value into
range, the unit the numbers look like.
"""
from __future__ import annotations

import math

import numpy as np

import gmt
from gmt.constants import MU_0
from gmt.extensions.steady import steady_state

from .measured import DataError, Run, harmonic_basis

__all__ = ["CURRENT_RANGE", "PERMEABILITY_RANGE", "DISPLACEMENT_RATIO_RANGE", "check_plausible"]

#: Plausible amplitude of the current's fundamental, [A] (module docstring).
CURRENT_RANGE = (1e-3, 20.0)
#: Plausible |mu| = B_m / (mu_0 H_m) from the sense voltage, [-].
PERMEABILITY_RANGE = (0.2, 200.0)
#: Plausible measured over modelled amplitude of y's fundamental, [-].
DISPLACEMENT_RATIO_RANGE = (0.05, 20.0)

#: Units a column's numbers might be in instead, as factors to the column's own unit.
_CURRENT_UNITS = {"mA": 1e-3, "kA": 1e3, "uA": 1e-6}
_VOLTAGE_UNITS = {"mV": 1e-3, "uV": 1e-6, "kV": 1e3}
_LENGTH_UNITS = {"m": 1.0, "mm": 1e-3, "um": 1e-6, "nm": 1e-9}


def _amplitude(run: Run, signal) -> float:
    coef, *_ = np.linalg.lstsq(harmonic_basis(run.time, run.frequency, 3), signal, rcond=None)
    return float(math.hypot(coef[1], coef[2]))


def _likely(value, allowed, units, own_factor=1.0):
    """The unit among ``units`` that brings ``value`` into ``allowed``, or None."""
    lo, hi = allowed
    for name, factor in units.items():
        if factor == own_factor:
            continue
        v = value * factor / own_factor
        if lo <= v <= hi:
            return name, factor
    return None


def check_plausible(runs, params: gmt.TransducerParameters | None = None) -> None:
    """Raise DataError for the first run whose magnitudes are implausible (module docstring).

    Parameters
    ----------
    runs : sequence of Run
        As :func:`smeha.measured.read_measurements` gives them (SI). The
        displacement column a run came from is ``run.meta["displacement_column"]``
        when the reader set it.
    params : TransducerParameters, optional
        Default Table 2.
    """
    params = params or gmt.TransducerParameters()
    for run in runs:
        _check_run(run, params)


def _check_run(run: Run, params) -> None:
    im = _amplitude(run, run.current)
    lo, hi = CURRENT_RANGE
    if not lo <= im <= hi:
        guess = _likely(im, CURRENT_RANGE, _CURRENT_UNITS)
        hint = (f"; the numbers look like {guess[0]} (I_m = {im * guess[1]:.3g} A): convert "
                "them to amperes" if guess else "")
        raise DataError(f"{run.where()}: column current_A: the current's amplitude is "
                        f"{im:.4g} A, outside the range [{lo:g}, {hi:g}] A of this transducer's "
                        f"coil (1 A drives H_m = {params.field_per_ampere / 1e3:.3g} kA/m, "
                        f"eq 1){hint}", run.source, run.name)
    hm = params.field_per_ampere * im
    w = 2.0 * math.pi * run.frequency
    if run.sense_voltage is not None:
        bm = _amplitude(run, run.sense_voltage) / (w * params.sense_turns * params.sense_area)
        mu = bm / (MU_0 * hm)
        lo, hi = PERMEABILITY_RANGE
        if not lo <= mu <= hi:
            guess = _likely(mu, PERMEABILITY_RANGE, _VOLTAGE_UNITS)
            hint = (f"; the numbers look like {guess[0]} (|mu| = {mu * guess[1]:.3g}): convert "
                    "them to volts" if guess else "")
            raise DataError(
                f"{run.where()}: column sense_voltage_V: the voltage's amplitude "
                f"{bm * w * params.sense_turns * params.sense_area:.4g} V gives B_m = "
                f"{bm:.4g} T and |mu| = B_m / (mu_0 H_m) = {mu:.4g} (eqs 19, 22), outside "
                f"[{lo:g}, {hi:g}] for Terfenol-D{hint}", run.source, run.name)
    else:  # B_m as the paper's Table 1 calibration gives it (gmt.calibration)
        bm = gmt.DEFAULT_CALIBRATION.flux_density_amplitude(run.frequency, im)
    loss = (params.hysteresis_coefficient, params.steinmetz_exponent, params.eddy_coefficient,
            params.excess_coefficient)
    model = abs(steady_state(params, run.frequency, im, bm, loss, harmonics=1).displacement[0])
    measured = _amplitude(run, run.displacement)
    ratio = measured / model
    lo, hi = DISPLACEMENT_RATIO_RANGE
    if not lo <= ratio <= hi:
        column = run.meta.get("displacement_column", "displacement") if run.meta else \
            "displacement"
        own = {"displacement_um": 1e-6, "displacement_m": 1.0}.get(column, 1.0)
        shown = 1.0 if column == "displacement_m" else 1e-6
        unit = {1e-6: "um", 1.0: "m"}[shown]
        guess = _likely(ratio, DISPLACEMENT_RATIO_RANGE,
                        {k: v / own for k, v in _LENGTH_UNITS.items()}, 1.0)
        hint = ""
        if guess:
            name, factor = guess
            target = {"m": "displacement_m", "um": "displacement_um"}.get(name)
            hint = (f"; the numbers look like {name} (the amplitude would then be "
                    f"{measured * factor * 1e6:.3g} um)"
                    + (f": put them under {target}" if target and target != column else
                       ": convert them"))
        raise DataError(
            f"{run.where()}: column {column}: the displacement's amplitude is "
            f"{measured / shown:.4g} {unit} at {run.frequency:g} Hz and {im:.3g} A, where the "
            f"paper's model of this transducer gives {model / shown:.4g} {unit} (eq 30, "
            f"Table 2; ratio {ratio:.3g}, plausible [{lo:g}, {hi:g}]){hint}",
            run.source, run.name)
