"""Local worker processes (smeha.pool): the jobs' results in order, where they ran, a worker
that dies. No co-simulation runs: the jobs are small module-level functions."""
import os
import sys

import pytest

from smeha import pool


def _where(k):
    return k * k, os.getpid()


def _dies(k):
    if k == 1:
        os._exit(3)  # the worker process ends without a result
    return k


def test_results_come_back_in_job_order_from_other_processes():
    jobs = [(k,) for k in range(6)]
    here = pool.run_jobs(_where, jobs, 1, desc="t", unit="job", quiet=True)
    away = pool.run_jobs(_where, jobs, 2, desc="t", unit="job", quiet=True)
    assert [r[0] for r in here] == [r[0] for r in away] == [k * k for k in range(6)]
    assert {r[1] for r in here} == {os.getpid()}
    assert os.getpid() not in {r[1] for r in away}


def test_a_worker_that_dies_is_reported_or_raised():
    finished = []
    results = pool.run_jobs(_dies, [(0,), (1,), (2,)], 2, desc="t", unit="job", quiet=True,
                            on_result=lambda i, r: finished.append(i),
                            on_error=lambda i, exc: f"failed: {type(exc).__name__}")
    assert results[1] == "failed: BrokenProcessPool" and sorted(finished) == [0, 1, 2]
    with pytest.raises(Exception, match="terminated abruptly"):
        pool.run_jobs(_dies, [(1,), (2,)], 2, desc="t", unit="job", quiet=True)


def test_workers_are_forked_where_the_platform_forks_safely():
    # Linux forks (the workers inherit the prepared process); Windows cannot, macOS's
    # system libraries are not fork-safe (Python's own default there is spawn)
    expected = "fork" if sys.platform.startswith("linux") else pool.START_METHOD
    assert pool.START_METHOD == expected
    if sys.platform in ("win32", "darwin"):
        assert pool.START_METHOD == "spawn"


def _blas_threads(_):
    import numpy  # noqa: F401 -- loads its BLAS, which threadpoolctl then finds
    from threadpoolctl import threadpool_info
    return [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]


def test_jobs_run_with_one_blas_thread_and_the_limit_is_restored():
    # smeha.pool's docstring: one BLAS thread a process while jobs run (threadpoolctl reads
    # the libraries' own setting), in this process and in the workers; afterwards this
    # process has the threads it had. The test processes run with one BLAS thread
    # (conftest.py); two here, so that a limit not set or not restored shows
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=2, user_api="blas"):
        before = _blas_threads(0)
        if not before:
            pytest.skip("no BLAS library that threadpoolctl controls")
        assert before == [2] * len(before)
        here = pool.run_jobs(_blas_threads, [(0,)], 1, desc="t", unit="job", quiet=True)
        away = pool.run_jobs(_blas_threads, [(0,), (1,)], 2, desc="t", unit="job", quiet=True)
        assert here == [[1] * len(before)]
        assert away == [[1] * len(before)] * 2
        assert _blas_threads(0) == before
