"""Child-process side of the FMU tests: run an FMU (or the gmt reference) and write JSON.

    python tests/fmu_runner.py COMMAND OUT.json [ARGS...]

Commands
--------
``reference OUT``          step gmt.Transducer (the repository's gmt) through every case
                           (and, as ``paper:<case>``, each variant case with the paper's model)
``behaviour OUT FMU``      FMU trajectories, two instances, reset, FMU state (fmpy)
``bad_input OUT FMU``      one fresh instance per bad input; FMI statuses and log messages
``memory OUT FMU N``       RSS while stepping N times
``cosim OUT FMU``          the FMI 2.0 FMU in libcosimpy and in fmpy, same inputs
``drive OUT FMU N H F A U0 [NAME=VALUE...]``  u = U0 + A cos(2 pi F t), N steps of H (the
                           C host's drive, tests/fmu_c_host.c)
``simulate_bad OUT FMU``   fmpy.simulate_fmu with every bad parameter
``init_mode OUT FMU``      the calculated parameters read in Initialization Mode (fmpy)
``ssp_fmpy OUT SSP F``     the EHA system's .ssp in fmpy's SSP master: piston position, flow
``builds OUT FMU...``      instantiate each FMU in turn in one process (fmpy), initialise and
                           step the ones that instantiate, then step the first again

Why a child process: pythonfmu FMUs run in the host's interpreter, and a host
that already imported ``gmt`` makes the FMU use that copy instead of the one
bundled in the FMU. The pytest process has imported gmt (conftest, doctests),
so every FMU is run here, in a process that has not: the FMU commands never
import gmt themselves, check that it is absent before the FMU loads, and
report which file the FMU's gmt came from. The reference runs in another child,
which imports the repository's gmt and no FMU.

Importable without side effects (pytest's doctest collection imports it).
"""
from __future__ import annotations

import json
import math
import os
import sys

#: Output columns of every row (fmu_src/smeha_fmu_interface.py OUTPUTS, sensed_displacement last so
#: the earlier columns keep their index).
OUTPUTS = ("current", "displacement", "velocity", "field", "flux_density", "magnetization",
           "strain", "force", "saturated", "saturation_count", "sensed_displacement")
REALS = OUTPUTS[:8]

#: The two_dof variant: half of Table 2's 0.02 kg on the output, on a joint of 1 kHz with
#: damping ratio 0.1, as smeha diagnose reports it (the derived frequency and ratio included).
_M2, _FJ, _ZJ = 0.01, 1000.0, 0.1
_KJ = _M2 * (2 * math.pi * _FJ) ** 2
TWO_DOF = {"rod_mass_kg": 0.01, "output_mass_kg": _M2, "joint_stiffness_N_per_m": _KJ,
           "joint_damping_N_s_per_m": 2 * _ZJ * math.sqrt(_KJ * _M2),
           "joint_frequency_Hz": _FJ, "joint_damping_ratio": _ZJ}

#: Model variants exercised (gmt.variants; FMU model_variant names, gmt.VARIANTS, and
#: parameters in SI as smeha diagnose reports them). H_m = 14773 A/m at 1 A with Table 2:
#: play thresholds at 0.2 ... 0.8 of it.
VARIANTS = {
    "v_hysteresis": ("rate_independent_hysteresis",
                     {"thresholds_A_per_m": [2954.5, 5909.1, 8863.6, 11818.2],
                      "weights": [0.3, 0.2, 0.1, 0.05]}),
    "v_saturation": ("magnetization_saturation", {"saturation_magnetization_A_per_m": 4e5}),
    "v_eddy": ("eddy_current_diffusion", {"time_constant_s": 1e-3, "order": 0.5}),
    "v_delay": ("transport_delay", {"delay_s": 2.37e-4}),
    "v_mechanics": ("mechanical_resonance", {"mass_kg": 4e-4, "damping_N_s_per_m": 58.9,
                                             "stiffness_N_per_m": 1.905e7}),
    "v_drift": ("thermal_drift", {"offset_rate_m_per_A2s": 1e-4, "gain_rate_per_A2s": 0.5,
                                  "thermal_time_constant_s": 0.05}),
    # forms other than a cause's first: the name is cause:form
    "v_slab": ("eddy_current_diffusion:slab", {"time_constant_s": 1e-3}),
    "v_two_dof": ("mechanical_resonance:two_dof", TWO_DOF),
}


def variant_parameters(cause, values) -> dict:
    """FMU start values selecting a variant (the String parameters)."""
    return {"model_variant": cause, "variant_parameters": json.dumps(values)}


