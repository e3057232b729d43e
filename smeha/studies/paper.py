"""Reproduce the paper's model results and compare them with its data.

Two tables, each a list of flat dicts ready for JSON (units in the keys):

* :func:`paper_rows` -- one row per Table 1 case (f, I_m): B_m, the complex
  permeability (eqs 16, 18, 20), the separated losses (eqs 7, 9, 11), and the
  steady-state loop of eq 30 (peak-to-peak, dy of eq 40), next to the
  measured values of Table 3 and the text;
* :func:`compensated_rows` -- one row per Table 3 frequency: the transducer
  driven through the inverse compensator (Figure 9) with the paper's control
  signals u = a + a cos(2 pi f t), dy of eq 41 against Table 3, the flow
  ratio q'/q and the linearity of eq 38-normalised displacement against the
  normalised control signal.

All physics is :mod:`gmt`'s; this module only drives it and arranges the
numbers. Inside, everything is SI; the ``_um``, ``_W``, ... keys are the
boundary.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

import gmt
from gmt.parameters import BRANCH_RULE
from gmt.sensing import flux_density_amplitude_from_voltage

from .. import paperdata

__all__ = ["SAMPLES_PER_CYCLE", "CYCLES", "LOOP_SAMPLES", "normalise", "linearity",
           "uncompensated_cycle", "paper_rows", "ROW_KEYS", "CompensatedRun", "compensated_run",
           "compensated_runs", "compensated_rows", "COMPENSATED_KEYS", "paper_report",
           "ROW_COLUMNS", "LOSS_COLUMNS", "COMPENSATED_COLUMNS", "format_table", "format_report"]

#: Samples per cycle and cycles of the compensated time-stepping run; the
#: last cycle is the steady state (the mechanics settle in < 1 ms).
SAMPLES_PER_CYCLE = 2000
CYCLES = 6

#: Samples per cycle of the closed-form uncompensated steady state.
LOOP_SAMPLES = 2000


def _um(x):
    return None if x is None else float(x) * 1e6


def _um_measured(x):
    """Measured value back in um; rounding undoes the um -> m -> um float noise."""
    return None if x is None else round(float(x) * 1e6, 9)


def _measured_lookup(frequency, current_amplitude, table, key, amplitude=1.0):
    """Value of ``table[key]`` at ``frequency`` (and I_m = ``amplitude``), or None."""
    if not math.isclose(current_amplitude, amplitude):
        return None
    for f, v in zip(table["frequency"], table[key]):
        if math.isclose(f, frequency):
            return float(v)
    return None


def normalise(x):
    """Min-max normalisation of the paper, X = (x - x_min) / (x_max - x_min), eq 38.

    Parameters
    ----------
    x : array

    Returns
    -------
    array
        In [0, 1]; all zeros when x is constant.

    Examples
    --------
    >>> normalise([2.0, 4.0, 3.0]).tolist()
    [0.0, 1.0, 0.5]
    """
    x = np.asarray(x, dtype=float)
    span = x.max() - x.min()
    return (x - x.min()) / span if span > 0 else np.zeros_like(x)


def linearity(control, displacement) -> tuple[float, float]:
    """Max deviation and correlation of eq 38-normalised y against normalised u.

    Parameters
    ----------
    control : array
        Control signal over one cycle (u, or the current i uncompensated).
    displacement : array
        y at the same instants.

    Returns
    -------
    (float, float)
        max |Y - U| [-] and the Pearson correlation of Y with U [-]; a
        perfectly linear, lag-free transducer gives (0, 1).
    """
    u = normalise(control)
    y = normalise(displacement)
    return float(np.max(np.abs(y - u))), float(np.corrcoef(u, y)[0, 1])


def uncompensated_cycle(params: gmt.TransducerParameters, frequency: float,
                        current_amplitude: float = 1.0,
                        samples: int = LOOP_SAMPLES) -> dict:
    """One cycle of the uncompensated steady state for i = I_m cos(2 pi f t).

    Closed form (:func:`gmt.periodic_response`), B_m from the default
    calibration (Table 1 at its own points).

    Returns
    -------
    dict of arrays
        ``time`` [s], ``current`` [A], ``displacement`` [m] (absolute,
        including the bias).
    """
    point = gmt.operating_point(params, gmt.Excitation(frequency, current_amplitude))
    t = np.linspace(0.0, 1.0 / frequency, samples, endpoint=False)
    r = gmt.periodic_response(params, point, t)
    return {"time": t, "current": r["current"], "displacement": r["displacement"]}


def paper_rows(params: gmt.TransducerParameters | None = None) -> list[dict]:
    """Model results for every Table 1 case, next to the paper's data.

    Parameters
    ----------
    params : TransducerParameters, optional
        Defaults to Table 2.

    Returns
    -------
    list of dict
        One row per Table 1 case; keys listed in :data:`ROW_KEYS`. Measured
        values absent from the paper are None.
    """
    params = params or gmt.TransducerParameters()
    t1 = paperdata.table1()
    t3 = paperdata.table3()
    st = paperdata.stated()
    rows = []
    for f, im, em, bm_table, role in zip(t1["frequency"], t1["current_amplitude"],
                                         t1["sense_voltage_amplitude"],
                                         t1["flux_density_amplitude"], t1["role"]):
        f, im = float(f), float(im)
        point = gmt.operating_point(params, gmt.Excitation(f, im))
        loop = gmt.loop_metrics(params, point)
        ends = gmt.periodic_response(params, point, np.array([0.0, 0.5 / f]))["displacement"]
        y_plus = _measured_lookup(f, im, t3, "displacement_at_current_max")
        y_minus = _measured_lookup(f, im, t3, "displacement_at_current_min")
        rows.append({
            "frequency_Hz": f,
            "current_amplitude_A": im,
            "role": str(role),
            "Bm_T": point.flux_density_amplitude,
            "Bm_source": point.flux_density_source,
            "Bm_table_T": float(bm_table),
            "Bm_from_Em_T": flux_density_amplitude_from_voltage(
                float(em), f, params.sense_turns, params.sense_area),
            "mu_real": point.mu_real,
            "mu_imag": point.mu_imag,
            "lag_deg": math.degrees(point.lag),
            "pp_um": _um(loop["peak_to_peak"]),
            "dy_um": _um(loop["dy"]),
            "y_at_i_plus_um": _um(ends[0] - loop["y_min"]),
            "y_at_i_minus_um": _um(ends[1] - loop["y_min"]),
            "P_hyst_W": point.losses.hysteresis,
            "P_eddy_W": point.losses.eddy,
            "P_excess_W": point.losses.excess,
            "P_total_W": point.losses.total,
            "pp_measured_um": _um_measured(_measured_lookup(f, im, st, "peak_to_peak")),
            "dy_measured_um": (None if y_plus is None else _um_measured(y_plus - y_minus)),
            "y_at_i_plus_measured_um": _um_measured(y_plus),
            "y_at_i_minus_measured_um": _um_measured(y_minus),
        })
    return rows


#: Keys of every :func:`paper_rows` row.
ROW_KEYS = ("frequency_Hz", "current_amplitude_A", "role", "Bm_T", "Bm_source", "Bm_table_T",
            "Bm_from_Em_T", "mu_real", "mu_imag", "lag_deg", "pp_um", "dy_um",
            "y_at_i_plus_um", "y_at_i_minus_um", "P_hyst_W", "P_eddy_W", "P_excess_W",
            "P_total_W", "pp_measured_um", "dy_measured_um", "y_at_i_plus_measured_um",
            "y_at_i_minus_measured_um")


@dataclass(frozen=True)
class CompensatedRun:
    """Last (steady-state) cycle of a compensated run, SI.

    Attributes
    ----------
    frequency : float
        f, [Hz].
    control_amplitude : float
        a of u = a + a cos(2 pi f t), [V].
    branch_rule : str
        Compensator's root-selection rule.
    time, control, current, displacement : array
        t [s] (from the start of the cycle), u [V], i [A], y [m] (absolute)
        at the same instants.
    saturation_count : int
        Saturated steps over the whole run (:class:`gmt.TransducerOutput`).
    saturated_last_cycle : int
        Saturated steps in the last cycle.
    """

    frequency: float
    control_amplitude: float
    branch_rule: str
    time: np.ndarray
    control: np.ndarray
    current: np.ndarray
    displacement: np.ndarray
    saturation_count: int
    saturated_last_cycle: int


def compensated_run(params: gmt.TransducerParameters, frequency: float,
                    control_amplitude: float, branch_rule: str = BRANCH_RULE,
                    samples_per_cycle: int = SAMPLES_PER_CYCLE,
                    cycles: int = CYCLES) -> CompensatedRun:
    """Drive :class:`gmt.Transducer` through the compensator with u = a + a cos(2 pi f t).

    The operating point of the compensator's model is (f, I_m = 1 A), the
    amplitude the paper identified at. ``Transducer.step`` holds u(t_k) over
    [t_k, t_k + h) and returns y(t_k + h); y is paired with u at the same
    instant. The compensator samples at every step of the run
    (``compensator_period`` 0): Figure 9 in its continuous-time limit, the
    paper giving no rate.
    """
    if samples_per_cycle < 4 or cycles < 2:
        raise gmt.ParameterError(
            f"samples_per_cycle = {samples_per_cycle} and cycles = {cycles} must be "
            ">= 4 and >= 2")
    drive = gmt.DriveParameters(compensated=True, branch_rule=branch_rule,
                                compensator_period=0.0)
    unit = gmt.Transducer(params, gmt.Excitation(frequency, 1.0), drive)
    h = 1.0 / (frequency * samples_per_cycle)
    n = samples_per_cycle * cycles
    t = h * np.arange(n + 1)
    u = control_amplitude * (1.0 + np.cos(2.0 * math.pi * frequency * t))
    y = np.empty(n + 1)
    i = np.empty(n + 1)
    sat = np.zeros(n + 1, dtype=bool)
    y[0] = unit.forward.displacement
    out = None
    for k in range(n):
        out = unit.step(float(u[k]), h)
        i[k] = out.current
        sat[k] = out.saturated
        y[k + 1] = out.displacement
    last = slice(n - samples_per_cycle, n)
    return CompensatedRun(frequency, control_amplitude, branch_rule,
                          t[last] - t[last][0], u[last], i[last], y[last],
                          out.saturation_count, int(sat[last].sum()))


def compensated_runs(params: gmt.TransducerParameters | None = None,
                     branch_rule: str = BRANCH_RULE, **kwargs) -> list[CompensatedRun]:
    """:func:`compensated_run` at every Table 3 frequency with the paper's amplitudes."""
    params = params or gmt.TransducerParameters()
    t3 = paperdata.table3()
    return [compensated_run(params, float(f), float(a), branch_rule, **kwargs)
            for f, a in zip(t3["frequency"], t3["control_amplitude"])]


