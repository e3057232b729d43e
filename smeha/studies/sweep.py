"""Parameter sweeps: a grid of flow-study cases on local processes or a Dask cluster.

A sweep spec is a TOML file (docs/SWEEP.md)::

    [grid]
    frequency = [50, 100]                         # [Hz]
    mode = ["uncompensated", "compensated"]
    load = [0, 150]                               # [N], optional
    circuit = ["realistic"]                       # optional: realistic, ideal, differential
    [settings]                                    # optional; any other field of Case
    cycles = 6                                    # pumping cycles simulated
    coupling = "force"                            # "force" or "displacement"
    backend = "fmu"                               # "fmu" or "direct"

Every point of the cartesian product of the grid is one
:class:`smeha.studies.flow.Case` (the grid keys and settings are its fields, with
its defaults), run by :func:`smeha.studies.flow.run_case`. The
results form one table, one row per point (:data:`COLUMNS`), written as CSV.
A point whose flow runs backwards or whose oil cavitates is recorded with
``status = "flagged"`` (finished, its reason from ``smeha simulate``); a point that
fails is recorded with ``status = "failed"`` and its error; the
others go on. A rerun onto the same table runs only the points that are
missing or failed there (points are keyed by their grid values and settings).

On a Dask cluster the FMU is not assumed to be on a shared file system: the
client reads its bytes, broadcasts them to the workers once, and each task
writes them to a content-addressed file in the worker's temporary directory
(:func:`_worker_fmu`) before it loads the FMU.
"""
from __future__ import annotations

import csv
import hashlib
import itertools
import math
import os
import sys
import tempfile
import tomllib
from dataclasses import dataclass, field
from dataclasses import fields as dataclass_fields
from pathlib import Path

import gmt
from gmt.errors import InputError, RunError

from ..outputs import replacing, save_figure
from . import flow

__all__ = ["GRID_KEYS", "SETTINGS_DEFAULTS", "OPTIONAL_SETTINGS", "RESULT_FIELDS", "FLAG_FIELDS",
           "KEY_COLUMNS", "COLUMNS", "TEXT_COLUMNS", "SpecError", "SweepError", "Point",
           "SweepResult", "parse_spec", "read_spec", "write_table", "read_table", "row_key",
           "FINISHED", "run_point", "run_point_shipped", "run_sweep", "format_summary",
           "DASK_INSTALL", "dask_missing",
           "plot_sweep"]

#: Grid keys: Case fields that take a list of values.
GRID_KEYS = ("frequency", "mode", "load", "circuit")
#: Settings keys shared by every point: the other Case fields, with Case's defaults.
SETTINGS_DEFAULTS = {f.name: f.default for f in dataclass_fields(flow.Case)
                     if f.name not in GRID_KEYS + ("variant",)}
#: Settings a table written before they existed has no column for (read as empty: such
#: rows keep their own keys and never match a point of this version).
OPTIONAL_SETTINGS = ("controller_period", "hydraulic_step", "coupling", "compensator_period")
#: Settings whose every run before they existed had their present default (the paper's
#: magnetics and sinusoid): a table without their column is read with it, so its
#: finished points still match.
DEFAULTED_SETTINGS = ("magnetics", "inverse", "waveform", "amplitude")

#: Result fields copied from flow.run_case's row dict, SI with unit suffixes.
RESULT_FIELDS = ("load_N", "flow_sim_m3_s", "flow_eq_m3_s", "flow_ratio", "dy_um",
                 "flow_sim_L_min", "flow_paper_m3_s", "dy_paper_um", "dy_free_um",
                 "flow_free_m3_s", "delivered_fraction", "control_amplitude_V",
                 "load_pressure_Pa", "p_pump_min_Pa", "p_pump_max_Pa", "p_min_Pa",
                 "p_min_volume", "volume_imbalance_m3", "volume_pumped_m3", "cycles_averaged",
                 "flow_reversed", "cavitation", "wall_s")