_NAN, _INF = float("nan"), float("inf")
#: Bad parameter values: case -> (start values, the parameter the error message must name).
#: tests/test_fmu_hosts.py adds every Real parameter set to NaN (read from the FMU).
BAD_PARAMETERS = {
    "frequency_zero": ({"frequency": 0.0}, "frequency"),
    "frequency_negative": ({"frequency": -50.0}, "frequency"),
    "frequency_nan": ({"frequency": _NAN}, "frequency"),
    "current_amplitude_zero": ({"current_amplitude": 0.0}, "current_amplitude"),
    "current_amplitude_negative": ({"current_amplitude": -1.0}, "current_amplitude"),
    "rod_length_negative": ({"rod_length": -0.08}, "rod_length"),
    "steinmetz_exponent_out_of_range": ({"steinmetz_exponent": 5.0}, "steinmetz_exponent"),
    "leakage_coefficient_below_one": ({"leakage_coefficient": 0.5}, "leakage_coefficient"),
    "mass_inf": ({"mass": _INF}, "mass"),
    "flux_density_amplitude_too_large": ({"flux_density_amplitude": 3.0},
                                         "flux_density_amplitude"),
    "current_limit_zero": ({"current_limit": 0.0, "compensated": True}, "current_limit"),
    "magnetics_unknown": ({"magnetics": "spice"}, "magnetics"),
    "inverse_model_unknown": ({"inverse_model": "jiles", "compensated": True}, "inverse_model"),
    "time_domain_with_a_variant": ({"magnetics": "time_domain",
                                    "model_variant": "transport_delay",
                                    "variant_parameters": '{"delay_s": 0.0005}'},
                                   "model_variant"),
    "reversible_permeability_below_one": ({"magnetics": "time_domain",
                                           "reversible_permeability": 0.5},
                                          "reversible_permeability"),
    "branch_rule_unknown": ({"branch_rule": "sideways"}, "branch_rule"),
    "model_variant_unknown": ({"model_variant": "maxwell"}, "model_variant"),
    "variant_parameters_not_json": ({"model_variant": "transport_delay",
                                     "variant_parameters": "{delay_s: 1}"},
                                    "variant_parameters"),
    "variant_parameters_out_of_range": ({"model_variant": "transport_delay",
                                         "variant_parameters": '{"delay_s": -0.001}'},
                                        "delay_s"),
    "variant_parameters_missing": ({"model_variant": "rate_independent_hysteresis",
                                    "variant_parameters": "{}"}, "thresholds_A_per_m"),
    "variant_parameters_for_paper": ({"variant_parameters": '{"delay_s": 0.001}'},
                                     "variant_parameters"),
    "model_variant_unknown_form": ({"model_variant": "eddy_current_diffusion:sphere",
                                    "variant_parameters": '{"time_constant_s": 1e-3}'},
                                   "model_variant"),
    "variant_parameters_derived_disagree": (
        {"model_variant": "mechanical_resonance:two_dof",
         "variant_parameters": json.dumps(dict(TWO_DOF, joint_frequency_Hz=2 * _FJ))},
        "joint_frequency_Hz"),
}


# -- test cases (identical in every process: seeded) ----------------------------------
def make_case(name: str):
    """(parameters, steps h_k, inputs u_k, forces F_k) of a named case.

    u_k and F_k are the inputs at t_k = sum(h_0..h_{k-1}), held over [t_k, t_k + h_k).
    """
    import numpy as np

    if name == "fixed50":  # paper's uncompensated drive, i = cos(2 pi 50 t) A
        params, n, f, a, off = {}, 4000, 50.0, 1.0, 0.0
        h = np.full(n, 1e-5)
        force = np.zeros(n)
    elif name == "random100":  # 100 Hz with Table 1's B_m, heavier rod, random steps
        params = {"frequency": 100.0, "flux_density_amplitude": 0.0531, "mass": 0.03}
        n, f, a, off = 1500, 100.0, 1.0, 0.0
        rng = np.random.default_rng(3)
        h = rng.uniform(2e-6, 4e-5, n)
        force = rng.uniform(-50.0, 50.0, n)
    elif name == "comp_control":  # compensated, Figure 9's rule, u = 2.2 + 2.2 cos(100 pi t)
        params = {"compensated": True}
        n, f, a, off = 4000, 50.0, 2.2, 2.2
        h = np.full(n, 1e-5)
        force = np.zeros(n)
    elif name == "comp_demand":  # compensated, demand rule, 70 Hz, current limit, random
        params = {"compensated": True, "branch_rule": "demand", "frequency": 70.0,
                  "current_limit": 0.9, "damping": 3000.0, "amplifier_gain": 1.5}
        n, f, a, off = 1500, 70.0, 1.9, 1.9
        rng = np.random.default_rng(7)
        h = rng.uniform(2e-6, 4e-5, n)
        force = rng.uniform(-20.0, 20.0, n)
    elif name in VARIANTS:  # a model variant: 100 Hz, variable steps, random forces
        params = variant_parameters(*VARIANTS[name])
        n, f, a, off = 1200, 100.0, 1.0, 0.0
        rng = np.random.default_rng(sorted(VARIANTS).index(name) + 11)
        # steps drawn from a few values: each new step costs a ZOH discretisation
        h = rng.choice([3e-6, 1e-5, 2.2e-5, 3.9e-5], n)
        force = rng.uniform(-20.0, 20.0, n)
        if name == "v_saturation":  # through the compensator, fixed step
            params["compensated"] = True
            n, f, a, off = 1500, 50.0, 2.2, 2.2
            h = np.full(n, 1e-5)
            force = np.zeros(n)
    elif name == "td_square":  # time-domain magnetics, 100 Hz square, random steps/forces
        params = {"magnetics": "time_domain", "frequency": 100.0}
        n, f, a, off = 1500, 100.0, 1.0, 0.0
        rng = np.random.default_rng(5)
        h = rng.uniform(2e-6, 4e-5, n)
        force = rng.uniform(-20.0, 20.0, n)
    elif name == "td_step":  # time-domain magnetics: 0 A, then a step to 1 A held (DC)
        params = {"magnetics": "time_domain"}
        n, f, a, off = 1500, 0.0, 0.0, 0.0
        h = np.full(n, 2e-5)
        force = np.zeros(n)
    elif name == "td_comp":  # time-domain model and inverse, u = 1.5 + 1.5 cos(200 pi t)
        params = {"magnetics": "time_domain", "compensated": True, "frequency": 100.0}
        n, f, a, off = 1500, 100.0, 1.5, 1.5
        h = np.full(n, 1e-5)
        force = np.zeros(n)
    else:
        raise KeyError(name)
    t = np.concatenate(([0.0], np.cumsum(h)[:-1]))
    u = off + a * np.cos(2 * math.pi * f * t)
    if name == "td_square":
        u = np.where(np.sin(2 * math.pi * f * t) >= 0.0, 1.0, -1.0)
    elif name == "td_step":
        u = np.where(t < 0.01, 0.0, 1.0)
    return params, h.tolist(), u.tolist(), force.tolist()


