"""Co-simulation of the transducer FMU with the hydraulic plant.

The master steps the transducer (the FMU through fmpy, or :class:`gmt.Transducer`
in-process: :class:`FmuTransducer`, :class:`DirectTransducer`) and the
hydraulics (:mod:`system_models.plant`, :mod:`system_models.kernel`) over
communication steps, with the valves switched by a sampled controller
(:class:`~system_models.controller.SampledValveController`). Two couplings:

Force port (default): cut where the physics is one-way
-------------------------------------------------------
In the paper's model nothing flows back from the rod to the magnetics: the
current, the compensator, the field, the magnetisation and the
magnetostrictive force F = A_r E^H lambda (eqs 1-26, 28, 31-37) do not depend
on the rod's motion. The stiff part of the system is the rod's mass-spring-
damper (eq 27) against the pump chamber's oil, a ~30 kHz mode (oil stiffness
beta A_d^2 / V ~ 9e8 N/m against K = 2e7 N/m). So the transducer hands over
F, and the plant integrates eq 27 *together with* the chamber, implicitly
(TR-BDF2: L-stable, second order), with m, c, K read from the transducer
(the FMU's calculated parameters: one source of truth, and a mechanics
variant acts in the plant). The transducer is stepped once per communication
step, before the plant and without save, restore or iteration, and the plant
integrates a window of steps in one compiled call.

The force over a step follows how it is produced: the digital compensator's
DAC holds its current between samples, so its force is piecewise constant
and held over each step (communication points fall on its samples); the
uncompensated amplifier follows u continuously, so its force is smooth and
taken linear between its values at the step's ends (the transducer is
stepped one step ahead of the plant to have the end value).

Displacement port (``coupling="displacement"``): the cross-check
----------------------------------------------------------------
The transducer integrates its own rod with the chamber's force A_d p_P held
over the step as its input; the plant takes the rod's motion back. Exchanging
force and motion once a step (Jacobi or Gauss-Seidel) is only conditionally
stable across the stiff rod-oil mode, so the master couples them implicitly
through the FMU's state save/restore:

1. save the FMU state at t;
2. guess the held force F (the end pressure of the last step times A_d);
3. restore, step the FMU over [t, t + h] with F held, read y(t + h), v(t + h);
4. integrate the circuit over the step along the cubic Hermite rod
   trajectory through (y, v) at both ends (:func:`kernel.circuit_step`);
5. the residual r(F) = F - A_d p_P(t + h): the held force equals the
   chamber's force at the end of the step -- the implicit (backward) choice,
   which damps the rod-oil mode however stiff the oil;
6. quasi-Newton (secant) on r, its slope carried from step to step, until
   |r| is below ``force_tolerance``; the last FMU step taken is the one kept.

It pays two FMU steps, a save and a restore, and ~2.5 hydraulic
integrations a step, and its held force is a first-order error in h; it is
kept as the independent check of the force port (the two agree on the flow,
``tests/test_cosim.py``).

Both couplings give the transducer the same control signal at its samples:
u(t_k) (the digital compensator samples it there); the continuous
uncompensated drive of the displacement port holds u(t_k + h/2), the value
that makes a held input lag it by no half step.
"""
from __future__ import annotations

import math
from ctypes import byref
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, NamedTuple, Protocol

import numpy as np

import gmt

from . import kernel
from .circuit import CircuitParameters, initial_state
from .controller import SampledValveController
from .defaults import (DEFAULT_COUPLING, DEFAULT_STEP, HYDRAULIC_STEP,
                       VALVE_CONTROLLER_PERIOD)
from .implicit import IntegrationError
from .plant import PlantParameters
from .plant import initial_state as plant_start
from .rod import RodParameters

