"""The EHA as an FMI system: its SSP package and OSP system structure.

Three FMUs make the actuator (docs/FMU.md, "The EHA as an FMI system"):

* ``drive`` (``SmehaDrive.fmu``): the controller's control signal u(t), the one the
  co-simulation harness drives the transducer with (:func:`smeha.studies.flow.control_signal`);
* ``transducer`` (``SmehaGmt.fmu``): amplifier or compensator, magnetics, and the
  magnetostrictive force F = A_r E^H lambda (eq 28), which does not depend on the rod's
  motion;
* ``plant`` (``SmehaPlant.fmu``): the pump chamber with the rod's eq 27, the valves and
  their controller (Figure 2's stages, switched as u rises and falls), the cylinder and
  the accumulator (``system_models``).

Connections: ``drive.u`` to ``transducer.u`` and ``plant.u``, ``transducer.force`` to
``plant.force``. The rod's m, c, K the plant integrates come from the transducer: in the
SSD as SSP 1.0 *parameter connections* (the transducer's calculated parameters
``equivalent_mass`` ... to the plant's parameters of the same names), and, for masters
that do not propagate parameters (fmpy 0.3.32's ``simulate_ssp``, libcosim's OSP
configuration), as the values the transducer FMU itself computes, read from it when the
files are written (:func:`describe`), like the rod's rest position.

Files: :func:`write_ssp` (``<name>.ssp``: ``SystemStructure.ssd``, the FMUs and one SSV
parameter set per component under ``resources/``, SSP 1.0), :func:`write_osp`
(``OspSystemStructure.xml``, the Open Simulation Platform's format that libcosim reads,
with the same values as initial values) and :func:`write_container` (the three as one
FMU, fmpy's container FMU). The runners are in :mod:`smeha.fmu.systemrun`.
"""
from __future__ import annotations

import os
import zipfile
from dataclasses import dataclass
from pathlib import Path
from xml.etree import ElementTree as ET

from system_models.defaults import VALVE_CONTROLLER_PERIOD

__all__ = ["NAMESPACES", "OSP_CONFIG_NAMESPACE", "SYSTEM_NAME", "SYSTEM_STEP", "COMPONENTS",
           "CONNECTIONS", "MECHANICS", "RECORDED", "SystemDescription", "describe", "ssv_values",
           "ssd_xml", "write_ssp", "osp_xml", "write_osp", "build_system", "CONTAINER_OUTPUTS",
           "write_container"]

#: Name of the system (the SSD's and the .ssp's).
SYSTEM_NAME = "SmehaEha"
#: The system's communication step, [s]: the plant's valve controller samples u at every
#: step, so the step is that controller's period (system_models.defaults; the harness's
#: controller samples at the same rate). docs/FMU.md explains the step's error.
SYSTEM_STEP = VALVE_CONTROLLER_PERIOD

#: Component -> FMU key of smeha.fmu.build.SPECS.
COMPONENTS = {"drive": "drive", "transducer": "transducer2", "plant": "plant"}
#: Signal connections (start component, connector, end component, connector).
CONNECTIONS = (("drive", "u", "transducer", "u"), ("drive", "u", "plant", "u"),
               ("transducer", "force", "plant", "force"))
#: Parameter connections: the transducer's calculated parameters to the plant's parameters
#: (SSP 1.0 allows calculatedParameter -> parameter; the same names on both sides).
MECHANICS = ("equivalent_mass", "equivalent_damping", "equivalent_stiffness", "output_mass",
             "joint_stiffness", "joint_damping")
#: Outputs declared as connectors (recorded by SSP masters) besides the connected ones.
RECORDED = {"transducer": ("current", "displacement"),
            "plant": ("rod_displacement", "p_pump", "p_big", "p_small", "p_accumulator",
                      "piston_position", "volume_into_big", "compression_volume",
                      "compressing", "valves_compressing", "stage")}

#: XML namespaces of the files written here, by the prefix they are written with (SSP 1.0's
#: three; the OSP annotation libcosim reads; OMSimulator's annotation, whose reader matches
#: elements by their prefixed names, so the prefixes are part of the format).
NAMESPACES = {"ssc": "http://ssp-standard.org/SSP1/SystemStructureCommon",
              "ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
              "ssv": "http://ssp-standard.org/SSP1/SystemStructureParameterValues",
              "osp": "http://opensimulationplatform.com/SSP/OSPAnnotations",
              "oms": "https://raw.githubusercontent.com/OpenModelica/OMSimulator/master/"
                     "schema/oms.xsd"}
