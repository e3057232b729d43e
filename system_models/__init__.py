"""The hydraulic plant of the electrohydrostatic actuator and the fmpy co-simulation master.

Empty until the system issue lands: pump chamber, the four active valves of
Figure 2, two-cavity cylinder, accumulator, and the harness that couples them
to the transducer FMU.
"""
