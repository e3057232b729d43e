"""The hydraulic plant of the electrohydrostatic actuator and the co-simulation master.

One component a module, SI units, parameters in validated frozen dataclasses:
``fluid``, ``chamber`` (pump chamber), ``valves`` (V1-V4), ``controller``
(the four stages of Figure 2, a sampled controller), ``cylinder``,
``accumulator``, ``rod`` (the transducer's mechanics as the plant carries
them), ``circuit`` (the assembled ``rhs(t, x, inputs, params)``) and ``plant``
(the circuit with the rod: what the force port integrates). ``presets`` names
circuits; ``defaults`` holds the co-simulation's default settings;
``implicit`` and ``kernel`` integrate (readable and compiled: a package of
the equations, the shared TR-BDF2 substep, the prescribed-rod step and the
plant's run); ``cosim`` is the master that couples the transducer FMU (fmpy)
or gmt in-process (``transducers``) to the plant, through the ``forceport``
or the ``displacementport``, recording at the communication points
(``record``); ``flowcheck`` checks the flow against eqs 39-41.
"""