CASES = ("fixed50", "random100", "comp_control", "comp_demand") + tuple(VARIANTS)
#: Cases with the time-domain magnetics (magnetics = "time_domain"): every drive inside.
TIME_DOMAIN_CASES = ("td_square", "td_step", "td_comp")
CASES = CASES + TIME_DOMAIN_CASES
#: Variant cases whose FMU state is saved, replayed and moved (behaviour's vstate_<case>).
STATEFUL_VARIANTS = ("v_delay", "v_hysteresis", "v_eddy", "v_slab", "v_two_dof")


# -- reference: the repository's gmt ------------------------------------------------------
def reference(out_path):
    import dataclasses

    import gmt

    results = {"gmt_file": gmt.__file__}
    for name in CASES + tuple(f"paper:{v}" for v in VARIANTS):
        params, h, u, force = make_case(name.removeprefix("paper:"))
        if name.startswith("paper:"):  # the same inputs through the paper's model
            params = {k: v for k, v in params.items()
                      if k not in ("model_variant", "variant_parameters")}

        def pick(cls):
            return {f.name: params[f.name] for f in dataclasses.fields(cls) if f.name in params}

        variant = gmt.ModelVariant.from_name(params.get("model_variant", "paper"),
                                             json.loads(params.get("variant_parameters", "{}")))
        tr = gmt.Transducer(gmt.TransducerParameters(**pick(gmt.TransducerParameters)),
                            gmt.Excitation(**pick(gmt.Excitation)),
                            gmt.DriveParameters(**pick(gmt.DriveParameters)),
                            variant=variant, magnetics=params.get("magnetics", "paper"),
                            time_domain=gmt.TimeDomainParameters(
                                **pick(gmt.TimeDomainParameters)))
        rows = []
        for hk, uk, fk in zip(h, u, force):
            o = tr.step(uk, hk, fk)
            m = o.magnetics
            rows.append([o.current, o.displacement, o.velocity, m.field, m.flux_density,
                         m.magnetization, m.strain, m.force, float(o.saturated),
                         float(o.saturation_count), o.sensed_displacement])
        results[name] = rows
    _write(out_path, results)


def bundled_module(name):
    """The loaded module an FMU bundles as ``name`` (under ``<name>_<build id>``)."""
    return next(module for key, module in sys.modules.items()
                if key.startswith(f"{name}_") and "." not in key
                and len(key) == len(name) + 13)


# -- fmpy wrapper for FMI 2.0 and 3.0 -------------------------------------------------------
_CALLBACKS = []  # keep ctypes callbacks alive


def fmi2_callbacks(logs):
    """fmpy's FMI 2.0 callbacks with a logger that appends (status, category, message) to
    ``logs``, kept alive in :data:`_CALLBACKS`."""
    from ctypes import byref

    from fmpy.fmi2 import (calloc, fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                           fmi2CallbackFunctions, fmi2CallbackLoggerTYPE, free)
    from fmpy.logging import addLoggerProxy

    def logger(env, inst, status, category, message):
        logs.append((int(status), (category or b"").decode(), message.decode()))

    cb = fmi2CallbackFunctions()
    cb.logger = fmi2CallbackLoggerTYPE(logger)
    cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
    cb.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
    addLoggerProxy(byref(cb))
    _CALLBACKS.append(cb)
    return cb


