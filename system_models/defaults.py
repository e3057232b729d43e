"""The co-simulation's default settings, each defined once (plain numbers: importing this
costs nothing, so the command line shows them in its help without loading the solver).

Every default of the package (:class:`system_models.cosim.CosimSettings`,
:class:`smeha.studies.flow.Case`, ``smeha simulate/flow/sweep``) reads these.
"""

#: Communication step, [s]: the largest that keeps the flow of ``smeha simulate``'s
#: default run (100 Hz, compensated, realistic circuit) within 0.5 % of the same run at
#: a quarter of the step (benchmarks/README.md, convergence: +0.07 %). With the digital
#: compensator's 100 us sample period (gmt.parameters.COMPENSATOR_PERIOD) a step is at
#: most one sample anyway: communication points fall on its samples.
DEFAULT_STEP = 1e-4

#: Longest substep of the plant's TR-BDF2, [s]. The digital compensator's force steps
#: at every sample (100 us) and the rod answers each step through its 7 us pole and the
#: ~30 kHz rod-oil mode; with 100 us substeps that costs up to 0.7 % of the flow (50 Hz
#: compensated, Figure 9's rule), with 50 us 0.05 % (benchmarks/README.md).
HYDRAULIC_STEP = 5e-5

#: Sample period of the valve controller, [s]: 10 us puts each switch within 5 us of the
#: drive's extreme (0.18 deg at 100 Hz), so the valve timing, and with it dy (eqs 40/41),
#: does not depend on the communication step.
VALVE_CONTROLLER_PERIOD = 1e-5

#: Pumping cycles simulated by default (the flow check discards 2, averages the rest).
DEFAULT_CYCLES = 8.0

#: Coupling of the transducer to the plant (system_models.cosim): the force port.
DEFAULT_COUPLING = "force"

#: The longest co-simulation a run accepts, [s] (CosimSettings.duration): 1e4 s is 1e8
#: communication steps at the default step, days of wall time.
MAXIMUM_DURATION = 1e4

#: Load of the realistic study, [N]: 150 N down-load, about 0.1 MPa of pressure rise the
#: pump must deliver on top of the area-ratio pressure difference (a differential cylinder
#: balances p_S A_S against p_B A_B). (system_models.presets.default_load)
REALISTIC_LOAD = 150.0

#: The flow check's compression strokes discarded at a run's start, and the fewest cycles a
#: run needs (system_models.flowcheck: two skipped, two more averaged).
SKIP_CYCLES = 2
MINIMUM_CYCLES = SKIP_CYCLES + 2
