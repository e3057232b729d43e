"""The FMU's variable table, defined once for both slaves, the build and the docs.

Both slaves (``smeha_gmt_fmu.py``, FMI 2.0, and ``smeha_gmt_fmu3.py``, FMI 3.0,
next to this file in ``fmu_src/``) register their variables from
:data:`VARIABLES` and take every callback from ``smeha_fmu_slave.TransducerSlave``,
which builds gmt's objects from the parameters named here;
``smeha.fmu.build`` writes the units of the FMI 2.0 model description from the
same table, and ``docs/FMU.md`` documents it.

The FMU bundles this file as ``resources/smeha_fmu_interface_<build>.py``, like every
module and package it bundles under its name and the build's identifier
(``smeha.fmu.build.bundled_names``: one Python interpreter serves every pythonfmu FMU of
a host process, and modules are shared by name), so that it meets no other Python FMU's
module, nor another build's. It imports nothing from ``smeha`` and does
not import ``gmt`` at module level; :func:`check_against_gmt` imports ``gmt``
when called, which inside an FMU is the bundled copy. ``smeha.fmu.build`` loads
this file from the source tree under another module name
(``smeha._smeha_fmu_interface``), so a process that builds an FMU and then loads
it still runs the FMU's bundled copy.

Names of the parameters are the field names of :class:`gmt.TransducerParameters`,
:class:`gmt.Excitation` and :class:`gmt.DriveParameters`; their start values are
those classes' defaults (paper, Table 2). :func:`check_against_gmt` fails the
build when the two drift apart.
"""
from __future__ import annotations

import math

# the record and the units every table of this project uses (bundled next to this file)
from smeha_fmu_variables import UNITS, Variable, unit_problems  # noqa: F401  (UNITS: re-exported)

#: modelName / modelIdentifier of the FMI 2.0 FMU (the FMU is ``SmehaGmt.fmu``).
MODEL_NAME_FMI2 = "SmehaGmt"
#: modelName / modelIdentifier of the FMI 3.0 FMU (``SmehaGmt3.fmu``).
MODEL_NAME_FMI3 = "SmehaGmt3"
#: Slave module names (in an FMU, suffixed with the build's identifier, like every bundled
#: module: see the module docstring).
SLAVE_MODULE_FMI2 = "smeha_gmt_fmu"
SLAVE_MODULE_FMI3 = "smeha_gmt_fmu3"
#: Module name of this file, in fmu_src/ and in the FMU's resources.
INTERFACE_MODULE = "smeha_fmu_interface"
#: The other modules of fmu_src/ the FMU bundles next to its slave: the callbacks both
#: slaves share, and the run-time set-up each slave runs first; the variable record and units
#: and the callbacks every FMU of this project shares.
SLAVE_LOGIC_MODULE = "smeha_fmu_slave"
RUNTIME_MODULE = "smeha_fmu_runtime"
VARIABLES_MODULE = "smeha_fmu_variables"
BASE_MODULE = "smeha_fmu_base"
#: Name under which the gmt package is bundled in the FMU's resources. Unique to
#: this project, so that a host that has imported its own ``gmt`` (the smeha
#: co-simulation master does) cannot make the FMU run the host's copy: one Python
#: interpreter serves every pythonfmu FMU of a process, and modules are shared by
#: name. gmt imports itself only relatively, so it works under any name.
BUNDLED_PHYSICS_PACKAGE = "smeha_fmu_gmt"


def physics():
    """The gmt package: inside an FMU its bundled copy, elsewhere the installed one."""
    import importlib
    import importlib.util
    # fall back only when the bundled package is absent, not when it fails to
    # import (a missing numpy must surface, not switch to the host's copy)
    if importlib.util.find_spec(BUNDLED_PHYSICS_PACKAGE) is not None:
        return importlib.import_module(BUNDLED_PHYSICS_PACKAGE)
    return importlib.import_module("gmt")

