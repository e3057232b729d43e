"""The source paper's measured and stated data, read from ``data/``.

The CSV files in ``data/`` (see ``data/README.md``) carry units in their
column names. :data:`COLUMNS` is the one map from those names to the SI names
used in Python, with the factor that converts to SI; every reader goes
through it. No pandas: :mod:`csv` and numpy.

Examples
--------
>>> t3 = table3()
>>> [float(f) for f in t3["frequency"]]
[50.0, 70.0, 80.0, 100.0]
>>> round(float(t3["displacement_at_control_max"][0]), 7)  # 46 um at 50 Hz
4.6e-05
"""
from __future__ import annotations

import csv
import os
from pathlib import Path

import numpy as np

__all__ = ["DATA_DIR_ENV", "COLUMNS", "TABLE1_FILE", "TABLE3_FILE", "STATED_FILE",
           "DataNotFoundError", "data_dir", "read_csv", "table1", "table3", "stated"]

#: Environment variable that points to another data directory.
DATA_DIR_ENV = "SMEHA_DATA_DIR"

#: CSV column -> (SI name, factor to SI). Text columns have factor None.
COLUMNS = {
    "frequency_Hz": ("frequency", 1.0),
    "current_amplitude_A": ("current_amplitude", 1.0),
    "sense_voltage_amplitude_V": ("sense_voltage_amplitude", 1.0),
    "flux_density_amplitude_T": ("flux_density_amplitude", 1.0),
    "role": ("role", None),
    "y_at_i_plus1_um": ("displacement_at_current_max", 1e-6),
    "y_at_i_minus1_um": ("displacement_at_current_min", 1e-6),
    "y_at_u0_um": ("displacement_at_control_zero", 1e-6),
    "y_at_um_um": ("displacement_at_control_max", 1e-6),
    "control_amplitude_V": ("control_amplitude", 1.0),
    "peak_to_peak_um": ("peak_to_peak", 1e-6),
}

TABLE1_FILE = "paper_table1.csv"
TABLE3_FILE = "paper_table3.csv"
STATED_FILE = "paper_stated.csv"


class DataNotFoundError(FileNotFoundError):
    """The ``data/`` directory or one of its files is missing."""


def data_dir() -> Path:
    """Directory holding the paper's CSV files.

    ``$SMEHA_DATA_DIR`` if set, else ``data/`` next to the ``smeha`` package
    (the repository root, which an editable install, ``pip install -e .``,
    keeps in place), else ``smeha/data/`` (a wheel carries data/ there).

    Raises
    ------
    DataNotFoundError
        When the directory does not exist.
    """
    env = os.environ.get(DATA_DIR_ENV)
    here = Path(__file__).resolve().parent
    path = Path(env) if env else next(
        (p for p in (here.parent / "data", here / "data") if (p / TABLE1_FILE).is_file()),
        here.parent / "data")
    if not path.is_dir():
        raise DataNotFoundError(
            f"paper data directory {path} not found: smeha reads data/ from its source "
            f"checkout (install with `pip install -e .`), or set {DATA_DIR_ENV}")
    return path


def read_csv(name: str) -> dict:
    """Read one data file into SI arrays through :data:`COLUMNS`.

    Lines starting with ``#`` (provenance) are skipped.

    Parameters
    ----------
    name : str
        File name inside :func:`data_dir`, e.g. ``"paper_table1.csv"``.

    Returns
    -------
    dict of numpy arrays
        SI name -> column (float arrays; text columns as str arrays).

    Raises
    ------
    DataNotFoundError
        When the file is missing.
    ValueError
        When a column is not in :data:`COLUMNS` or a number does not parse.
    """
    path = data_dir() / name
    if not path.is_file():
        raise DataNotFoundError(f"paper data file {path} not found")
    with path.open(newline="", encoding="utf-8") as fh:
        lines = [line for line in fh if line.strip() and not line.lstrip().startswith("#")]
    reader = csv.DictReader(lines)
    raw = {col: [] for col in reader.fieldnames or ()}
    for row in reader:
        for col in raw:
            raw[col].append(row[col].strip())
    out = {}
    for col, values in raw.items():
        if col not in COLUMNS:
            raise ValueError(f"{path.name}: unknown column {col!r} (known: {sorted(COLUMNS)})")
        key, factor = COLUMNS[col]
        if factor is None:
            out[key] = np.array(values, dtype=str)
        else:
            try:
                out[key] = np.array([float(v) for v in values]) * factor
            except ValueError as exc:
                raise ValueError(f"{path.name}, column {col!r}: {exc}") from None
    return out


def table1() -> dict:
    """Paper, Table 1: ``frequency`` [Hz], ``current_amplitude`` [A],
    ``sense_voltage_amplitude`` [V], ``flux_density_amplitude`` [T], ``role``."""
    return read_csv(TABLE1_FILE)


def table3() -> dict:
    """Paper, Table 3: ``frequency`` [Hz], displacements [m] at the valve
    switching instants, ``control_amplitude`` a [V] of u = a + a cos(2 pi f t)."""
    return read_csv(TABLE3_FILE)


def stated() -> dict:
    """Stated in the text: ``frequency`` [Hz], ``current_amplitude`` [A],
    uncompensated ``peak_to_peak`` [m]."""
    return read_csv(STATED_FILE)
