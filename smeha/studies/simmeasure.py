"""A co-simulated run as a measurement of the transducer (docs/MEASURED.md), for
``smeha identify`` and ``smeha diagnose``.

What the diagnosis fits is the transducer on its own (eq 30 through eq 27: the rod moved by
its magnetostrictive force alone, eqs 25-27), from the coil current, the rod's displacement
and the sensing coil's voltage. In the pump the rod also carries the chamber's force A_d p_P
(1.5 MPa and more over 20 mm^2 of piston, the valves switching it twice a cycle), so the
record's ``rod_displacement`` is the free stroke minus the chamber's push: the paper's model
of the transducer cannot describe it, and the diagnosis answered ``unexplained`` for the
paper's own model. A lab diagnoses a transducer on its own, so the measurement written here
is the transducer's own channels, which the force port records beside the pump's
(:data:`system_models.record.RESULT_FIELDS`): the FMU's rod with no chamber force, as its
displacement sensor reads it (``free_displacement``; a variant's sensor delay included), and
its flux density B, turned into the sensing coil's voltage by eq 21.

Like a lab's record (and the independent generator's, tests/labsim/), the channels are
sampled on one clock, the communication step (the extra points the valve actions add are
left out), and carry sensor noise: without any noise the diagnosis compares the
co-simulation's numerical error (1e-4 of the stroke) with a noise level of 1e-10 um and
finds every model outside it. The noise is Gaussian, its default that of the generator's
lab (0.05 um on y, 0.5 mV on E), seeded by the run's name, so a data set is reproducible.
"""
from __future__ import annotations

import zlib

import numpy as np

import gmt

from .. import measured

__all__ = ["DISPLACEMENT_NOISE", "VOLTAGE_NOISE", "run_name", "sense_voltage",
           "hold_correction", "uneven_steps", "variant_sensor", "measurement_run"]

#: Default sensor noise (standard deviation) on the displacement, [m], and on the sensing
#: coil's voltage, [V]: those of the independent generator's lab (tests/labsim/acquisition.py).
DISPLACEMENT_NOISE = 0.05e-6
VOLTAGE_NOISE = 0.5e-3


def run_name(mode: str, frequency: float, amplitude: float | None) -> str:
    """'<mode>_<f>Hz', with '_<a>' (the control amplitude, A uncompensated, V compensated)
    when the run's amplitude is not the study's default."""
    name = f"{mode}_{frequency:g}Hz"
    if amplitude is not None:
        name += f"_{amplitude:g}{'A' if mode == 'uncompensated' else 'V'}"
    return name


def sense_voltage(time, flux_density, params: gmt.TransducerParameters | None = None):
    """The sensing coil's voltage E = -N_c A_c dB/dt (eq 21) at the samples, [V].

    dB/dt by the fourth-order central difference on the evenly spaced samples
    (-B_(k+2) + 8 B_(k+1) - 8 B_(k-1) + B_(k-2)) / 12 h, whose gain on a harmonic of
    angular frequency w is (8 sin wh - sin 2wh) / 6 wh = 1 - (wh)^4/30 + ...: 5e-7 at 100
    samples a period (Abramowitz & Stegun 1964, 25.3.6). The first and last two samples
    have no such difference and are returned as NaN.
    """
    params = params or gmt.TransducerParameters()
    t = np.asarray(time, dtype=float)
    b = np.asarray(flux_density, dtype=float)
    h = float(np.mean(np.diff(t)))
    rate = np.full(b.size, np.nan)
    rate[2:-2] = (-b[4:] + 8.0 * b[3:-1] - 8.0 * b[1:-3] + b[:-4]) / (12.0 * h)
    return gmt.sensing.induced_voltage(rate, params.sense_turns, params.sense_area)


def _rod_matrices(mechanics) -> tuple:
    """(A, b, output row) of the rod's state space (system_models.rod: one mass (y, v), or
    rod and output mass (y_1, v_1, y_2, v_2), the sensor on the output)."""
    m, c, k, m2, kj, cj = (tuple(mechanics) + (0.0, 0.0, 0.0))[:6]
    if m2 > 0.0:
        a = np.array([[0.0, 1.0, 0.0, 0.0],
                      [-(k + kj) / m, -(c + cj) / m, kj / m, cj / m],
                      [0.0, 0.0, 0.0, 1.0],
                      [kj / m2, cj / m2, -kj / m2, -cj / m2]])
        return a, np.array([0.0, 1.0 / m, 0.0, 0.0]), 2
    return np.array([[0.0, 1.0], [-k / m, -c / m]]), np.array([0.0, 1.0 / m]), 0