#: Result fields that are flags (written true/false).
FLAG_FIELDS = ("flow_reversed", "cavitation")
#: Columns of the sweep table: the point (grid values and settings), its status, its results.
KEY_COLUMNS = GRID_KEYS + tuple(SETTINGS_DEFAULTS)
COLUMNS = KEY_COLUMNS + ("status", "error") + RESULT_FIELDS
#: Text columns (the others are numbers, or empty).
TEXT_COLUMNS = ("mode", "circuit", "backend", "branch_rule", "coupling", "status", "error",
                "p_min_volume", "magnetics", "inverse", "waveform")


class SpecError(InputError):
    """A sweep spec or sweep table that cannot be used (exit status 2 on the command line)."""


class SweepError(RunError):
    """The sweep cannot run at all, e.g. no scheduler at the address (exit status 1)."""


def _key(values: dict) -> tuple:
    """A point's key from its column values (numbers as floats, so CSV round-trips match)."""
    return tuple(v if isinstance(v, str) or v is None else float(v)
                 for v in (values.get(c) for c in KEY_COLUMNS))


@dataclass(frozen=True)
class Point:
    """One grid point: its :class:`smeha.studies.flow.Case` (``load`` None if not in the grid)."""

    case: flow.Case

    @property
    def key(self) -> tuple:
        """The key of the point in a sweep table."""
        return _key(self.columns())

    def columns(self) -> dict:
        return {name: getattr(self.case, name) for name in KEY_COLUMNS}

    def __getattr__(self, name):  # the case's fields: point.frequency, point.backend ...
        if name in KEY_COLUMNS:
            return getattr(self.case, name)
        raise AttributeError(name)


@dataclass
class SweepResult:
    """Rows of the spec's points (grid order) and the counts of the run."""

    rows: list[dict]
    skipped: int = 0
    failed: int = 0
    ran: int = 0
    kept: list[dict] = field(default_factory=list)  # table rows outside this grid, kept as read

    def as_dict(self) -> dict:
        return {"rows": self.rows, "skipped": self.skipped, "failed": self.failed,
                "ran": self.ran}


# --------------------------------------------------------------------------- spec


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _check_list(section: str, key: str, values, kind: str, check) -> list:
    name = f"{section}.{key}"
    if not isinstance(values, list):
        raise SpecError(f"{name} = {values!r}: must be a list of {kind}")
    if not values:
        raise SpecError(f"{name} is an empty list; give at least one value")
    for v in values:
        if not check(v):
            raise SpecError(f"{name}: {v!r} is not {kind}")
    if len(set(values)) != len(values):
        raise SpecError(f"{name} = {values!r} repeats a value")
    return values


def _reject_unknown(section: str, table: dict, keys: tuple) -> None:
    """SpecError naming every key of [section] that is not one of ``keys``."""
    unknown = set(table) - set(keys)
    if unknown:
        raise SpecError(f"unknown key(s) {section}.{f', {section}.'.join(sorted(unknown))}; "
                        f"the {section} keys are {keys}")


