"""The magnetisation stage's time-stepped forms keep the describing-function split.

The paper's mu' and mu'' are the describing function of the magnetisation at
the operating point (I_m, w): its first harmonic per unit H_m (Gelb & Vander
Velde, *Multiple-Input Describing Functions and Nonlinear System Design*,
McGraw-Hill 1968). The periodic forms therefore add to the paper's M only the
part of a hysteresis or saturation operator's output that is *not* its
fundamental (:func:`gmt.extensions.harmonic_remainder`). In the time domain
the same split is: the operator applied to each sample, minus a fixed linear
term c_h H + c_q H_q, where H_q = H_m sin(w t) is the quadrature field the
paper's model already rebuilds (eq 31) and c_h, c_q are the operator's
fundamental at the operating point,

    c_h - j c_q = (2 / (N H_m)) sum_n P_n e^{-j theta_n},

computed once at construction over one period of N = :data:`GRID` samples of
the operator's periodic output (for saturation, on the periodic magnetisation
the stages before it give). For i = I_m cos(w t) this is exactly the periodic
form; for any other waveform (the compensated current, a host's input) it
applies the same correction, as the paper applies mu' and mu'' of its
operating point to any waveform.
"""
from __future__ import annotations

import numpy as np

from ..constants import MU_0
from ..forward import Magnetics
from ..magnetostriction import magnetostrictive_force

#: Samples of one period over which a magnetic operator's fundamental is computed.
GRID = 4096


class MagnetizationStage:
    """Mixin of the magnetisation-stage step forms: output minus its fundamental.

    A subclass sets ``self.coefficients = self.fundamental(periodic output)``
    and implements ``addition(mag)`` (the operator's change of M for this
    sample, [A/m]); :meth:`adjust` adds it minus c_h H + c_q H_q.
    """

    def grid(self):
        """theta over one period, :data:`GRID` points, [rad]."""
        return 2.0 * np.pi * np.arange(GRID) / GRID

    def fundamental(self, periodic_output):
        """(c_h, c_q): the fundamental of one period as c_h H + c_q H_q (module docstring)."""
        n = len(periodic_output)
        c1 = 2.0 * np.fft.rfft(periodic_output)[1] / n
        hm = self.point.field_amplitude
        return float(c1.real / hm), float(-c1.imag / hm)

    def with_magnetization(self, base: Magnetics, delta) -> Magnetics:
        """``base`` with ``delta`` [A/m] added to M (and mu_0 delta to B), eqs 4-5, 25, 28.

        The strain gains K_lambda (2 (M_b + M) delta + delta^2), which makes it
        K_lambda (M_b + M + delta)^2 for the paper's strain (eq 25) and keeps the
        section's spread term of the eddy-current diffusion forms.
        """
        p = self.params
        m = base.magnetization
        lam = base.strain + p.magnetostriction_coefficient * (
            2.0 * (p.bias_magnetization + m) * delta + delta * delta)
        return Magnetics(base.field, base.quadrature_field,
                         base.flux_density + MU_0 * delta, m + delta, lam,
                         magnetostrictive_force(lam, p.rod_area, p.youngs_modulus))

    def addition(self, mag: Magnetics) -> float:
        """The operator's change of M at this sample, [A/m]."""
        raise NotImplementedError

    def adjust(self, mag, step, time):
        ch, cq = self.coefficients
        delta = self.addition(mag) - (ch * mag.field + cq * mag.quadrature_field)
        return self.with_magnetization(mag, delta)
