"""The transducer as the co-simulation master drives it: the FMU, or gmt in-process.

:class:`FmuTransducer` runs the transducer FMU (FMI 2.0 co-simulation) through
the library fmpy loaded, calling the FMI functions directly
(:func:`fmi2_functions`); :class:`DirectTransducer` runs :class:`gmt.Transducer`
in the same process. Both answer what the master asks
(:class:`TransducerBackend`): the force port steps the drive alone
(:meth:`~TransducerBackend.drive_step`: current and magnetostrictive force),
the displacement port steps the rod with the chamber's force held and saves
and restores the state (:mod:`system_models.displacementport`). The master
reads the rod's mechanics (m, c, K, or a variant's two masses) from here, so
the plant of the force port carries the FMU's own values.
"""
from __future__ import annotations

from ctypes import byref
from pathlib import Path
from typing import NamedTuple, Protocol

import gmt

#: The FMU's calculated parameters, in the order of :class:`gmt.RodMechanics`.
FMU_MECHANICS = ("equivalent_mass", "equivalent_damping", "equivalent_stiffness",
                 "output_mass", "joint_stiffness", "joint_damping")


class Drive(NamedTuple):
    """How the transducer produces its force (what the master aligns and interpolates)."""

    compensated: bool  #: the digital compensator drives the coil (force held between samples)
    sample_period: float  #: its sample period T_c, [s] (0: a sample every step)
    #: the force is continuous whatever the current does (the time-domain magnetics: B, so
    #: M and F, cannot jump): linear over a step even behind the compensator's held current
    continuous_force: bool = False


class TransducerBackend(Protocol):
    """What the master needs from a transducer (FMU or in-process)."""

    def rod_state(self) -> tuple:
        """(y, v) of the rod now, [m, m/s]."""

    def drive(self) -> Drive: ...

    def mechanics(self) -> tuple:
        """The rod's mechanics, :class:`gmt.RodMechanics` fields."""

    def step(self, time: float, step: float, control: float, force: float) -> tuple:
        """Advance over [time, time + step] with the chamber force on the rod held; (y, v,
        current) after (the displacement port)."""

    def drive_step(self, time: float, step: float, control: float) -> tuple:
        """Advance over [time, time + step] with no force on the rod; (current,
        magnetostrictive force) over the step (the force port)."""

    def sensors(self) -> tuple:
        """What the last :meth:`drive_step` left on the transducer's own sensors: (flux
        density B over that step [T], the displacement its sensor reads at the step's end
        [m]) of the transducer with no force on its rod (the force port)."""

    def save(self): ...

    def restore(self, state) -> None: ...

    def close(self) -> None: ...


class DirectTransducer:
    """:class:`gmt.Transducer` (optionally with a :class:`gmt.ModelVariant`) in-process."""

    def __init__(self, params=None, excitation=None, drive=None, variant=None,
                 magnetics="paper", inverse=None):
        self.model = gmt.Transducer(params, excitation, drive, variant=variant,
                                    magnetics=magnetics, inverse=inverse)

    def rod_state(self):
        return self.model.forward.displacement, self.model.forward.velocity

    def drive(self):
        return Drive(self.model.compensator is not None, self.model.sample_period,
                     self.model.magnetics == "time_domain")

    def mechanics(self):
        return tuple(self.model.rod_mechanics())

    def step(self, time, step, control, force):
        out = self.model.step(control, step, force)
        return out.displacement, out.velocity, out.current

    def drive_step(self, time, step, control):
        out = self.model.step(control, step, 0.0)
        self._sensors = (out.magnetics.flux_density, out.sensed_displacement)
        return out.current, out.magnetics.force

    def sensors(self):
        return self._sensors

    def outside_design_point(self) -> bool:
        """Whether the coil current departs from the model's operating point now
        (:class:`gmt.design_point.DriveMonitor`)."""
        return bool(self.model.monitor.outside)

    def save(self):
        return self.model.get_state()

    def restore(self, state):
        self.model.set_state(state)

    def close(self):
        pass


_EXTRACTED: dict = {}