AUTHOR = "smeha developers"
LICENSE = "MIT"
DESCRIPTION = ("Giant magnetostrictive transducer (GMT) of a smart-material "
               "electrohydrostatic actuator: amplifier, inverse compensator and the "
               "complex-permeability model of eq 30 (smeha, gmt package)")

#: Accepted values of the String parameter ``model_variant`` (gmt.VARIANTS): the
#: paper's model, or the paper's plus the extension for one cause ``smeha diagnose`` names,
#: ``cause:form`` for a form other than the cause's first (gmt.ModelVariant.name).
MODEL_VARIANTS = ("paper", "rate_independent_hysteresis",
                  "rate_independent_hysteresis:preisach", "magnetization_saturation",
                  "eddy_current_diffusion", "eddy_current_diffusion:slab",
                  "eddy_current_diffusion:cylinder", "eddy_current_diffusion:slab_magnetization",
                  "eddy_current_diffusion:cylinder_magnetization", "transport_delay",
                  "mechanical_resonance", "mechanical_resonance:two_dof", "thermal_drift")
#: Accepted values of the String parameter ``branch_rule`` (gmt.parameters.BRANCH_RULES).
BRANCH_RULES = ("control", "demand")
#: Accepted values of the String parameter ``magnetics`` (gmt.transducer.MAGNETICS).
MAGNETICS = ("paper", "time_domain")
#: Accepted values of ``inverse_model``: the inverse of the magnetics in use, or either.
INVERSE_MODELS = ("same", *MAGNETICS)

#: DefaultExperiment: five periods of the paper's 50 Hz case at a 10 us step.
DEFAULT_EXPERIMENT = {"start_time": 0.0, "stop_time": 0.1, "step_size": 1e-5}

def _in(name, unit, description, start=0.0):
    return Variable(name, "Real", "input", unit, description, start, "input")


def _par(group, name, unit, description, start, kind="Real"):
    return Variable(name, kind, "parameter", unit if kind == "Real" else None,
                    description, start, group)


def _calc(name, unit, description):
    return Variable(name, "Real", "calculatedParameter", unit, description, None, "mechanics")


def _out(name, unit, description, kind="Real"):
    return Variable(name, kind, "output", unit if kind == "Real" else None,
                    description, None, "output")


_T, _E, _D, _M, _TD = "transducer", "excitation", "drive", "model", "timedomain"

