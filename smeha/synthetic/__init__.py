"""Seeded synthetic measured runs: the paper's model plus one hidden effect.

The diagnosis workflow must name the cause of a misfit from data
alone. This package makes its test data: measured-like :class:`~smeha.measured.Run`
objects at several frequencies and current amplitudes, from the paper's model
(eq 30: the magnetics of :mod:`gmt` at the samples, the mechanics of eq 27
integrated as the continuous system, :mod:`smeha.synthetic.response`) with at
most one physical effect added that the paper's model lacks. The caller (a
test) chooses the effect; the runs carry it in ``Run.meta`` (the diagnosis must
not read ``meta``; tests do).

What is recorded, as a bench would
----------------------------------
* ``current`` -- the coil current i = I_m cos(w t) measured with Gaussian noise
  (``current_noise``, [A]); the model is driven by the true sinusoid.
* ``control`` -- the command u = I_m cos(w t) / K_a (K_a = 1 A/V, the paper's
  amplifier); the command is digital and carries no noise.
* ``displacement`` -- y(t) in metres minus the bias displacement of the magnet
  alone, plus a random constant offset per run (measured displacements are
  relative, as the paper's Table 3 zeroes them at the loop minimum), plus
  Gaussian noise ``noise_um``.
* ``sense_voltage`` -- E = -N_c A_c dB/dt (eq 21) of the model's B(t), plus
  Gaussian noise ``voltage_noise``, [V]. dB/dt of the paper's B is exact
  (B is a sinusoid, eq 4); an effect's change of B is differentiated by
  second-order central differences.

Times are t_k = k h, h = 1 / (f * samples_per_cycle), k = 0 ... cycles *
samples_per_cycle - 1. The mechanics start at rest at the bias displacement at
t = 0, as :func:`gmt.simulate` does (its transient dies within ~1 ms).

The noise of run (f, I_m) for a given ``seed`` is the same whatever the effect
and its strength: ``generate_runs(effect, seed=s)`` minus
``generate_runs(None, seed=s)`` is the effect alone. The effect's own
parameters are drawn (``jitter``) from a second, independent stream.

The hidden effects
------------------
Each effect is a *truth* formulation chosen to differ from the candidate
extensions the diagnosis fits (so the diagnosis cannot win by sharing the
generator's formula); each reduces to the paper's model as its strength goes
to 0, and ``strength = 0`` returns the paper's model exactly.

===============================  ==============================================
effect                           truth formulation (its module here)
===============================  ==============================================
``rate_independent_hysteresis``  classical Preisach model (Mayergoyz 1991;
                                 Tan & Baras 2004) of the applied field,
                                 lognormal-coercivity x Gaussian-interaction
                                 density, Everett-function evaluation,
                                 added to the paper's M (eq 5)
``magnetization_saturation``     Langevin anhysteretic M_s L(x),
                                 L = coth x - 1/x (Jiles & Atherton 1986), of
                                 the total effective field with the bias M_b
                                 inside, linearised at the bias to match eq 5
``eddy_current_diffusion``       1-D magnetic diffusion across a slab of the
                                 rod's thickness, finite differences in space,
                                 exact first-order-hold time integration, flux
                                 and strain averaged over the thickness
                                 (Bertotti 1998, ch. 8 and 12; Stoll 1974)
``transport_delay``              a delay line on the displacement sensor:
                                 y_meas(t) = y(t - tau), y rebuilt between
                                 samples by a cubic spline of the fine record
``mechanical_resonance``         two masses: the rod (m_1, K, c) and an output
                                 mass m_2 on a compliant joint (k_j, c_j); the
                                 sensor reads m_2 (Engdahl 2000, ch. 4)
``thermal_drift``                first-order thermal model of coil heating
                                 i^2 R(T), with K_lambda(T) and a sensor
                                 offset proportional to the temperature rise
                                 (Engdahl 2000; Clark 1980 for K_lambda(T))
===============================  ==============================================

Strength ``1.0`` makes each effect clearly visible (RMS change of y of a few
um on the runs where the effect matters, against 0.05 um of noise); the
effect's size scales monotonically with ``strength`` (see
:func:`truth_parameters` for how each parameter scales).

Modules
-------
==============  =====================================================================
``truth``       :data:`EFFECTS`, :data:`NOMINAL`, :func:`truth_parameters`
``hysteresis``  the Preisach operator (:func:`preisach`)
``saturation``  the Langevin law (:func:`saturated_magnetization`)
``eddy``        slab diffusion (:func:`slab_diffusion`)
``resonance``   the two-mass mechanics (:func:`two_mass_response`)
``thermal``     the coil's temperature rise (:func:`temperature_rise`)
``delay``       the sensor's delay line
``foh``         linear systems under a first-order hold, exactly
``response``    one run without noise, time-stepped (:func:`true_response`)
``dataset``     the recorded runs with noise (:func:`generate_runs`)
==============  =====================================================================

References
----------
* I. D. Mayergoyz, *Mathematical Models of Hysteresis*, Springer 1991, ch. 1.
* X. Tan, J. S. Baras, "Modeling and control of hysteresis in magnetostrictive
  actuators", Automatica 40 (2004) 1469-1480.
* D. C. Jiles, D. L. Atherton, "Theory of ferromagnetic hysteresis",
  J. Magn. Magn. Mater. 61 (1986) 48-60.
* G. Bertotti, *Hysteresis in Magnetism*, Academic Press 1998, ch. 8 (eddy
  currents in laminations, magnetic diffusion).
* R. L. Stoll, *The Analysis of Eddy Currents*, Clarendon 1974 (slab solution
  tanh(q)/q used in the tests).
* G. Engdahl (ed.), *Handbook of Giant Magnetostrictive Materials*, Academic
  Press 2000 (Terfenol-D properties: M_s ~ 765 kA/m, rho ~ 0.6 uOhm m,
  thermal behaviour, transducer dynamics).
* A. E. Clark, "Magnetostrictive rare earth-Fe2 compounds", in Ferromagnetic
  Materials vol. 1, North-Holland 1980 (temperature dependence of
  magnetostriction; delta-E).
"""
from .eddy import slab_diffusion
from .hysteresis import preisach
from .resonance import two_mass_matrices, two_mass_response
from .response import FINE, true_response
from .dataset import OFFSET_RANGE, generate_runs, run_name
from .saturation import inverse_langevin, langevin, langevin_slope, saturated_magnetization
from .thermal import temperature_rise
from .truth import EFFECTS, MAGNETIC_EFFECTS, NOMINAL, truth_parameters

__all__ = [
    "EFFECTS", "MAGNETIC_EFFECTS", "NOMINAL", "OFFSET_RANGE", "FINE", "truth_parameters",
    "preisach", "langevin", "langevin_slope", "inverse_langevin", "saturated_magnetization",
    "slab_diffusion", "two_mass_matrices", "two_mass_response", "temperature_rise",
    "true_response", "run_name", "generate_runs",
]