#: The OspSystemStructure.xml's default namespace (libcosim's configuration format).
OSP_CONFIG_NAMESPACE = "http://opensimulationplatform.com/MSMI/OSPSystemStructure"
_NS = NAMESPACES
for _prefix, _uri in _NS.items():
    ET.register_namespace(_prefix, _uri)
_OSP_CONFIG_NS = OSP_CONFIG_NAMESPACE


@dataclass(frozen=True)
class SystemDescription:
    """One EHA system: what the files describe.

    Attributes
    ----------
    name : str
    step : float
        Communication step, [s].
    stop_time : float
        [s] (the DefaultExperiment's).
    parameters : dict
        component -> {FMU variable name: value}, the values each component is given.
    types : dict
        component -> {variable name: (FMI type, causality, unit or None, start value as
        text or None)}, of every variable the files name.
    fmus : dict
        component -> path of its FMU.
    """

    name: str
    step: float
    stop_time: float
    parameters: dict
    types: dict
    fmus: dict


def _s(tag: str, ns: str = "ssd") -> str:
    return f"{{{_NS[ns]}}}{tag}"


def _value_text(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value)
    return str(value)


def _kinds(fmu_path) -> dict:
    """{variable: (FMI type, causality, unit, start)} of an FMU's model description."""
    from fmpy import read_model_description

    md = read_model_description(str(fmu_path), validate=False)
    return {v.name: (v.type, v.causality, v.unit, v.start) for v in md.modelVariables}


def describe(case, fmus: dict, step: float = SYSTEM_STEP, name: str = SYSTEM_NAME
             ) -> SystemDescription:
    """The system of a :class:`smeha.studies.flow.Case`: the harness's run, as three FMUs.

    Parameters
    ----------
    case : smeha.studies.flow.Case
        Frequency, mode, circuit, load, cycles (the stop time), branch rule, model
        variant and compensator period are used; the harness's own step settings are not.
    fmus : dict
        component -> FMU path (:data:`COMPONENTS`).
    step : float
        The communication step, [s].
    """
    from system_models import presets
    from system_models.cosim import FmuTransducer

    from . import build
    from ..studies.flow import control_signal

    plant_table = build.table("smeha_plant_interface")
    transducer = case.fmu_start_values()
    # the transducer FMU is the source of the rod's mechanics and of its rest position
    unit = FmuTransducer(fmus["transducer"], transducer, instance_name="ssp_writer")
    try:
        mechanics = unit.mechanics()
        rest = unit.rod_state()[0]
    finally:
        unit.close()
    compensated = case.mode == "compensated"
    plant = {**plant_table.circuit_values(presets.circuit(case.circuit)),
             **plant_table.rod_values(mechanics), "rod_start_displacement": float(rest),
             "load_force": float(case.load_force), "extrapolate_force": not compensated}
    control, _ = control_signal(case.mode, case.frequency)
    drive = {"offset": control.offset, "amplitude": control.amplitude,
             "frequency": float(case.frequency)}
    parameters = {"drive": drive, "transducer": transducer, "plant": plant}
    types = {c: _kinds(fmus[c]) for c in COMPONENTS}
    return SystemDescription(name, float(step), case.cycles / case.frequency, parameters,
                             types, {c: Path(fmus[c]) for c in COMPONENTS})


def _connectors(desc: SystemDescription) -> dict:
    """component -> [(connector, kind)] the SSD declares, in order."""
    out = {c: [] for c in COMPONENTS}
    for a, ca, b, cb in CONNECTIONS:
        for comp, conn in ((a, ca), (b, cb)):
            if (conn, desc.types[comp][conn][1]) not in out[comp]:
                out[comp].append((conn, desc.types[comp][conn][1]))
    for name in MECHANICS:
        out["transducer"].append((name, "calculatedParameter"))
        out["plant"].append((name, "parameter"))
    for comp, names in RECORDED.items():
        out[comp].extend((n, "output") for n in names if (n, "output") not in out[comp])
    return out


def ssv_values(values: dict, types: dict) -> dict:
    """The parameter values a component's .ssv holds: ``values`` but the String ones that
    equal the FMU's start value.

    OMSimulator reads Real, Integer and Boolean SSV parameters only (its ``Values.cpp``
    logs "Unknown ParameterBinding-type" for ``ssv:String`` and skips it); a String at its
    start value needs no binding, so only a String that departs from it (docs/FMU.md,
    "The EHA as an FMI system") is written, and OMSimulator then runs with the start value.
    """
    return {name: value for name, value in values.items()
            if not (types[name][0] == "String" and str(value) == types[name][3])}


