"""Measured transducer data: the run structure and the CSV format.

A measurement file is CSV in long form, one row a sample, units in the column
names (docs/MEASURED.md):

=====================  ==========================================  ========
column                 meaning                                     required
=====================  ==========================================  ========
``run``                run label (text); rows of a run are          yes
                       contiguous or not, they are grouped by it
``frequency_Hz``       excitation frequency of the run [Hz]         yes
``time_s``             sample time [s], increasing within a run     yes
``current_A``          coil current [A]                             yes
``displacement_m`` or  rod displacement [m] or [um] (one of the     yes
``displacement_um``    two)
``sense_voltage_V``    sensing-coil voltage [V] (eq 21)             no
``control_V``          control signal u [V]                         no
=====================  ==========================================  ========

Lines starting with ``#`` are comments (provenance), blank lines are skipped,
columns not listed are ignored. An optional column may be left empty for a
whole run (that run has no such signal), not for part of one.

Inside the code everything is SI: the reader converts through
:data:`COLUMNS` once.

Checks
------
:func:`read_measurements` raises :class:`DataError`, naming the file, the run
and the line (1-based, counting every line of the file, header and comments
included), for: an empty file or one without data rows, a missing or
duplicated column, a value that is not a finite number, a run label that is
empty, a ``frequency_Hz`` that is not positive or changes within a run, time
not strictly increasing within a run, an optional column filled for part of a
run, a run shorter than one excitation period, and a current whose
fundamental frequency (:func:`fundamental_frequency`) differs from
``frequency_Hz`` by more than :data:`FREQUENCY_TOLERANCE`.
"""
from __future__ import annotations

import csv
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.optimize import minimize_scalar

from .outputs import replacing

from gmt.errors import InputError

__all__ = ["COLUMNS", "REQUIRED", "DISPLACEMENT_COLUMNS", "OPTIONAL_COLUMNS",
           "FREQUENCY_TOLERANCE", "MIN_SAMPLES", "DataError", "Run", "harmonic_basis",
           "fundamental_frequency", "read_measurements", "write_measurements"]

#: CSV column -> (attribute of :class:`Run`, factor to SI). Displacement may come
#: in metres or micrometres.
COLUMNS = {
    "time_s": ("time", 1.0),
    "current_A": ("current", 1.0),
    "displacement_m": ("displacement", 1.0),
    "displacement_um": ("displacement", 1e-6),
    "sense_voltage_V": ("sense_voltage", 1.0),
    "control_V": ("control", 1.0),
}
REQUIRED = ("run", "frequency_Hz", "time_s", "current_A")
DISPLACEMENT_COLUMNS = ("displacement_m", "displacement_um")
OPTIONAL_COLUMNS = ("sense_voltage_V", "control_V")

#: Largest relative difference between ``frequency_Hz`` and the current's
#: fundamental frequency estimated from the samples, [-].
FREQUENCY_TOLERANCE = 0.02

#: Fewest samples a run may have (a sinusoid and an offset need three; the
#: frequency check needs a few per period).
MIN_SAMPLES = 8


class DataError(InputError):
    """A measurement file that cannot be used; the message names file, run and row.

    Parameters
    ----------
    message : str
        The full message (already naming file, run and line).
    path : str, optional
        File the error is in.
    run : str, optional
        Run label.
    line : int, optional
        1-based line number in the file.
    """

    def __init__(self, message, path=None, run=None, line=None):
        super().__init__(message)
        self.path = path
        self.run = run
        self.line = line


