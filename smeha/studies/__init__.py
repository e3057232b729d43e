"""The studies: what a user runs the transducer FMU and the EHA for.

- :mod:`smeha.studies.flow`: the flow study (one co-simulation case, both modes at each
  frequency, load lines, the check against eqs 40/41) and its tables;
  :mod:`smeha.studies.flowplots` its figures; :mod:`smeha.studies.flowcommands` the
  ``simulate``, ``flow`` and ``sweep`` commands; :mod:`smeha.studies.variantcheck` says
  when a model variant (``flow --variant``) is not physical in the pump.
- :mod:`smeha.studies.sweep`: a grid of flow-study cases on local processes or Dask.
- :mod:`smeha.studies.paper`: the paper's model results against its tables;
  :mod:`smeha.studies.paperdiag` the diagnosis of the paper's own data;
  :mod:`smeha.studies.paperplots` the figures of ``smeha paper --plots``.

The command line (:mod:`smeha.cli`) only wires them.
"""