#: Every variable, in registration order (inputs, parameters, outputs).
VARIABLES: tuple[Variable, ...] = (
    # -- inputs ----------------------------------------------------------------
    _in("u", "V", "Control signal u: uncompensated, coil current i = amplifier_gain*u; "
        "compensated, demanded displacement y_d = displacement_per_volt*(u - control_offset) "
        "above the bottom of the stroke (Figure 9). Held over the step."),
    _in("external_force", "N", "External axial force on the output rod, opposing "
        "elongation (e.g. pump-chamber pressure times piston area), eq 27. Held over the step."),
    # -- TransducerParameters (paper, Table 2) -----------------------------------
    _par(_T, "rod_diameter", "m", "Diameter d of the Terfenol-D rod (Table 2)", 10e-3),
    _par(_T, "rod_length", "m", "Length L of the rod, eq 1 (Table 2)", 80e-3),
    _par(_T, "mass", "kg", "Equivalent moving mass m, eq 27 (Table 2)", 0.02),
    _par(_T, "damping", "N.s/m", "Equivalent viscous damping c, eq 27 (Table 2)", 2945.0),
    _par(_T, "stiffness", "N/m", "Equivalent stiffness K, eq 27 (Table 2)", 1.963e7),
    _par(_T, "bias_magnetization", "A/m", "Bias magnetisation M_b of the permanent "
         "magnet, eq 25 (Table 2)", 250e3),
    _par(_T, "coil_turns", "1", "Excitation coil turns N, eq 1 (Table 2)", 1300.0),
    _par(_T, "hysteresis_coefficient", "W.s/(m3.T^n)", "Hysteresis loss coefficient "
         "K_h of eq 7 (Table 2)", 85805.0),
    _par(_T, "steinmetz_exponent", "1", "Steinmetz exponent n of eq 7, in [1, 3] "
         "(Table 2)", 1.8092),
    _par(_T, "eddy_coefficient", "W.s2/(m3.T2)", "Eddy-current loss coefficient K_e "
         "of eq 9 (Table 2)", 2753.39),
    _par(_T, "excess_coefficient", "W.s1.5/(m3.T1.5)", "Excess (anomalous) loss "
         "coefficient K_ex of eq 11 (Table 2)", 895.80),
    _par(_T, "magnetostriction_coefficient", "m2/A2", "Magnetostriction coefficient "
         "K_lambda of eq 26 (Table 2)", 1.4694e-14),
    _par(_T, "sense_turns", "1", "Sensing-coil turns N_c, eq 21 (Table 2)", 150.0),
    _par(_T, "sense_area", "m2", "Sensing-coil cross-section A_c, eq 21 (Table 2)", 380e-6),
    _par(_T, "leakage_coefficient", "1", "Flux leakage coefficient k_f >= 1, eq 1 "
         "(Table 2)", 1.1),
    _par(_T, "low_field_hysteresis_coefficient", "W.s/(m3.(A/m)3)", "Low-field "
         "(Rayleigh) hysteresis coefficient K'_h of eq 6; 0 = not identified", 0.0),
    # -- Excitation: the operating point of the complex permeability -------------
    _par(_E, "frequency", "Hz", "Excitation frequency f of the operating point, "
         "in (0, 1000] Hz (eqs 1-2)", 50.0),
    _par(_E, "current_amplitude", "A", "Current amplitude I_m of the operating point, "
         "in (0, 100] A (eqs 1-2)", 1.0),
    _par(_E, "flux_density_amplitude", "T", "Measured flux-density amplitude B_m "
         "(Table 1); 0 = take it from the Table 1 calibration", 0.0),
    _par(_E, "follow_drive", None, "false: the model stays at (frequency, "
         "current_amplitude) and outside_design_point flags a drive that departs from it; "
         "true: the operating point follows the sinusoid the coil current is, measured over "
         "each period (B_m from the Table 1 calibration; paper's model only)", False,
         kind="Boolean"),
    # -- DriveParameters: amplifier and inverse compensator (Figure 9) -----------
    _par(_D, "amplifier_gain", "A/V", "Amplifier gain K_a, coil current per volt of "
         "control signal", 1.0),
    _par(_D, "current_limit", "A", "Largest coil current magnitude the amplifier "
         "delivers", 3.0),
    _par(_D, "compensated", None, "true: inverse compensator in the loop (Figure 9); "
         "false: i = amplifier_gain*u", False, kind="Boolean"),
    _par(_D, "displacement_per_volt", "m/V", "Compensated drive: demanded displacement "
         "per volt of control signal (paper: 10 um/V)", 10e-6),
    _par(_D, "control_offset", "V", "Compensated drive: control signal u_0 that "
         "commands the bottom of the stroke", 0.0),
    _par(_D, "branch_rule", None, "Compensated drive: root of eq 33 chosen by the sign "
         "of u(n)-u(n-1), \"control\" (Figure 9), or of the demanded magnetisation, "
         "\"demand\" (default: its result does not depend on compensator_period)", "demand",
         kind="String"),
    _par(_D, "compensator_period", "s", "Compensated drive: sample period T_c of the "
         "digital compensator, in [0, 1] s. It samples u at t = n*T_c from the start and "
         "holds its current until the next sample (a step that crosses a sample is split "
         "there); 0 = a sample at the start of every step. Default 1e-4 s (10 kHz)", 1e-4),
    # -- model selection ----------------------------------------------------------
    _par(_M, "model_variant", None, "Transducer model: \"paper\" (eqs 1-37 of the source "
         "paper), or the paper's plus the extension for the cause smeha diagnose names: "
         "\"rate_independent_hysteresis\" (play operators), "
         "\"rate_independent_hysteresis:preisach\", \"magnetization_saturation\", "
         "\"eddy_current_diffusion\" (lag), \"eddy_current_diffusion:slab\", "
         "\"eddy_current_diffusion:cylinder\", "
         "\"eddy_current_diffusion:slab_magnetization\", "
         "\"eddy_current_diffusion:cylinder_magnetization\", "
         "\"transport_delay\" (sensed_displacement "
         "only), \"mechanical_resonance\" (one DOF), \"mechanical_resonance:two_dof\", "
         "\"thermal_drift\"; several of these joined by \"+\" combine them (one form "
         "of each cause); anything else is an error",
         "paper", kind="String"),
    _par(_M, "variant_parameters", None, "JSON object of the extension's SI parameters, "
         "keyed as the candidate's \"parameters\" in smeha diagnose --json, e.g. "
         "{\"delay_s\": 0.0005}; {} for \"paper\"; for a combination, one such object "
         "per member keyed by the member's name", "{}", kind="String"),
    _par(_M, "magnetics", None, "Magnetics of the transducer model: \"paper\" (the complex "
         "permeability of eqs 3-20, defined for one sinusoid at (frequency, "
         "current_amplitude)) or \"time_domain\" (the paper's loss separation as a field "
         "separation, valid for any current: outside_design_point stays false; "
         "model_variant \"paper\" only)", "paper", kind="String"),
    _par(_M, "inverse_model", None, "Compensated drive: the model the compensator inverts, "
         "\"same\" (that of magnetics), \"paper\" (Figure 9, eqs 31-37) or "
         "\"time_domain\" (the explicit inverse for any demanded stroke)", "same",
         kind="String"),
    # -- TimeDomainParameters: what magnetics "time_domain" adds to Table 2 ---------
    _par(_TD, "reversible_permeability", "1", "Time-domain magnetics: relative permeability "
         "of the reversible curve about the bias (fitted to Table 1 at 5 Hz)", 12.08),
    _par(_TD, "steinmetz_upper", "T", "Time-domain magnetics: largest flux-density half-swing "
         "for which the hysteresis loss per cycle is K_h B_m^n (eq 7)", 0.2),
    _par(_TD, "steinmetz_lower", "T", "Time-domain magnetics: half-swing below which the "
         "hysteresis loss turns Rayleigh-like (dH/dB finite at reversals)", 2e-3),
    _par(_TD, "rate_coefficient", "A/m.T^(q-beta).(s/T)^(q-1)", "Time-domain magnetics: "
         "k_w of the rate field k_w dB_pp^(beta-q) abs(dB/dt)^(q-1) (gmt.timedomain.dynamic; "
         "0: off)", 0.0),
    _par(_TD, "rate_exponent", "1", "Time-domain magnetics: q of the rate field", 2.0),
    _par(_TD, "swing_exponent", "1", "Time-domain magnetics: beta, the rate field's and the "
         "relaxation's scaling with the loop's peak-to-peak swing", 2.0),
    _par(_TD, "relaxation_coefficient", "A/m.T^(1-beta)", "Time-domain magnetics: k_r of "
         "the relaxation field k_r dB_pp^(beta-2) x, dx/dt = dB/dt - x/tau (0: off)", 0.0),
    _par(_TD, "relaxation_time", "s", "Time-domain magnetics: tau of the relaxation", 1e-6),
    _par(_TD, "second_hysteresis_coefficient", "W.s/(m3.T^n)", "Time-domain magnetics: K_h2 of a "
         "second stop density, hysteresis loss per cycle K_h B^n + K_h2 B^n2 (0: off)", 0.0),
    _par(_TD, "second_steinmetz_exponent", "1", "Time-domain magnetics: n2 of the second "
         "stop density", 3.5),
    _par(_TD, "steinmetz_break", "T", "Time-domain magnetics: half-swing above which the "
         "hysteresis loss per cycle grows as B^steinmetz_exponent_high (2: no break)", 2.0),
    _par(_TD, "steinmetz_exponent_high", "1", "Time-domain magnetics: the hysteresis "
         "exponent above steinmetz_break", 2.0),
    # -- calculated parameters: the mechanics the force drives, for a host that
    #    integrates the rod with its load (e.g. a pump chamber fed the output `force`)
    _calc("equivalent_mass", "kg", "Mass m of eq 27 in effect: Table 2's mass, the "
          "re-identified one of model_variant \"mechanical_resonance\", or the rod's m_1 of "
          "\"mechanical_resonance:two_dof\""),
    _calc("equivalent_damping", "N.s/m", "Damping c of eq 27 in effect"),
    _calc("equivalent_stiffness", "N/m", "Stiffness K of eq 27 in effect"),
    _calc("output_mass", "kg", "Output mass m_2 on the joint (two_dof variant): it carries "
          "external_force and the output displacement; 0 = the output is the rod (one mass)"),
    _calc("joint_stiffness", "N/m", "Joint stiffness k_j between rod and output mass "
          "(two_dof variant; 0 otherwise)"),
    _calc("joint_damping", "N.s/m", "Joint damping c_j between rod and output mass "
          "(two_dof variant; 0 otherwise)"),
    # -- outputs ------------------------------------------------------------------
    _out("current", "A", "Coil current i delivered over the last step"),
    _out("displacement", "m", "Rod displacement y at the end of the last step, including "
         "the bias displacement (eq 30)"),
    _out("velocity", "m/s", "Rod velocity dy/dt at the end of the last step"),
    _out("sensed_displacement", "m", "Displacement a sensor on the output rod reads at the "
         "end of the last step: equal to displacement, except with model_variant "
         "\"transport_delay\", y(t - delay_s)"),
    _out("field", "A/m", "Applied magnetic field H over the last step (eq 1)"),
    _out("flux_density", "T", "Flux density B over the last step (eq 4)"),
    _out("magnetization", "A/m", "Magnetisation M of the coil field over the last step "
         "(eq 5)"),
    _out("strain", "1", "Magnetostrictive strain lambda = K_lambda (M_b + M)^2, bias "
         "included, over the last step (eq 25)"),
    _out("force", "N", "Magnetostrictive (blocked) force A_r E^H lambda over the last "
         "step (eq 28)"),
    _out("saturated", None, "true when the last step's current was limited or the "
         "compensator's demand was out of reach", kind="Boolean"),
    _out("saturation_count", None, "Steps saturated since initialisation or reset",
         kind="Integer"),
    _out("outside_design_point", None, "true while the coil current departs from the "
         "sinusoid at (operating_frequency, operating_current_amplitude) the complex "
         "permeability is defined for (eqs 1-2, 31): frequency off by more than 5 %, "
         "amplitude or offset by more than 1 % of I_m (judged each period), standing still "
         "(DC, a step's plateau) or stepping; uncompensated, also a first sample that is "
         "not the drive's peak I_m (one sample cannot tell a current at rest from a "
         "sinusoid of another phase: cleared when the current moves); a warning is logged "
         "the first time (and for that first sample). Always "
         "false with magnetics \"time_domain\" (every drive is inside that model)",
         kind="Boolean"),
    _out("operating_frequency", "Hz", "Frequency f of the operating point the model runs "
         "at: the frequency parameter, or with follow_drive the drive's last full period's"),
    _out("operating_current_amplitude", "A", "Current amplitude I_m of the operating point "
         "the model runs at: the current_amplitude parameter, or with follow_drive the "
         "drive's last full period's"),
)