def _ssv(component: str, values: dict, types: dict) -> bytes:
    root = ET.Element(_s("ParameterSet", "ssv"), {"version": "1.0", "name": component})
    params = ET.SubElement(root, _s("Parameters", "ssv"))
    for name, value in ssv_values(values, types).items():
        kind = types[name][0]
        p = ET.SubElement(params, _s("Parameter", "ssv"), {"name": name})
        ET.SubElement(p, _s(kind, "ssv"), {"value": _value_text(value)})
    ET.indent(root, "  ")
    return ET.tostring(root, encoding="UTF-8", xml_declaration=True) + b"\n"


def _units(desc: SystemDescription, connectors: dict) -> list:
    from . import build
    units = build.iface.UNITS
    return sorted({desc.types[c][n][2] for c, conns in connectors.items() for n, _ in conns
                   if desc.types[c][n][0] == "Real" and desc.types[c][n][2] in units})


def ssd_xml(desc: SystemDescription, fmu_names: dict) -> bytes:
    """The SystemStructure.ssd of ``desc`` (SSP 1.0), the FMUs as ``resources/<name>``."""
    from .. import __version__
    from . import build

    root = ET.Element(_s("SystemStructureDescription"), {
        "version": "1.0", "name": desc.name, "generationTool": f"smeha {__version__}",
        "description": "Smart-material electrohydrostatic actuator: drive signal, giant "
                       "magnetostrictive transducer, hydraulic plant (smeha)"})
    system = ET.SubElement(root, _s("System"), {"name": "eha"})
    elements = ET.SubElement(system, _s("Elements"))
    connectors = _connectors(desc)
    for comp in COMPONENTS:
        el = ET.SubElement(elements, _s("Component"), {
            "name": comp, "type": "application/x-fmu-sharedlibrary",
            "source": f"resources/{fmu_names[comp]}"})
        conns = ET.SubElement(el, _s("Connectors"))
        for name, kind in connectors[comp]:
            fmi_type, _, unit, _ = desc.types[comp][name]
            c = ET.SubElement(conns, _s("Connector"), {"name": name, "kind": kind})
            ET.SubElement(c, _s(fmi_type, "ssc"), {"unit": unit} if fmi_type == "Real" and unit
                          else {})
        bindings = ET.SubElement(el, _s("ParameterBindings"))
        ET.SubElement(bindings, _s("ParameterBinding"), {"source": f"resources/{comp}.ssv"})
    connections = ET.SubElement(system, _s("Connections"))
    for a, ca, b, cb in CONNECTIONS + tuple(("transducer", n, "plant", n) for n in MECHANICS):
        ET.SubElement(connections, _s("Connection"), {
            "startElement": a, "startConnector": ca, "endElement": b, "endConnector": cb})
    _openmodelica_master(system, desc.step)
    units = ET.SubElement(root, _s("Units"))
    for name in _units(desc, connectors):
        unit = ET.SubElement(units, _s("Unit", "ssc"), {"name": name})
        ET.SubElement(unit, _s("BaseUnit", "ssc"),
                      {k: str(v) for k, v in build.iface.UNITS[name].items() if v})
    experiment = ET.SubElement(root, _s("DefaultExperiment"), {
        "startTime": "0.0", "stopTime": repr(desc.stop_time)})
    # libcosim reads its fixed step from this annotation (cosim/ssp/ssp_parser.cpp)
    notes = ET.SubElement(experiment, _s("Annotations"))
    note = ET.SubElement(notes, _s("Annotation", "ssc"), {"type": "com.opensimulationplatform"})
    algorithm = ET.SubElement(note, _s("Algorithm", "osp"))
    ET.SubElement(algorithm, _s("FixedStepAlgorithm", "osp"), {"baseStepSize": repr(desc.step)})
    ET.indent(root, "  ")
    return ET.tostring(root, encoding="UTF-8", xml_declaration=True) + b"\n"


def _openmodelica_master(system: ET.Element, step: float) -> None:
    """OMSimulator's master for ``system``: its fixed-step master ("oms-ma") at ``step``.

    OMSimulator takes a system's kind (weakly coupled, its master, the step) only from its
    own annotation on the system (``Model::getSystemType`` in OMSimulator's sources); without
    it the system is refused ("Unable to add System"). The OSP annotation beside it gives
    libcosim the same step; fmpy reads neither.
    """
    notes = ET.SubElement(system, _s("Annotations"))
    note = ET.SubElement(notes, _s("Annotation", "ssc"), {"type": "org.openmodelica"})
    info = ET.SubElement(ET.SubElement(note, _s("Annotations", "oms")),
                         _s("SimulationInformation", "oms"))
    ET.SubElement(info, _s("FixedStepMaster", "oms"), {"description": "oms-ma",
                                                       "stepSize": repr(step)})