def extracted(path) -> str:
    """Extract an FMU once per process and file version; removed at exit (a worker
    forked from this process uses the same directory, and leaves it to this process).

    Every instance of one FMU then runs from one resources directory, so the
    Python modules the FMU brings (shared by name in the host's interpreter)
    always come from the copy its slave expects.
    """
    import atexit
    import shutil

    from fmpy import extract
    p = Path(path).resolve()
    key = (str(p), p.stat().st_mtime_ns)
    if key not in _EXTRACTED:
        _EXTRACTED[key] = extract(str(p))
        atexit.register(shutil.rmtree, _EXTRACTED[key], True)
    return _EXTRACTED[key]


#: FMI 2.0 functions the master calls directly, with their C argument types.
_FMI2_PROTOTYPES = {
    "fmi2SetReal": ("component", "vr", "size", "reals"),
    "fmi2GetReal": ("component", "vr", "size", "reals"),
    "fmi2DoStep": ("component", "time", "step", "boolean"),
    "fmi2GetFMUstate": ("component", "state_pointer"),
    "fmi2SetFMUstate": ("component", "state"),
    "fmi2FreeFMUstate": ("component", "state_pointer"),
}


def fmi2_functions(fmu) -> dict:
    """The FMU's FMI 2.0 C functions, called without fmpy's Python wrappers.

    fmpy's ``setReal``/``getReal`` build two ctypes arrays per call and its
    logging wrapper costs ~2 us a call, together about half of what the FMI
    adds to a co-simulation step. This takes the functions from the shared
    library fmpy loaded (``fmu.dll``, a :class:`ctypes.CDLL`) as new function
    objects with the FMI 2.0 standard's C prototypes (FMI 2.0.x, section
    2.1), so nothing depends on fmpy's private tables. Raises a
    :class:`RuntimeError` naming fmpy's version if fmpy's ``FMU2Slave`` no
    longer has ``dll`` and ``component``.
    """
    import ctypes

    from fmpy.fmi2 import (fmi2Boolean, fmi2Component, fmi2FMUstate, fmi2Real, fmi2Status,
                           fmi2ValueReference)
    dll, component = getattr(fmu, "dll", None), getattr(fmu, "component", None)
    if not isinstance(dll, ctypes.CDLL) or component is None:
        import fmpy
        raise RuntimeError(f"fmpy {fmpy.__version__}: FMU2Slave has no loaded library 'dll' "
                           "or no 'component'; system_models.transducers.fmi2_functions needs "
                           "updating for this fmpy")
    types = {"component": fmi2Component, "vr": ctypes.POINTER(fmi2ValueReference),
             "size": ctypes.c_size_t, "reals": ctypes.POINTER(fmi2Real), "time": fmi2Real,
             "step": fmi2Real, "boolean": fmi2Boolean,
             "state_pointer": ctypes.POINTER(fmi2FMUstate), "state": fmi2FMUstate}
    out = {}
    for name, args in _FMI2_PROTOTYPES.items():
        function = dll[name]  # a new function object: fmpy's own keeps its settings
        function.argtypes = [types[a] for a in args]
        function.restype = fmi2Status
        out[name] = function
    return out