BY_NAME: dict[str, Variable] = {v.name: v for v in VARIABLES}
PARAMETERS = tuple(v.name for v in VARIABLES if v.causality == "parameter")
OUTPUTS = tuple(v.name for v in VARIABLES if v.causality == "output")
TRANSDUCER_PARAMETERS = tuple(v.name for v in VARIABLES if v.group == _T)
EXCITATION_PARAMETERS = tuple(v.name for v in VARIABLES if v.group == _E)
DRIVE_PARAMETERS = tuple(v.name for v in VARIABLES if v.group == _D)
TIME_DOMAIN_PARAMETERS = tuple(v.name for v in VARIABLES if v.group == _TD)
#: Calculated parameters, in the order of :class:`gmt.RodMechanics`' fields.
MECHANICS = tuple(v.name for v in VARIABLES if v.group == "mechanics")
#: Real outputs, in :data:`OUTPUTS` order (``smeha_fmu_slave.output_values``).
REAL_OUTPUTS = tuple(v.name for v in VARIABLES if v.causality == "output" and v.kind == "Real")
#: Every variable's name, in VARIABLES order (a saved FMU state holds the values as a
#: tuple in this order, ``smeha_fmu_slave``)
VARIABLE_NAMES = tuple(v.name for v in VARIABLES)


