"""Core-loss measurements: one CSV row per operating point, read into flux waveforms.

File format (plain CSV, ``#`` comment lines allowed at the top, units in the
column names as everywhere in ``data/``):

=======================  ==================================================
column                   meaning
=======================  ==================================================
``frequency_Hz``         f, [Hz], > 0 (required)
``loss_W_m3``            measured core loss per volume, [W/m^3], > 0
                         (required)
``flux_density_T``       peak flux density B_pk, half the peak-to-peak
                         swing, [T] (required with duty cycles)
``duty_1`` .. ``duty_4`` the waveform in MagNet's convention: ``duty_1 =
                         -1`` a sinusoid; ``duty_2 = duty_4 = 0`` a
                         triangle rising for ``duty_1`` of the period;
                         ``duty_2 = duty_4 > 0`` a trapezoid (below)
``flux_samples_T``       instead of the duties: B over one period at equal
                         time steps, numbers separated by spaces (one
                         maximum and one minimum per period)
``outlier_factor_pct``   optional; rows with |value| >= 5 are skipped
=======================  ==================================================

MagNet's trapezoid (its documentation and ``magnet.core``, mag-net 0.1.0): B
rises for d_P = ``duty_1`` of the period from -B_P to B_P, moves to B_N over
d_0 = ``duty_2``, falls to -B_N over d_N = ``duty_3``, returns to -B_P over
d_0 = ``duty_4``, d_P + d_N + 2 d_0 = 1. The winding voltage is
proportional to (1 - d_P + d_N) during the rise, -(1 + d_P - d_N) during the
fall and -(d_P - d_N) in the "flat" parts (the bridge's blocking capacitor),
so B_P d_N (1 + d_P - d_N) = B_N d_P (1 - d_P + d_N) with max(B_P, B_N) = B_pk:
the flat parts are flat only when d_P = d_N.
"""
from __future__ import annotations

import csv
import gzip
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError

__all__ = ["DataError", "CoreLossData", "read_core_losses", "magnet_file", "read_magnet",
           "WAVEFORMS"]

#: Waveform families, in the order of the tables.
WAVEFORMS = ("sine", "triangle", "trapezoid", "samples")
#: Rows with |outlier factor| at or above this are skipped, [%].
OUTLIER_LIMIT = 5.0
_DUTY_TOLERANCE = 1e-6


class DataError(InputError):
    """A core-loss file that cannot be read: the message names the file, row and column."""


@dataclass(frozen=True)
class CoreLossData:
    """Measured operating points with their flux waveforms (SI).

    ``durations`` and ``swings`` (rows x segments) describe each non-sinusoidal
    waveform as straight segments (zero-length segments pad the rows); sinusoids
    have zeros there.
    """

    name: str  #: material or file name
    frequency: np.ndarray  #: f, [Hz]
    flux_density: np.ndarray  #: B_pk, half the peak-to-peak swing, [T]
    waveform: np.ndarray  #: index into :data:`WAVEFORMS`
    duty: np.ndarray  #: (rows, 4) MagNet's duty cycles, [-] (-1 for sinusoids and samples)
    durations: np.ndarray  #: (rows, segments) segment durations, [s]
    swings: np.ndarray  #: (rows, segments) change of B over each segment, [T]
    loss: np.ndarray  #: measured loss per volume, [W/m^3]

    def __len__(self) -> int:
        return len(self.frequency)

    def family(self, name: str) -> np.ndarray:
        """Boolean mask of the rows of one waveform family."""
        return self.waveform == WAVEFORMS.index(name)

    def subset(self, mask) -> "CoreLossData":
        """The rows where ``mask`` is true."""
        return CoreLossData(self.name, *(getattr(self, k)[mask] for k in (
            "frequency", "flux_density", "waveform", "duty", "durations", "swings", "loss")))