def compensated_rows(params: gmt.TransducerParameters | None = None,
                     branch_rule: str = BRANCH_RULE,
                     runs: list[CompensatedRun] | None = None) -> list[dict]:
    """Compensated against uncompensated, per Table 3 frequency.

    Parameters
    ----------
    params : TransducerParameters, optional
        Defaults to Table 2.
    branch_rule : {"control", "demand"}
        Compensator's root rule (``"control"`` is Figure 9's).
    runs : list of CompensatedRun, optional
        Precomputed :func:`compensated_runs` (so plots and table share one run).

    Returns
    -------
    list of dict
        Keys listed in :data:`COMPENSATED_KEYS`. ``dy_comp_um`` is
        y(u = u_max) - y(u = 0) (eq 41 window), ``dy_um`` is
        y(i = 1) - y(i = -1) (eq 40 window), ``flow_ratio`` is q'/q =
        dy_comp / dy (eqs 40-41 at the same f and A_d).
    """
    params = params or gmt.TransducerParameters()
    runs = runs if runs is not None else compensated_runs(params, branch_rule)
    t3 = paperdata.table3()
    rows = []
    for run, f, y_plus, y_minus, y_u0, y_um in zip(
            runs, t3["frequency"], t3["displacement_at_current_max"],
            t3["displacement_at_current_min"], t3["displacement_at_control_zero"],
            t3["displacement_at_control_max"]):
        y = run.displacement
        dy_comp = y[np.argmax(run.control)] - y[np.argmin(run.control)]
        point = gmt.operating_point(params, gmt.Excitation(run.frequency, 1.0))
        dy = gmt.loop_metrics(params, point)["dy"]
        cycle = uncompensated_cycle(params, run.frequency)
        dev_c, corr_c = linearity(run.control, y)
        dev_u, corr_u = linearity(cycle["current"], cycle["displacement"])
        rows.append({
            "frequency_Hz": run.frequency,
            "control_amplitude_V": run.control_amplitude,
            "branch_rule": run.branch_rule,
            "dy_comp_um": _um(dy_comp),
            "dy_comp_measured_um": _um_measured(y_um - y_u0),
            "pp_comp_um": _um(y.max() - y.min()),
            "y_at_u0_um": _um(y[np.argmin(run.control)] - y.min()),
            "y_at_um_um": _um(y[np.argmax(run.control)] - y.min()),
            "dy_um": _um(dy),
            "dy_measured_um": _um_measured(y_plus - y_minus),
            "flow_ratio": dy_comp / dy,
            "flow_ratio_measured": float((y_um - y_u0) / (y_plus - y_minus)),
            "max_dev_comp": dev_c,
            "corr_comp": corr_c,
            "max_dev_uncomp": dev_u,
            "corr_uncomp": corr_u,
            "current_peak_A": float(np.max(np.abs(run.current))),
            "saturation_count": run.saturation_count,
            "saturated_last_cycle": run.saturated_last_cycle,
            "samples_per_cycle": len(run.time),
        })
    return rows