def coerce(name: str, value):
    """``value`` converted to the Python type of variable ``name`` (no range check)."""
    return BY_NAME[name].coerce(value)


def parameter_values(source) -> dict:
    """The parameters' current values, read as attributes of ``source`` (a slave)."""
    return {name: coerce(name, getattr(source, name)) for name in PARAMETERS}


def check_against_gmt() -> None:
    """Raise ``AssertionError`` if the table's parameters differ from gmt's dataclasses.

    Checks names and order of every field of TransducerParameters, Excitation and
    DriveParameters and that each start value equals the field's default.
    """
    import dataclasses

    gmt = physics()

    pairs = ((gmt.TransducerParameters, TRANSDUCER_PARAMETERS),
             (gmt.Excitation, EXCITATION_PARAMETERS),
             (gmt.DriveParameters, DRIVE_PARAMETERS),
             (gmt.TimeDomainParameters, TIME_DOMAIN_PARAMETERS))
    problems = []
    for cls, names in pairs:
        fields = {f.name: f.default for f in dataclasses.fields(cls)}
        if tuple(fields) != names:
            problems.append(f"{cls.__name__} fields {tuple(fields)} != FMU parameters {names}")
            continue
        for name in names:
            start = BY_NAME[name].start
            default = fields[name]
            same = (start == default if not isinstance(default, float)
                    else math.isclose(start, default, rel_tol=0.0, abs_tol=0.0))
            if not same:
                problems.append(f"{name}: FMU start {start!r} != gmt default {default!r}")
    if tuple(BRANCH_RULES) != tuple(gmt.parameters.BRANCH_RULES):
        problems.append(f"branch rules {BRANCH_RULES} != gmt {gmt.parameters.BRANCH_RULES}")
    if tuple(MAGNETICS) != tuple(gmt.transducer.MAGNETICS):
        problems.append(f"magnetics {MAGNETICS} != gmt {gmt.transducer.MAGNETICS}")
    if tuple(MODEL_VARIANTS) != tuple(gmt.VARIANTS):
        problems.append(f"model variants {MODEL_VARIANTS} != gmt {gmt.VARIANTS}")
    if MECHANICS != ("equivalent_mass", "equivalent_damping", "equivalent_stiffness",
                     "output_mass", "joint_stiffness", "joint_damping") \
            or len(MECHANICS) != len(gmt.RodMechanics._fields):
        problems.append(f"calculated parameters {MECHANICS} do not follow gmt.RodMechanics "
                        f"{gmt.RodMechanics._fields}")
    if REAL_OUTPUTS != ("current", "displacement", "velocity", "sensed_displacement", "field",
                        "flux_density", "magnetization", "strain", "force",
                        "operating_frequency", "operating_current_amplitude"):
        problems.append(f"Real outputs {REAL_OUTPUTS} are not in output_values' order")
    problems.extend(unit_problems(VARIABLES))
    if problems:
        raise AssertionError("FMU interface out of date with gmt:\n  " + "\n  ".join(problems))
