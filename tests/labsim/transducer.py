"""One run of the transducer as continuous signals: the paper's model (eqs 1-30) plus the
effects, from the drive's switch-on at t = 0 (rod at rest at its bias point before).

Signal chain (each arrow exact unless marked):

    i = I_m cos(w t + phi0) u(t)                                   (drive, eq 1 for H)
    H -> [eddy currents F(s)] -> H_eff                             (``lti``, linear)
    M_lin = F * M_paper,  M_paper = Re((mu_c - 1) H~)              (eqs 3-5, 16, 20)
    M_P = hysteresis(H_eff)                        (``hysteresis`` or ``jiles_atherton``)
    M_tot = S(M_b(t) + M_lin + M_P)   (S = a saturation law, or identity)
    B - B_bias = mu_0 (H_eff + M_tot - S(M_b(0)))                  (eq 5)
    F - F_bias = A_r E^H [K_l(T) M_tot^2 - K_l(T0) S(M_b(0))^2] + thermal expansion (eqs 25, 28)
    y = G_sensor(s) G_mech(s) F (eq 27, two masses or the continuum rod; delayed),
    E = -N_c A_c dB/dt (eq 21), or with the air flux -N_c d/dt [A_r B + (A_c - A_r) mu_0 H]

M_b(t) = M_b except with the magnet-warming drift, whose relative change eps(t) is a constant
plus decaying exponentials; the outputs are then expanded to second order in eps about its
final value (exact without saturation, where they are quadratic in eps).

Nonlinear stages act on the periodic steady state through a phase grid and FFT (smooth
stages: exponentially convergent; the hysteresis branches: coefficients ~ n^-3 for Preisach,
cut below 1e-14 of the largest), and on the transient through a fine time grid (``waveform``
first-order hold), computed only when the record starts before the transient has died out.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import lti, paper
from .constants import MU_0, Transducer
from .effects import EffectSet
from .waveform import Waveform, evaluate_response, harmonic_sum, respond

#: Phase-grid points per period for the smooth nonlinear stages (hysteresis: its own).
PHASE_POINTS = 256
#: Transient grid: at least this many steps per period.
TRANSIENT_STEPS_PER_PERIOD = 2048
#: A transient term is negligible after this many of its time constants (exp(-40) ~ 4e-18).
DECAY_CONSTANTS = 40.0


@dataclass(frozen=True)
class ContinuousRun:
    """Noiseless continuous signals of one run; t = 0 is the drive's switch-on."""

    frequency: float
    current: Waveform  # i(t), [A]
    flux: Waveform  # B(t) - B(0-), [T]
    force: Waveform  # F(t) - F(0-), [N]
    mechanics: lti.Zpk | lti.Modal  # displacement per force, [m/N]
    delay: float  # sensor-chain delay of the displacement, [s]
    sensor: lti.Zpk | None  # the displacement sensor's filter, [-]
    sense_gain: float  # -N_c A_c, [m^2]
    settle_time: float  # after it, transients are below 1e-15 of the signal, [s]
    permeability: paper.Permeability
    air_flux: Waveform | None = None  # mu_0 H of the applied field in the coil's air, [T]
    rod_share: float = 1.0  # A_r / A_c, the rod's share of the sense coil's area, [-]

    def displacement(self, t, anti_alias: lti.Zpk | None = None) -> np.ndarray:
        """y(t) - y(0-) at the sensor, after the optional filter, [m]."""
        parts = [p for p in (anti_alias, self.sensor) if p is not None]
        system = lti.chain(*parts, self.mechanics)
        return evaluate_response(system, self.force, np.asarray(t) - self.delay)

    def sense_voltage(self, t, anti_alias: lti.Zpk, air_flux: bool = False) -> np.ndarray:
        """E(t) = -N_c A_c dB/dt (eq 21) after the anti-alias filter, [V].

        ``air_flux``: the coil, wound around the excitation coil, links the rod's flux and
        the air's between rod and coil, E = -N_c d/dt [A_r B + (A_c - A_r) mu_0 H]; eddy
        currents in the rod do not shield the air's share.
        """
        system = lti.modal(anti_alias * lti.derivative(self.sense_gain))
        if not air_flux:
            return evaluate_response(system, self.flux, t)
        linked = self.flux.scaled(self.rod_share) + self.air_flux.scaled(1.0 - self.rod_share)
        return evaluate_response(system, linked, t)

    def current_signal(self, t, anti_alias: lti.Zpk | None = None) -> np.ndarray:
        """i(t) after the optional filter, [A]."""
        if anti_alias is None:
            return self.current.evaluate(t)
        return evaluate_response(lti.modal(anti_alias), self.current, t)


