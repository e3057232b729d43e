"""The paper's loss separation (eqs 7-12) as a field separation in the time domain.

Bertotti's statistical theory of losses writes the applied field as the sum of
a rate-independent part and two dynamic parts [1]_::

    H = H_hys(B, history) + k_e dB/dt + k_ex |dB/dt|^(1/2) sign(dB/dt)

The power each part absorbs, H dB/dt per volume, is the hysteresis loss, the
classical eddy-current loss k_e (dB/dt)^2 (eq 8) and the excess loss
k_ex |dB/dt|^(3/2) (eq 10). For a sinusoidal B = B_m sin(w t) the dynamic
parts give, per cycle,

    k_e integral (dB/dt)^2 dt = 2 pi^2 k_e B_m^2 f          (= K_e B_m^2 f, eq 9)
    k_ex integral |dB/dt|^1.5 dt = C k_ex B_m^1.5 f^0.5      (= K_ex B_m^1.5 f^0.5, eq 11)

with C = (2 pi)^1.5 <|cos|^1.5>, <.> the mean over a period. Hence
k_e = K_e / (2 pi^2) and k_ex = K_ex / C. The mean is a Beta integral,

    <|cos|^p> = (2/pi) integral_0^(pi/2) cos^p x dx = Gamma((p+1)/2) / (sqrt(pi) Gamma(p/2 + 1)),

so <|cos|^1.5> = Gamma(5/4) / (sqrt(pi) Gamma(7/4)) = 0.556 and C = 8.7635 (the
constant of Lin et al. [2]_). The hysteresis part's loss per cycle is K_h B_m^n
(eq 7) by construction of :mod:`gmt.timedomain.hysteresis`.

References
----------
.. [1] G. Bertotti, *Hysteresis in Magnetism*, Academic Press, 1998, ch. 12.
.. [2] D. Lin, P. Zhou, W. N. Fu, Z. Badics, Z. J. Cendes, "A dynamic core loss
   model for soft ferromagnetic and power ferrite materials in transient
   finite element analysis", IEEE Trans. Magn. 40(2), 2004, 1318-1321.
.. [3] M. Abramowitz and I. A. Stegun, *Handbook of Mathematical Functions*,
   1964, 6.2.1 and 6.2.2 (Beta function).
"""
from __future__ import annotations

import math

__all__ = ["EXCESS_CONSTANT", "cos_power_mean", "eddy_field_coefficient",
           "excess_field_coefficient", "dynamic_field", "waveform_losses"]


def cos_power_mean(p: float) -> float:
    """<|cos x|^p> over a period, Gamma((p+1)/2) / (sqrt(pi) Gamma(p/2 + 1)), [-].

    Examples
    --------
    >>> round(cos_power_mean(2.0), 15)   # <cos^2> = 1/2
    0.5
    """
    return math.exp(math.lgamma(0.5 * (p + 1.0)) - math.lgamma(0.5 * p + 1.0)) / math.sqrt(math.pi)


#: C = (2 pi)^1.5 <|cos|^1.5> = 8.7635: K_ex = C k_ex for a sinusoidal B (eq 11).
EXCESS_CONSTANT = (2.0 * math.pi) ** 1.5 * cos_power_mean(1.5)


def eddy_field_coefficient(eddy_coefficient: float) -> float:
    """k_e = K_e / (2 pi^2), [A s/(m T)] from K_e of eq 9 [W s^2/(m^3 T^2)]."""
    return eddy_coefficient / (2.0 * math.pi ** 2)


def excess_field_coefficient(excess_coefficient: float) -> float:
    """k_ex = K_ex / C, [A s^0.5/(m T^0.5)] from K_ex of eq 11 [W s^1.5/(m^3 T^1.5)]."""
    return excess_coefficient / EXCESS_CONSTANT


def dynamic_field(rate, k_e: float, k_ex: float):
    """The eddy and excess fields (k_e dB/dt, k_ex |dB/dt|^0.5 sign(dB/dt)), [A/m].

    Parameters
    ----------
    rate : float or numpy array
        dB/dt, [T/s].
    k_e, k_ex : float
        Field coefficients (:func:`eddy_field_coefficient`, :func:`excess_field_coefficient`).
    """
    if isinstance(rate, float):
        root = math.sqrt(abs(rate))
        return k_e * rate, (k_ex * root if rate > 0.0 else -k_ex * root)
    import numpy as np

    rate = np.asarray(rate, dtype=float)
    return k_e * rate, k_ex * np.sign(rate) * np.sqrt(np.abs(rate))


def waveform_losses(rate, step: float, k_e: float, k_ex: float) -> tuple[float, float]:
    """Eddy and excess loss per volume of a sampled dB/dt, sum of k (dB/dt)^q h, [J/m^3].

    A rectangle rule over the samples of ``rate`` (mid-step rates give
    second order); for the closed forms of a sine, square or trapezoid see the
    tests.
    """
    import numpy as np

    rate = np.asarray(rate, dtype=float)
    return (float(k_e * np.sum(rate * rate) * step),
            float(k_ex * np.sum(np.abs(rate) ** 1.5) * step))