def parse_spec(spec: dict) -> list[Point]:
    """The grid points of a parsed spec (a dict as :mod:`tomllib` gives it).

    Raises
    ------
    SpecError
        Unknown sections or keys, wrong types, empty lists, or values a
        :class:`~smeha.studies.flow.Case` rejects; the message names the key.
    """
    unknown = set(spec) - {"grid", "settings"}
    if unknown:
        raise SpecError(f"unknown section(s) {sorted(unknown)}; a spec has [grid] and "
                        "optionally [settings]")
    grid = spec.get("grid")
    if not isinstance(grid, dict):
        raise SpecError("the spec has no [grid] table")
    if "ideal" in grid:
        raise SpecError("grid.ideal: the circuits are named now: grid.circuit = "
                        f"[...], each one of {flow.CIRCUITS}")
    _reject_unknown("grid", grid, GRID_KEYS)
    for key in ("frequency", "mode"):
        if key not in grid:
            raise SpecError(f"grid.{key} is missing")
    freqs = _check_list("grid", "frequency", grid["frequency"], "a positive number [Hz]",
                        lambda v: _is_number(v) and v > 0)
    modes = _check_list("grid", "mode", grid["mode"], f"one of {flow.MODES}",
                        lambda v: v in flow.MODES)
    loads = (_check_list("grid", "load", grid["load"], "a finite number [N]", _is_number)
             if "load" in grid else [None])
    circuits = (_check_list("grid", "circuit", grid["circuit"],
                            f"one of {flow.CIRCUITS}", lambda v: v in flow.CIRCUITS)
                if "circuit" in grid else ["realistic"])

    settings = spec.get("settings", {})
    if not isinstance(settings, dict):
        raise SpecError("[settings] must be a table")
    _reject_unknown("settings", settings, tuple(SETTINGS_DEFAULTS))
    values = {}
    for key, value in settings.items():
        if isinstance(SETTINGS_DEFAULTS[key], str) or key in TEXT_COLUMNS:
            if not isinstance(value, str):
                raise SpecError(f"settings.{key} = {value!r}: must be a string")
        elif not _is_number(value):
            raise SpecError(f"settings.{key} = {value!r}: must be a number")
        values[key] = value if isinstance(value, str) else float(value)
        try:  # Case's own check of this setting (its range, its allowed names)
            flow.Case(frequency=float(freqs[0]), mode=modes[0], **{key: values[key]})
        except gmt.ParameterError as exc:
            raise SpecError(f"settings.{key} = {value!r}: {exc}") from None
    return [Point(flow.Case(frequency=float(f), mode=m,
                                 load=None if ld is None else float(ld), circuit=c, **values))
            for f, m, ld, c in itertools.product(freqs, modes, loads, circuits)]


