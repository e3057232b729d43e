"""Princeton's MagNet core-loss database (v1): the compact copy in ``data/magnet/``.

The package ``mag-net`` 0.1.0 (MIT, Copyright (c) 2021 Minjie Chen) holds one
pandas HDF5 table per ferrite, ``magnet/data/<material>_database.h5``, with the
columns Frequency [Hz], Flux_Density [T] (peak, half the peak-to-peak swing),
Duty_1..Duty_4 [-], Outlier_Factor [%] and Power_Loss [W/m^3]. The project
ships the rows with |Outlier_Factor| < :data:`OUTLIER_LIMIT` as plain CSV
(``data/magnet/<material>.csv.gz``, the format of :mod:`smeha.coreloss.measurements`),
so that the study and its tests run offline. :func:`extract_from_wheel` rebuilds
that copy from the wheel (``pip download --no-deps mag-net==0.1.0``); it needs
h5py, which nothing else needs.
"""
from __future__ import annotations

import gzip
import io
import zipfile
from pathlib import Path

import numpy as np

from . import MATERIALS
from .measurements import OUTLIER_LIMIT

__all__ = ["MATERIALS", "OUTLIER_LIMIT", "WHEEL", "extract_from_wheel"]

#: The wheel the copy comes from, and its SHA-256.
WHEEL = ("mag_net-0.1.0-py3-none-any.whl",
         "da5b7710fd057987484b1085c075b9d641402763dea49054b1265284cbdb22ea")

_HEADER = ("# Princeton MagNet v1 ({material}), from {wheel} (MIT, Copyright (c) 2021 Minjie "
           "Chen; data/README.md).\n# Rows with |outlier factor| < {limit:g} %.\n"
           "frequency_Hz,flux_density_T,duty_1,duty_2,duty_3,duty_4,outlier_factor_pct,"
           "loss_W_m3\n")


def _read_h5(raw: bytes):
    """(column names, values) of a pandas fixed-format HDF5 table."""
    import h5py  # only for rebuilding the copy

    with h5py.File(io.BytesIO(raw), "r") as f:
        names = [c.decode() for c in f["dataframe/block0_items"][()]]
        return names, np.asarray(f["dataframe/block0_values"][()], dtype=float)


def extract_from_wheel(wheel: str | Path, out_dir: str | Path) -> list[Path]:
    """Write ``<material>.csv.gz`` for every material of the wheel into ``out_dir``.

    Parameters
    ----------
    wheel : path of ``mag_net-0.1.0-py3-none-any.whl``
    out_dir : folder, created if missing

    Returns
    -------
    list of Path
        The files written.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    with zipfile.ZipFile(wheel) as z:
        for material in MATERIALS:
            names, v = _read_h5(z.read(f"magnet/data/{material}_database.h5"))
            col = {n: v[:, names.index(n)] for n in names}
            keep = np.abs(col["Outlier_Factor"]) < OUTLIER_LIMIT
            lines = [_HEADER.format(material=material, wheel=WHEEL[0], limit=OUTLIER_LIMIT)]
            for k in np.flatnonzero(keep):
                duty = ",".join(f"{col[f'Duty_{i}'][k]:g}" for i in range(1, 5))
                lines.append(f"{col['Frequency'][k]:.0f},{col['Flux_Density'][k]:.5g},{duty},"
                             f"{col['Outlier_Factor'][k]:.4g},{col['Power_Loss'][k]:.6g}\n")
            path = out / f"{material}.csv.gz"
            with gzip.GzipFile(path, "wb", mtime=0) as g:  # mtime 0: the same bytes each time
                g.write("".join(lines).encode())
            written.append(path)
    return written
