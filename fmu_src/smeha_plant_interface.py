"""The plant FMU's variable table: the EHA's hydraulics with the transducer's rod in them.

``SmehaPlant.fmu`` (FMI 2.0 co-simulation) packages :mod:`system_models`' plant -- the pump
chamber with the rod's eq 27, the four active valves and their controller (Figure 2's
stages), the two-cavity cylinder and the accumulator -- for a host that couples it to the
transducer FMU through the magnetostrictive force (eq 28). Defined once here for the slave
(``smeha_plant_fmu.py``), the build (units, ``smeha.fmu.build``) and ``docs/FMU.md``.

Parameters: every field of :class:`system_models.circuit.CircuitParameters`' components,
named ``<component>_<field>`` (``fluid_bulk_modulus``, ``v1_area``; a valve's
``response`` is an Integer code, :data:`VALVE_RESPONSES`), start values from the
``realistic`` circuit (:func:`system_models.presets.realistic_circuit`); the rod's mechanics
under the names of the transducer FMU's calculated parameters (``equivalent_mass`` ...),
from which a system takes them; and the controller's and integrator's settings.

Bundled in the FMU as ``resources/smeha_plant_interface.py``, with ``system_models`` as
``resources/smeha_plant_system_models`` and ``gmt`` (its parameter checks) as
``resources/smeha_plant_gmt`` (names unique to this FMU, each suffixed with the build's
identifier in the FMU: one Python interpreter serves every pythonfmu FMU of a process,
and modules are shared by name). Imports nothing from
``smeha``; ``system_models`` through :func:`physics`, which inside the FMU is the bundled
copy.
"""
from __future__ import annotations

import dataclasses

from smeha_fmu_variables import Variable, unit_problems

MODEL_NAME = "SmehaPlant"
#: Module names (unique to this project, see the module docstring).
SLAVE_MODULE = "smeha_plant_fmu"
INTERFACE_MODULE = "smeha_plant_interface"
MODEL_MODULE = "smeha_plant_model"
BUNDLED_PLANT_PACKAGE = "smeha_plant_system_models"
BUNDLED_GMT_PACKAGE = "smeha_plant_gmt"
#: What the FMU imports at run time beyond the standard library: the compiled kernel of
#: ``system_models`` needs numba (the build compiles it into the FMU: numba's cache).
REQUIRED_PACKAGES = ("numpy", "numba")

AUTHOR = "smeha developers"
LICENSE = "MIT"
DESCRIPTION = ("Hydraulic plant of a smart-material electrohydrostatic actuator: pump chamber "
               "with the transducer rod's eq 27, four active valves switched by Figure 2's "
               "stages, two-cavity cylinder, accumulator; driven by the magnetostrictive "
               "force of eq 28 (smeha, system_models package)")
#: DefaultExperiment: a few pumping cycles at 100 Hz at the valve controller's period.
DEFAULT_EXPERIMENT = {"start_time": 0.0, "stop_time": 0.05, "step_size": 1e-5}


def physics():
    """The system_models package: inside an FMU its bundled copy, elsewhere the installed one."""
    import importlib
    import importlib.util
    # fall back only when the bundled package is absent, not when it fails to import
    if importlib.util.find_spec(BUNDLED_PLANT_PACKAGE) is not None:
        return importlib.import_module(BUNDLED_PLANT_PACKAGE)
    return importlib.import_module("system_models")


def _submodules():
    import importlib
    root = physics().__name__
    return {name: importlib.import_module(f"{root}.{name}")
            for name in ("circuit", "controller", "defaults", "plant", "presets", "rod",
                         "valves")}


_SM = _submodules()

#: Integer codes of a valve's ``response`` (system_models.valves.RESPONSES, in that order).
VALVE_RESPONSES = tuple(_SM["valves"].RESPONSES)

#: The circuit's components: (prefix, CircuitParameters field, class).
COMPONENTS = (("fluid", "fluid"), ("chamber", "chamber"), ("cylinder", "cylinder"),
              ("accumulator", "accumulator"), ("v1", "valves"), ("v2", "valves"),
              ("v3", "valves"), ("v4", "valves"))

