"""Local worker processes for many co-simulations (``smeha flow``, ``smeha sweep``).

Before its first point a fresh Python process imports numpy, scipy, fmpy and
the plant, loads the compiled kernel from numba's cache (~0.4 s) and extracts
the FMU and loads it, its bundled physics imported (~0.3 s): ~1.5 s of CPU on
this project's 2-core machine, against ~0.2 s a point of the flow study.
Spawned workers therefore made short sweeps slower with two workers than with
one (benchmarks/README.md, Sweeps). So the parent does that work once
(:func:`prepare`) and the workers are forked from it where the platform forks
safely (:data:`START_METHOD`): they start warm, and two workers take about the
CPU time of one. One worker, or one job, runs in this process.

Each process uses **one BLAS thread** while it runs jobs (:func:`one_blas_thread`):
the jobs already keep the cores busy, one a process. OpenBLAS's threads wait for
work by spinning, so two of them a process on a machine whose cores are taken
make small dense problems many times slower: the QR factorisation of a
20000 x 60 matrix took 1.5 s with OpenBLAS's default threads on the project's
2-core machine with one other job running, 0.10 s with one thread
(benchmarks/blas_threads.py); the fit of a Preisach density to labsim's Preisach
hysteresis (seed 101, 800 samples a period, one other job running) took 42.6 s against
4.2 s.
"""
from __future__ import annotations

import multiprocessing
import os
import sys
from typing import Callable

__all__ = ["START_METHOD", "default_workers", "one_blas_thread", "prepare", "run_jobs"]

#: How worker processes start: forked from the prepared parent on Linux and the other
#: POSIX systems that fork; spawned (a fresh interpreter: imports, kernel and FMU loaded
#: again in each worker) on Windows, which cannot fork, and on macOS, whose system
#: libraries are not safe to use in a forked child (Python's default there is spawn).
START_METHOD = ("fork" if "fork" in multiprocessing.get_all_start_methods()
                and sys.platform != "darwin" else "spawn")


def default_workers() -> int:
    """Worker processes when the user names none: 2 where :data:`START_METHOD` forks (the
    project's 2-core machine; a forked worker costs little), else 1 (a spawned worker
    imports everything again), never more than the CPUs this process may use."""
    try:
        cpus = len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        cpus = os.cpu_count() or 1
    return min(2, cpus) if START_METHOD == "fork" else 1


def one_blas_thread():
    """A context in which BLAS and LAPACK (numpy's and scipy's OpenBLAS or MKL) use one
    thread in this process (module docstring; threadpoolctl); it restores the limits it
    found when it ends."""
    from threadpoolctl import threadpool_limits
    return threadpool_limits(limits=1, user_api="blas")


def _worker_started():
    """A worker process's set-up: one BLAS thread for its life (module docstring; the
    limit holds from :func:`one_blas_thread`'s call, never restored here), and Ctrl-C left
    to the parent, which stops the workers (:func:`run_jobs`): a terminal sends SIGINT to
    every process of the command."""
    import signal
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    one_blas_thread()


def prepare(workers: int, fmu_path=None, say: Callable[[str], None] | None = None) -> None:
    """Before :func:`run_jobs`: the hydraulic kernel compiled if numba's cache lacks it
    (``say`` is told first: it takes ~20 s); for workers to be forked
    (:data:`START_METHOD`, ``workers`` > 1), the kernel loaded and the FMU extracted and
    instantiated once (then freed) here, for them to inherit: its library and bundled
    modules loaded, a worker's own instance takes ~10 ms (a missing FMU is for the runs to
    report)."""
    from pathlib import Path

    from system_models import kernel
    kernel.ensure_compiled(say)
    if workers > 1 and START_METHOD == "fork":
        from system_models.transducers import FmuTransducer
        kernel.load()
        if fmu_path is not None and Path(fmu_path).is_file():
            FmuTransducer(fmu_path).close()  # extracted, and its modules imported


def run_jobs(function, jobs: list, workers: int, *, desc: str, unit: str, quiet: bool,
             on_result: Callable[[int, object], None] | None = None,
             on_error: Callable[[int, BaseException], object] | None = None) -> list:
    """``function(*job)`` for every job, with a progress bar on stderr; results in job order.

    Parameters
    ----------
    function : callable
        A module-level function (it is sent to the workers by name).
    jobs : list of tuple
        Its arguments, one tuple a job.
    workers : int
        Worker processes: 1 (or a single job) runs the jobs in this process,
        more runs them in ``min(workers, len(jobs))`` processes started with
        :data:`START_METHOD`. Call :func:`prepare` first.
    desc, unit, quiet
        The progress bar's label and unit; ``quiet`` hides it.
    on_result : callable, optional
        Called as ``on_result(i, result)`` as job i finishes (in finishing order).
    on_error : callable, optional
        For a job whose worker raised or died: ``on_error(i, exception)`` gives
        its result; without it the exception propagates.
    """
    from tqdm import tqdm
    results = [None] * len(jobs)
    if workers <= 1 or len(jobs) <= 1:
        with one_blas_thread(), tqdm(total=len(jobs), desc=desc, unit=unit,
                                     disable=quiet, file=sys.stderr) as bar:
            for i, job in enumerate(jobs):
                results[i] = function(*job)
                if on_result is not None:
                    on_result(i, results[i])
                bar.update(1)
        return results
    import concurrent.futures as cf
    ctx = multiprocessing.get_context(START_METHOD)
    pool = cf.ProcessPoolExecutor(max_workers=min(workers, len(jobs)), mp_context=ctx,
                                  initializer=_worker_started)
    try:
        # the workers start (fork) at the first submission, before the progress bar's thread
        futures = {pool.submit(function, *job): i for i, job in enumerate(jobs)}
        with tqdm(total=len(jobs), desc=desc, unit=unit, disable=quiet,
                  file=sys.stderr) as bar:
            for future in cf.as_completed(futures):
                i = futures[future]
                try:
                    results[i] = future.result()
                except Exception as exc:  # noqa: BLE001 -- handed to on_error, or re-raised
                    if on_error is None:
                        raise
                    results[i] = on_error(i, exc)
                if on_result is not None:
                    on_result(i, results[i])
                bar.update(1)
    except BaseException:  # Ctrl-C or a failed job: the jobs left are not run
        _stop(pool)
        raise
    pool.shutdown()
    return results


def _stop(pool) -> None:
    """Stop a process pool now: queued jobs cancelled, running workers terminated."""
    processes = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        process.terminate()
    for process in processes:
        process.join(timeout=5)
