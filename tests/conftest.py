"""Shared fixtures for the physics tests.

The reference data below are typed in from the source paper (Tables 1-3 and the
text, converted to SI), never read from ``gmt``, so that the tests compare the
package against the paper and against the paper's equations evaluated
independently here (:class:`PaperModel`).
"""
from __future__ import annotations

import math
from types import SimpleNamespace

import numpy  # noqa: F401  (numpy's and scipy's BLAS loaded, for the limit below)
import pytest
import scipy.linalg  # noqa: F401
from threadpoolctl import threadpool_limits

import gmt

# One BLAS thread in each test process: the suite runs one process a core (pytest-xdist's
# workers), so BLAS's own threads would only contend for the same cores, and OpenBLAS's
# threads wait for work by spinning (smeha.pool's docstring). Measured: the finer-grid
# relays of tests/test_preisach.py (a 10,548-long dot product a sample, which OpenBLAS
# splits over its threads) took 32 s of CPU with its default threads on a loaded 2-core
# machine and 0.24 s with one. The limit holds for the whole process (never restored) and
# acts on the BLAS libraries loaded by then: numpy's and scipy's, imported above.
threadpool_limits(limits=1, user_api="blas")


@pytest.hookimpl(tryfirst=True)
def pytest_sessionstart(session):
    """Under pytest-xdist, compile the hydraulic kernel once, here, before the workers start.

    numba writes its compiled code to a cache beside the kernel's sources (about 45 s of
    CPU on this project's machine when the cache is empty: a fresh checkout, a Python of
    its own). Workers that reach their first kernel test while the cache is still empty
    each compile it; compiled once before them, every worker loads it (~0.4 s). Done for
    the configured test paths (the whole suite, or its fast tests: both use the kernel),
    not for named files, which may not need it.
    """
    config = session.config
    if (hasattr(config, "workerinput") or (getattr(config.option, "numprocesses", 0) or 0) < 2
            or config.args_source is not pytest.Config.ArgsSource.TESTPATHS):
        return
    from system_models import kernel
    kernel.ensure_compiled()

#: Permeability of free space, [H/m] (eq 3); 4 pi 1e-7, as in every textbook
#: before the 2019 SI revision (the difference, 5e-10 relative, is immaterial).
MU_0 = 4e-7 * math.pi

#: Paper, Table 2, converted to SI: mm -> m, mm^2 -> m^2, kA/m -> A/m.
TABLE_2 = SimpleNamespace(
    rod_diameter=0.010,  # d = 10 mm
    rod_length=0.080,  # L = 80 mm
    mass=0.02,  # m = 0.02 kg
    damping=2945.0,  # c = 2945 N s/m
    stiffness=1.963e7,  # K = 1.963e7 N/m
    bias_magnetization=250.0e3,  # M_b = 250 kA/m
    coil_turns=1300.0,  # N = 1300
    hysteresis_coefficient=85805.0,  # K_h
    steinmetz_exponent=1.8092,  # n
    eddy_coefficient=2753.39,  # K_e
    excess_coefficient=895.80,  # K_ex
    magnetostriction_coefficient=1.4694e-14,  # K_lambda, m^2/A^2
    sense_turns=150.0,  # N_c
    sense_area=380.0e-6,  # A_c = 380 mm^2
    leakage_coefficient=1.1,  # k_f
)

#: Paper, Table 1: (f [Hz], I_m [A], E_m [V], B_m [T]).
TABLE_1 = (
    (5.0, 0.5, 0.053, 0.0300),
    (5.0, 0.7, 0.095, 0.0530),
    (50.0, 1.0, 1.140, 0.0637),
    (70.0, 1.0, 1.500, 0.0590),
    (80.0, 1.0, 1.620, 0.0570),
    (100.0, 1.0, 1.900, 0.0531),
)

#: Paper, Table 3: f [Hz] -> (y|i=1, y|i=-1, y|u=0, y|u=u_m), [um].
TABLE_3 = {
    50.0: (42.0, 1.8, 0.0, 46.0),
    70.0: (38.0, 3.0, 0.0, 42.0),
    80.0: (36.0, 4.0, 0.0, 40.0),
    100.0: (31.2, 4.6, 0.0, 35.2),
}

class PaperModel:
    """The paper's equations evaluated by hand from Table 2 as typed in above.

    Deliberately independent of :mod:`gmt`: plain ``math`` on the printed
    equations, so a test comparing the two checks the package, not itself.
    """

    def __init__(self, t2=TABLE_2):
        self.t2 = t2
        self.rod_area = math.pi * t2.rod_diameter ** 2 / 4.0  # A_r, eq 28
        self.volume = self.rod_area * t2.rod_length  # V, eqs 6-14
        self.youngs_modulus = t2.stiffness * t2.rod_length / self.rod_area  # not in Table 2

    def field_amplitude(self, current_amplitude):
        """H_m = N I_m / (k_f L), eq 1, [A/m]."""
        t2 = self.t2
        return t2.coil_turns * current_amplitude / (t2.leakage_coefficient * t2.rod_length)

    def losses(self, f, b_m):
        """(P_h, P_eddy, P_ex) for the rod, eqs 7, 9, 11, [W]."""
        t2, v = self.t2, self.volume
        p_h = t2.hysteresis_coefficient * b_m ** t2.steinmetz_exponent * f * v
        p_e = t2.eddy_coefficient * (b_m * f) ** 2 * v
        p_x = t2.excess_coefficient * (b_m * f) ** 1.5 * v
        return p_h, p_e, p_x

    def mu_imag(self, f, current_amplitude, b_m):
        """mu'' at intermediate fields, eq 16 (written out, not via eq 14)."""
        t2 = self.t2
        h_m = self.field_amplitude(current_amplitude)
        num = (t2.hysteresis_coefficient * b_m ** t2.steinmetz_exponent
               + t2.eddy_coefficient * b_m ** 2 * f
               + t2.excess_coefficient * b_m ** 1.5 * f ** 0.5)
        return num / (math.pi * MU_0 * h_m ** 2)

    def mu_real(self, f, current_amplitude, b_m):
        """mu' = sqrt((B_m / (mu_0 H_m))^2 - mu''^2), eq 20."""
        h_m = self.field_amplitude(current_amplitude)
        return math.sqrt((b_m / (MU_0 * h_m)) ** 2 - self.mu_imag(f, current_amplitude, b_m) ** 2)

    def force_gain(self):
        """A_r E^H K_lambda, eqs 25 and 28, [N m^2/A^2]."""
        return self.rod_area * self.youngs_modulus * self.t2.magnetostriction_coefficient


@pytest.fixture
def params():
    """The default transducer: paper, Table 2."""
    return gmt.TransducerParameters()


@pytest.fixture
def table2():
    """Paper, Table 2 in SI, typed in (not read from gmt)."""
    return TABLE_2


@pytest.fixture
def table1():
    """Paper, Table 1: (f, I_m, E_m, B_m) rows."""
    return TABLE_1


@pytest.fixture
def table3():
    """Paper, Table 3: f -> (y|i=1, y|i=-1, y|u=0, y|u=u_m) in um."""
    return TABLE_3


@pytest.fixture
def paper():
    """The paper's equations by hand (see :class:`PaperModel`)."""
    return PaperModel()


@pytest.fixture
def mu_0():
    """Permeability of free space, [H/m]."""
    return MU_0