class FmuTransducer:
    """The transducer FMU (FMI 2.0 co-simulation) driven through fmpy.

    Parameters
    ----------
    path : str or Path
        The ``.fmu`` file.
    start_values : dict
        Parameter name -> value (the FMU's variables: fmu_src/smeha_fmu_interface.py).
    instance_name : str
    """

    def __init__(self, path, start_values=None, instance_name="transducer"):
        from fmpy import read_model_description
        from fmpy.fmi2 import FMU2Slave, fmi2FMUstate, fmi2Real, fmi2True, fmi2ValueReference

        self._unzipdir = extracted(path)
        md = read_model_description(self._unzipdir)
        self._vr = {v.name: v.valueReference for v in md.modelVariables}
        self._types = {v.name: v.type for v in md.modelVariables}
        self.fmu = FMU2Slave(guid=md.guid, unzipDirectory=self._unzipdir,
                             modelIdentifier=md.coSimulation.modelIdentifier,
                             instanceName=instance_name)
        self.fmu.instantiate()
        self.fmu.setupExperiment(startTime=0.0)
        self.fmu.enterInitializationMode()
        for name, value in (start_values or {}).items():
            self.set(name, value)
        self.fmu.exitInitializationMode()
        self._c = fmi2_functions(self.fmu)
        self._in_vr = (fmi2ValueReference * 2)(self._vr["u"], self._vr["external_force"])
        self._in_val = (fmi2Real * 2)()
        outputs = ("displacement", "velocity", "current", "force", "flux_density",
                   "sensed_displacement")
        self._out_vr = (fmi2ValueReference * 4)(*(self._vr[n] for n in outputs[:4]))
        self._out_val = (fmi2Real * 4)()
        # the force port sets u alone (external_force stays 0) and reads current and force,
        # and in the same call the transducer's own sensors (sensors())
        self._drive_out_vr = (fmi2ValueReference * 4)(*(self._vr[n] for n in outputs[2:]))
        self._true = fmi2True
        self._new_state = fmi2FMUstate
        self._state = None

    def rod_state(self):
        return tuple(self.fmu.getReal([self._vr["displacement"], self._vr["velocity"]]))

    def drive(self):
        compensated = bool(self.fmu.getBoolean([self._vr["compensated"]])[0])
        continuous = ("magnetics" in self._vr and self.fmu.getString(
            [self._vr["magnetics"]])[0] in ("time_domain", b"time_domain"))
        return Drive(compensated, float(self.fmu.getReal([self._vr["compensator_period"]])[0])
                     if compensated else 0.0, continuous)

    def mechanics(self):
        return tuple(self.fmu.getReal([self._vr[n] for n in FMU_MECHANICS]))

    def set(self, name, value):
        """Set one variable by name, whatever its FMI type."""
        vr = [self._vr[name]]
        kind = self._types[name]
        if kind == "Real":
            self.fmu.setReal(vr, [float(value)])
        elif kind == "Integer":
            self.fmu.setInteger(vr, [int(value)])
        elif kind == "Boolean":
            self.fmu.setBoolean(vr, [bool(value)])
        else:
            self.fmu.setString(vr, [str(value)])

    def _check(self, name, status):
        if status > 1:  # above fmi2Warning, as fmpy's wrapper
            from fmpy.fmi1 import FMICallException
            raise FMICallException(function=name, status=status)

    def step(self, time, step, control, force):
        c, comp, val, out = self._c, self.fmu.component, self._in_val, self._out_val
        val[0], val[1] = control, force
        self._check("fmi2SetReal", c["fmi2SetReal"](comp, self._in_vr, 2, val))
        self._check("fmi2DoStep", c["fmi2DoStep"](comp, time, step, self._true))
        self._check("fmi2GetReal", c["fmi2GetReal"](comp, self._out_vr, 3, out))
        return out[0], out[1], out[2]

    def drive_step(self, time, step, control):
        c, comp, val, out = self._c, self.fmu.component, self._in_val, self._out_val
        val[0] = control
        self._check("fmi2SetReal", c["fmi2SetReal"](comp, self._in_vr, 1, val))
        self._check("fmi2DoStep", c["fmi2DoStep"](comp, time, step, self._true))
        self._check("fmi2GetReal", c["fmi2GetReal"](comp, self._drive_out_vr, 4, out))
        return out[0], out[1]

    def sensors(self):
        return self._out_val[2], self._out_val[3]

    def outside_design_point(self) -> bool:
        """The FMU's ``outside_design_point`` output now."""
        return bool(self.fmu.getBoolean([self._vr["outside_design_point"]])[0])

    def save(self):
        comp = self.fmu.component
        # one saved state at a time: free the previous one (flat memory)
        if self._state is not None:
            self._check("fmi2FreeFMUstate", self._c["fmi2FreeFMUstate"](comp, byref(self._state)))
        self._state = self._new_state()
        self._check("fmi2GetFMUstate", self._c["fmi2GetFMUstate"](comp, byref(self._state)))
        return self._state

    def restore(self, state):
        self._check("fmi2SetFMUstate", self._c["fmi2SetFMUstate"](self.fmu.component, state))

    def close(self):
        if self._state is not None:
            self.fmu.freeFMUstate(self._state)
            self._state = None
        self.fmu.terminate()
        self.fmu.freeInstance()