#: Unit and description of each field of the circuit's components (SI; the dataclasses'
#: docstrings give the physics and the sources of the defaults).
FIELDS = {
    "fluid": (
        ("density", "kg/m3", "Oil density at the reference pressure"),
        ("bulk_modulus", "Pa", "Bulk modulus of the air-free oil"),
        ("air_fraction", "1", "Volume fraction of entrained air at the reference pressure"),
        ("reference_pressure", "Pa", "Absolute pressure at which air_fraction is stated"),
        ("air_polytropic_index", "1", "Polytropic exponent of the air bubbles"),
        ("viscosity", "Pa.s", "Dynamic viscosity of the oil"),
    ),
    "chamber": (
        ("dead_volume", "m3", "Pump chamber volume with the rod at reference_displacement"),
        ("piston_area", "m2", "Pump piston area A_d (paper, Table 2: 1256 mm^2)"),
        ("reference_displacement", "m", "Rod displacement at which the chamber volume is "
         "dead_volume (the transducer's bias displacement)"),
    ),
    "cylinder": (
        ("bore_diameter", "m", "Cylinder bore"),
        ("rod_diameter", "m", "Piston-rod diameter"),
        ("stroke", "m", "Travel between the end stops"),
        ("dead_volume_big", "m3", "Big (cap) cavity volume at the end of travel that empties it"),
        ("dead_volume_small", "m3", "Small (rod) cavity volume at the end of travel that "
         "empties it"),
        ("mass", "kg", "Piston, rod and load mass"),
        ("friction", "N.s/m", "Viscous friction coefficient"),
        ("stop_stiffness", "N/m", "End-stop contact stiffness"),
        ("stop_damping", "N.s/m", "End-stop contact damping"),
        ("through_rod", None, "true: equal-area (through-rod) cylinder; false: differential"),
    ),
    "accumulator": (
        ("precharge_pressure", "Pa", "Absolute gas pressure with no oil inside"),
        ("gas_volume", "m3", "Gas volume at the pre-charge"),
        ("polytropic_index", "1", "n of p V^n = const for the gas"),
        ("port_stiffness", "Pa/m3", "Pressure drop per m^3 withdrawn from an empty accumulator"),
    ),
    "valves": (
        ("area", "m2", "Flow area fully open"),
        ("discharge_coefficient", "1", "Discharge coefficient C_d"),
        ("transition_pressure", "Pa", "Pressure difference below which the flow is laminar"),
        ("leakage_fraction", "1", "Closed-valve area as a fraction of area"),
        ("response", None, "Opening response: " + ", ".join(
            f"{i} {name}" for i, name in enumerate(VALVE_RESPONSES))
         + " (delay: a dead time of opening_time after each command)"),
        ("opening_time", "s", "Time constant (first_order) or dead time (delay) of the opening"),
    ),
}

#: The rod's mechanics (system_models.rod.RodParameters, gmt.RodMechanics' fields), under
#: the names of the transducer FMU's calculated parameters.
ROD = (("equivalent_mass", "kg", "Mass m of eq 27 (the rod's m_1 with two masses)"),
       ("equivalent_damping", "N.s/m", "Damping c of eq 27"),
       ("equivalent_stiffness", "N/m", "Stiffness K of eq 27"),
       ("output_mass", "kg", "Output mass m_2 carrying the pump piston; 0 = one mass"),
       ("joint_stiffness", "N/m", "Joint stiffness between rod and output mass"),
       ("joint_damping", "N.s/m", "Joint damping between rod and output mass"))


def _kind(value) -> str:
    """FMI type of a field's value as the FMU takes it (a valve response: its Integer code)."""
    return "Boolean" if isinstance(value, bool) else "Integer" if isinstance(value, int) \
        else "Real"


def _start(value):
    return VALVE_RESPONSES.index(value) if isinstance(value, str) else value


def _circuit_fields(circuit):
    """(FMU name, value as the FMU takes it, unit, description, component) of every field."""
    for prefix, attr in COMPONENTS:
        part = getattr(circuit, attr)
        if attr == "valves":
            part = part[int(prefix[1]) - 1]
        label = prefix.upper() if attr == "valves" else prefix.capitalize()
        for name, unit, text in FIELDS[attr]:
            yield f"{prefix}_{name}", _start(getattr(part, name)), unit, f"{label}: {text}", attr


def circuit_values(circuit) -> dict:
    """The FMU's parameter values of a :class:`system_models.circuit.CircuitParameters`
    (the inverse of :func:`plant_parameters` for the circuit)."""
    return {name: value for name, value, _, _, _ in _circuit_fields(circuit)}


def rod_values(mechanics) -> dict:
    """The FMU's parameter values of the rod's mechanics (a :class:`gmt.RodMechanics`, a
    :class:`system_models.rod.RodParameters` or a sequence in their order)."""
    values = dataclasses.astuple(mechanics) if dataclasses.is_dataclass(mechanics) \
        else tuple(mechanics)
    return {name: float(v) for (name, _, _), v in zip(ROD, values, strict=True)}


