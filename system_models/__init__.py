"""The hydraulic plant of the electrohydrostatic actuator and the co-simulation master.

One component a module, SI units, parameters in validated frozen dataclasses:
``fluid``, ``chamber`` (pump chamber), ``valves`` (V1-V4), ``controller``
(the four stages of Figure 2, a sampled controller), ``cylinder``,
``accumulator``, ``rod`` (the transducer's mechanics as the plant carries
them), ``circuit`` (the assembled ``rhs(t, x, inputs, params)``) and ``plant``
(the circuit with the rod: what the force port integrates). ``presets`` names
circuits; ``defaults`` holds the co-simulation's default settings;
``implicit`` and ``kernel`` integrate (readable and compiled); ``cosim`` is the
master that couples the transducer FMU (fmpy) or gmt in-process to the plant;
``flowcheck`` checks the flow against eqs 39-41.
"""