class Fmu:
    """One FMU instance through fmpy, FMI 2.0 or 3.0, with its log captured."""

    def __init__(self, path, name="i1", unzipdir=None):
        from fmpy import extract, read_model_description

        self.md = md = read_model_description(path)
        self.fmi = md.fmiVersion[0]
        self.dir = unzipdir or extract(path)
        self.vars = {v.name: v for v in md.modelVariables}
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        self.logs = []
        self._out_vr = [self.vr[n] for n in REALS + ("sensed_displacement",)]
        if self.fmi == "2":
            from fmpy.fmi2 import FMU2Slave

            cb = fmi2_callbacks(self.logs)
            self.s = FMU2Slave(guid=md.guid, unzipDirectory=self.dir,
                               modelIdentifier=md.coSimulation.modelIdentifier,
                               instanceName=name)
            self.s.instantiate(callbacks=cb, loggingOn=True)
        else:
            from fmpy.fmi3 import FMU3Slave

            def logger(env, status, category, message):
                self.logs.append((int(status), (category or b"").decode(), message.decode()))

            self.s = FMU3Slave(guid=md.guid, unzipDirectory=self.dir,
                               modelIdentifier=md.coSimulation.modelIdentifier,
                               instanceName=name)
            self.s.instantiate(loggingOn=True, logMessage=logger)

    # every call returns the FMI status (0 ok, 1 warning, 2 discard, 3 error, 4 fatal)
    def call(self, function, *args):
        from fmpy.fmi1 import FMICallException

        try:
            function(*args)
            return 0
        except FMICallException as exc:
            return exc.status

    def set(self, name, value):
        kind = self.vars[name].type
        vr = [self.vr[name]]
        setter = {"Real": "setReal", "Float64": "setFloat64", "Boolean": "setBoolean",
                  "String": "setString", "Integer": "setInteger", "Int32": "setInt32"}[kind]
        return self.call(getattr(self.s, setter), vr, [value])

    def init(self, params=None):
        statuses = [self.set(k, v) for k, v in (params or {}).items()]
        if self.fmi == "2":
            statuses.append(self.call(self.s.setupExperiment, None, 0.0))
            statuses.append(self.call(self.s.enterInitializationMode))
        else:
            statuses.append(self.call(self.s.enterInitializationMode, None, 0.0))
        statuses.append(self.call(self.s.exitInitializationMode))
        return statuses

    def inputs(self, u, force):
        if self.fmi == "2":
            self.s.setReal([self.vr["u"], self.vr["external_force"]], [u, force])
        else:
            self.s.setFloat64([self.vr["u"], self.vr["external_force"]], [u, force])

    def step(self, t, h):
        return self.call(self.s.doStep, t, h)

    def outputs(self):
        s = self.s
        if self.fmi == "2":
            reals = s.getReal(self._out_vr)
            sat = s.getBoolean([self.vr["saturated"]])[0]
            count = s.getInteger([self.vr["saturation_count"]])[0]
        else:
            reals = s.getFloat64(self._out_vr)
            sat = s.getBoolean([self.vr["saturated"]])[0]
            count = s.getInt32([self.vr["saturation_count"]])[0]
        return list(reals[:-1]) + [float(bool(sat)), float(count), reals[-1]]

    def get_state(self):
        return self.s.getFMUstate() if self.fmi == "2" else self.s.getFMUState()

    def set_state(self, state):
        f = self.s.setFMUstate if self.fmi == "2" else self.s.setFMUState
        return self.call(f, state)

    def serialize(self, state):
        f = self.s.serializeFMUstate if self.fmi == "2" else self.s.serializeFMUState
        return bytes(f(state))

    def deserialize(self, data):
        f = self.s.deSerializeFMUstate if self.fmi == "2" else self.s.deserializeFMUState
        return f(data)

    def reset(self):
        return self.call(self.s.reset)


def run_case(fmu, name, start=0, stop=None, t0=0.0):
    """Step ``fmu`` through steps [start, stop) of a case; return (rows, statuses, t)."""
    _, h, u, force = make_case(name)
    stop = len(h) if stop is None else stop
    rows, statuses, t = [], [], t0
    for k in range(start, stop):
        fmu.inputs(u[k], force[k])
        statuses.append(fmu.step(t, h[k]))
        t += h[k]
        rows.append(fmu.outputs())
    return rows, statuses, t


def _case_time(name, k):
    _, h, _, _ = make_case(name)
    return math.fsum(h[:k])


# -- behaviour: trajectories, instances, reset, state ---------------------------------------
def behaviour(out_path, fmu_path):
    res = {"gmt_imported_before_fmu": "gmt" in sys.modules}
    fmus = _behaviour_cases(fmu_path, res)
    unzip = fmus["fixed50"].dir
    a, b = _behaviour_pair(fmu_path, unzip, res)
    r = _behaviour_reset(fmu_path, unzip, res)
    s, other = _behaviour_state(fmu_path, unzip, res)
    _behaviour_variant_states(fmu_path, unzip, res)
    res["logs"] = {n: f.logs for n, f in {**fmus, "a": a, "b": b, "reset": r, "state": s,
                                            "other": other}.items()}
    _write(out_path, res)


def _behaviour_cases(fmu_path, res) -> dict:
    """Every case in an instance of its own (one extraction); their rows into ``res``."""
    fmus = {}
    for name in CASES:
        fmu = Fmu(fmu_path, name=name, unzipdir=fmus["fixed50"].dir if fmus else None)
        if not fmus:
            res["gmt_file"] = bundled_module("smeha_fmu_gmt").__file__
            res["unzipdir"] = fmu.dir
        params = make_case(name)[0]
        res[f"init_{name}"] = fmu.init(params)
        rows, statuses, _ = run_case(fmu, name)
        res[f"solo_{name}"] = rows
        res[f"outside_{name}"] = bool(fmu.s.getBoolean([fmu.vr["outside_design_point"]])[0])
        res[f"status_{name}"] = sorted(set(statuses))
        fmus[name] = fmu
    return fmus


def _behaviour_pair(fmu_path, unzip, res):
    """Two instances in one process, stepped alternately."""
    a = Fmu(fmu_path, "pair_a", unzip)
    b = Fmu(fmu_path, "pair_b", unzip)
    a.init(make_case("fixed50")[0])
    b.init(make_case("comp_demand")[0])
    _, ha, ua, fa = make_case("fixed50")
    _, hb, ub, fb = make_case("comp_demand")
    ta = tb = 0.0
    rows_a, rows_b = [], []
    for k in range(max(len(ha), len(hb))):
        if k < len(ha):
            a.inputs(ua[k], fa[k])
            a.step(ta, ha[k])
            ta += ha[k]
            rows_a.append(a.outputs())
        if k < len(hb):
            b.inputs(ub[k], fb[k])
            b.step(tb, hb[k])
            tb += hb[k]
            rows_b.append(b.outputs())
    res["pair_fixed50"], res["pair_comp_demand"] = rows_a, rows_b
    return a, b