#: Fields of the structured array :func:`cosimulate` returns (SI).
RESULT_FIELDS = (
    "time", "control", "current", "rod_displacement", "rod_velocity", "force",
    "p_pump", "p_big", "p_small", "p_accumulator", "piston_position", "piston_velocity",
    "q_v1", "q_v2", "q_v3", "q_v4", "volume_into_big", "compression_volume",
    "compressing", "valves_compressing", "iterations",
)
#: SI unit of each field, as CSV column names carry it (``p_pump_Pa``, ``q_v1_m3_s``):
#: "" for a 0/1 flag (``compressing``: the controller's pump phase, ``valves_compressing``:
#: the phase the valves act on) and a count (``iterations`` of the coupling).
RESULT_UNITS = {
    "time": "s", "control": "V", "current": "A", "rod_displacement": "m",
    "rod_velocity": "m_s", "force": "N", "p_pump": "Pa", "p_big": "Pa", "p_small": "Pa",
    "p_accumulator": "Pa", "piston_position": "m", "piston_velocity": "m_s",
    "q_v1": "m3_s", "q_v2": "m3_s", "q_v3": "m3_s", "q_v4": "m3_s", "volume_into_big": "m3",
    "compression_volume": "m3", "compressing": "", "valves_compressing": "", "iterations": "",
}

COUPLINGS = ("force", "displacement")

#: The FMU's calculated parameters, in the order of :class:`gmt.RodMechanics`.
FMU_MECHANICS = ("equivalent_mass", "equivalent_damping", "equivalent_stiffness",
                 "output_mass", "joint_stiffness", "joint_damping")


class Drive(NamedTuple):
    """How the transducer produces its force (what the master aligns and interpolates)."""

    compensated: bool  #: the digital compensator drives the coil (force held between samples)
    sample_period: float  #: its sample period T_c, [s] (0: a sample every step)


# ==================================================================== transducers


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

    def save(self): ...

    def restore(self, state) -> None: ...

    def close(self) -> None: ...


class DirectTransducer:
    """:class:`gmt.Transducer` (optionally with a :class:`gmt.ModelVariant`) in-process."""

    def __init__(self, params=None, excitation=None, drive=None, variant=None):
        self.model = gmt.Transducer(params, excitation, drive, variant=variant)

    def rod_state(self):
        return self.model.forward.displacement, self.model.forward.velocity

    def drive(self):
        return Drive(self.model.compensator is not None, self.model.sample_period)

    def mechanics(self):
        return tuple(self.model.rod_mechanics())

    def step(self, time, step, control, force):
        out = self.model.step(control, step, force)
        return out.displacement, out.velocity, out.current

    def drive_step(self, time, step, control):
        out = self.model.step(control, step, 0.0)
        return out.current, out.magnetics.force

    def save(self):
        return self.model.get_state()

    def restore(self, state):
        self.model.set_state(state)

    def close(self):
        pass


_EXTRACTED: dict = {}