#: Keys of every :func:`compensated_rows` row.
COMPENSATED_KEYS = ("frequency_Hz", "control_amplitude_V", "branch_rule", "dy_comp_um",
                    "dy_comp_measured_um", "pp_comp_um", "y_at_u0_um", "y_at_um_um", "dy_um",
                    "dy_measured_um", "flow_ratio", "flow_ratio_measured", "max_dev_comp",
                    "corr_comp", "max_dev_uncomp", "corr_uncomp", "current_peak_A",
                    "saturation_count", "saturated_last_cycle", "samples_per_cycle")


def paper_report(params: gmt.TransducerParameters | None = None,
                 branch_rule: str = BRANCH_RULE,
                 runs: list[CompensatedRun] | None = None) -> dict:
    """The whole comparison as one JSON-ready dict.

    ``{"rows": ..., "compensated": ..., "diagnosis": ...}``; the diagnosis is
    :func:`smeha.studies.paperdiag.paper_data_diagnosis`.
    """
    from .paperdiag import paper_data_diagnosis
    params = params or gmt.TransducerParameters()
    return {"rows": paper_rows(params),
            "compensated": compensated_rows(params, branch_rule, runs),
            "diagnosis": _plain(paper_data_diagnosis(params))}


def _plain(obj):
    """numpy scalars to Python numbers, recursively (for json with allow_nan=False)."""
    if isinstance(obj, dict):
        return {k: _plain(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_plain(v) for v in obj]
    if isinstance(obj, np.generic):
        return obj.item()
    return obj


# -- terminal tables ----------------------------------------------------------

#: (key, header, format) of the terminal tables.
ROW_COLUMNS = (
    ("frequency_Hz", "f [Hz]", "{:g}"),
    ("current_amplitude_A", "I_m [A]", "{:g}"),
    ("role", "role", "{}"),
    ("Bm_T", "B_m [T]", "{:.4f}"),
    ("Bm_from_Em_T", "B_m eq22 [T]", "{:.4f}"),
    ("mu_real", "mu'", "{:.3f}"),
    ("mu_imag", "mu''", "{:.3f}"),
    ("lag_deg", "lag [deg]", "{:.1f}"),
    ("pp_um", "pp [um]", "{:.1f}"),
    ("pp_measured_um", "pp meas [um]", "{:.1f}"),
    ("dy_um", "dy [um]", "{:.1f}"),
    ("dy_measured_um", "dy meas [um]", "{:.1f}"),
)
LOSS_COLUMNS = (
    ("frequency_Hz", "f [Hz]", "{:g}"),
    ("current_amplitude_A", "I_m [A]", "{:g}"),
    ("P_hyst_W", "P_h [W]", "{:.4f}"),
    ("P_eddy_W", "P_eddy [W]", "{:.4f}"),
    ("P_excess_W", "P_ex [W]", "{:.4f}"),
    ("P_total_W", "P_total [W]", "{:.4f}"),
    ("y_at_i_plus_um", "y(i=+I_m) [um]", "{:.1f}"),
    ("y_at_i_plus_measured_um", "meas [um]", "{:.1f}"),
    ("y_at_i_minus_um", "y(i=-I_m) [um]", "{:.1f}"),
    ("y_at_i_minus_measured_um", "meas [um]", "{:.1f}"),
)
COMPENSATED_COLUMNS = (
    ("frequency_Hz", "f [Hz]", "{:g}"),
    ("control_amplitude_V", "a [V]", "{:g}"),
    ("dy_comp_um", "dy' [um]", "{:.1f}"),
    ("dy_comp_measured_um", "dy' meas [um]", "{:.1f}"),
    ("dy_um", "dy [um]", "{:.1f}"),
    ("dy_measured_um", "dy meas [um]", "{:.1f}"),
    ("flow_ratio", "q'/q", "{:.3f}"),
    ("flow_ratio_measured", "q'/q meas", "{:.3f}"),
    ("max_dev_comp", "maxdev comp", "{:.3f}"),
    ("max_dev_uncomp", "maxdev unc", "{:.3f}"),
    ("corr_comp", "corr comp", "{:.4f}"),
    ("corr_uncomp", "corr unc", "{:.4f}"),
    ("saturation_count", "saturated", "{:d}"),
)


def format_table(rows: list[dict], columns) -> str:
    """Right-aligned plain-text table; None shows as ``-``."""
    cells = [[header for _, header, _ in columns]]
    for row in rows:
        cells.append(["-" if row.get(key) is None else fmt.format(row[key])
                      for key, _, fmt in columns])
    widths = [max(len(r[k]) for r in cells) for k in range(len(columns))]
    lines = ["  ".join(c.rjust(w) for c, w in zip(r, widths)) for r in cells]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def format_report(report: dict) -> str:
    """The terminal form of :func:`paper_report`."""
    rows, comp = report["rows"], report["compensated"]
    rule = comp[0]["branch_rule"] if comp else "control"
    n = comp[0]["samples_per_cycle"] if comp else SAMPLES_PER_CYCLE
    parts = [
        "Table 1 cases: complex permeability and steady-state loop, i = I_m cos(2 pi f t)",
        "(B_m: model input from the Table 1 calibration; B_m eq22 from E_m; "
        "dy = y(i=+I_m) - y(i=-I_m), eq 40)",
        format_table(rows, ROW_COLUMNS),
        "",
        "Losses (eqs 7, 9, 11) and loop ends relative to the loop minimum "
        "(measured: Table 3)",
        format_table(rows, LOSS_COLUMNS),
        "",
        f"Compensated (Figure 9, branch rule '{rule}'), u = a + a cos(2 pi f t), "
        f"last of {CYCLES} cycles at {n} samples/cycle",
        "(dy' = y(u=u_max) - y(u=0), eq 41; q'/q = dy'/dy; linearity: eq 38-normalised y "
        "vs normalised u (comp) or i (unc); saturated: steps over the run)",
        format_table(comp, COMPENSATED_COLUMNS),
    ]
    if "diagnosis" in report:
        from .paperdiag import format_paper_diagnosis
        parts += ["", format_paper_diagnosis(report["diagnosis"])]
    return "\n".join(parts)
