"""One run without noise: the paper's model with the hidden effect added, time-stepped.

The paper's model (eq 30: the magnetics of :mod:`gmt` at the samples, the mechanics of
eq 27 integrated as the continuous system, :func:`_continuous_mechanics`) runs on a grid
:data:`FINE` times finer than the record's; the effect then changes what its truth
formulation changes (:data:`_CHANGES`): M and B, and through them the force; the force;
the mechanics; or the displacement sensor.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

import gmt
from gmt.constants import MU_0
from gmt.forward import bias_displacement, magnetics
from gmt.magnetostriction import magnetostriction, magnetostrictive_force

from .delay import delayed
from .eddy import slab_diffusion
from .foh import foh_response
from .hysteresis import preisach
from .resonance import two_mass_response
from .saturation import saturated_magnetization
from .thermal import temperature_rise

__all__ = ["FINE", "true_response"]

#: Internal steps per sample of the generator's models: the force is taken linear between
#: the internal samples (relative error about (w h / FINE)^2 / 12, 3e-6 at 256 samples a
#: period) and the effects' own integrations run on the same grid.
FINE = 4


def _paper_force(params, magnetization):
    """Magnetostrictive force A_r E^H K_lambda (M_b + M)^2, eqs 25 and 28, [N]."""
    return magnetostrictive_force(
        magnetostriction(magnetization, params.bias_magnetization,
                         params.magnetostriction_coefficient),
        params.rod_area, params.youngs_modulus)


def _continuous_mechanics(params, force, step):
    """y of eq 27 for the force samples ``force`` [N], linear between samples, [m].

    The continuous transducer: the mechanics integrated exactly for a force
    linear between the samples (first-order hold, :func:`foh_response`), from
    rest at the bias displacement at t = 0, as :func:`gmt.simulate` starts. Not
    the paper's zero-order-hold stepper, which would delay the response by
    half a step (and more where the mechanics are fast against the step).
    """
    a = np.array([[0.0, 1.0], [-params.stiffness / params.mass,
                               -params.damping / params.mass]])
    b = np.array([0.0, 1.0 / params.mass])
    y_b = bias_displacement(params)
    u = np.asarray(force, dtype=float) - params.stiffness * y_b
    return y_b + foh_response(a, b, [1.0, 0.0], u, step, x0=[0.0, 0.0])


@dataclass(frozen=True)
class _PaperRun:
    """The paper's model over one run on the fine grid (SI): what each effect changes."""

    frequency: float  # f, [Hz]
    current_amplitude: float  # I_m, [A]
    samples_per_cycle: int  # of the fine grid
    step: float  # h, [s]
    angular_frequency: float  # w, [rad/s]
    time: np.ndarray  # t_k = k h, [s]
    current: np.ndarray  # i = I_m cos(w t), [A]
    point: object  # the operating point (gmt.operating_point)
    paper: dict  # the magnetics of eq 30 at the samples (gmt.simulate)
    displacement: np.ndarray  # y of eq 27, continuous mechanics, [m]
    flux_density_rate: np.ndarray  # dB/dt of eq 4, [T/s]


def _paper_run(params, frequency, current_amplitude, cycles, samples_per_cycle) -> _PaperRun:
    """The paper's model over ``cycles`` periods of ``samples_per_cycle`` samples."""
    f, im = float(frequency), float(current_amplitude)
    n = int(cycles * samples_per_cycle)
    h = 1.0 / (f * samples_per_cycle)
    w = 2.0 * math.pi * f
    t = h * np.arange(n)
    i = im * np.cos(w * t)
    point = gmt.operating_point(params, gmt.Excitation(f, im))
    paper = gmt.simulate(params, point, i, h)  # the magnetics of eq 30 at the samples
    paper_y = _continuous_mechanics(params, paper["force"], h)
    # dB/dt of eq 4 exactly: dH/dt = -w H_q, dH_q/dt = w H
    dbdt = MU_0 * w * (point.mu_real * -paper["quadrature_field"]
                       + point.mu_imag * paper["field"])
    return _PaperRun(frequency=f, current_amplitude=im, samples_per_cycle=samples_per_cycle,
                     step=h, angular_frequency=w, time=t, current=i, point=point, paper=paper,
                     displacement=paper_y, flux_density_rate=dbdt)


def _magnetic_change(run, params, magnetization, flux_density=None, force=None) -> dict:
    """The record of an effect on M: B (default mu_0 (H + M)), dB/dt, M and y, SI.

    dB/dt is the paper's exact one plus the effect's change of B by second-order
    central differences; y is eq 27 driven by ``force`` (default eqs 25 and 28 of M).
    """
    paper = run.paper
    b_eff = MU_0 * (paper["field"] + magnetization) if flux_density is None else flux_density
    if force is None:
        force = _paper_force(params, magnetization)
    return {"flux_density": b_eff,
            "flux_density_rate": run.flux_density_rate + np.gradient(
                b_eff - paper["flux_density"], run.step, edge_order=2),
            "magnetization": magnetization,
            "displacement": _continuous_mechanics(params, force, run.step)}