def _behaviour_reset(fmu_path, unzip, res):
    """Reset: the same parameters again, and back to the start values."""
    r = Fmu(fmu_path, "reset", unzip)
    r.init(make_case("comp_demand")[0])
    run_case(r, "comp_demand", 0, 600)
    res["reset_status"] = r.reset()
    r.init(make_case("comp_demand")[0])
    res["reset_same"] = run_case(r, "comp_demand")[0]
    run_case(r, "comp_demand", 0, 300)
    r.reset()
    r.init()  # no parameters set: the start values apply again
    res["reset_defaults"] = run_case(r, "fixed50")[0]
    return r


def _behaviour_state(fmu_path, unzip, res):
    """FMU state: save at k1, run to k2, restore, replay (and into another instance)."""
    k1, k2 = 700, 1400
    s = Fmu(fmu_path, "state", unzip)
    s.init(make_case("comp_demand")[0])
    run_case(s, "comp_demand", 0, k1)
    t1 = _case_time("comp_demand", k1)
    st = s.get_state()
    blob = s.serialize(st)
    res["state_bytes"] = len(blob)
    res["state_json_keys"] = sorted(json.loads(blob.decode()))
    first = run_case(s, "comp_demand", k1, k2, t1)[0]
    res["state_set_status"] = s.set_state(st)
    again = run_case(s, "comp_demand", k1, k2, t1)[0]
    st2 = s.deserialize(blob)
    res["state_reserialized_equal"] = s.serialize(st2) == blob
    s.set_state(st2)
    from_bytes = run_case(s, "comp_demand", k1, k2, t1)[0]
    s.set_state(st)  # a state can be restored more than once
    twice = run_case(s, "comp_demand", k1, k2, t1)[0]
    # into another instance initialised with different (default) parameters
    other = Fmu(fmu_path, "state_other", unzip)
    other.init()
    run_case(other, "fixed50", 0, 50)
    other.set_state(other.deserialize(blob))
    moved = run_case(other, "comp_demand", k1, k2, t1)[0]
    res.update(state_first=first, state_again=again, state_from_bytes=from_bytes,
               state_twice=twice, state_moved=moved, state_k1=k1, state_k2=k2)
    return s, other


def _behaviour_variant_states(fmu_path, unzip, res):
    """The same with stateful variants: the delay line (its length varies), the plays, the
    lag's sections, the diffusion's modes and the rod mass of the two masses."""
    for case in STATEFUL_VARIANTS:
        k1, k2 = 500, 1000
        v = Fmu(fmu_path, f"state_{case}", unzip)
        v.init(make_case(case)[0])
        run_case(v, case, 0, k1)
        t1 = _case_time(case, k1)
        st = v.get_state()
        blob = v.serialize(st)
        first = run_case(v, case, k1, k2, t1)[0]
        v.set_state(st)
        again = run_case(v, case, k1, k2, t1)[0]
        v.set_state(v.deserialize(blob))
        from_bytes = run_case(v, case, k1, k2, t1)[0]
        moved_to = Fmu(fmu_path, f"state_{case}_other", unzip)
        moved_to.init()
        run_case(moved_to, "fixed50", 0, 50)
        moved_to.set_state(moved_to.deserialize(blob))
        moved = run_case(moved_to, case, k1, k2, t1)[0]
        res[f"vstate_{case}"] = {"first": first, "again": again, "from_bytes": from_bytes,
                                 "moved": moved, "k1": k1, "k2": k2, "bytes": len(blob),
                                 "transducer_state": len(json.loads(blob)["transducer"])}


# -- bad input --------------------------------------------------------------------------------
def bad_input(out_path, fmu_path):
    import io

    results = {"gmt_imported_before_fmu": "gmt" in sys.modules}
    # what the FMU writes to the process's stderr (an unusable instance's reason)
    stderr, sys.stderr = sys.stderr, io.StringIO()
    try:
        _bad_input(results, fmu_path)
    finally:
        results["stderr"], sys.stderr = sys.stderr.getvalue(), stderr
    _write(out_path, results)


class _Instances:
    """Fresh instances of one FMU (one extraction), and the outputs of clean runs."""

    def __init__(self, fmu_path):
        self.fmu_path, self.unzip, self.clean_cache = fmu_path, None, {}

    def fresh(self, name, params=None):
        fmu = Fmu(self.fmu_path, name, self.unzip)
        self.unzip = fmu.dir
        return fmu, fmu.init(params)

    def clean(self, params, inputs):
        """Outputs after stepping a fresh instance through ``inputs`` [(u, F, h)]."""
        key = json.dumps([params, inputs])
        if key not in self.clean_cache:
            fmu, _ = self.fresh(f"clean{len(self.clean_cache)}", params)
            t = 0.0
            for u, f, h in inputs:
                fmu.inputs(u, f)
                fmu.step(t, h)
                t += h
            self.clean_cache[key] = fmu.outputs()
        return self.clean_cache[key]


def _bad_input(results, fmu_path):
    instances = _Instances(fmu_path)
    _bad_inputs(instances, results)
    for name, (params, _) in BAD_PARAMETERS.items():
        fmu, init = instances.fresh(name, params)
        fmu.inputs(1.0, 0.0)
        steps = [fmu.step(0.0, 1e-5), fmu.step(1e-5, 1e-5)]
        results[name] = {"init": init, "bad_step": steps[0], "statuses": steps,
                         "logs": fmu.logs}
    _bad_sequences(instances, results)
    results["process_survived"] = True