def simulate(
    transducer: Transducer,
    frequency: float,
    current_amplitude: float,
    phase: float,
    effects: EffectSet,
    transient: bool = True,
    bm_scale: float = 1.0,
) -> ContinuousRun:
    """The continuous run for i = I_m cos(2 pi f t + phase), t >= 0."""
    omega = 2.0 * math.pi * frequency
    perm = paper.permeability(transducer, frequency, current_amplitude, bm_scale)
    drive = np.exp(1j * phase)
    current = Waveform.sinusoid(omega, current_amplitude * drive)
    field = Waveform.sinusoid(omega, perm.field_amplitude * drive)
    air = field.scaled(MU_0)
    magnetization = Waveform.sinusoid(omega, (perm.complex - 1.0) * perm.field_amplitude * drive)
    slowest = math.inf
    if effects.eddy is not None:
        eddy = effects.eddy.transfer()
        if getattr(effects.eddy, "acts_on", "field") == "field":  # H: M and B follow
            field = respond(eddy, field)
        magnetization = respond(eddy, magnetization)
        slowest = eddy.slowest_rate
    stage = _NonlinearStage(transducer, effects, omega, current_amplitude)
    extra_m, square, window = stage.run(field, magnetization, transient)
    flux = (field + magnetization + extra_m).scaled(MU_0)
    force = _force(transducer, effects, current_amplitude, square, stage.bias_total)
    if effects.resonance is not None:
        mechanics = effects.resonance.mechanics(transducer)
    else:
        mechanics = lti.mass_spring_damper(transducer.mass, transducer.damping,
                                           transducer.stiffness)
    rates = [slowest, lti.as_modal(mechanics).slowest_rate]
    sensor, delay = None, 0.0
    if effects.delay is not None:
        sensor, delay = effects.delay.sensor(), effects.delay.delay
    if sensor is not None:
        rates.append(lti.modal(sensor).slowest_rate)
    settle = max(2.0 * 2.0 * math.pi / omega, window + DECAY_CONSTANTS / min(rates))
    sense_gain = -transducer.sense_turns * transducer.sense_area
    return ContinuousRun(frequency, current, flux, force, mechanics, delay, sensor, sense_gain,
                         settle, perm, air, transducer.rod_area / transducer.sense_area)


class _NonlinearStage:
    """Hysteresis, saturation and the square of eq 25, on the periodic state and transient;
    with the magnet-warming drift, the bias M_b (1 + eps(t))."""

    def __init__(self, transducer: Transducer, effects: EffectSet, omega: float,
                 current_amplitude: float) -> None:
        self.bias = transducer.bias_magnetization
        self.effects = effects
        self.omega = omega
        drift = effects.thermal_bias
        self.drift = drift.bias_drift(current_amplitude) if drift is not None else None
        self.initial_eps = 0.0 if self.drift is None else self._eps(np.array(0.0))
        self.bias_total = float(self._saturate(np.array(self._bias(self.initial_eps))))

    def _eps(self, t):
        """Relative change of the bias magnetisation at times t, [-]."""
        final, rates, coefficients = self.drift
        t = np.asarray(t, dtype=float)
        return final + np.sum(coefficients[:, None] * np.exp(-rates[:, None] * t.ravel()),
                              axis=0).reshape(t.shape)

    def _bias(self, eps):
        return self.bias if self.drift is None else self.bias * (1.0 + eps)

    def _saturate(self, m):
        sat = self.effects.saturation
        return m if sat is None else sat.saturate(m, self.bias)

    def _outputs(self, h, m_lin, m_p, eps=0.0):
        """(M_tot - S(M_b(0)) - M_lin, M_tot^2 - S(M_b(0))^2) pointwise."""
        total = self._saturate(self._bias(eps) + m_lin + m_p)
        return total - self.bias_total - m_lin, total**2 - self.bias_total**2

    def _hysteresis_periodic(self, field: Waveform, phase):
        hyst = self.effects.hysteresis
        if hyst is None:
            return np.zeros(np.shape(phase))
        a1 = field.steady()[1]
        return hyst.periodic(abs(a1), phase + np.angle(a1))

    def _periodic_waveforms(self, h, m_lin, m_p):
        """Waveforms of the two outputs for one period of inputs (and the bias drift)."""
        if self.drift is None:
            extra, square = self._outputs(h, m_lin, m_p)
            return (Waveform.periodic(self.omega, _harmonics(extra)),
                    Waveform.periodic(self.omega, _harmonics(square)))
        final, rates, coefficients = self.drift
        d = float(np.sum(np.abs(coefficients)))  # the range of eps - final over the run
        at = [self._outputs(h, m_lin, m_p, final + k * d) for k in ((0, -1, 1) if d else (0,))]
        waves = []
        for which in (0, 1):
            x0 = at[0][which]
            groups = [(0.0, x0)]
            if d:
                x1 = (at[2][which] - at[1][which]) / (2 * d)
                x2 = (at[2][which] + at[1][which] - 2 * x0) / (2 * d * d)
                groups += [(r, c * x1) for r, c in zip(rates, coefficients)]
                groups += [(rates[i] + rates[j], (1 if i == j else 2) * coefficients[i]
                            * coefficients[j] * x2)
                           for i in range(rates.size) for j in range(i, rates.size)]
            scale = max(float(np.max(np.abs(values))) for _, values in groups)
            wave = None
            for rate, values in groups:
                if np.max(np.abs(values)) > 1e-13 * scale:
                    part = Waveform.periodic(self.omega, _harmonics(values), float(rate))
                    wave = part if wave is None else wave + part
            waves.append(wave)
        return waves[0], waves[1]

    def run(self, field: Waveform, magnetization: Waveform, transient: bool):
        """Waveforms of the extra magnetisation and of M_tot^2 - S(M_b)^2; transient length."""
        hyst = self.effects.hysteresis
        points = hyst.phase_points if hyst is not None else PHASE_POINTS
        phase = 2.0 * math.pi * np.arange(points) / points
        t = phase / self.omega
        h_per = harmonic_sum(field.steady(), self.omega, t)
        m_per = harmonic_sum(magnetization.steady(), self.omega, t)
        extra_w, square_w = self._periodic_waveforms(
            h_per, m_per, self._hysteresis_periodic(field, phase))
        linear = field + magnetization  # its exponents: the eddy filter's, on H or M alone
        needs_grid = linear.has_transient_deviation or hyst is not None
        if not (transient and needs_grid):
            return extra_w, square_w, _transient_window(linear, field, self.effects,
                                                        self.omega)
        step, times = _transient_grid(linear, field, self.effects, self.omega)
        h_full, m_full = field.evaluate(times), magnetization.evaluate(times)
        h_steady = harmonic_sum(field.steady(), self.omega, times)
        m_steady = harmonic_sum(magnetization.steady(), self.omega, times)
        p_full = hyst.sequence(h_full) if hyst is not None else 0.0
        p_steady = self._hysteresis_periodic(field, self.omega * times)
        eps = 0.0 if self.drift is None else self._eps(times)
        extra_f, square_f = self._outputs(h_full, m_full, p_full, eps)
        extra_s, square_s = self._outputs(h_steady, m_steady, p_steady, eps)
        extra_w = _with_grid(extra_w, step, extra_f - extra_s)
        square_w = _with_grid(square_w, step, square_f - square_s)
        return extra_w, square_w, times[-1]


