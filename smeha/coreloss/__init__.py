"""Core losses: measured data in, the loss laws of the time-domain magnetics scored on them.

Modules: :mod:`~smeha.coreloss.measurements` (the CSV format and MagNet's rows),
:mod:`~smeha.coreloss.magnetdb` (the shipped copy of MagNet v1 and its extraction),
:mod:`~smeha.coreloss.models` (the laws and their fits), :mod:`~smeha.coreloss.study`
(calibrate, predict, score, hold out), :mod:`~smeha.coreloss.plots` (error maps),
:mod:`~smeha.coreloss.commands` (``smeha losses``). docs/LOSSES.md is the user guide.
Nothing heavy is imported here.
"""

__all__ = ["MATERIALS"]

#: The ten ferrites of Princeton's MagNet v1, in the order of its documentation.
MATERIALS = ("N87", "3C90", "3C94", "3E6", "3F4", "77", "78", "N27", "N30", "N49")
