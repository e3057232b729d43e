"""The hydraulic plant of the electrohydrostatic actuator.

One component a module, SI units, parameters in validated frozen dataclasses:
``fluid``, ``chamber`` (pump chamber), ``valves`` (V1-V4), ``controller``
(the four stages of Figure 2), ``cylinder``, ``accumulator``, and ``circuit``
(the assembled ``rhs(t, x, inputs, params)``). The fmpy co-simulation harness
that couples it to the transducer FMU is the system issue's next step.
"""