@dataclass
class Run:
    """One measured run at one excitation frequency (SI).

    Attributes
    ----------
    name : str
        Run label.
    frequency : float
        Excitation frequency f, [Hz].
    time : array
        Sample times, [s], increasing.
    current : array
        Coil current i, [A].
    displacement : array
        Rod displacement y, [m] (relative: any constant offset).
    sense_voltage : array or None
        Sensing-coil voltage E, [V] (eq 21).
    control : array or None
        Control signal u, [V].
    source : str
        File (and first row) the run was read from, for messages.
    meta : dict
        Free-form information about the run.
    lines : array of int or None
        1-based line number in the file of each sample (set by the reader),
        so later checks can name the row.
    """

    name: str
    frequency: float
    time: np.ndarray
    current: np.ndarray
    displacement: np.ndarray
    sense_voltage: np.ndarray | None = None
    control: np.ndarray | None = None
    source: str = ""
    meta: dict = field(default_factory=dict)
    lines: np.ndarray | None = None

    @property
    def current_amplitude(self) -> float:
        """Amplitude of the current's fundamental, [A] (least squares over the run)."""
        w = 2.0 * np.pi * self.frequency
        basis = np.column_stack([np.cos(w * self.time), np.sin(w * self.time),
                                 np.ones_like(self.time)])
        coef, *_ = np.linalg.lstsq(basis, self.current, rcond=None)
        return float(np.hypot(coef[0], coef[1]))

    @property
    def cycles(self) -> float:
        """Number of excitation periods the run spans."""
        return float((self.time[-1] - self.time[0]) * self.frequency)

    def where(self, index=None) -> str:
        """Location for messages: ``"FILE, run 'NAME', line N"`` or the run's line range.

        Parameters
        ----------
        index : int, optional
            Sample index; without it, the run's first to last line.
        """
        path = self.source.rsplit(":", 1)[0] if self.source else "<memory>"
        if self.lines is None or len(self.lines) == 0:
            return f"{path}, run {self.name!r}"
        if index is None:
            return f"{path}, run {self.name!r}, lines {self.lines[0]}-{self.lines[-1]}"
        return f"{path}, run {self.name!r}, line {self.lines[index]}"


# -- the current's fundamental frequency ---------------------------------------------------


def harmonic_basis(time, frequency, harmonics):
    """Columns [1, cos(k w t), sin(k w t) for k = 1..harmonics] for least squares."""
    w = 2.0 * np.pi * frequency
    cols = [np.ones_like(time)]
    for k in range(1, harmonics + 1):
        cols += [np.cos(k * w * time), np.sin(k * w * time)]
    return np.column_stack(cols)


def _sinusoid_rss(time, signal, frequency, harmonics=3):
    """Residual sum of squares of the best offset + harmonics 1..``harmonics`` of ``frequency``."""
    basis = harmonic_basis(time, frequency, harmonics)
    # normal equations: the trigonometric columns are near-orthogonal over a whole run
    coef = np.linalg.solve(basis.T @ basis, basis.T @ signal)
    r = signal - basis @ coef
    return float(r @ r)


