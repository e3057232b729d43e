"""The co-simulation's hot loop, compiled: TR-BDF2 steps of the circuit and of the plant.

What and why
------------
Each communication step integrates the stiff hydraulics: TR-BDF2 (two
damped-Newton solves a substep, each needing the right-hand side a few times
and its Jacobian). In Python every one of those is hundreds of tiny numpy and
attribute operations (~4 ms per step); the same arithmetic on plain floats,
compiled by numba, takes microseconds.

What is compiled is the *numerical method* only: the assembly of the
equations (the same as :func:`system_models.circuit.rhs` and
:func:`system_models.plant.rhs`), damped Newton, TR-BDF2 and the halving of
a failing substep (the same as :mod:`system_models.implicit`). The *physics*
is not rewritten: the kernel calls the components' plain-number functions
(``mixture_bulk_modulus``, ``orifice_flow``, ``opening_area``,
``gas_spring_pressure``, ``piston_acceleration_of``, ``rod_rates``), which
the readable modules use themselves and ``numba.extending.register_jitable``
lets numba compile. The Jacobian is by forward differences (a dozen
evaluations of compiled arithmetic cost less than one call of an analytic
Python Jacobian). ``tests/test_kernel.py`` checks the right-hand sides
against the readable ones to round-off, the circuit's step against
:func:`implicit.tr_bdf2` to the Newton tolerance and the plant's steps
against scipy's Radau (different numerics) to TR-BDF2's own error.

Two ways the rod enters (the co-simulation's two couplings):

* **prescribed** (displacement port, :func:`circuit_step`): the 10 circuit
  states (:data:`system_models.circuit.STATE_NAMES`), the rod moving on the
  cubic Hermite path through (y, v) at both ends of the step;
* **integrated** (force port, :func:`plant_run`): the plant's states, the
  circuit's and then the rod's (:mod:`system_models.rod`: 2 or 4), the
  magnetostrictive force given at both ends of each step and interpolated
  linearly (equal ends: held).

Cost per substep (measured on recorded co-simulation calls): a right-hand
side ~0.17 us (the physics' powers and roots), a Jacobian with its LU ~2 us,
a solve with the factors ~0.13 us. Hence the Newton matrix I - c J is kept
while the substep length and the valve commands stay the same -- over a
call's substeps and steps -- and formed afresh only where Newton stalls; the
BDF2 stage starts from a linear extrapolation; the last Newton correction is
applied without another right-hand side; and nothing is allocated per
substep.

Parameters travel as one float array (:func:`pack`).

Modules: :mod:`.equations` (the packed parameters and the rates),
:mod:`.trbdf2` (the substep and its Newton solves, shared), :mod:`.prescribed`
(:func:`circuit_step`) and :mod:`.integrated` (:func:`plant_run`); the names
above are importable from here.

numba's cache and its freshness
-------------------------------
numba caches each compiled entry point next to its source file and keys it by
that file's content only: code it compiled in from another file (another
module of this package, a component's ``jitable`` physics) could change and
the cache would still be taken. So every entry point's cache is keyed by all
of those files together (:func:`_stamp_caches`): changing any of them
recompiles the kernel at its next use.
"""
from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np

from ..circuit import CircuitParameters
from ..rod import RodParameters
from . import equations, integrated, prescribed, trbdf2
from .equations import NC, accumulator_pressure, flows, pack, rates, state_size
from .integrated import GROWTH, PLANT_EXTRA, SWITCH_START, _plant_run, new_control, plant_run
from .prescribed import circuit_step
from .trbdf2 import CHAMBER_EMPTIED, NEWTON_FAILED, OK, RTOL

__all__ = ["pack", "state_size", "flows", "accumulator_pressure", "rates", "circuit_step",
           "plant_run", "new_control", "PLANT_EXTRA", "SWITCH_START", "GROWTH", "OK",
           "NEWTON_FAILED", "CHAMBER_EMPTIED", "RTOL", "NC", "compiled", "ensure_compiled",
           "load"]


def _sources() -> list[Path]:
    """The files whose code the compiled kernel holds: this package's modules with compiled
    functions and the components' modules with ``jitable`` physics
    (:mod:`system_models._jit`)."""
    here = Path(__file__).resolve().parent
    return ([p for p in sorted(here.glob("*.py")) if "\n@njit" in p.read_text(encoding="utf-8")]
            + [p for p in sorted(here.parent.glob("*.py"))
               if "\n@jitable" in p.read_text(encoding="utf-8")])


def _stamp_caches() -> None:
    """Key the cache of every compiled function of the kernel by all of :func:`_sources`.

    numba keys a function's cache by its own file's content (its cache
    locator's source stamp); this gives each the stamp of the whole set
    instead, through numba's cache object (numba 0.5x-0.6x). Should numba's
    cache no longer have that shape, its own keying stays (stale code after
    editing another file is then possible).
    """
    digest = hashlib.sha256()
    try:
        for path in _sources():
            digest.update(path.name.encode())
            digest.update(path.read_bytes())
    except OSError:  # sources not on a file system (a zip): numba's own keying
        return
    stamp = digest.digest()
    for module in (equations, trbdf2, prescribed, integrated):
        for value in vars(module).values():
            cache_file = getattr(getattr(value, "_cache", None), "_cache_file", None)
            if cache_file is not None and hasattr(cache_file, "_source_stamp"):
                cache_file._source_stamp = stamp


_stamp_caches()


def compiled() -> bool:
    """Whether numba's on-disk cache holds the kernel's compiled code for these sources
    (else the first call compiles it, ~20 s on this project's machine, and caches it next
    to the package's files)."""
    try:
        return bool(_plant_run._cache._cache_file._load_index())  # numba's FunctionCache
    except Exception:  # noqa: BLE001 -- another numba, an unreadable index: assume not
        return False


def ensure_compiled(say=None) -> None:
    """Compile the kernel's entry points now if numba's cache does not hold them, telling
    ``say`` (a callable taking a message) first: a run, or worker processes started after
    this, then load the compiled code instead of each compiling it."""
    if compiled():
        return
    if say is not None:
        say("compiling the hydraulic kernel (numba; the first run only, ~20 s, then cached)")
    load()


def load() -> None:
    """Compile the kernel's entry points, or load them from numba's cache (~0.4 s), into
    this process: processes forked from it (:mod:`smeha.pool`) then have them loaded."""
    circuit = CircuitParameters()
    packed = pack(circuit, RodParameters())
    x = np.concatenate((np.full(3, 1.5e6), [1e-5, 0.025, 0.0, 0.0, 0.0, 0.0, 0.0],
                        [7e-5, 0.0]))
    plant_run(x, [1e-5], [[1400.0, 1400.0]], [[1.0, 0.0, 0.0, 1.0]], 0.0, packed)
    circuit_step(x[:10], (7e-5, 0.0), (7e-5, 0.0), 1e-5, (1.0, 0.0, 0.0, 1.0), 0.0, circuit)
    flows(x, packed)
    accumulator_pressure(x, packed)