def write_ssp(desc: SystemDescription, path: str | os.PathLike) -> Path:
    """Write the .ssp of ``desc`` (SSD, the three FMUs, one SSV per component); return it."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    names = {c: desc.fmus[c].name for c in COMPONENTS}
    tmp = path.with_name(path.name + ".tmp")
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("SystemStructure.ssd", ssd_xml(desc, names))
        for comp in COMPONENTS:
            z.write(desc.fmus[comp], f"resources/{names[comp]}")
            z.writestr(f"resources/{comp}.ssv",
                       _ssv(comp, desc.parameters[comp], desc.types[comp]))
    os.replace(tmp, path)
    return path


def osp_xml(desc: SystemDescription, sources: dict) -> bytes:
    """The OspSystemStructure.xml of ``desc`` (libcosim), the FMUs at ``sources`` (URIs
    relative to the file)."""
    # elements in the OSP namespace as the document's default one (xmlns written as given)
    root = ET.Element("OspSystemStructure", {"xmlns": _OSP_CONFIG_NS, "version": "0.1"})
    for tag, value in (("StartTime", 0.0), ("EndTime", desc.stop_time),
                       ("BaseStepSize", desc.step)):
        ET.SubElement(root, tag).text = repr(float(value))
    ET.SubElement(root, "Algorithm").text = "fixedStep"
    sims = ET.SubElement(root, "Simulators")
    for comp in COMPONENTS:
        sim = ET.SubElement(sims, "Simulator", {"name": comp, "source": sources[comp],
                                                "stepSize": repr(desc.step)})
        initial = ET.SubElement(sim, "InitialValues")
        for name, value in desc.parameters[comp].items():
            iv = ET.SubElement(initial, "InitialValue", {"variable": name})
            ET.SubElement(iv, desc.types[comp][name][0], {"value": _value_text(value)})
    conns = ET.SubElement(root, "Connections")
    for a, ca, b, cb in CONNECTIONS:
        vc = ET.SubElement(conns, "VariableConnection")
        ET.SubElement(vc, "Variable", {"simulator": a, "name": ca})
        ET.SubElement(vc, "Variable", {"simulator": b, "name": cb})
    ET.indent(root, "  ")
    return ET.tostring(root, encoding="UTF-8", xml_declaration=True) + b"\n"


def write_osp(desc: SystemDescription, folder: str | os.PathLike) -> Path:
    """Write ``folder/OspSystemStructure.xml`` for ``desc``, the FMUs referred to where they
    are (relative paths); return the file."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    sources = {c: Path(os.path.relpath(desc.fmus[c].resolve(), folder.resolve())).as_posix()
               for c in COMPONENTS}
    path = folder / "OspSystemStructure.xml"
    path.write_bytes(osp_xml(desc, sources))
    return path


def build_system(out: str | os.PathLike, frequency: float = 100.0,
                 mode: str = "compensated", circuit: str = "realistic",
                 validate: bool = True, built: dict | None = None) -> tuple[Path, ...]:
    """Build the three FMUs into ``out`` and write the system of one case there:
    ``<out>/SmehaEha.ssp``, ``<out>/SmehaEha/OspSystemStructure.xml`` (the FMUs referred to
    as ``../<name>.fmu``) and the container FMU ``<out>/SmehaEha.fmu``. Returns the three.

    ``built`` gives components whose FMU was just built (component -> path).

    Raises
    ------
    smeha.fmu.build.BuildError
        An FMU could not be built.
    gmt.ParameterError
        A bad frequency, mode or circuit.
    """
    from . import build
    from ..studies.flow import Case

    case = Case(frequency, mode, circuit=circuit)  # checks the values before any build
    out = Path(out)
    fmus = dict(built or {})
    for comp, key in COMPONENTS.items():
        if comp not in fmus:
            fmus[comp] = build.build_fmu(key, out, validate=validate)
    desc = describe(case, fmus)
    return (write_ssp(desc, out / f"{SYSTEM_NAME}.ssp"), write_osp(desc, out / SYSTEM_NAME),
            write_container(desc, out / f"{SYSTEM_NAME}.fmu"))


# -- the system as one FMU: fmpy's container FMU ------------------------------------------------
#: Outputs the container FMU exposes, per component (its parameters are all exposed too).
CONTAINER_OUTPUTS = {"drive": ("u",), "transducer": ("current", "displacement", "force"),
                     "plant": ("rod_displacement", "rod_velocity", "p_pump", "p_big", "p_small",
                               "p_accumulator", "piston_position", "piston_velocity", "q_v1",
                               "q_v2", "q_v3", "q_v4", "volume_into_big",
                               "compression_volume", "compressing", "valves_compressing",
                               "stage")}


