"""Co-simulation of the transducer FMU with the hydraulic circuit.

An explicit master loop (fmpy ``FMU2Slave``) that, each communication step of
length h, gives the transducer its control signal u and the axial force of
the pump chamber on its rod, takes back the rod's displacement and velocity,
and integrates the hydraulics over the step.

Why not plain explicit coupling
-------------------------------
The chamber's oil is far stiffer than the rod: beta A_d^2 / V ~ 9e8 N/m
against K = 2e7 N/m (Table 2; beta = 1.4 GPa, V = 2.5 cm^3). Rod and oil form a ~30 kHz
oscillator; exchanging the force and the motion once per step with a
zero-order hold (Jacobi or Gauss-Seidel) is only conditionally stable. With
stiff oil it diverges at a 20 us step (the ideal circuit: past 1e8 Pa within
the first compression stroke, ``tests/test_cosim.py``); the realistic circuit
survives it only because entrained air softens the oil at low pressure and
the open valves join the chamber to far larger volumes -- a margin that
vanishes as the oil gets stiffer or the chamber is isolated. This master
couples the two implicitly through the FMU's state save/restore, stable
whatever the stiffness:

1. save the FMU state at t;
2. guess the held force F (the end pressure of the last step times A_d);
3. restore, step the FMU over [t, t + h] with F held, read y(t + h), v(t + h);
4. integrate the circuit over the step along the cubic Hermite rod
   trajectory through (y, v) at both ends, with TR-BDF2 (second order and
   L-stable: the valve orifices make the oil stiffer still), the chamber fed
   the rod velocity each stage's formula implies so the swept volume is exact;
5. the residual r(F) = F - A_d p_P(t + h): the held force equals the
   chamber's force at the end of the step -- the implicit (backward) choice,
   which damps the rod-oil mode however stiff the oil. (Matching the mean
   pressure over the step instead balances the impulse exactly but leaves
   that mode undamped at the interface: with TR-BDF2 hydraulics and the
   ideal circuit's stiff oil it grows until the rod leaves its chamber.)
6. quasi-Newton (secant) on r, its slope carried from step to step, until
   |r| is below ``force_tolerance``; the last FMU step taken is the one kept.

The transducer's mechanics are affine in F for a held current, so the secant
slope is exact and two iterations usually suffice. The same loop runs with
the FMU (:class:`FmuTransducer`) or with :class:`gmt.Transducer` in-process
(:class:`DirectTransducer`), so the FMU can be checked against the direct
coupling.
"""
from __future__ import annotations

import math
from collections import deque
from ctypes import byref
from pathlib import Path
from dataclasses import dataclass
from typing import Callable, Protocol

import numpy as np

import gmt

from .circuit import CircuitInputs, CircuitParameters, initial_state, valve_flows
from .controller import SampledValveController, pump_phase, valve_commands
from .implicit import IntegrationError, backward_euler, tr_bdf2

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


class TransducerBackend(Protocol):
    """What the master needs from a transducer (FMU or in-process)."""

    def rod_state(self) -> tuple:
        """(y, v) of the rod now, [m, m/s]."""

    def step(self, time: float, step: float, control: float, force: float) -> tuple:
        """Advance over [time, time + step]; return (y, v, current) at the end."""

    def save(self): ...

    def restore(self, state) -> None: ...

    def close(self) -> None: ...