def fundamental_frequency(time, signal, pad=8) -> float:
    """Fundamental frequency of a sampled periodic signal, [Hz].

    The peak of a zero-padded, Hann-windowed FFT (on a uniform grid; a
    non-uniformly sampled signal is interpolated onto one first) brackets the
    frequency to within one unpadded bin; a bounded Brent search then
    minimises the residual of a least-squares fit (offset and harmonics 1-3 of
    the trial frequency, as far as the sampling resolves them) on the original
    samples within that bin.

    Parameters
    ----------
    time : array
        Sample times, [s], strictly increasing.
    signal : array
        Samples.
    pad : int
        Zero-padding factor of the FFT.

    Returns
    -------
    float
        Frequency, [Hz]; NaN if the signal has no alternating part.
    """
    t = np.asarray(time, dtype=float)
    x = np.asarray(signal, dtype=float)
    n = t.size
    span = t[-1] - t[0]
    if n < 4 or not span > 0 or not np.ptp(x) > 0:
        return math.nan
    grid = np.linspace(t[0], t[-1], n)
    xu = np.interp(grid, t, x)
    xu = (xu - xu.mean()) * np.hanning(n)
    nfft = int(2 ** math.ceil(math.log2(n * pad)))
    spectrum = np.abs(np.fft.rfft(xu, nfft))
    freqs = np.fft.rfftfreq(nfft, d=span / (n - 1))
    spectrum[0] = 0.0
    peak = freqs[int(np.argmax(spectrum))]
    if not peak > 0:
        return math.nan
    bin_width = 1.0 / span
    lo, hi = max(peak - bin_width, 0.25 * peak), peak + bin_width
    # harmonics 2, 3 of a distorted current (a clipped or compensated drive) in the
    # basis too, as far as the sampling resolves them
    nyquist = 0.5 * (n - 1) / span
    harmonics = int(max(1, min(3, nyquist // hi)))
    res = minimize_scalar(lambda f: _sinusoid_rss(t, x, f, harmonics), bounds=(lo, hi),
                          method="bounded", options={"xatol": 1e-9 * peak})
    return float(res.x)


# -- reading -------------------------------------------------------------------------------


def _float(text, path, run, line, column):
    try:
        value = float(text)
    except ValueError:
        raise DataError(f"{path}, run {run!r}, line {line}: column {column} = {text!r} "
                        "is not a number", path, run, line) from None
    if not math.isfinite(value):
        raise DataError(f"{path}, run {run!r}, line {line}: column {column} = {text!r} "
                        "is not a finite number", path, run, line)
    return value


def _header(path, rows):
    """(header, its line number); skips comment and blank lines."""
    for row in rows:
        if not row or all(not c.strip() for c in row):
            continue
        if row[0].lstrip().startswith("#"):
            continue
        return [c.strip() for c in row], rows.line_num
    raise DataError(f"{path}, line 1: empty file (no header row, no data)", path, None, 1)


def read_measurements(path) -> list[Run]:
    """Read a measurement file (format in the module docstring), checked.

    Parameters
    ----------
    path : str or path-like
        CSV file.

    Returns
    -------
    list of Run
        One per run label, in order of first appearance, SI units.

    Raises
    ------
    DataError
        For every defect listed in the module docstring; the message names the
        file, the run and the line.
    FileNotFoundError
        When the file does not exist.
    """
    path = str(path)
    try:
        with open(path, newline="", encoding="utf-8-sig") as fh:
            return _read(path, fh)
    except UnicodeDecodeError as exc:
        raise DataError(f"{path}: not a UTF-8 text file ({exc.reason} at byte {exc.start})",
                        path) from None
    except csv.Error as exc:
        raise DataError(f"{path}: not readable as CSV ({exc})", path) from None


def _read(path, fh) -> list[Run]:
    rows = csv.reader(fh)
    header, header_line = _header(path, rows)
    where = f"{path}, line {header_line} (header)"
    seen = set()
    for name in header:
        if name and name in seen:
            raise DataError(f"{where}: column {name!r} appears twice", path, None, header_line)
        seen.add(name)
    missing = [c for c in REQUIRED if c not in seen]
    if missing:
        raise DataError(f"{where}: missing column(s) {', '.join(missing)}; a measurement file "
                        f"needs {', '.join(REQUIRED)} and one of "
                        f"{' or '.join(DISPLACEMENT_COLUMNS)}", path, None, header_line)
    disp = [c for c in DISPLACEMENT_COLUMNS if c in seen]
    if not disp:
        raise DataError(f"{where}: missing column displacement_m or displacement_um",
                        path, None, header_line)
    if len(disp) == 2:
        raise DataError(f"{where}: both displacement_m and displacement_um; give one",
                        path, None, header_line)
    index = {name: k for k, name in enumerate(header)}
    numeric = ["frequency_Hz", "time_s", "current_A", disp[0]]
    optional = [c for c in OPTIONAL_COLUMNS if c in seen]

    runs: dict[str, dict] = {}
    for row in rows:
        line = rows.line_num
        if not row or all(not c.strip() for c in row):
            continue
        if row[0].lstrip().startswith("#"):
            continue
        if len(row) != len(header):
            label = row[index["run"]].strip() if len(row) > index["run"] else ""
            raise DataError(f"{path}, run {label!r}, line {line}: {len(row)} fields, the "
                            f"header has {len(header)}", path, label or None, line)
        name = row[index["run"]].strip()
        if not name:
            raise DataError(f"{path}, run '', line {line}: empty run label", path, None, line)
        rec = runs.setdefault(name, {"lines": [], **{c: [] for c in numeric + optional}})
        rec["lines"].append(line)
        for c in numeric:
            rec[c].append(_float(row[index[c]].strip(), path, name, line, c))
        for c in optional:
            text = row[index[c]].strip()
            rec[c].append(None if text == "" else _float(text, path, name, line, c))
    if not runs:
        raise DataError(f"{path}, line {header_line}: no data rows after the header",
                        path, None, header_line)
    return [_make_run(path, name, rec, disp[0], optional) for name, rec in runs.items()]


def _make_run(path, name, rec, disp_column, optional) -> Run:
    lines = np.asarray(rec["lines"], dtype=int)

    def fail(message, k=None):
        line = int(lines[0] if k is None else lines[k])
        loc = (f"lines {lines[0]}-{lines[-1]}" if k is None else f"line {line}")
        raise DataError(f"{path}, run {name!r}, {loc}: {message}", path, name, line)

    freq = np.asarray(rec["frequency_Hz"])
    changed = np.flatnonzero(freq != freq[0])
    if changed.size:
        k = int(changed[0])
        fail(f"frequency_Hz = {freq[k]:g} differs from {freq[0]:g} at the run's first line "
             f"{lines[0]}; frequency_Hz must be constant within a run", k)
    f = float(freq[0])
    if not f > 0:
        fail(f"frequency_Hz = {f:g} must be > 0", 0)
    time = np.asarray(rec["time_s"])
    bad = np.flatnonzero(np.diff(time) <= 0.0)
    if bad.size:
        k = int(bad[0]) + 1
        fail(f"time_s = {time[k]:.17g} s does not increase (previous sample, line "
             f"{lines[k - 1]}: {time[k - 1]:.17g} s)", k)
    signals = {}
    for c in optional:
        values = rec[c]
        empty = [v is None for v in values]
        if all(empty):
            signals[c] = None
            continue
        if any(empty):
            k = empty.index(True) if not empty[0] else empty.index(False)
            fail(f"column {c} is {'empty' if empty[k] else 'filled'} here but "
                 f"{'filled' if empty[k] else 'empty'} at line {lines[0]}: leave it empty "
                 "for a whole run or for none of it", k)
        signals[c] = np.asarray(values, dtype=float)
    if time.size < MIN_SAMPLES:
        fail(f"{time.size} samples; a run needs at least {MIN_SAMPLES}")
    cycles = (time[-1] - time[0]) * f
    if cycles < 1.0:
        fail(f"spans {time[-1] - time[0]:.6g} s = {cycles:.3g} periods of {f:g} Hz; a run "
             "needs at least one full period")
    current = np.asarray(rec["current_A"])
    f_est = fundamental_frequency(time, current)
    if not math.isfinite(f_est):
        fail("current_A has no alternating part, so the run's frequency cannot be checked")
    if abs(f_est - f) > FREQUENCY_TOLERANCE * f:
        fail(f"the current's fundamental frequency is {f_est:.6g} Hz but frequency_Hz = "
             f"{f:g} Hz (differ by {abs(f_est / f - 1) * 100:.1f} %, tolerance "
             f"{FREQUENCY_TOLERANCE * 100:g} %)")
    attr, factor = COLUMNS[disp_column]
    return Run(name=name, frequency=f, time=time, current=current,
               displacement=np.asarray(rec[disp_column]) * factor,
               sense_voltage=signals.get("sense_voltage_V"),
               control=signals.get("control_V"),
               source=f"{path}:{lines[0]}", lines=lines,
               meta={"frequency_estimate_Hz": f_est, "displacement_column": disp_column})


# -- writing -------------------------------------------------------------------------------


def write_measurements(path, runs, displacement_unit="um") -> Path:
    """Write runs in the measurement format (module docstring), one row a sample.

    Parameters
    ----------
    path : str or path-like
        CSV file to write (overwritten).
    runs : iterable of Run
        Runs, SI units.
    displacement_unit : {"um", "m"}
        Unit of the displacement column (``displacement_um`` or ``displacement_m``).

    Returns
    -------
    Path
        The file written. Numbers are written with ``repr`` (shortest exact
        form), so reading back gives the same floats (micrometres: to rounding).

    Raises
    ------
    ValueError
        For an unknown unit, or a run whose arrays differ in length.
    """
    if displacement_unit not in ("um", "m"):
        raise ValueError(f"displacement_unit = {displacement_unit!r} is not one of 'um', 'm'")
    dcol = f"displacement_{displacement_unit}"
    scale = 1.0 / COLUMNS[dcol][1]
    runs = list(runs)
    has_sense = any(r.sense_voltage is not None for r in runs)
    has_control = any(r.control is not None for r in runs)
    header = ["run", "frequency_Hz", "time_s", "current_A", dcol]
    header += ["sense_voltage_V"] * has_sense + ["control_V"] * has_control
    path = Path(path)
    with replacing(path) as tmp, open(tmp, "w", newline="", encoding="utf-8") as fh:
        out = csv.writer(fh, lineterminator="\n")
        out.writerow(header)
        for r in runs:
            n = len(r.time)
            arrays = [r.current, r.displacement] + [a for a, on in
                                                    ((r.sense_voltage, has_sense),
                                                     (r.control, has_control)) if on]
            for a in arrays:
                if a is not None and len(a) != n:
                    raise ValueError(f"run {r.name!r}: arrays of different lengths "
                                     f"({len(a)} and {n} samples)")
            sense = r.sense_voltage if has_sense else None
            control = r.control if has_control else None
            f = repr(float(r.frequency))
            for k in range(n):
                row = [r.name, f, repr(float(r.time[k])), repr(float(r.current[k])),
                       repr(float(r.displacement[k] * scale))]
                if has_sense:
                    row.append("" if sense is None else repr(float(sense[k])))
                if has_control:
                    row.append("" if control is None else repr(float(control[k])))
                out.writerow(row)
    return path
