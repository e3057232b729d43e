"""The FMI 2.0 FMU in another host: libcosimpy (libcosim) against fmpy.

libcosimpy 0.0.6 loads FMI 2.0 only. It runs in a child process (see
tests/fmu_fixtures.py) with the same inputs as fmpy; libcosim keeps time in
integer nanoseconds, and the fmpy run is given the step sizes libcosim hands the
FMU (t_{k+1}/1e9 - t_k/1e9), so the two hosts must agree exactly.
"""
from __future__ import annotations

import pytest

try:
    from fmu_fixtures import fmu_dist, max_relative_difference, run_runner, runner_dir  # noqa: F401
except ImportError:  # tests/ imported as a package
    from tests.fmu_fixtures import (fmu_dist, max_relative_difference,  # noqa: F401
                                    run_runner, runner_dir)

pytestmark = pytest.mark.integration


def test_libcosim_and_fmpy_give_the_same_outputs(fmu_dist, runner_dir):
    pytest.importorskip("libcosimpy")
    res = run_runner("cosim", runner_dir / "cosim", fmu_dist["2"], 2000)
    assert res["gmt_imported_before_fmu"] is False
    assert res["error_code"] == 0
    assert res["final_time_ns"] == 2000 * 10_000
    assert len(res["libcosim"]) == len(res["fmpy"]) == 2000
    assert max_relative_difference(res["libcosim"], res["fmpy"]) <= 1e-12
    # the drive is the paper's 50 Hz sinusoid: the current swings through +-1 A
    currents = [row[0] for row in res["libcosim"]]
    assert max(currents) == pytest.approx(1.0) and min(currents) == pytest.approx(-1.0, abs=1e-3)