def _hysteresis(run, truth, params) -> dict:
    """The Preisach part added to the paper's M, from one period's history."""
    if truth["preisach_magnetization"] == 0.0:
        return {}
    hm = params.field_per_ampere * run.current_amplitude
    m_pre = preisach(run.paper["field"], coercive_field=truth["coercive_field"],
                     coercive_log_spread=truth["coercive_log_spread"],
                     interaction_spread=truth["interaction_spread"],
                     history=(hm, -hm))
    return _magnetic_change(run, params,
                            run.paper["magnetization"] + truth["preisach_magnetization"] * m_pre)


def _saturation(run, truth, params) -> dict:
    """The paper's M through the Langevin anhysteretic."""
    if math.isinf(truth["saturation_magnetization"]):
        return {}
    return _magnetic_change(run, params, saturated_magnetization(
        run.paper["magnetization"], params.bias_magnetization,
        truth["saturation_magnetization"]))


def _eddy(run, truth, params) -> dict:
    """M and B diffused across the slab, averaged; the strain averaged locally."""
    if not truth["diffusion_time"] > 0.0:
        return {}
    h, w, im = run.step, run.angular_frequency, run.current_amplitude
    # warm-up: the slowest slab mode decays as exp(-pi^2 t / (mu sigma d^2))
    warm = max(1, math.ceil(20.0 * truth["diffusion_time"] / math.pi ** 2 * run.frequency))
    tw = h * np.arange(-warm * run.samples_per_cycle, 0)
    mag_w = magnetics(params, run.point, im * np.cos(w * tw), im * np.sin(w * tw))
    nw = tw.size
    m_all = np.concatenate((mag_w.magnetization, run.paper["magnetization"]))
    b_all = np.concatenate((mag_w.flux_density, run.paper["flux_density"]))
    m_x, wts = slab_diffusion(m_all, h, truth["diffusion_time"], truth["nodes"])
    b_x, _ = slab_diffusion(b_all, h, truth["diffusion_time"], truth["nodes"])
    m_x = m_x[:, nw:]
    # strain is local: average (M_b + M(x))^2 over the thickness (parallel fibres)
    force = _paper_force(params, 0.0) * (
        wts @ (params.bias_magnetization + m_x) ** 2) / params.bias_magnetization ** 2
    return _magnetic_change(run, params, wts @ m_x, flux_density=wts @ b_x[:, nw:],
                            force=force)


def _delay(run, truth, params) -> dict:
    """The displacement read through the sensor's delay line."""
    tau = truth["delay"]
    if tau > 0.0:
        return {"displacement": delayed(params, run.time, run.displacement, tau)}
    return {}


def _resonance(run, truth, params) -> dict:
    """The output mass's displacement on the compliant joint."""
    if math.isinf(truth["joint_stiffness"]):
        return {}
    return {"displacement": two_mass_response(run.paper["force"], run.step, params, truth,
                                              run.displacement)}


def _thermal(run, truth, params) -> dict:
    """The coil's temperature rise, K_lambda(T) and the sensor offset it causes."""
    dtemp = temperature_rise(run.time, run.current_amplitude, run.frequency, truth)
    out = {"temperature_rise": dtemp}
    if truth["thermal_resistance"] > 0.0:
        force = run.paper["force"] * (1.0 + truth["strain_coefficient_tc"] * dtemp)
        out["displacement"] = (_continuous_mechanics(params, force, run.step)
                               + truth["offset_tc"] * dtemp)
    return out


#: What each effect changes in the paper's record (entries of :func:`true_response`).
_CHANGES = {
    "rate_independent_hysteresis": _hysteresis,
    "magnetization_saturation": _saturation,
    "eddy_current_diffusion": _eddy,
    "transport_delay": _delay,
    "mechanical_resonance": _resonance,
    "thermal_drift": _thermal,
}


def true_response(effect, truth, params, frequency, current_amplitude, cycles=8,
                  samples_per_cycle=256) -> dict:
    """Noise-free record of one run with the hidden effect, SI.

    The models run on a grid :data:`FINE` times finer than the samples
    (the mechanics of eq 27 integrated exactly for a force linear between the
    internal samples, :func:`_continuous_mechanics`) and are read at the samples.

    Returns
    -------
    dict
        ``time``, ``current`` (true), ``displacement`` (absolute, including the
        bias displacement), ``flux_density`` and ``flux_density_rate`` (dB/dt),
        and for some effects internals (``temperature_rise``, ...).
    """
    out = _fine_response(effect, truth, params, frequency, current_amplitude, cycles,
                         samples_per_cycle * FINE)
    n = int(cycles * samples_per_cycle)
    return {k: np.asarray(v)[::FINE][:n] for k, v in out.items()}


def _fine_response(effect, truth, params, frequency, current_amplitude, cycles,
                   samples_per_cycle) -> dict:
    """:func:`true_response` on the fine grid."""
    run = _paper_run(params, frequency, current_amplitude, cycles, samples_per_cycle)
    out = {"time": run.time, "current": run.current, "displacement": run.displacement,
           "flux_density": run.paper["flux_density"],
           "flux_density_rate": run.flux_density_rate}
    if effect is None:  # the paper's model alone
        return out
    if effect not in _CHANGES:
        raise gmt.ParameterError(f"effect = {effect!r} is not one of {tuple(_CHANGES)} or None")
    out.update(_CHANGES[effect](run, truth, params))
    return out
