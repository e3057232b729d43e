"""BLAS threads and the fits run side by side (smeha.pool.one_blas_thread).

Prints the time of the dense factorisation the Preisach density's fit repeats (a QR
decomposition of a 20000 x 60 matrix, smeha.diagnose.linearfit._reduced) with OpenBLAS's
default threads and with one, first alone, then with a second process doing the same
beside it (as smeha.pool's two workers do), all measured in one run:

    python benchmarks/blas_threads.py [--rows 20000] [--cols 60] [--repeat 10] [--json]
"""
from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import sys
import time

import numpy as np
from threadpoolctl import threadpool_info, threadpool_limits


def _qr_seconds(rows, cols, repeat, threads):
    """Mean seconds of one reduced QR of a random rows x cols matrix."""
    a = np.random.default_rng(0).random((rows, cols))
    with threadpool_limits(limits=threads, user_api="blas"):
        np.linalg.qr(a, mode="reduced")  # warm
        t = time.perf_counter()
        for _ in range(repeat):
            np.linalg.qr(a, mode="reduced")
        return (time.perf_counter() - t) / repeat


def _beside(rows, cols, repeat, threads, stop):
    """A second process doing the same until told to stop."""
    while not stop.is_set():
        _qr_seconds(rows, cols, repeat, threads)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", type=int, default=20000)
    ap.add_argument("--cols", type=int, default=60)
    ap.add_argument("--repeat", type=int, default=10)
    ap.add_argument("--json", action="store_true", help="print the figures as JSON")
    a = ap.parse_args(argv)
    if a.rows < a.cols or a.cols < 1 or a.repeat < 1:
        print(f"blas_threads: need rows >= cols >= 1 and repeat >= 1, got {a.rows}, "
              f"{a.cols}, {a.repeat}", file=sys.stderr)
        return 2
    info = [f"{i['internal_api']} {i.get('version')} ({i['num_threads']} threads)"
            for i in threadpool_info() if i["user_api"] == "blas"]
    out = {"blas": info, "cpus": len(os.sched_getaffinity(0)), "load": os.getloadavg()[0],
           "rows": a.rows, "cols": a.cols, "repeat": a.repeat, "qr_ms": {}}
    say = (lambda *_: None) if a.json else print
    say(f"BLAS: {', '.join(info)}; CPUs: {out['cpus']}; load {out['load']:.1f}")
    say(f"QR of a {a.rows} x {a.cols} matrix, mean of {a.repeat}:")
    ctx = multiprocessing.get_context("fork")
    for beside in (False, True):
        for threads in (None, 1):
            stop = ctx.Event()
            other = None
            if beside:
                other = ctx.Process(target=_beside,
                                    args=(a.rows, a.cols, a.repeat, threads, stop))
                other.start()
                time.sleep(0.5)
            s = _qr_seconds(a.rows, a.cols, a.repeat, threads)
            if other is not None:
                stop.set()
                other.join()
            label = "default threads" if threads is None else "one thread"
            where = "beside a second such process" if beside else "alone"
            out["qr_ms"][f"{label}, {where}"] = s * 1e3
            say(f"  {label:16s} {where:30s} {s * 1e3:9.1f} ms")
    if a.json:
        print(json.dumps(out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
