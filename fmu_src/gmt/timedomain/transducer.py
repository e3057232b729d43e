"""The time-domain model's parts as :class:`gmt.Transducer` builds them.

Kept here so that the transducer module stays the drive chain: it asks for a
forward stepper and a compensator and gets the time-domain ones.
"""
from __future__ import annotations

from ..errors import ParameterError
from ..inverse import stroke
from .inverse import TimeDomainCompensator
from .magnetics import TimeDomainStepper

__all__ = ["time_domain_stepper", "time_domain_compensator"]


def time_domain_stepper(params, excitation, variant, td=None) -> TimeDomainStepper:
    """The forward model for ``magnetics="time_domain"``.

    Raises
    ------
    ParameterError
        With a model variant (its extensions are written for the paper's
        magnetics) or ``follow_drive`` (there is no operating point to follow).
    """
    if not variant.is_paper:
        raise ParameterError(f"model_variant = {variant.name!r}: the time-domain magnetics "
                             "run the paper's model only (model_variant 'paper')")
    if excitation.follow_drive:
        raise ParameterError("follow_drive = True has no meaning with the time-domain "
                             "magnetics (they follow any drive); set it False")
    return TimeDomainStepper(params, td)


def time_domain_compensator(params, point, drive, td=None) -> TimeDomainCompensator:
    """The time-domain inverse as the sampled compensator, with the paper compensator's y_d.

    The demand's zero is the bottom of the stroke at the operating point
    (:func:`gmt.inverse.stroke`), as for Figure 9's compensator, so that both
    answer the same control signal with the same demanded displacement.
    """
    return TimeDomainCompensator(params, td, drive, stroke(params, point)[0])
