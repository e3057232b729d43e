"""The package's errors: one small family, so that a bug is never taken for bad input.

Two bases (defined in :mod:`gmt.errors`, the lowest layer, so that the transducer's
physics, the hydraulics and the studies share them):

* :class:`InputError` (a ``ValueError``): input the user can mend. The command line prints
  its message on one line with exit status 2. Members: :class:`gmt.ParameterError` (a
  parameter outside its range), :class:`smeha.cliargs.UsageError` (options that
  contradict each other, a file whose content is wrong), :class:`smeha.measured.DataError`
  (a measurement file that cannot be used), :class:`smeha.studies.sweep.SpecError` (a sweep
  spec or table that cannot be used), and the diagnosis's refusals of its runs.
* :class:`RunError` (a ``RuntimeError``): a run that stopped on good input. Exit status 1,
  one line. Members: :class:`system_models.implicit.IntegrationError` (and its
  ``CavitationError``), :class:`system_models.displacementport.CouplingError`,
  :class:`smeha.studies.sweep.SweepError` (no scheduler, say).

:func:`smeha.cli.main` catches these two and nothing else of the package's own: any other
exception inside a study is a bug, and shows its traceback.
"""
from gmt.errors import InputError, ParameterError, RunError

__all__ = ["InputError", "RunError", "ParameterError"]