def _variables():
    circuit = _SM["presets"].realistic_circuit()
    rod = _SM["rod"].RodParameters()
    chamber = circuit.chamber
    return (
        Variable("force", "Real", "input", "N", "Magnetostrictive force F on the rod, eq 28 "
                 "(the transducer FMU's output force); held over the step, or extrapolated "
                 "from the last two steps (extrapolate_force)", 0.0, "input"),
        Variable("u", "Real", "input", "V", "Control signal u the transducer is driven with: "
                 "the valve controller samples it at each step and switches Figure 2's stages "
                 "as it rises (compressing) and falls (expanding)", 0.0, "input"),
        *(Variable(name, _kind(value), "parameter", unit if _kind(value) == "Real" else None,
                   text, value, group)
          for name, value, unit, text, group in _circuit_fields(circuit)),
        *(Variable(name, "Real", "parameter", unit, text + " (the transducer FMU's calculated "
                   "parameter of that name)", rod_values(rod)[name], "rod")
          for name, unit, text in ROD),
        Variable("rod_start_displacement", "Real", "parameter", "m", "Rod displacement at "
                 "the start, at rest (the transducer FMU's displacement before its first "
                 "step)", chamber.reference_displacement, "settings"),
        Variable("load_force", "Real", "parameter", "N", "External load on the cylinder, "
                 "opposing 'down'", _SM["presets"].default_load("realistic"), "settings"),
        Variable("direction_up", "Boolean", "parameter", None, "false: the cylinder is driven "
                 "down (Figure 2's stages 1 and 2); true: up (stages 3 and 4)", False,
                 "settings"),
        Variable("extrapolate_force", "Boolean", "parameter", None, "false: the force is "
                 "held over each step (a force that steps at a sampled drive's samples, the "
                 "digital compensator's); true: extrapolated linearly from the last two "
                 "steps' values (a force that varies continuously, the uncompensated drive): "
                 "with a host that delivers it one step late, both keep it in step with the "
                 "valves (docs/FMU.md)", False, "settings"),
        Variable("hydraulic_step", "Real", "parameter", "s", "Longest substep of the plant's "
                 "implicit integrator (TR-BDF2); after each valve action the substeps start "
                 "at 1 us and grow", _SM["defaults"].HYDRAULIC_STEP, "settings"),
        *(Variable(name, "Real", "output", unit, text, None, "output") for name, unit, text in (
            ("rod_displacement", "m", "Displacement of the rod's end in the pump chamber (the "
             "output mass with two masses), eq 27"),
            ("rod_velocity", "m/s", "Velocity of the rod's end in the pump chamber"),
            ("p_pump", "Pa", "Pump chamber pressure"),
            ("p_big", "Pa", "Big (cap) cavity pressure"),
            ("p_small", "Pa", "Small (rod) cavity pressure"),
            ("p_accumulator", "Pa", "Accumulator pressure"),
            ("piston_position", "m", "Cylinder piston position"),
            ("piston_velocity", "m/s", "Cylinder piston velocity"),
            ("q_v1", "m3/s", "Flow through V1, pump chamber to big cavity"),
            ("q_v2", "m3/s", "Flow through V2, big cavity to accumulator"),
            ("q_v3", "m3/s", "Flow through V3, pump chamber to small cavity"),
            ("q_v4", "m3/s", "Flow through V4, small cavity to accumulator"),
            ("volume_into_big", "m3", "Net oil volume into the big cavity through V1 and V2 "
             "since the start (its mean slope is the cylinder flow of eqs 39-41)"),
            ("compression_volume", "m3", "Oil volume taken up by compression in the chamber "
             "and cavities since the start"))),
        Variable("compressing", "Boolean", "output", None, "The controller's phase: true "
                 "while u rose at its last sample (the chamber compressing)", None, "output"),
        Variable("valves_compressing", "Boolean", "output", None, "The phase the valves act "
                 "on, after their dead times (V1 open going down, V3 going up)", None,
                 "output"),
        Variable("stage", "Integer", "output", None, "The stage of Figure 2 the controller "
                 "commands (1-4)", None, "output"),
    )