class DirectTransducer:
    """:class:`gmt.Transducer` behind the backend interface (no FMI)."""

    def __init__(self, params=None, excitation=None, drive=None):
        self.model = gmt.Transducer(params, excitation, drive)

    def rod_state(self):
        return self.model.forward.displacement, self.model.forward.velocity

    def step(self, time, step, control, force):
        out = self.model.step(control, step, force)
        return out.displacement, out.velocity, out.current

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
        from fmpy.fmi2 import FMU2Slave

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
        self._in = [self._vr["u"], self._vr["external_force"]]
        self._out = [self._vr["displacement"], self._vr["velocity"], self._vr["current"]]
        # The master's per-step FMI calls (set inputs, doStep, get outputs, get/set/free
        # the state) go straight to the C functions fmpy loaded, with their argument
        # arrays built once and the status checked here as fmpy does: fmpy's setReal/
        # getReal build two ctypes arrays per call and its logging wrapper costs ~2 us a
        # call, together about half of what the FMI adds to a direct coupling.
        from fmpy.fmi2 import fmi2FMUstate, fmi2Real, fmi2True, fmi2ValueReference
        fn = self.fmu._functions
        self._c = {name: fn[name] for name in (
            "fmi2SetReal", "fmi2DoStep", "fmi2GetReal", "fmi2GetFMUstate",
            "fmi2SetFMUstate", "fmi2FreeFMUstate")}
        self._in_vr = (fmi2ValueReference * 2)(*self._in)
        self._in_val = (fmi2Real * 2)()
        self._out_vr = (fmi2ValueReference * 3)(*self._out)
        self._out_val = (fmi2Real * 3)()
        self._true = fmi2True
        self._new_state = fmi2FMUstate
        self._state = None

    def rod_state(self):
        return tuple(self.fmu.getReal(self._out[:2]))

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


@dataclass(frozen=True)
class CosimSettings:
    """Settings of one co-simulation run.

    Attributes
    ----------
    duration : float
        Simulated time, [s].
    step : float
        Communication step h, [s].
    direction : {"down", "up"}
        Commanded cylinder direction (Figure 2).
    load_force : float
        External load on the cylinder, opposing "down", [N].
    force_tolerance : float
        Interface residual |F - A_d p_P(t + h)| accepted, [N]; 1e-4 N is
        0.08 Pa of chamber pressure, above the hydraulics' Newton noise.
    max_iterations : int
        Secant iterations per step before giving up.
    substeps : int
        Substeps of the hydraulic integrator per communication step.
    method : {"tr_bdf2", "backward_euler"}
        Hydraulic integrator: TR-BDF2 (second order, L-stable; default) or
        backward Euler (first order).
    kernel : {"compiled", "python"}
        TR-BDF2 from :mod:`system_models.kernel` (numba; default, ~35x
        faster) or the readable reference in :mod:`system_models.implicit`
        (analytic Jacobian). Both take the same steps; their results differ
        by the Newton tolerance. Backward Euler is Python only.
    controller_period : float or None
        Sample period of the valve controller, [s]. None: the controller
        samples at the communication points (valves switch on the step grid
        and dead times round to it). Given: a
        :class:`~system_models.controller.SampledValveController` switches at
        its own samples, the valves act after their exact dead times, and a
        step is split where they do -- the valve timing then no longer
        depends on the communication step, which can grow past the dead time.
    hydraulic_step : float or None
        Longest substep of the hydraulic integrator, [s]: each communication
        step takes at least ceil(h / hydraulic_step) substeps (and at least
        ``substeps``). None: ``substeps`` alone.
    """

    duration: float = 0.1
    step: float = 20e-6
    direction: str = "down"
    load_force: float = 0.0
    force_tolerance: float = 1e-4
    max_iterations: int = 25
    substeps: int = 1
    method: str = "tr_bdf2"
    kernel: str = "compiled"
    controller_period: float | None = None
    hydraulic_step: float | None = None

    def __post_init__(self):
        gmt.errors.check_range("duration", self.duration, 0.0, 1e4, unit="s")
        gmt.errors.check_range("step", self.step, 0.0, 1.0, unit="s")
        gmt.errors.check_range("force_tolerance", self.force_tolerance, 0.0, 1e6, unit="N")
        if self.method not in ("tr_bdf2", "backward_euler"):
            raise gmt.ParameterError(
                f"method = {self.method!r} is not one of ('tr_bdf2', 'backward_euler')")
        if self.controller_period is not None:
            gmt.errors.check_range("controller_period", self.controller_period, 0.0, 1.0,
                                   unit="s")
        if self.hydraulic_step is not None:
            gmt.errors.check_range("hydraulic_step", self.hydraulic_step, 0.0, 1.0, unit="s")
        if self.kernel not in ("compiled", "python"):
            raise gmt.ParameterError(
                f"kernel = {self.kernel!r} is not one of ('compiled', 'python')")
        if self.direction not in ("down", "up"):
            raise gmt.ParameterError(f"direction = {self.direction!r} is not one of ('down', 'up')")