def _harmonics(values: np.ndarray, tolerance: float = 1e-14) -> np.ndarray:
    """Coefficients a_n (x = Re sum a_n exp(j n theta)) of one period sampled at P points,
    cut after the last harmonic above ``tolerance`` times the largest."""
    spectrum = np.fft.rfft(values) / values.size
    coef = 2.0 * spectrum
    coef[0] = spectrum[0].real
    coef = coef[: values.size // 2]  # drop the Nyquist bin
    big = np.nonzero(np.abs(coef) > tolerance * max(np.max(np.abs(coef)), 1e-300))[0]
    return coef[: (big[-1] + 1) if big.size else 1]


def _with_grid(w: Waveform, step: float, deviation: np.ndarray) -> Waveform:
    return Waveform(w.omega, w.decays, w.harmonics, w.exponents, w.amplitudes, step, deviation)


def _transient_window(linear: Waveform, field: Waveform, effects: EffectSet,
                      omega: float) -> float:
    """Time after the switch-on beyond which the magnetic state is periodic, [s]; ``linear``
    holds the transients of H and M, ``field`` is the hysteresis input."""
    window = 0.0
    if linear.exponents.size:
        window = DECAY_CONSTANTS / float(np.min(-linear.exponents.real))
    if effects.hysteresis is not None:
        window += effects.hysteresis.window(omega, abs(field.steady()[1]))
    return window


def _transient_grid(linear: Waveform, field: Waveform, effects: EffectSet, omega: float):
    period = 2.0 * math.pi / omega
    step = period / TRANSIENT_STEPS_PER_PERIOD
    if linear.exponents.size:
        step = min(step, 1.0 / (25.0 * float(np.min(-linear.exponents.real))))
    window = _transient_window(linear, field, effects, omega)
    count = int(math.ceil(window / step)) + 1
    return step, np.arange(count) * step


def _force(transducer, effects, current_amplitude, square: Waveform, bias_total) -> Waveform:
    """F - F_bias from M_tot^2 - S(M_b)^2 (eqs 25, 28), with the thermal drift if present."""
    per_strain = transducer.force_per_strain
    kappa = per_strain * transducer.magnetostriction_coefficient
    thermal = effects.thermal if effects.thermal_bias is None else None  # else: in the bias
    if thermal is None:
        return square.scaled(kappa)
    alpha = thermal.strain_coefficient
    rise_inf = thermal.final_rise(current_amplitude)
    change = rise_inf - thermal.initial_rise
    constant = (kappa * alpha * bias_total**2 + per_strain * thermal.expansion_coefficient) * change
    steady = square.steady() * kappa * (1.0 + alpha * rise_inf)
    steady = steady.copy()
    steady[0] += constant
    drift = -square.steady() * kappa * alpha * change
    drift = drift.copy()
    drift[0] -= constant
    grid = square.grid
    if grid.size:
        times = np.arange(grid.size) * square.grid_step
        rise = rise_inf - change * np.exp(-times / thermal.time_constant)
        grid = grid * kappa * (1.0 + alpha * rise)
    return Waveform(
        square.omega,
        (0.0, 1.0 / thermal.time_constant),
        (steady, drift),
        square.exponents,
        square.amplitudes * kappa,
        square.grid_step,
        grid,
    )