def trapezoid_segments(frequency, peak, d_p, d_0, d_n):
    """(durations [s], swings [T]) of MagNet's trapezoid (module docstring), arrays (rows, 4)."""
    d_p, d_0, d_n = (np.asarray(a, dtype=float) for a in (d_p, d_0, d_n))
    rising_larger = d_p > d_n
    ratio = d_n * (1.0 + d_p - d_n) / (d_p * (1.0 - d_p + d_n))  # B_N / B_P
    b_p = np.where(rising_larger, 1.0, 1.0 / ratio) * peak
    b_n = np.where(rising_larger, ratio, 1.0) * peak
    period = 1.0 / np.asarray(frequency, dtype=float)
    durations = np.column_stack([d_p, d_0, d_n, d_0]) * period[:, None]
    swings = np.column_stack([2.0 * b_p, b_n - b_p, -2.0 * b_n, b_n - b_p])
    return durations, swings


def _waveforms(where, frequency, peak, duty):
    """Family index and segments of each duty-cycle row; DataError names a bad row."""
    n = len(frequency)
    family = np.zeros(n, dtype=int)
    durations = np.zeros((n, 4))
    swings = np.zeros((n, 4))
    sine = duty[:, 0] == -1.0
    d1, d2, d3, d4 = duty.T
    total = d1 + d2 + d3 + d4
    bad = ~sine & ((np.abs(total - 1.0) > _DUTY_TOLERANCE) | (np.abs(d2 - d4) > _DUTY_TOLERANCE)
                   | (d1 <= 0.0) | (d3 <= 0.0) | (d2 < 0.0))
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise DataError(f"{where}, data row {k + 1}: duty_1..duty_4 = {tuple(duty[k])} is not "
                        "a waveform: -1 for a sinusoid, or duty_2 = duty_4 >= 0, duty_1 > 0, "
                        "duty_3 > 0 summing to 1")
    tri = ~sine & (d2 == 0.0)
    trap = ~sine & (d2 > 0.0)
    family[tri], family[trap] = WAVEFORMS.index("triangle"), WAVEFORMS.index("trapezoid")
    period = 1.0 / frequency
    durations[tri, 0], durations[tri, 1] = d1[tri] * period[tri], d3[tri] * period[tri]
    swings[tri, 0], swings[tri, 1] = 2.0 * peak[tri], -2.0 * peak[tri]
    durations[trap], swings[trap] = trapezoid_segments(frequency[trap], peak[trap], d1[trap],
                                                       d2[trap], d3[trap])
    return family, durations, swings


def _sampled(where, k, text, frequency):
    """(B_pk, durations, swings) of a ``flux_samples_T`` cell."""
    try:
        b = np.array([float(v) for v in text.split()])
    except ValueError:
        raise DataError(f"{where}, data row {k + 1}: flux_samples_T is not a list of "
                        "numbers") from None
    if len(b) < 3 or not np.all(np.isfinite(b)):
        raise DataError(f"{where}, data row {k + 1}: flux_samples_T needs at least 3 finite "
                        f"values, got {len(b)}")
    steps = np.diff(np.append(b, b[0]))
    signs = np.sign(steps[steps != 0.0])
    if (np.count_nonzero(signs != np.roll(signs, 1)) if len(signs) else 0) != 2:
        raise DataError(f"{where}, data row {k + 1}: flux_samples_T must rise to one maximum "
                        "and fall to one minimum per period (minor loops are not supported)")
    h = 1.0 / (frequency * len(b))
    return 0.5 * (b.max() - b.min()), np.full(len(b), h), steps


def _number(where, k, row, name, low=None):
    text = (row.get(name) or "").strip()
    try:
        value = float(text)
    except ValueError:
        raise DataError(f"{where}, data row {k + 1}: {name} = {text!r} is not a number") from None
    if not np.isfinite(value) or (low is not None and not value > low):
        raise DataError(f"{where}, data row {k + 1}: {name} = {value:g} is outside the "
                        f"allowed range ({low:g}, inf)" if low is not None
                        else f"{where}, data row {k + 1}: {name} is not finite")
    return value