def _extracted(path) -> str:
    """Extract an FMU once per process and file version; removed at exit.

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
                           "or no 'component'; system_models.cosim.fmi2_functions needs "
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

        self._unzipdir = _extracted(path)
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
        outputs = ("displacement", "velocity", "current", "force")
        self._out_vr = (fmi2ValueReference * 4)(*(self._vr[n] for n in outputs))
        self._out_val = (fmi2Real * 4)()
        # the force port sets u alone (external_force stays 0) and reads current and force
        self._drive_out_vr = (fmi2ValueReference * 2)(*(self._vr[n] for n in outputs[2:]))
        self._true = fmi2True
        self._new_state = fmi2FMUstate
        self._state = None

    def rod_state(self):
        return tuple(self.fmu.getReal([self._vr["displacement"], self._vr["velocity"]]))

    def drive(self):
        compensated = bool(self.fmu.getBoolean([self._vr["compensated"]])[0])
        return Drive(compensated, float(self.fmu.getReal([self._vr["compensator_period"]])[0])
                     if compensated else 0.0)

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
        self._check("fmi2GetReal", c["fmi2GetReal"](comp, self._drive_out_vr, 2, out))
        return out[0], out[1]

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


# ==================================================================== settings


@dataclass(frozen=True)
class CosimSettings:
    """Settings of one co-simulation run.

    Attributes
    ----------
    duration : float
        Simulated time, [s].
    step : float
        Communication step h, [s] (default :data:`DEFAULT_STEP`). Steps are
        also cut at every valve action and, with a sampled compensator, at
        its samples.
    coupling : {"force", "displacement"}
        The force port (default) or the displacement port (module docstring).
    direction : {"down", "up"}
        Commanded cylinder direction (Figure 2).
    load_force : float
        External load on the cylinder, opposing "down", [N].
    controller_period : float
        Sample period of the valve controller, [s]
        (:data:`VALVE_CONTROLLER_PERIOD`); the valves act after their exact
        dead times, at communication points.
    hydraulic_step : float or None
        Longest substep of the hydraulic integrator, [s] (default
        :data:`~system_models.defaults.HYDRAULIC_STEP`). Force port: after
        every valve action the substeps start at 1 us and grow fourfold up to
        this (:func:`kernel.plant_run`); None: the communication step.
        Displacement port: ceil(h / hydraulic_step) equal substeps a step
        (None: one).
    window : int
        Force port: communication steps the plant integrates per compiled
        call (records and observers still see every step).
    force_tolerance : float
        Displacement port: interface residual |F - A_d p_P(t + h)| accepted,
        [N]; 1e-4 N is 0.08 Pa of chamber pressure, above the hydraulics'
        Newton noise.
    max_iterations : int
        Displacement port: secant iterations per step before giving up.
    """

    duration: float = 0.1
    step: float = DEFAULT_STEP
    coupling: str = DEFAULT_COUPLING
    direction: str = "down"
    load_force: float = 0.0
    controller_period: float = VALVE_CONTROLLER_PERIOD
    hydraulic_step: float | None = HYDRAULIC_STEP
    window: int = 64
    force_tolerance: float = 1e-4
    max_iterations: int = 25

    def __post_init__(self):
        gmt.errors.check_range("duration", self.duration, 0.0, 1e4, unit="s")
        gmt.errors.check_range("step", self.step, 0.0, 1.0, unit="s")
        gmt.errors.check_range("controller_period", self.controller_period, 0.0, 1.0, unit="s")
        if self.hydraulic_step is not None:
            gmt.errors.check_range("hydraulic_step", self.hydraulic_step, 0.0, 1.0, unit="s")
        gmt.errors.check_range("force_tolerance", self.force_tolerance, 0.0, 1e6, unit="N")
        gmt.errors.check_range("window", self.window, 1, 1e6, low_open=False)
        if self.coupling not in COUPLINGS:
            raise gmt.ParameterError(f"coupling = {self.coupling!r} is not one of {COUPLINGS}")
        if self.direction not in ("down", "up"):
            raise gmt.ParameterError(f"direction = {self.direction!r} is not one of ('down', 'up')")


class CouplingError(RuntimeError):
    """The interface iteration did not converge in a step."""


# ==================================================================== the run


class _Grid:
    """Communication points: multiples of the step, the compensator's samples, valve actions."""

    def __init__(self, step, end, sample_period, controller: SampledValveController):
        self.step, self.end, self.sample = step, end, sample_period
        self.controller = controller
        self.tol = 1e-9 * step

    def points(self, t, count) -> np.ndarray:
        """t and the next ``count`` communication points after it (fewer at the end)."""
        tol, step = self.tol, self.step
        high = min(t + (count + 1) * step, self.end)
        k0 = math.floor((t + tol) / step) + 1
        candidates = [np.arange(k0, k0 + count + 2) * step, [self.end]]
        if self.sample > 0.0:
            j0 = math.floor((t + tol) / self.sample) + 1
            candidates.append(np.arange(j0, j0 + count + 2) * self.sample)
        candidates.append(self.controller.actions_between(t, high + step))
        points = np.sort(np.concatenate(candidates))
        points = points[(points > t + tol) & (points <= self.end + tol)]
        # one point where the sources coincide (within the tolerance)
        keep = np.concatenate(([True], np.diff(points) > tol))
        points = points[keep][:count]
        if points.size and self.end - points[-1] <= tol:
            points[-1] = self.end
        return np.concatenate(([t], points))

    def next(self, t) -> float:
        """The communication point after t."""
        return float(self.points(t, 1)[1])