#: Every variable, in registration order (inputs, parameters, outputs).
VARIABLES: tuple[Variable, ...] = _variables()
BY_NAME: dict[str, Variable] = {v.name: v for v in VARIABLES}
PARAMETERS = tuple(v.name for v in VARIABLES if v.causality == "parameter")
OUTPUTS = tuple(v.name for v in VARIABLES if v.causality == "output")
REAL_OUTPUTS = tuple(v.name for v in VARIABLES if v.causality == "output" and v.kind == "Real")
VARIABLE_NAMES = tuple(v.name for v in VARIABLES)


def coerce(name: str, value):
    """``value`` converted to the Python type of variable ``name`` (no range check)."""
    return BY_NAME[name].coerce(value)


def plant_parameters(values: dict):
    """The :class:`system_models.plant.PlantParameters` of a set of parameter values.

    Raises
    ------
    gmt.ParameterError
        A value outside the range system_models accepts; the message names the FMU
        variable (``v2_area = ...``) and its allowed range.
    """
    parts, valves = {}, []
    for prefix, attr in COMPONENTS:
        kwargs = {}
        for name, _, _ in FIELDS[attr]:
            value = values[f"{prefix}_{name}"]
            if name == "response":
                if not 0 <= int(value) < len(VALVE_RESPONSES):
                    raise parameter_error(f"{prefix}_response = {value!r} is not one of the codes "
                                 f"{dict(enumerate(VALVE_RESPONSES))}")
                value = VALVE_RESPONSES[int(value)]
            kwargs[name] = value
        built = _named(_component_class(attr), kwargs, {k: f"{prefix}_{k}" for k in kwargs})
        if attr == "valves":
            valves.append(built)
        else:
            parts[attr] = built
    circuit = _SM["circuit"].CircuitParameters(**parts, valves=tuple(valves))
    rod_class = _SM["rod"].RodParameters
    fields = [f.name for f in dataclasses.fields(rod_class)]
    rod = _named(rod_class, {f: values[name] for f, (name, _, _) in zip(fields, ROD)},
                 {f: name for f, (name, _, _) in zip(fields, ROD)})
    return _SM["plant"].PlantParameters(circuit, rod)


def _component_class(attr):
    """The dataclass of the circuit's component ``attr`` (a CircuitParameters field)."""
    default = getattr(_SM["circuit"].CircuitParameters(), attr)
    return type(default[0] if attr == "valves" else default)


def parameter_error(message: str):
    """A gmt.ParameterError (the bundled gmt's inside the FMU) with ``message``."""
    from importlib import import_module
    gmt = import_module(BUNDLED_GMT_PACKAGE if physics().__name__ == BUNDLED_PLANT_PACKAGE
                        else "gmt")
    return gmt.ParameterError(message)


def _named(cls, kwargs, names: dict):
    """``cls(**kwargs)``, its ParameterError naming the FMU variable (``names``: field -> it)."""
    try:
        return cls(**kwargs)
    except ValueError as exc:
        text = str(exc)
        field, sep, rest = text.partition(" = ")
        named = f"{names[field]}{sep}{rest}" if sep and field in names else text
        raise parameter_error(named) from None


def check_against_system_models() -> None:
    """Raise ``AssertionError`` if the table no longer covers system_models' dataclasses.

    Every field of each circuit component (in order), of the rod's mechanics and of
    gmt.RodMechanics (the transducer FMU's calculated parameters) has its variable, the
    valve responses are system_models', and the start values give back the realistic
    circuit.
    """
    problems = []
    for attr in ("fluid", "chamber", "cylinder", "accumulator", "valves"):
        cls = _component_class(attr)
        names = tuple(f.name for f in dataclasses.fields(cls))
        table = tuple(name for name, _, _ in FIELDS[attr])
        if names != table:
            problems.append(f"{cls.__name__} fields {names} != FMU parameters {table}")
    rod_fields = tuple(f.name for f in dataclasses.fields(_SM["rod"].RodParameters))
    if len(rod_fields) != len(ROD):
        problems.append(f"RodParameters fields {rod_fields} != FMU parameters {ROD}")
    if tuple(_SM["valves"].RESPONSES) != VALVE_RESPONSES:
        problems.append(f"valve responses {VALVE_RESPONSES} != {_SM['valves'].RESPONSES}")
    start = {v.name: v.start for v in VARIABLES if v.causality == "parameter"}
    if not problems and plant_parameters(start).circuit != _SM["presets"].realistic_circuit():
        problems.append("the start values do not give the realistic circuit")
    problems.extend(unit_problems(VARIABLES))
    if problems:
        raise AssertionError("plant FMU interface out of date with system_models:\n  "
                             + "\n  ".join(problems))