def _bad_inputs(instances, results):
    """10 good steps, one bad (u, F, h), 10 good, per case: the bad step must change nothing."""
    def input_case(name, params, bad):
        fmu, init = instances.fresh(name, params)
        good = [(1.0 + 0.1 * k, 5.0, 1e-5) for k in range(20)]
        statuses, t = [], 0.0
        for k, (u, f, h) in enumerate(good):
            if k == 10:
                fmu.inputs(bad[0], bad[1])
                statuses.append(fmu.step(t, bad[2]))
            fmu.inputs(u, f)
            statuses.append(fmu.step(t, h))
            t += h
        results[name] = {"init": init, "bad_step": statuses[10], "statuses": statuses,
                         "recovered_exactly": fmu.outputs() == instances.clean(params, good),
                         "logs": fmu.logs}

    nan, inf = float("nan"), float("inf")
    input_case("u_nan", {}, (nan, 0.0, 1e-5))
    input_case("u_inf", {}, (inf, 0.0, 1e-5))
    input_case("u_nan_compensated", {"compensated": True}, (nan, 0.0, 1e-5))
    input_case("force_nan_compensated", {"compensated": True}, (1.0, nan, 1e-5))
    input_case("force_minus_inf", {}, (1.0, -inf, 1e-5))
    input_case("step_zero", {}, (1.0, 0.0, 0.0))
    input_case("step_negative", {}, (1.0, 0.0, -1e-5))
    input_case("step_nan", {"compensated": True}, (1.0, 0.0, nan))
    input_case("step_inf", {}, (1.0, 0.0, inf))
    # a discarded step must roll a stateful variant back too
    input_case("u_nan_variant_delay", variant_parameters(*VARIANTS["v_delay"]),
               (nan, 0.0, 1e-5))
    input_case("step_zero_variant_hysteresis", variant_parameters(*VARIANTS["v_hysteresis"]),
               (1.0, 0.0, 0.0))


def _bad_sequences(instances, results):
    """A parameter set after initialisation, failures in a row, a corrupt serialised state."""
    nan = float("nan")
    # a fixed parameter set after initialisation is refused and changes nothing
    fmu, init = instances.fresh("parameter_after_init")
    set_status = fmu.set("mass", 1.0)
    fmu.inputs(1.0, 0.0)
    step = fmu.step(0.0, 1e-5)
    results["parameter_after_init"] = {
        "init": init, "set": set_status, "bad_step": step,
        "recovered_exactly": fmu.outputs() == instances.clean({}, [(1.0, 0.0, 1e-5)]),
        "logs": fmu.logs}

    # many failures in a row in one instance (two exceptions reaching pythonfmu crash it)
    fmu, init = instances.fresh("repeated_failures", {"frequency": -1.0})
    statuses = [fmu.step(0.0, 1e-5) for _ in range(3)]
    fmu.reset()
    statuses += fmu.init()
    fmu.inputs(nan, 0.0)
    statuses += [fmu.step(0.0, 1e-5) for _ in range(3)]
    fmu.inputs(1.0, 0.0)
    statuses += [fmu.step(0.0, 0.0), fmu.step(0.0, 1e-5)]
    results["repeated_failures"] = {"init": init, "statuses": statuses, "logs": fmu.logs}

    # a corrupt serialised state
    fmu, init = instances.fresh("corrupt_state")
    fmu.inputs(1.0, 0.0)
    fmu.step(0.0, 1e-5)
    try:
        st = fmu.deserialize(b"{not json")
        set_status = fmu.set_state(st)
    except Exception as exc:  # fmpy raises on a failed call
        set_status = getattr(exc, "status", repr(exc))
    step = fmu.step(1e-5, 1e-5)
    results["corrupt_state"] = {"init": init, "set": set_status, "bad_step": step,
                                "recovered_exactly": fmu.outputs()
                                == instances.clean({}, [(1.0, 0.0, 1e-5)] * 2),
                                "logs": fmu.logs}


# -- the same drive as tests/fmu_c_host.c, and every bad parameter through simulate_fmu ---------
#: Outputs the drive command records (and the C host prints), in this order.
DRIVE_OUTPUTS = ("current", "displacement", "velocity", "flux_density", "force")


def drive(out_path, fmu_path, steps, h, frequency, amplitude, offset, *settings):
    """u = offset + amplitude cos(2 pi f t) at t = k h, as the C host drives it; rows
    [t, outputs]."""
    steps, h, frequency, amplitude, offset = (int(steps), float(h), float(frequency),
                                              float(amplitude), float(offset))
    fmu = Fmu(fmu_path, "drive")
    params = {}
    for item in settings:
        name, value = item.split("=", 1)
        kind = fmu.vars[name].type
        params[name] = (value if kind == "String" else value in ("1", "true")
                        if kind == "Boolean" else float(value))
    init = fmu.init(params)
    vrs = [fmu.vr[n] for n in DRIVE_OUTPUTS]
    point = [fmu.vr["operating_frequency"], fmu.vr["operating_current_amplitude"]]
    get = fmu.s.getReal if fmu.fmi == "2" else fmu.s.getFloat64
    rows, statuses, flags, points = [], [], [], []
    for k in range(steps):
        t = k * h
        fmu.inputs(offset + amplitude * math.cos(2.0 * math.pi * frequency * t), 0.0)
        statuses.append(fmu.step(t, h))
        if statuses[-1] != 0:
            break
        rows.append([(k + 1) * h] + list(get(vrs)))
        flags.append(bool(fmu.s.getBoolean([fmu.vr["outside_design_point"]])[0]))
        points.append(list(get(point)))
    _write(out_path, {"init": init, "statuses": sorted(set(statuses)), "rows": rows,
                      "outside_design_point": flags, "operating_point": points,
                      "logs": fmu.logs, "python": sys.version, "executable": sys.executable})