#: Range kept for the interface slope dr/dF of the secant iteration.
SLOPE_RANGE = (0.5, 1.0e4)


class CouplingError(RuntimeError):
    """The interface iteration did not converge in a step."""


def _hermite(y0, v0, y1, v1, h):
    """Cubic through (y0, v0) at 0 and (y1, v1) at h: the rod position y(s) as a callable.

    The integrators derive the rod velocity they need from positions (secant or
    stage formula), so only the position is returned.
    """
    dy = y1 - y0

    def pos(s):
        r = s / h
        return (y0 + v0 * s + (3 * dy - h * (2 * v0 + v1)) * r * r
                + (h * (v0 + v1) - 2 * dy) * r * r * r)

    return pos


def _integrate_step(x, rod0, rod1, segments, load, params, h, substeps, held_valves,
                    method="tr_bdf2", compiled=False, packed=None):
    """Integrate the circuit over one step, split where the valve commands change.

    ``segments`` is [(s, commands), ...]: the commands in force from s (time
    into the step) to the next entry; the first s is 0. Each segment gets
    ``substeps`` in proportion to its length (at least one).

    ``packed`` is :func:`kernel.pack` of ``params`` when the caller has it.

    Returns (x_end, p_P at the end, volume into B, compression volume, halvings).
    """
    use_kernel = compiled and method == "tr_bdf2"
    if use_kernel:
        from . import kernel
        kernel_params = params if packed is None else packed
    else:  # the Python integrators sample the rod's trajectory themselves
        pos = _hermite(rod0[0], rod0[1], rod1[0], rod1[1], h)
    x = np.array(x, dtype=float)
    volume_big = compressed = 0.0
    deepest = 0
    bounds = [s for s, _ in segments[1:]] + [h]
    for (s0, commands), s1 in zip(segments, bounds):
        for k in range(4):  # valves without their own dynamics take the command at once
            if held_valves[k]:
                x[6 + k] = commands[k]
        n_sub = max(1, math.ceil(substeps * (s1 - s0) / h - 1e-9))
        if use_kernel:
            status, x, _, dvol, dcomp, halvings = kernel.circuit_step(
                x, rod0, rod1, h, commands, load, kernel_params, n_sub, segment=(s0, s1))
            if status == kernel.CHAMBER_EMPTIED:
                raise gmt.ParameterError(
                    f"rod displacement {max(rod0[0], rod1[0]):g} m empties the pump chamber")
            if status == kernel.NEWTON_FAILED:
                raise IntegrationError(f"Newton did not converge within a {h:g} s step")
        elif method == "tr_bdf2":
            def inputs_at(s, velocity, s0=s0, commands=commands):
                return CircuitInputs(pos(s0 + s), velocity, commands, load)

            x, _, dvol, dcomp, halvings = tr_bdf2(x, s1 - s0, inputs_at, params, n_sub)
        else:
            def inputs_over(a, b, s0=s0, commands=commands):
                # secant velocity: the chamber receives exactly A_d (y(b) - y(a))
                return CircuitInputs(pos(s0 + b), (pos(s0 + b) - pos(s0 + a)) / (b - a),
                                     commands, load)

            x, _, dvol, dcomp, halvings = backward_euler(x, s1 - s0, inputs_over, params, n_sub)
        volume_big += dvol
        compressed += dcomp
        deepest = max(deepest, halvings)
    return x, x[0], volume_big, compressed, deepest


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
        u(t), [V].
    circuit : CircuitParameters
    settings : CosimSettings
    progress : callable, optional
        Called as progress(steps_done, n_steps).
    observer : callable, optional
        Called with each finished record (a row of the array below), in
        time order; e.g. :class:`system_models.flowcheck.RunningFlow`.
    keep_record : bool
        False keeps only the last two records: memory stays flat however
        long the run (the observer sees every record); the result is then
        the final record alone.

    Returns
    -------
    numpy structured array
        One record per communication point t_k = k h (fields
        :data:`RESULT_FIELDS`): the state at t_k and the inputs held over
        [t_k, t_k + h) (control u(t_k + h/2), current, force, valve phase);
        the last record
        carries the final state only. ``volume_into_big`` is the net volume
        that has entered the big cavity through V1 and V2 since t = 0, and
        ``compression_volume`` the oil volume taken up by compression in the
        chamber and cavities since t = 0, [m^3] (see :func:`volume_balance`).
    """
    h = settings.step
    n_steps = int(round(settings.duration / h))
    area = circuit.chamber.piston_area
    held_valves = np.array([v.response != "first_order" for v in circuit.valves])
    delays = [v.opening_time if v.response == "delay" else 0.0 for v in circuit.valves]
    max_delay = max(delays)
    x = initial_state(circuit)
    rod = backend.rod_state()
    force = x[0] * area
    dtype = [(name, float) for name in RESULT_FIELDS]
    out = np.zeros(n_steps + 1 if keep_record else 2, dtype=dtype)
    history = deque()  # (time, commands) kept for max_delay, for delayed valves
    slope = None
    volume_big = 0.0
    compressed = 0.0
    compressing = True
    compiled = settings.kernel == "compiled"
    packed = None
    if compiled:
        from . import kernel
        packed = kernel.pack(circuit)
    controller = (None if settings.controller_period is None else SampledValveController(
        settings.direction, control, settings.controller_period, delays))
    t_end = n_steps * h
    t, h_k, k = 0.0, h, 0
    while True:
        if controller is None:
            t = k * h
        else:
            # communication points at every valve action: a step never spans one
            h_k = min(h, t_end - t)
            event = controller.next_event(t, t + h_k)
            if event is not None:
                h_k = event - t
        last = t >= t_end - 1e-9 * h
        if keep_record and k == len(out):
            out = np.concatenate((out, np.zeros(len(out) // 4 + 8, dtype=out.dtype)))
        u = control(t)
        # the controller generates u, so it knows where u goes over the coming
        # step: the phase of [t, t + h) follows u(t + h) - u(t), and the valves
        # switch at the control signal's extremes, not a step after them
        if controller is None:
            compressing = pump_phase(control(t + h_k), u, compressing)
        else:
            compressing = controller.phase_at(t)
        if keep_record:
            rec = out[k]
        else:
            out[k % 2] = 0  # a reused slot: clear what the last record in it left
            rec = out[k % 2]
        rec["time"], rec["control"], rec["compressing"] = t, u, float(compressing)
        rec["rod_displacement"], rec["rod_velocity"] = rod
        rec["volume_into_big"] = volume_big
        rec["compression_volume"] = compressed
        _record_circuit(rec, x, circuit, packed)
        if last:
            rec["force"] = force
            previous = out[k - 1 if keep_record else (k - 1) % 2]
            rec["valves_compressing"] = previous["valves_compressing"] if k else compressing
            if observer is not None:
                observer(rec)
            break
        if controller is None:
            cmd_now = tuple(1.0 if c else 0.0
                            for c in valve_commands(settings.direction, compressing))
            history.append((t, cmd_now))
            while len(history) > 1 and history[1][0] <= t - max_delay:
                history.popleft()
            commands = tuple(_command_at(history, t - delays[j], j) for j in range(4))
            segments = [(0.0, commands)]
        else:
            segments = [(ts - t, c) for ts, c in controller.segments(t, t + h_k)]
            commands = segments[0][1]
        # phase the valves actually act on (after their dead times): V1 is open
        # while compressing going down, V3 while compressing going up
        rec["valves_compressing"] = commands[0 if settings.direction == "down" else 2]
        # the value held over [t, t + h): u at the step's midpoint. A hold of
        # u(t) would lag the signal by h/2 -- a first-order error in where the
        # rod is when the valves switch; the midpoint value removes it
        u_held = control(t + 0.5 * h_k)
        rec["control"] = u_held
        saved = backend.save()
        f_k, r_prev, f_prev = force, None, None
        substeps = max(1, math.ceil(settings.substeps * h_k / h - 1e-9))
        if settings.hydraulic_step is not None:
            substeps = max(substeps, math.ceil(h_k / settings.hydraulic_step - 1e-9))
        for it in range(1, settings.max_iterations + 1):
            if it > 1:
                backend.restore(saved)
            y1, v1, current = backend.step(t, h_k, u_held, f_k)
            try:
                x1, p_end, dvol, dcomp, halvings = _integrate_step(
                    x, rod, (y1, v1), segments, settings.load_force, circuit, h_k, substeps,
                    held_valves, settings.method, compiled, packed)
            except (gmt.ParameterError, IntegrationError):
                if f_prev is None:
                    raise
                # the trial force drove the rod somewhere the oil cannot follow
                # (e.g. emptying the chamber): back off towards the last force
                # that integrated, and trust the slope less
                f_k = 0.5 * (f_k + f_prev)
                slope = None if slope is None else min(slope * 4.0, SLOPE_RANGE[1])
                continue
            if halvings:
                # repeat with that discretisation throughout, so r(F) stays smooth
                substeps *= 2 ** halvings
                r_prev = f_prev = None
                continue
            r = f_k - area * p_end
            if abs(r) <= settings.force_tolerance:
                break
            # secant slope dr/dF, carried over from step to step; updated only
            # from iterates far enough apart that Newton's tolerance in the
            # hydraulics cannot corrupt it, and kept in its physical range:
            # dr/dF = 1 + A_d dp/dF >= 1 (pushing the rod back lowers the
            # chamber pressure), up to ~1e3 and more for the stiffest oil
            if r_prev is not None and abs(f_k - f_prev) > 10.0 * settings.force_tolerance:
                slope = min(max((r - r_prev) / (f_k - f_prev), SLOPE_RANGE[0]), SLOPE_RANGE[1])
            f_prev, r_prev = f_k, r
            if slope is None:
                # first step of the run: a small probe gives dr/dF by difference
                f_k = f_k - math.copysign(min(abs(r), 1.0), r)
            else:
                f_k = f_k - r / slope
        else:
            raise CouplingError(
                f"interface force did not converge in {settings.max_iterations} iterations "
                f"at t = {t:g} s (residual {r:g} N); reduce the step")
        rec["current"], rec["force"], rec["iterations"] = current, f_k, it
        if observer is not None:
            observer(rec)
        volume_big += dvol
        compressed += dcomp
        x, rod, force = x1, (y1, v1), f_k
        if progress is not None:
            progress(min(int(round((t + h_k) / h)), n_steps), n_steps)
        t += h_k
        k += 1
    return out[:k + 1] if keep_record else out[[k % 2]]


def _command_at(history, time, valve):
    """Command of one valve in force at ``time`` (the last issued at or before it)."""
    cmd = history[0][1][valve]
    for t, c in history:
        if t <= time + 1e-15:
            cmd = c[valve]
        else:
            break
    return cmd


def _record_circuit(rec, x, circuit: CircuitParameters, packed=None):
    from .accumulator import accumulator_pressure
    rec["p_pump"], rec["p_big"], rec["p_small"] = x[0], x[1], x[2]
    rec["p_accumulator"] = accumulator_pressure(circuit.accumulator, x[3])
    rec["piston_position"], rec["piston_velocity"] = x[4], x[5]
    if packed is None:
        q = valve_flows(x, circuit)
    else:
        from . import kernel
        q = kernel.flows(x, packed)
    rec["q_v1"], rec["q_v2"], rec["q_v3"], rec["q_v4"] = q


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