class _Writer:
    """The record: one row a communication point, kept or streamed to an observer."""

    def __init__(self, size_hint, keep, observer):
        self.dtype = np.dtype([(name, float) for name in RESULT_FIELDS])
        self.keep, self.observer = keep, observer
        self.rows = np.zeros(size_hint + 1 if keep else 0, dtype=self.dtype)
        self.count = 0
        self.last = None

    def add(self, columns: dict, n: int):
        """Append n rows given as {field: array or scalar}."""
        block = np.zeros(n, dtype=self.dtype)
        for name, values in columns.items():
            block[name] = values
        if self.observer is not None:
            for row in block:
                self.observer(row)
        if self.keep:
            if self.count + n > len(self.rows):
                grow = np.zeros(max(n, len(self.rows) // 4 + 8), dtype=self.dtype)
                self.rows = np.concatenate((self.rows, grow))
            self.rows[self.count:self.count + n] = block
        self.count += n
        self.last = block[-1:].copy()

    def result(self):
        return self.rows[:self.count] if self.keep else self.last


def _circuit_columns(x, rod, packed) -> dict:
    """Record columns of circuit states (rows of x, [:, :10]) and the rod's (y, v) rows."""
    x = np.atleast_2d(x)
    q = np.array([kernel.flows(row, packed) for row in x])
    p_a = np.array([kernel.accumulator_pressure(row, packed) for row in x])
    return _columns(x, np.atleast_2d(rod), q, p_a)


def _columns(x, rod, q, p_a) -> dict:
    return {"p_pump": x[:, 0], "p_big": x[:, 1], "p_small": x[:, 2], "p_accumulator": p_a,
            "piston_position": x[:, 4], "piston_velocity": x[:, 5],
            "rod_displacement": rod[:, 0], "rod_velocity": rod[:, 1],
            "q_v1": q[:, 0], "q_v2": q[:, 1], "q_v3": q[:, 2], "q_v4": q[:, 3]}


def cosimulate(backend: TransducerBackend, control: Callable[[float], float],
               circuit: CircuitParameters, settings: CosimSettings,
               progress: Callable[[int, int], None] | None = None,
               observer: Callable[[np.void], None] | None = None,
               keep_record: bool = True) -> np.ndarray:
    """Run one co-simulation.

    Parameters
    ----------
    backend : TransducerBackend
        The transducer (FMU or direct), initialised and at rest.
    control : callable
        u(t), [V] (vectorised over an array of times if it can be: the valve
        controller samples it in blocks).
    circuit : CircuitParameters
    settings : CosimSettings
    progress : callable, optional
        Called as progress(steps_done, n_steps), n_steps = duration / step.
    observer : callable, optional
        Called with each finished record (a row of the array below), in
        time order; e.g. :class:`system_models.flowcheck.RunningFlow`.
    keep_record : bool
        False keeps no record (memory stays flat however long the run; the
        observer sees every row); the result is then the final row alone.

    Returns
    -------
    numpy structured array
        One record per communication point t_k (fields :data:`RESULT_FIELDS`):
        the state at t_k and what acts over [t_k, t_k+1): the control signal
        given the transducer, the coil current, the magnetostrictive force
        (force port) or the chamber force held on the rod (displacement
        port), the controller's phase and the valves' phase (after their
        dead times); the last record carries the final state.
        ``volume_into_big`` is the net volume that has entered the big
        cavity through V1 and V2 since t = 0, and ``compression_volume`` the
        oil volume taken up by compression in the chamber and cavities since
        t = 0, [m^3] (see :func:`volume_balance`). ``rod_displacement`` is
        the rod's end in the pump chamber (the output mass with two masses).
    """
    n_steps = int(round(settings.duration / settings.step))
    end = n_steps * settings.step
    drive = backend.drive()
    delays = [v.opening_time if v.response == "delay" else 0.0 for v in circuit.valves]
    controller = SampledValveController(settings.direction, control,
                                        settings.controller_period, delays)
    grid = _Grid(settings.step, end, drive.sample_period if drive.compensated else 0.0,
                 controller)
    writer = _Writer(n_steps, keep_record, observer)
    run = _force_port if settings.coupling == "force" else _displacement_port
    run(backend, control, circuit, settings, drive, controller, grid, writer, progress,
        n_steps)
    return writer.result()


def _substeps(h, settings) -> int:
    if settings.hydraulic_step is None:
        return 1
    return max(1, math.ceil(h / settings.hydraulic_step - 1e-9))


def _valve_phase(commands, direction):
    """The phase the valves act on: V1 open going down, V3 going up (Figure 2)."""
    return commands[0 if direction == "down" else 2]


def _force_port(backend, control, circuit, settings, drive, controller, grid, writer,
                progress, n_steps):
    """The force port: the transducer one step ahead, the plant a window at a time."""
    rod = RodParameters.of(backend.mechanics())
    plant = PlantParameters(circuit, rod)
    packed = plant.packed
    n = kernel.state_size(packed)
    out = 10 if rod.size == 2 else 12  # index of the chamber side's y in the state
    z = plant_start(plant, backend.rod_state()[0])
    linear = not drive.compensated  # a continuous drive: the force linear over a step
    volume = compressed = 0.0
    substeps = kernel.new_control()  # the plant's substep length, carried across windows
    valves = 0 if settings.direction == "down" else 2  # V1 or V3: open while compressing
    first = _circuit_columns(z[:10], z[out:out + 2], packed)
    # the transducer's step from t = 0: (t, h, u, current, force)
    times = grid.points(0.0, 1)
    u0 = control(0.0)
    pending = (u0,) + tuple(backend.drive_step(0.0, times[1], u0))
    t = 0.0
    previous = None  # the last row's valve phase (the final row repeats it)
    while end_not_reached(t, grid):
        # the window's communication points, and one more for the transducer's look-ahead
        points = grid.points(t, settings.window + 1)
        m = min(settings.window, points.size - 1)
        starts, steps = points[:m], np.diff(points[:m + 1])
        u = np.empty(m + 1)
        current, force = np.empty(m + 1), np.empty(m + 1)
        u[0], current[0], force[0] = pending
        for k in range(1, m + 1):
            if k < points.size - 1:
                u[k] = control(points[k])
                current[k], force[k] = backend.drive_step(points[k],
                                                          points[k + 1] - points[k], u[k])
            else:  # the run's end: the last step holds its force
                u[k], current[k], force[k] = u[k - 1], current[k - 1], force[k - 1]
        pending = (u[m], current[m], force[m])
        commands = controller.commands_over(starts)
        forces = np.column_stack((force[:m], force[1:] if linear else force[:m]))
        status, done, rows = kernel.plant_run(
            z, steps, forces, commands, settings.load_force, packed,
            max_substep=settings.hydraulic_step, control=substeps)
        if status != kernel.OK:
            at = starts[done]
            if status == kernel.CHAMBER_EMPTIED:
                raise gmt.ParameterError(f"the rod empties the pump chamber at t = {at:g} s")
            raise IntegrationError(f"the plant's Newton did not converge at t = {at:g} s "
                                   f"(step {steps[done]:g} s); give a shorter hydraulic_step")
        # row k: the state at the start of step k (the end of step k - 1)
        ends_x, ends_q, ends_pa = rows[:, :n], rows[:, n:n + 4], rows[:, n + 4]
        cols = _stack_first(first, _columns(ends_x[:-1], ends_x[:-1, out:out + 2],
                                            ends_q[:-1], ends_pa[:-1]))
        vol_end, comp_end = volume + rows[:, n + 5], compressed + rows[:, n + 6]
        cols.update({
            "time": starts, "control": u[:m], "current": current[:m], "force": force[:m],
            "compressing": controller.phases_over(starts),
            "valves_compressing": commands[:, valves],
            "volume_into_big": np.concatenate(([volume], vol_end[:-1])),
            "compression_volume": np.concatenate(([compressed], comp_end[:-1])),
            "iterations": 1.0})
        writer.add(cols, m)
        z = ends_x[-1].copy()
        volume, compressed = vol_end[-1], comp_end[-1]
        first = _columns(ends_x[-1:], ends_x[-1:, out:out + 2], ends_q[-1:], ends_pa[-1:])
        previous = commands[-1, valves]
        t = float(points[m])
        controller.forget_before(t)
        if progress is not None:
            progress(min(int(round(t / settings.step)), n_steps), n_steps)
    final = dict(first, time=t, control=control(t), current=pending[1], force=pending[2],
                 compressing=float(controller.phase_at(t)),
                 valves_compressing=previous if previous is not None else 0.0,
                 volume_into_big=volume, compression_volume=compressed, iterations=0.0)
    writer.add(final, 1)


def end_not_reached(t, grid) -> bool:
    return grid.end - t > grid.tol


def _stack_first(first: dict, rest: dict) -> dict:
    return {k: np.concatenate((np.atleast_1d(first[k]), rest[k])) for k in first}


#: Range kept for the interface slope dr/dF of the secant iteration.
SLOPE_RANGE = (0.5, 1.0e4)


def _displacement_port(backend, control, circuit, settings, drive, controller, grid, writer,
                       progress, n_steps):
    """The displacement port: the transducer's rod, the chamber force iterated (docstring)."""
    packed = kernel.pack(circuit)
    area = circuit.chamber.piston_area
    x = initial_state(circuit)
    rod = backend.rod_state()
    force = x[0] * area
    volume = compressed = 0.0
    slope = [None]  # the secant slope, carried from step to step
    t = 0.0
    previous = None
    while end_not_reached(t, grid):
        h = grid.next(t) - t
        commands = controller.commands_at(t)
        # the digital compensator samples u(t); the continuous drive holds u(t + h/2)
        u = control(t) if drive.compensated else control(t + 0.5 * h)
        result = _solve_interface(backend, t, h, u, force, x, rod, commands, packed, settings,
                                  area, slope)
        x1, (y1, v1), current, force1, iterations, dvol, dcomp = result
        row = _circuit_columns(x[:10], rod, packed)
        previous = _valve_phase(commands, settings.direction)
        row.update(time=t, control=u, current=current, force=force1,
                   compressing=float(controller.phase_at(t)), valves_compressing=previous,
                   volume_into_big=volume, compression_volume=compressed,
                   iterations=float(iterations))
        writer.add(row, 1)
        volume += dvol
        compressed += dcomp
        x, rod, force = x1, (y1, v1), force1
        t += h
        if progress is not None:
            progress(min(int(round(t / settings.step)), n_steps), n_steps)
    row = _circuit_columns(x[:10], rod, packed)
    row.update(time=t, control=control(t), current=0.0, force=force,
               compressing=float(controller.phase_at(t)),
               valves_compressing=previous if previous is not None else 0.0,
               volume_into_big=volume, compression_volume=compressed, iterations=0.0)
    writer.add(row, 1)


def _solve_interface(backend, t, h, u, force, x, rod, commands, packed, settings, area, slope):
    """One displacement-port step: the held chamber force F with F = A_d p_P(t + h).

    Returns (x at t + h, (y, v) at t + h, current, F, iterations, volume into
    the big cavity, compression volume).
    """
    saved = backend.save()
    f_k, r_prev, f_prev = force, None, None
    substeps = _substeps(h, settings)
    for it in range(1, settings.max_iterations + 1):
        if it > 1:
            backend.restore(saved)
        y1, v1, current = backend.step(t, h, u, f_k)
        status, x1, _, dvol, dcomp, halvings = kernel.circuit_step(
            x, rod, (y1, v1), h, commands, settings.load_force, packed, substeps)
        if status != kernel.OK:
            if f_prev is None:
                if status == kernel.CHAMBER_EMPTIED:
                    raise gmt.ParameterError(
                        f"rod displacement {max(rod[0], y1):g} m empties the pump chamber")
                raise IntegrationError(f"Newton did not converge within a {h:g} s step")
            # the trial force drove the rod somewhere the oil cannot follow
            # (e.g. emptying the chamber): back off towards the last force
            # that integrated, and trust the slope less
            f_k = 0.5 * (f_k + f_prev)
            slope[0] = None if slope[0] is None else min(slope[0] * 4.0, SLOPE_RANGE[1])
            continue
        if halvings:
            # repeat with that discretisation throughout, so r(F) stays smooth
            substeps *= 2 ** halvings
            r_prev = f_prev = None
            continue
        r = f_k - area * x1[0]
        if abs(r) <= settings.force_tolerance:
            return x1, (y1, v1), current, f_k, it, dvol, dcomp
        # secant slope dr/dF, carried over from step to step; updated only
        # from iterates far enough apart that Newton's tolerance in the
        # hydraulics cannot corrupt it, and kept in its physical range:
        # dr/dF = 1 + A_d dp/dF >= 1 (pushing the rod back lowers the
        # chamber pressure), up to ~1e3 and more for the stiffest oil
        if r_prev is not None and abs(f_k - f_prev) > 10.0 * settings.force_tolerance:
            slope[0] = min(max((r - r_prev) / (f_k - f_prev), SLOPE_RANGE[0]), SLOPE_RANGE[1])
        f_prev, r_prev = f_k, r
        if slope[0] is None:
            # first step of the run: a small probe gives dr/dF by difference
            f_k = f_k - math.copysign(min(abs(r), 1.0), r)
        else:
            f_k = f_k - r / slope[0]
    raise CouplingError(
        f"interface force did not converge in {settings.max_iterations} iterations "
        f"at t = {t:g} s (residual {r:g} N); reduce the step")


def volume_balance(record, circuit: CircuitParameters) -> tuple[float, float]:
    """Oil volume bookkeeping of a run: (imbalance, pumped volume), [m^3].

    Continuity over the whole circuit: the volume the rod and piston sweep out
    of the chamber and cavities, plus the oil stored in the accumulator, plus
    the oil absorbed by compression, sums to zero. The imbalance is that sum
    at the end of the run (round-off when every flow leaving one volume enters
    another); the pumped volume, A_d times the rod's total travel, gives its
    scale.
    """
    from .accumulator import oil_volume_at
    first, last = record[0], record[-1]
    cyl, ch = circuit.cylinder, circuit.chamber
    dx = last["piston_position"] - first["piston_position"]
    geometric = (-ch.piston_area * (last["rod_displacement"] - first["rod_displacement"])
                 + cyl.big_area * dx - cyl.small_area * dx
                 + oil_volume_at(circuit.accumulator, last["p_accumulator"])
                 - oil_volume_at(circuit.accumulator, first["p_accumulator"]))
    pumped = ch.piston_area * float(np.sum(np.abs(np.diff(record["rod_displacement"]))))
    return float(geometric + last["compression_volume"]), pumped