def read_spec(path) -> list[Point]:
    """Read and check a TOML sweep spec; return its grid points."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file")
    try:
        with open(path, "rb") as fh:
            spec = tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise SpecError(f"{path}: not valid TOML ({exc})") from None
    except UnicodeDecodeError:
        raise SpecError(f"{path}: not valid TOML (not UTF-8 text)") from None
    try:
        return parse_spec(spec)
    except SpecError as exc:
        raise SpecError(f"{path}: {exc}") from None


# --------------------------------------------------------------------------- table


def _format(value) -> str:
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value)
    return str(value)


def write_table(rows, path) -> Path:
    """Write sweep rows as CSV (:data:`COLUMNS`; empty cells for None), atomically."""
    path = Path(path)
    with replacing(path) as tmp, open(tmp, "w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(COLUMNS)
        for r in rows:
            writer.writerow([_format(r.get(c)) for c in COLUMNS])
    return path


def _parse_cell(column: str, text: str):
    if column in ("status", "error"):
        return text
    if column in TEXT_COLUMNS:
        return text or None
    if text == "":
        return None
    if column in FLAG_FIELDS:
        if text.lower() not in ("true", "false"):
            raise ValueError(f"{column} = {text!r}")
        return text.lower() == "true"
    return float(text)


def read_table(path) -> list[dict]:
    """Read a sweep table written by :func:`write_table`; [] if the file does not exist."""
    path = Path(path)
    if not path.is_file():
        return []
    try:
        return _read_table(path)
    except UnicodeDecodeError:
        raise SpecError(f"{path}: not a sweep table (not UTF-8 text); give another --out"
                        ) from None


def _read_table(path) -> list[dict]:
    with open(path, newline="", encoding="utf-8") as fh:
        reader = csv.DictReader(fh)
        names = reader.fieldnames or []
        legacy = "circuit" not in names and "ideal" in names  # tables before named circuits
        missing = [c for c in KEY_COLUMNS + ("status",)
                   if c not in names and c not in OPTIONAL_SETTINGS + DEFAULTED_SETTINGS
                   and not (legacy and c == "circuit")]
        if missing:
            raise SpecError(f"{path}: not a sweep table (no column(s) {missing}); "
                            "give another --out")
        rows = []
        for n, raw in enumerate(reader, start=2):
            if legacy:
                raw["circuit"] = "ideal" if raw.get("ideal", "").lower() == "true" else "realistic"
            for c in DEFAULTED_SETTINGS:
                if c not in names and SETTINGS_DEFAULTS[c] is not None:
                    raw[c] = str(SETTINGS_DEFAULTS[c])
            try:
                rows.append({c: _parse_cell(c, raw.get(c) or "") for c in COLUMNS})
            except ValueError as exc:
                raise SpecError(f"{path}, line {n}: bad value ({exc})") from None
    return rows


def row_key(row: dict) -> tuple:
    """The point key (:attr:`Point.key`) of a table row."""
    return _key({c: row.get(c) for c in KEY_COLUMNS})


# --------------------------------------------------------------------------- tasks


#: Status of a finished point: "ok", or "flagged" when its flow ran backwards or its oil
#: went below what oil holds (smeha.studies.flow.flag_row); both are kept on a rerun.
FINISHED = ("ok", "flagged")


def _status(row: dict | None, error: str | None) -> str:
    if error is not None:
        return "failed"
    return "flagged" if any(row.get(f) for f in FLAG_FIELDS) else "ok"


def _result_row(point: Point, row: dict | None, error: str | None) -> dict:
    out = point.columns()
    out["status"] = _status(row, error)
    out["error"] = "" if error is None else error
    for name in RESULT_FIELDS:
        value = None if row is None else row.get(name)
        out[name] = (value if value is None or isinstance(value, (bool, str))
                     else float(value))
    return out


def run_point(point: Point, fmu_path=None) -> dict:
    """Run one point; a failure becomes a row with status "failed" and the error message."""
    try:
        _, _, row = flow.run_case(point.case, fmu_path)
    except Exception as exc:  # noqa: BLE001 -- any failure of one point is recorded, not raised
        return _result_row(point, None, f"{type(exc).__name__}: {exc}")
    return _result_row(point, row, None)


def _worker_fmu(name: str, data: bytes, digest: str) -> Path:
    """The shipped FMU as a file on this worker: <tmp>/smeha-fmu/<digest>-<name>.

    Content-addressed, so a stale or different FMU at the client's path on the
    worker is never used; written atomically, so worker processes sharing a
    temporary directory do not race.
    """
    folder = Path(tempfile.gettempdir()) / "smeha-fmu"
    target = folder / f"{digest[:16]}-{name}"
    if not target.is_file():
        folder.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=folder, suffix=".part")
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.replace(tmp, target)
    return target


def run_point_shipped(point: Point, fmu: tuple | None) -> dict:
    """Dask task: write the shipped FMU ``(name, bytes, sha256)`` to a file, run the point."""
    fmu_path = None
    if fmu is not None and point.backend == "fmu":
        try:
            fmu_path = _worker_fmu(*fmu)
        except OSError as exc:
            return _result_row(point, None, f"cannot write the shipped FMU on the worker: {exc}")
    return run_point(point, fmu_path)


# --------------------------------------------------------------------------- executors


def _progress(total: int, quiet: bool):
    from tqdm import tqdm
    return tqdm(total=total, desc="sweep points", unit="point", disable=quiet, file=sys.stderr)


def _collect(future, point, on_result=None) -> dict:
    """A finished future's row; a task that raised (a worker process died, a Dask worker
    was lost) becomes a failed row. Hands the row to ``on_result``."""
    try:
        row = future.result()
    except Exception as exc:  # noqa: BLE001 -- recorded, the sweep goes on
        row = _result_row(point, None, f"{type(exc).__name__}: {exc}")
    if on_result is not None:
        on_result(point, row)
    return row


def _run_local(points, fmu_path, workers: int, quiet: bool, on_result=None,
               say=None) -> list[dict]:
    from .. import pool
    fmu = fmu_path or flow.default_fmu_path()
    pool.prepare(workers, fmu if any(p.backend == "fmu" for p in points) else None,
                 None if quiet else say)

    def finished(i, row):
        if on_result is not None:
            on_result(points[i], row)

    def broken(i, exc):  # the worker process died (or could not take the point)
        return _result_row(points[i], None, f"{type(exc).__name__}: {exc}")
    return pool.run_jobs(run_point, [(p, fmu_path) for p in points], workers,
                         desc="sweep points", unit="point", quiet=quiet,
                         on_result=finished, on_error=broken)


#: How to install what --scheduler needs (the optional dependencies ``smeha[dask]``).
DASK_INSTALL = "pip install 'smeha[dask]'"


def dask_missing() -> str | None:
    """The first Dask package ``--scheduler`` needs that is not installed, or None."""
    import importlib.util
    return next((name for name in ("dask", "distributed")
                 if importlib.util.find_spec(name) is None), None)


def _run_dask(points, fmu_path, scheduler: str, quiet: bool, on_result=None) -> list[dict]:
    try:
        from dask.distributed import Client, as_completed
    except ImportError:
        raise SweepError(f"--scheduler needs Dask: {DASK_INSTALL}") \
            from None
    try:
        client = Client(scheduler, timeout="20s")
    except (OSError, TimeoutError) as exc:
        raise SweepError(f"--scheduler {scheduler}: cannot connect ({exc})") from None
    results = [None] * len(points)
    try:
        fmu = None
        if fmu_path is not None:
            data = Path(fmu_path).read_bytes()
            payload = (Path(fmu_path).name, data, hashlib.sha256(data).hexdigest())
            fmu = client.scatter([payload], broadcast=True)[0]  # one future for the tuple
        futures = {client.submit(run_point_shipped, p, fmu, pure=False): i
                   for i, p in enumerate(points)}
        with _progress(len(points), quiet) as bar:
            for fut in as_completed(list(futures)):
                i = futures[fut]
                results[i] = _collect(fut, points[i], on_result)
                bar.update(1)
    finally:
        client.close()
    return results


def run_sweep(points, out, fmu_path=None, workers: int = 2, scheduler: str | None = None,
              quiet: bool = False, say=None) -> SweepResult:
    """Run the points not finished in the table ``out``, writing it as points finish.

    Rows of ``out`` whose point is in ``points`` with status "ok" are kept and
    not run again (``skipped``); rows of other points stay in the table, after
    this grid's rows. The table is rewritten after every finished point, so an
    interrupted sweep keeps what it had finished and a rerun picks up from there.
    """
    existing = read_table(out)
    done = {row_key(r): r for r in existing if r["status"] in FINISHED}
    keys = {p.key for p in points}
    kept = [r for r in existing if row_key(r) not in keys]
    todo = [p for p in points if p.key not in done]
    fresh = {}

    def record(point, row):
        fresh[point.key] = row
        finished = [done.get(p.key) or fresh.get(p.key) for p in points]
        write_table([r for r in finished if r is not None] + kept, out)

    if scheduler and todo:
        _run_dask(todo, fmu_path, scheduler, quiet, on_result=record)
    elif todo:
        _run_local(todo, fmu_path, workers, quiet, on_result=record, say=say)
    rows = [done[p.key] if p.key in done else fresh[p.key] for p in points]
    write_table(rows + kept, out)
    return SweepResult(rows=rows, skipped=len(points) - len(todo),
                       failed=sum(r["status"] == "failed" for r in rows), ran=len(todo),
                       kept=kept)


def format_summary(result: SweepResult, out) -> str:
    """A short table of the sweep for the terminal."""
    lines = [f"{'f [Hz]':>7}  {'mode':<13}  {'load [N]':>8}  {'circuit':<12}  {'status':<7}  "
             f"{'q sim [m3/s]':>12}  {'sim/eq':>6}  {'dy [um]':>7}  {'wall [s]':>8}"]
    notes = []
    for r in result.rows:
        if r["status"] in FINISHED:
            tail = (f"{r['flow_sim_m3_s']:>12.4e}  {r['flow_ratio']:>6.3f}  {r['dy_um']:>7.2f}  "
                    f"{r['wall_s']:>8.3f}")
        else:
            tail = r["error"]
        load = "-" if r["load"] is None else f"{r['load']:g}"
        flags = [name for name, field in (("flow reversed", "flow_reversed"),
                                          ("cavitation", "cavitation")) if r.get(field)]
        mark = "  (!) " + ", ".join(flags) if flags else ""
        lines.append(f"{r['frequency']:>7g}  {r['mode']:<13}  {load:>8}  "
                     f"{r['circuit']:<12}  {r['status']:<7}  {tail}{mark}")
        if flags:
            notes.append(f"{r['frequency']:g} Hz {r['mode']} {load} N")
    if notes:
        lines.append(f"(!) flagged: {'; '.join(notes)}: 'smeha simulate' on a point prints "
                     "the reason (the rod's lag or the load past its stall point, cavitation)")
    lines.append(f"{len(result.rows)} points: {result.ran} run, {result.skipped} skipped "
                 f"(finished earlier), {result.failed} failed; table {out}")
    return "\n".join(lines)


def plot_sweep(rows, path) -> Path:
    """Mean cylinder flow against frequency, one line per (mode, load, circuit, magnetics,
    drive); the title states what all lines share. An image by the path's suffix."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .flowplots import MARKERS, MODE_COLOURS, drive_label

    ok = [r for r in rows if r["status"] in FINISHED]
    fig, ax = plt.subplots(figsize=(6.5, 4.8))

    def key(r):
        return (r["mode"], r["load_N"], r["circuit"], drive_label(r))
    groups = sorted({key(r) for r in ok})
    drives = sorted({g[3] for g in groups})
    # colour = mode, as in every flow figure (smeha.studies.flowplots); marker and line =
    # load, circuit, drive
    cases = sorted({g[1:] for g in groups})
    for group in groups:
        mode, load, circuit, drive = group
        rs = sorted((r for r in ok if key(r) == group), key=lambda r: r["frequency"])
        k = cases.index(group[1:])
        label = f"{mode}, {load:g} N, {circuit}" + (f", {drive}" if len(drives) > 1 else "")
        ax.plot([r["frequency"] for r in rs], [r["flow_sim_m3_s"] * 1e6 for r in rs],
                color=MODE_COLOURS[mode], marker=MARKERS[k % len(MARKERS)],
                ls=("-", "--", "-.", ":")[k % 4], label=label)
    flagged = [r for r in ok if r["status"] == "flagged"]
    if flagged:  # a reversed flow or cavitation, marked as in every flow figure
        ax.scatter([r["frequency"] for r in flagged], [r["flow_sim_m3_s"] * 1e6 for r in flagged],
                   s=140, facecolors="none", edgecolors="black", lw=1.4, zorder=5,
                   label="(!) flow reversed or cavitation")
        ax.axhline(0.0, color="grey", lw=0.6)
    ax.set_xlabel("pumping frequency f [Hz]")
    ax.set_ylabel("mean cylinder flow [cm^3/s]")
    ax.set_title("Sweep: flow against frequency" + (f"\n{drives[0]}" if len(drives) == 1
                                                    else ""), fontsize=10)
    ax.grid(alpha=0.3)
    if groups:
        ax.legend(fontsize=7)
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    return Path(path)