def hold_correction(time, force, mechanics) -> np.ndarray:
    """What the rod's displacement gains when its force is linear between the samples
    instead of held at each sample's value, [m].

    The transducer steps its own rod with the force held over a step (the exact
    zero-order hold of eq 27); under a continuous drive its displacement then trails the
    rod's by half a step (a ZOH is a delay of h/2 to first order: 2.6 us at h = 50 us,
    which the diagnosis names as a transport delay). The co-simulation's plant takes the
    force linear over a step (system_models.forceport); the difference of the two exact
    discretisations is the response to the force's ramp within each step,
    d_(k+1) = Phi d_k + Gamma_1 (F_(k+1) - F_k), with Phi = e^(A h) and Gamma_1 from the
    exponential of the system augmented by the input and its ramp (Franklin, Powell &
    Workman, *Digital Control of Dynamic Systems*, 3rd ed. 1998, sec. 6.3.2, the
    triangle hold).
    """
    from scipy.linalg import expm
    a, b, out = _rod_matrices(mechanics)
    n = a.shape[0]
    t, f = np.asarray(time, dtype=float), np.asarray(force, dtype=float)
    d = np.zeros(n)
    y = np.zeros(t.size)
    cache = {}
    for k in range(t.size - 1):
        h = t[k + 1] - t[k]
        key = round(h * 1e12)
        if key not in cache:
            big = np.zeros((n + 2, n + 2))
            big[:n, :n], big[:n, n], big[n, n + 1] = a * h, b * h, 1.0
            e = expm(big)
            cache[key] = (e[:n, :n], e[:n, n + 1])
        phi, gamma = cache[key]
        d = phi @ d + gamma * (f[k + 1] - f[k])
        y[k + 1] = d[out]
    return y


def _on_clock(t, step) -> np.ndarray:
    """The rows on the sample clock (multiples of ``step``), one a tick."""
    ticks = np.round(t / step)
    on_clock = np.abs(t - ticks * step) <= 1e-9 * step
    on_clock[1:] &= np.diff(ticks) > 0  # one sample a tick (a valve action on the tick)
    return on_clock


def uneven_steps(record, step) -> int:
    """Communication points between the clock's ticks (valve actions, but the run's end):
    the transducer took the steps around them unevenly. Its paper magnetics' quadrature is
    less accurate there: at 150 Hz and 50 us, B lagged 0.34 deg, which the diagnosis saw
    (docs/DIAGNOSE.md, Simulated data)."""
    t = np.asarray(record["time"])[:-1]
    return int(np.count_nonzero(~_on_clock(t, step)))


def variant_sensor(variant):
    """The displacement sensor of a model variant (its time-stepped form, at rest at 0), or
    None for the paper's model and variants whose sensor reads the rod as it is."""
    if variant is None or variant.is_paper:
        return None
    chain = getattr(gmt.Transducer(variant=variant).forward, "chain", None)
    sensor = getattr(chain, "sensor", None)
    if sensor is not None:
        sensor.reset(0.0)
    return sensor


def measurement_run(record, name: str, frequency: float, step: float,
                    displacement_noise: float = DISPLACEMENT_NOISE,
                    voltage_noise: float = VOLTAGE_NOISE, seed: int = 0,
                    mechanics=None, sensor=None) -> measured.Run:
    """The record's transducer channels as a measured run (module docstring).

    Parameters
    ----------
    record : structured array
        :func:`system_models.cosim.cosimulate`'s record, from the force port (its
        ``free_displacement`` and ``flux_density``).
    name : str
        The run's label.
    frequency, step : float
        The drive's frequency [Hz] and the communication step, the sample clock [s].
    displacement_noise, voltage_noise : float
        Standard deviations of the sensor noise on y [m] and on E [V], >= 0.
    seed : int
        With the run's name, the noise's seed.
    mechanics : sequence or None
        The rod's :class:`gmt.RodMechanics` under a continuous drive (the force linear
        between samples, :func:`hold_correction`); None under a held one (the digital
        compensator's current), whose transducer output is exact.
    sensor : object or None
        The variant's displacement sensor (:func:`variant_sensor`): the correction reaches
        the reading through it, as the rod's displacement does (a transport delay of 50 us
        left out put 0.06 um of error into a 200 Hz run).
    """
    gmt.errors.check_range("displacement_noise", displacement_noise, 0.0, 1e-3, unit="m")
    gmt.errors.check_range("voltage_noise", voltage_noise, 0.0, 10.0, unit="V")
    if not np.all(np.isfinite(record["free_displacement"])):
        raise gmt.ParameterError(
            "the record has no free displacement of the transducer (the displacement "
            "port's rod carries the chamber's force): a measurement needs coupling 'force'")
    y_free = record["free_displacement"]
    if mechanics is not None:
        correction = hold_correction(record["time"], record["force"], mechanics)
        if sensor is not None:  # linear, at rest at 0: the correction as the sensor reads it
            correction = np.array([correction[0]] + [
                sensor.sensed(d, t) for d, t in zip(correction[1:], record["time"][1:])])
        y_free = y_free + correction
    on_clock = _on_clock(record["time"], step)
    rows, y_free = record[on_clock], y_free[on_clock]
    voltage = sense_voltage(rows["time"], rows["flux_density"])
    rows, y_free, voltage = rows[2:-2], y_free[2:-2], voltage[2:-2]
    rng = np.random.default_rng([seed, zlib.crc32(name.encode())])
    y = y_free + displacement_noise * rng.standard_normal(len(rows))
    e = voltage + voltage_noise * rng.standard_normal(len(rows))
    return measured.Run(name, frequency, rows["time"].copy(), rows["current"].copy(), y,
                        sense_voltage=e, control=rows["control"].copy())
