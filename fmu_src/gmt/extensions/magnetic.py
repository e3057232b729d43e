"""What the magnetisation stage's time-stepped forms share: adding their change of M.

Hysteresis adds its operator's output to M, saturation maps M through its law
(:mod:`gmt.extensions.hysteresis`, :mod:`gmt.extensions.saturation`); either
way M changes by some delta, B by mu_0 delta (eq 4) and the strain as eq 25
says (:meth:`MagnetizationStage.with_magnetization`). The paper's part of M is
the one the operating point carries (:meth:`gmt.variants.Chain.paper_point`):
the part whose total, with the extension's change, gives the measured B_m.
"""
from __future__ import annotations

import numpy as np

from ..constants import MU_0
from ..forward import Magnetics
from ..magnetostriction import magnetostrictive_force


class MagnetizationStage:
    """Mixin of the magnetisation-stage step forms (module docstring)."""

    #: The field stage's time-stepped form (set by :class:`gmt.variants.Chain`; None
    #: without one): where it shields the field, the form switches on the field inside.
    field_stage = None

    @property
    def point_switching_gain(self) -> complex:
        """The field the form switches on per applied field at the operating point's
        fundamental, [-]: the field stage's
        :meth:`gmt.extensions.Extension.switching_gain`, 1 without one (the periodic
        waveform)."""
        stage = self.field_stage
        if stage is None:
            return 1.0
        return complex(np.ravel(stage.switching_gain(stage.values,
                                                     self.point.angular_frequency))[0])

    def switching_field(self, mag: Magnetics) -> float:
        """The field the form's relays or plays switch on this step, [A/m]: the section-mean
        field inside where the field stage shields it (``shields_field``), else H."""
        stage = self.field_stage
        held = stage.held_switching_field if stage is not None and stage.shields_field else None
        return mag.field if held is None else held

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