def simulate_bad(out_path, fmu_path):
    """fmpy.simulate_fmu with each bad parameter (BAD_PARAMETERS, and every Real one NaN).

    Records, per case, the exception simulate_fmu raised (or None) and what the FMU wrote
    to stderr; the FMU is simulated with fmpy's defaults (no logging), as a user would.
    """
    import io

    from fmpy import read_model_description, simulate_fmu

    md = read_model_description(fmu_path)
    cases = {name: params for name, (params, _) in BAD_PARAMETERS.items()}
    for v in md.modelVariables:
        if v.causality == "parameter" and v.type in ("Real", "Float64"):
            cases[f"{v.name}_nan"] = {v.name: _NAN}
    results = {}
    for name, params in cases.items():
        stderr, sys.stderr = sys.stderr, io.StringIO()
        try:
            simulate_fmu(fmu_path, start_values=params, stop_time=1e-3, output_interval=1e-4)
            raised = None
        except Exception as exc:  # the point: what simulate_fmu raises
            raised = f"{type(exc).__name__}: {exc}"
        finally:
            told, sys.stderr = sys.stderr.getvalue(), stderr
        results[name] = {"raised": raised, "stderr": told, "params": list(params)}
    _write(out_path, results)


# -- memory -------------------------------------------------------------------------------------
def rss_mb() -> float:
    """Resident set size of this process, [MB] (Linux /proc)."""
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    return math.nan


