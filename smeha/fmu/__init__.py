"""The FMU tooling: build the project's FMUs and connect them into the EHA system.

* :mod:`smeha.fmu.build` builds, patches, makes reproducible and validates each FMU
  (``smeha build``);
* :mod:`smeha.fmu.native` makes the Linux binary load its Python at run time and writes
  the build environment record;
* :mod:`smeha.fmu.ssp` writes the EHA system of one case as SSP 1.0, OSP and container FMU;
* :mod:`smeha.fmu.systemrun` runs that system in fmpy's SSP master, libcosim and the
  container FMU, and checks its cylinder flow.

The physics is in ``gmt`` and ``system_models``; nothing here computes any.
"""
