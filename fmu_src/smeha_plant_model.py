"""The hydraulic plant as a co-simulation host steps it: the plant FMU's logic (no physics).

A host steps the plant FMU over [t, t + h] after setting its inputs: the transducer's
magnetostrictive force F (eq 28) and the control signal u. :class:`PlantModel`

1. gives u to the valve controller
   (:class:`system_models.controller.FedValveController`), which samples it there and
   switches Figure 2's stages as u rises and falls, each valve acting its dead time
   after the sample that changed its command;
2. cuts the step at every valve action inside it, so the commands are constant over
   each piece, as the kernel wants them;
3. takes the force over the step as the host delivered it: held, or extrapolated
   linearly from this step's and the last step's values (``extrapolate_force``: a force
   that varies continuously, delivered one step late by a host that steps every unit at
   once, follows its trend instead of lagging by another half step);
4. integrates the pieces in one call of the compiled plant
   (:func:`system_models.plant.run`: the circuit with the rod's eq 27, TR-BDF2);
5. keeps the running volume into the big cavity and the oil taken up by compression.

The physics is all in ``system_models``, inside the FMU its bundled copy
(``smeha_plant_interface.physics``).
"""
from __future__ import annotations

import importlib
import math

from smeha_plant_interface import parameter_error, physics, plant_parameters


class PlantModel:
    """The plant of one FMU instance, built from its parameter values (by FMU name).

    Raises
    ------
    gmt.ParameterError
        A parameter outside its range (the message names it).
    """

    def __init__(self, values: dict):
        root = physics().__name__
        sm = {name: importlib.import_module(f"{root}.{name}")
              for name in ("accumulator", "circuit", "controller", "implicit", "kernel",
                                 "plant")}
        self._sm = sm
        self.params = plant_parameters(values)
        step = values["hydraulic_step"]
        if not (0.0 < step <= 1.0):
            raise parameter_error(f"hydraulic_step = {step!r} s is outside the allowed range "
                                  "(0, 1] s")
        self.max_substep = float(step)
        self.load = float(values["load_force"])
        self.extrapolate = bool(values["extrapolate_force"])
        direction = "up" if values["direction_up"] else "down"
        circuit = self.params.circuit
        self.controller = sm["controller"].FedValveController(
            direction, sm["controller"].dead_times(circuit.valves))
        self.z = sm["plant"].initial_state(self.params, float(values["rod_start_displacement"]))
        self.substeps = sm["kernel"].new_control()  # carried from step to step
        self.previous = None  # (time, force) of the last step: the force's trend
        self.volume = self.compressed = 0.0
        # before the first step: flows and accumulator pressure of the initial state (readable
        # forms: nothing compiled runs at initialisation)
        self.flows = tuple(float(q) for q in sm["circuit"].valve_flows(self.z[:10], circuit))
        self.accumulator_pressure = float(sm["accumulator"].accumulator_pressure(
            circuit.accumulator, self.z[3]))

    def step(self, time: float, step: float, force: float, control: float) -> None:
        """Advance over [time, time + step] with the force F [N] and the control signal u [V].

        On an error the model is left as it was (the host may retry the step).

        Raises
        ------
        gmt.ParameterError
            A step that is not positive, an input that is not finite, or the rod
            emptying the pump chamber.
        system_models.implicit.IntegrationError
            The integrator's Newton iteration failed.
        """
        if not (step > 0.0 and math.isfinite(step)):
            raise parameter_error(f"step = {step!r} s is outside the allowed range (0, inf) s")
        for name, value in (("force", force), ("u", control)):
            if not math.isfinite(value):
                raise parameter_error(f"{name} = {value!r} is not finite")
        saved = self.controller.get_state(), self.substeps.copy()
        try:
            self._advance(time, step, force, control)
        except Exception:
            self.controller.set_state(saved[0])
            self.substeps[:] = saved[1]
            raise

    def _advance(self, time, step, force, control):
        sm, ctl = self._sm, self.controller
        ctl.sample(time, control)
        slope = 0.0
        if self.extrapolate and self.previous is not None and time > self.previous[0]:
            slope = (force - self.previous[1]) / (time - self.previous[0])
        end = time + step
        edges, commands = [time], []
        while True:  # pieces between the valve actions inside the step
            ctl.advance(edges[-1])
            commands.append(tuple(ctl.commands))
            at = ctl.next_action(edges[-1], end)
            edges.append(end if at is None else at)
            if at is None:
                break
        ctl.advance(end)  # what acts at the step's end is in force from there (the outputs)
        steps = [b - a for a, b in zip(edges[:-1], edges[1:])]
        forces = [(force + slope * (a - time), force + slope * (b - time))
                  for a, b in zip(edges[:-1], edges[1:])]
        run = sm["plant"].run(self.z, steps, forces, commands, self.load, self.params,
                              self.max_substep, self.substeps)
        if run.status != sm["kernel"].OK:
            if run.status == sm["kernel"].CHAMBER_EMPTIED:
                raise parameter_error(f"the rod empties the pump chamber at t = {time:g} s")
            raise sm["implicit"].IntegrationError(
                f"the plant's Newton iteration did not converge in the step at t = {time:g} s; "
                "give a shorter hydraulic_step or communication step")
        self.z = run.states[-1].copy()
        self.flows = tuple(float(q) for q in run.flows[-1])
        self.accumulator_pressure = float(run.accumulator_pressure[-1])
        self.volume += float(run.volume_into_big[-1])
        self.compressed += float(run.compression_volume[-1])
        self.previous = (time, force)

    def outputs(self) -> dict:
        """The output variables now (smeha_plant_interface.OUTPUTS), SI."""
        z, ctl = self.z, self.controller
        y, v = self._sm["plant"].chamber_side(z, self.params)
        q = self.flows
        return {"rod_displacement": float(y), "rod_velocity": float(v),
                "p_pump": float(z[0]), "p_big": float(z[1]), "p_small": float(z[2]),
                "p_accumulator": self.accumulator_pressure, "piston_position": float(z[4]),
                "piston_velocity": float(z[5]), "q_v1": q[0], "q_v2": q[1], "q_v3": q[2],
                "q_v4": q[3], "volume_into_big": self.volume,
                "compression_volume": self.compressed, "compressing": bool(ctl.compressing),
                "valves_compressing": bool(ctl.valves_compressing), "stage": int(ctl.stage)}

    def get_state(self) -> dict:
        """Everything that changes, as JSON-ready values (:meth:`set_state`)."""
        return {"z": [float(x) for x in self.z], "substeps": [float(x) for x in self.substeps],
                "controller": self.controller.get_state(), "previous": self.previous,
                "volume": self.volume, "compressed": self.compressed, "flows": list(self.flows),
                "accumulator_pressure": self.accumulator_pressure}

    def set_state(self, state: dict) -> None:
        import numpy as np

        self.z = np.array(state["z"], dtype=float)
        self.substeps = np.array(state["substeps"], dtype=float)
        self.controller.set_state(state["controller"])
        self.previous = None if state["previous"] is None else tuple(state["previous"])
        self.volume, self.compressed = float(state["volume"]), float(state["compressed"])
        self.flows = tuple(float(q) for q in state["flows"])
        self.accumulator_pressure = float(state["accumulator_pressure"])