def memory(out_path, fmu_path, n):
    n = int(float(n))
    fmu = Fmu(fmu_path, "memory")
    fmu.init()
    h, w = 1e-5, 2 * math.pi * 50.0
    samples = []
    t = 0.0
    warmup = min(10000, n // 10)
    for k in range(n):
        fmu.inputs(math.cos(w * t), 0.0)
        fmu.step(t, h)
        fmu.outputs()
        t += h
        if k + 1 == warmup or (k + 1) % max(1, n // 10) == 0:
            samples.append((k + 1, rss_mb()))
    _write(out_path, {"steps": n, "samples": samples})


# -- libcosimpy ------------------------------------------------------------------------------------
def cosim(out_path, fmu_path, n="2000"):
    """fixed50 (first n steps) in libcosimpy and in fmpy; fixed step 10 us."""
    n = int(n)
    from libcosimpy.CosimEnums import CosimVariableType  # noqa: F401
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimManipulator import CosimManipulator
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave

    log_output_level(CosimLogLevel.WARNING)
    before = "gmt" in sys.modules
    _, h, u, force = make_case("fixed50")
    h = h[:n]
    step_ns = round(h[0] * 1e9)
    ex = CosimExecution.from_step_size(step_size=step_ns)
    slave = CosimLocalSlave(fmu_path=os.path.abspath(fmu_path), instance_name="gmt")
    if not slave.ptr():
        raise RuntimeError("libcosim could not load the FMU")
    idx = ex.add_local_slave(slave)
    vr = {v.name.decode(): v.reference for v in ex.slave_variables(idx)}
    obs = CosimObserver.create_last_value()
    ex.add_observer(obs)
    man = CosimManipulator.create_override()
    ex.add_manipulator(man)
    ex.real_initial_value(idx, vr["u"], u[0])
    ex.real_initial_value(idx, vr["external_force"], force[0])
    ex.real_initial_value(idx, vr["frequency"], 50.0)
    rows = []
    for k in range(n):
        man.slave_real_values(idx, [vr["u"], vr["external_force"]], [u[k], force[k]])
        if not ex.step(1):
            raise RuntimeError(f"libcosim step {k} failed: {ex.status()}")
        reals = obs.last_real_values(idx, [vr[c] for c in REALS + ("sensed_displacement",)])
        sat = obs.last_boolean_values(idx, [vr["saturated"]])
        count = obs.last_integer_values(idx, [vr["saturation_count"]])
        rows.append(list(reals[:-1]) + [float(bool(sat[0])), float(count[0]), reals[-1]])
    status = ex.status()
    # libcosim keeps time in integer nanoseconds and hands the FMU
    # h_k = t_{k+1}/1e9 - t_k/1e9 (not always 1e-5 exactly): give fmpy the same steps
    fm = Fmu(fmu_path, "fmpy")
    fm.init()
    fmpy_rows = []
    for k in range(n):
        t, t_next = k * step_ns / 1e9, (k + 1) * step_ns / 1e9
        fm.inputs(u[k], force[k])
        fm.step(t, t_next - t)
        fmpy_rows.append(fm.outputs())
    _write(out_path, {"gmt_imported_before_fmu": before, "libcosim": rows, "fmpy": fmpy_rows,
                      "final_time_ns": status.current_time, "error_code": status.error_code})
    # Teardown of libcosim's execution with a pythonfmu slave inside this same interpreter
    # aborts now and then ("corrupted double-linked list", SIGABRT) once the results are
    # written: seen in 1 of ~10 runs on a loaded machine, never before the JSON. Keep the
    # objects alive and leave without finalisation (see __main__); docs/FMU.md notes it.
    _KEEP.extend((ex, slave, obs, man, fm))


#: Objects whose destructors must not run before the process ends (libcosim teardown).
_KEEP: list = []


# -- calculated parameters in Initialization Mode ------------------------------------------
#: The calculated parameters (fmu_src/smeha_fmu_interface.py MECHANICS, gmt.RodMechanics order).
MECHANICS = ("equivalent_mass", "equivalent_damping", "equivalent_stiffness", "output_mass",
             "joint_stiffness", "joint_damping")


def init_mode(out_path, fmu_path):
    """The calculated parameters read between entering and exiting Initialization Mode.

    ``paper``: mass, damping and stiffness set before entering, stiffness set again inside;
    ``two_dof``: the two-mass variant selected before entering. Each records the values
    read in Initialization Mode (before and after a parameter set there) and after it.
    """
    res = {"gmt_imported_before_fmu": "gmt" in sys.modules}
    for case, before, inside in (
            ("paper", {"mass": 0.05, "damping": 1000.0, "stiffness": 2e7}, {"stiffness": 3e7}),
            ("two_dof", variant_parameters("mechanical_resonance:two_dof", TWO_DOF), {})):
        fmu = Fmu(fmu_path, name=case)
        get = fmu.s.getReal if fmu.fmi == "2" else fmu.s.getFloat64
        vrs = [fmu.vr[n] for n in MECHANICS]
        statuses = [fmu.set(k, v) for k, v in before.items()]
        if fmu.fmi == "2":
            statuses.append(fmu.call(fmu.s.setupExperiment, None, 0.0))
            statuses.append(fmu.call(fmu.s.enterInitializationMode))
        else:
            statuses.append(fmu.call(fmu.s.enterInitializationMode, None, 0.0))
        entered = list(get(vrs))
        statuses += [fmu.set(k, v) for k, v in inside.items()]
        inside_values = list(get(vrs))
        statuses.append(fmu.call(fmu.s.exitInitializationMode))
        res[case] = {"entered": entered, "inside": inside_values, "exited": list(get(vrs)),
                     "statuses": statuses, "logs": fmu.logs}
    _write(out_path, res)


# -- the EHA system's .ssp in fmpy ----------------------------------------------------------
def ssp_fmpy(out_path, ssp_path, frequency):
    """The .ssp in fmpy's SSP master (smeha.fmu.systemrun.run_fmpy): the plant's piston
    position at the end of each step, and the cylinder flow of the flow check."""
    from smeha.fmu import systemrun

    run = systemrun.run_fmpy(ssp_path)
    flow = systemrun.flow(run.record, float(frequency), 1256e-6).flow_sim
    _write(out_path, {"time": run.record["time"].tolist(),
                      "piston_position": run.record["piston_position"].tolist(),
                      "flow": flow, "wall": run.wall})


def builds(out_path, *fmu_paths):
    """One process, FMUs instantiated in turn: whether each instantiated, its log, and the
    output it reads (``displacement``, or the drive's ``u``) over 10 steps of 10 us (the
    transducer's u = cos(2 pi 50 t)); then the first FMU steps 10 more."""
    results, live = [], []
    for k, path in enumerate(fmu_paths):
        unit = _Unit(path, f"i{k}")
        entry = {"path": path, "instantiated": unit.instantiate(), "logs": unit.logs}
        if entry["instantiated"]:
            entry["rows"] = unit.run(0)
            live.append(unit)
        results.append(entry)
    _write(out_path, {"runs": results, "first_again": live[0].run(10) if live else []})


class _Unit:
    """Any FMU of the project through fmpy (FMI 2.0 or 3.0), its log captured."""

    def __init__(self, path, name):
        from fmpy import extract, read_model_description

        self.md = read_model_description(path)
        self.fmi, self.name, self.logs = self.md.fmiVersion[0], name, []
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.dir = extract(path)

    def instantiate(self) -> bool:
        from fmpy.fmi3 import FMU3Slave

        cs = self.md.coSimulation
        try:
            if self.fmi == "2":
                from fmpy.fmi2 import FMU2Slave

                cb = fmi2_callbacks(self.logs)
                self.s = FMU2Slave(guid=self.md.guid, unzipDirectory=self.dir,
                                   modelIdentifier=cs.modelIdentifier, instanceName=self.name)
                self.s.instantiate(callbacks=cb, loggingOn=True)
            else:
                def logger(env, status, category, message):
                    self.logs.append((int(status), (category or b"").decode(),
                                      message.decode()))

                self.s = FMU3Slave(guid=self.md.guid, unzipDirectory=self.dir,
                                   modelIdentifier=cs.modelIdentifier, instanceName=self.name)
                self.s.instantiate(loggingOn=True, logMessage=logger)
        except Exception:  # fmpy: "Failed to instantiate ..."
            return False
        if self.fmi == "2":
            self.s.setupExperiment(startTime=0.0)
            self.s.enterInitializationMode()
        else:
            self.s.enterInitializationMode(startTime=0.0)
        self.s.exitInitializationMode()
        return True

    def run(self, start, n=10, h=1e-5):
        get = self.s.getReal if self.fmi == "2" else self.s.getFloat64
        put = self.s.setReal if self.fmi == "2" else self.s.setFloat64
        out = self.vr.get("displacement", self.vr.get("u"))
        rows = []
        for k in range(start, start + n):
            if "external_force" in self.vr:
                put([self.vr["u"]], [math.cos(2 * math.pi * 50.0 * k * h)])
            self.s.doStep(k * h, h)
            rows.append(get([out])[0])
        return rows


def _write(path, obj):
    with open(path, "w") as fh:
        json.dump(obj, fh, default=str)


COMMANDS = {"reference": reference, "behaviour": behaviour, "bad_input": bad_input,
            "memory": memory, "cosim": cosim, "drive": drive, "simulate_bad": simulate_bad,
            "init_mode": init_mode, "ssp_fmpy": ssp_fmpy, "builds": builds}

if __name__ == "__main__":
    COMMANDS[sys.argv[1]](*sys.argv[2:])
    if _KEEP:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(0)