def write_container(desc: SystemDescription, path: str | os.PathLike) -> Path:
    """Write the system of ``desc`` as one FMI 2.0 co-simulation FMU (fmpy's container FMU,
    ``fmpy.container_fmu``): the three FMUs inside, connected as in the SSD, stepped with
    the system's step from one communication point and then connected (Jacobi, as the SSP
    and OSP masters do); every component parameter a parameter ``<component>.<name>``
    starting at the system's value, the outputs of :data:`CONTAINER_OUTPUTS` as
    ``<component>.<name>``. Returns the path.

    Two things fmpy 0.3.32's writer leaves to its caller: the container maps value
    reference i + 1 to its i-th variable (0 is time), so ``time`` comes first; and
    connections must name FMI 3.0 types (``Float64``), which it converts for variables only.

    The container passes its connections on once as it leaves Initialization Mode, reading
    its units' outputs before they leave it (a start value given here to a connected input
    is overwritten then): the units give their initial outputs there (the drive u(t0)), so
    every unit's first step sees them, as in libcosim and OMSimulator.
    """
    import tempfile
    import uuid

    import attrs
    from fmpy import read_model_description
    from fmpy.container_fmu.cli import create_container_fmu
    from fmpy.container_fmu.config import Component, Configuration, Connection
    from fmpy.model_description import (CoSimulation, DefaultExperiment, ModelDescription,
                                        ModelVariable, Unknown)

    from . import build

    def fmi3_type(variable):
        return attrs.evolve(variable, type={"Real": "Float64", "Integer": "Int32"}.get(
            variable.type, variable.type))

    components, inner = {}, {}
    for comp in COMPONENTS:
        md = read_model_description(str(desc.fmus[comp]))
        inner[comp] = {v.name: v for v in md.modelVariables}
        components[comp] = Component(name=comp, filename=Path(desc.fmus[comp]),
                                     modelDescription=md)
    connections = [Connection(components[a], [fmi3_type(inner[a][ca])], components[b],
                              [fmi3_type(inner[b][cb])]) for a, ca, b, cb in CONNECTIONS]
    variables = [ModelVariable(name="time", type="Real", causality="independent",
                               variability="continuous")]
    mappings = {}
    for comp, values in desc.parameters.items():
        for name, value in values.items():
            v = inner[comp][name]
            variables.append(ModelVariable(
                name=f"{comp}.{name}", type=v.type, causality="parameter", variability="fixed",
                initial="exact", start=_value_text(value), description=v.description))
            mappings[variables[-1]] = [(components[comp], v)]
    for comp, names in CONTAINER_OUTPUTS.items():
        for name in names:
            v = inner[comp][name]
            variables.append(ModelVariable(
                name=f"{comp}.{name}", type=v.type, causality="output",
                variability=v.variability, initial="calculated", description=v.description))
            mappings[variables[-1]] = [(components[comp], v)]
    token = "{%s}" % uuid.uuid5(build.GUID_NAMESPACE, repr(
        (desc.name, desc.step, sorted((c, sorted(p.items())) for c, p in
                                      desc.parameters.items()),
         [read_model_description(str(desc.fmus[c])).guid for c in COMPONENTS])))
    md = ModelDescription(
        fmiVersion="2.0", modelName=desc.name, instantiationToken=token,
        description="Smart-material electrohydrostatic actuator as one FMU: drive signal, "
                    "giant magnetostrictive transducer, hydraulic plant (smeha)",
        generationTool="smeha with fmpy's container FMU",
        defaultExperiment=DefaultExperiment(startTime="0.0", stopTime=repr(desc.stop_time),
                                            stepSize=repr(desc.step)),
        coSimulation=CoSimulation(modelIdentifier="container_fmu",
                                  fixedInternalStepSize=desc.step),
        modelVariables=variables)
    # FMI 2.0 ModelStructure: every output, and as initial unknowns (initial="calculated")
    outputs = [v for v in variables if v.causality == "output"]
    md.outputs = [Unknown(variable=v) for v in outputs]
    md.initialUnknowns = [Unknown(variable=v) for v in outputs]
    config = Configuration(parallelDoStep=False, modelDescription=md,
                           components=list(components.values()), connections=connections,
                           variableMappings=mappings)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="smeha_container_") as tmp:
        create_container_fmu(config, Path(tmp), path.resolve())  # empties tmp first
    return path