def read_core_losses(path, name: str | None = None) -> CoreLossData:
    """Read a core-loss file (module docstring; ``.csv`` or ``.csv.gz``).

    Raises
    ------
    DataError
        A missing column, a value that is not a number or out of range, a duty
        set that is no waveform; the message names the file, the row and the column.
    """
    path = Path(path)
    where = str(path)
    opener = gzip.open if path.suffix == ".gz" else open
    try:
        with opener(path, "rt", newline="") as fh:
            lines = [ln for ln in fh if not ln.startswith("#")]
    except (UnicodeDecodeError, OSError, EOFError) as exc:  # binary, not gzip, unreadable
        raise DataError(f"{where}: not a core-loss text file ({type(exc).__name__}: "
                        f"{str(exc).splitlines()[0] if str(exc) else 'unreadable'}; "
                        "docs/LOSSES.md)") from None
    reader = csv.DictReader(lines)
    columns = set(reader.fieldnames or ())
    for need in ("frequency_Hz", "loss_W_m3"):
        if need not in columns:
            raise DataError(f"{where}: column {need} is missing (columns: "
                            f"{', '.join(sorted(columns)) or 'none'}; docs/LOSSES.md)")
    duties = all(f"duty_{i}" in columns for i in range(1, 5)) and "flux_density_T" in columns
    if not duties and "flux_samples_T" not in columns:
        raise DataError(f"{where}: give the waveform as flux_density_T with duty_1..duty_4, or "
                        "as flux_samples_T (docs/LOSSES.md)")
    rows = [r for k, r in enumerate(reader) if not (
        "outlier_factor_pct" in columns and (r.get("outlier_factor_pct") or "").strip()
        and abs(_number(where, k, r, "outlier_factor_pct")) >= OUTLIER_LIMIT)]
    if not rows:
        raise DataError(f"{where}: no data rows")
    f = np.array([_number(where, k, r, "frequency_Hz", 0.0) for k, r in enumerate(rows)])
    loss = np.array([_number(where, k, r, "loss_W_m3", 0.0) for k, r in enumerate(rows)])
    n = len(rows)
    peak, family = np.zeros(n), np.zeros(n, dtype=int)
    duty = -np.ones((n, 4))
    sampled = [bool((r.get("flux_samples_T") or "").strip()) for r in rows]
    segs = {}
    for k, r in enumerate(rows):
        if sampled[k]:
            peak[k], *segs[k] = _sampled(where, k, r["flux_samples_T"], f[k])
            family[k] = WAVEFORMS.index("samples")
        elif duties:
            peak[k] = _number(where, k, r, "flux_density_T", 0.0)
            duty[k] = [_number(where, k, r, f"duty_{i}") for i in range(1, 5)]
        else:
            raise DataError(f"{where}, data row {k + 1}: flux_samples_T is empty")
    width = max([4] + [len(v[0]) for v in segs.values()])
    durations, swings = np.zeros((n, width)), np.zeros((n, width))
    plain = ~np.array(sampled)
    fam, dur4, sw4 = _waveforms(where, f[plain], peak[plain], duty[plain])
    family[plain] = fam
    durations[plain, :4], swings[plain, :4] = dur4, sw4
    for k, (d, s) in segs.items():
        durations[k, :len(d)], swings[k, :len(s)] = d, s
    return CoreLossData(name or path.name.split(".")[0], f, peak, family, duty, durations,
                        swings, loss)


def magnet_file(material: str) -> Path:
    """The shipped copy of one MagNet material (``data/magnet/<material>.csv.gz``)."""
    from ..paperdata import data_dir
    from . import MATERIALS

    if material not in MATERIALS:
        raise DataError(f"material = {material!r} is not one of MagNet's "
                        f"{', '.join(MATERIALS)} (or give a CSV file)")
    return Path(data_dir()) / "magnet" / f"{material}.csv.gz"


def read_magnet(material: str) -> CoreLossData:
    """The rows of one MagNet material with |outlier factor| < 5 %."""
    return read_core_losses(magnet_file(material), material)
