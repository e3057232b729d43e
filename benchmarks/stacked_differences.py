"""The diagnosis' finite differences: stacked evaluations against one evaluation a column.

:mod:`smeha.diagnose.differences` evaluates a point and its finite-difference steps as one
batch of the runs stacked once per point
(:meth:`smeha.diagnose.candidates.Evaluator.residuals_stacked`). This benchmark takes one
labsim dataset (tests/labsim, the independent generator; default: the Preisach density
with eddy diffusion, ``preisach_random`` / ``diffusion_random``, seed 3, 800 samples a
period) and, in one process:

* per single candidate (at its first start, the paper's base values): the time of one
  evaluation of the training runs, of the Jacobian (scipy's '2-point' steps) by one
  evaluation a column, and by the stacked evaluations; their ratio; and the largest
  difference between the two Jacobians (0: the same to the bit);
* with ``--diagnose``: the whole diagnosis (one worker) with the stacking and with it
  undone (``residuals_stacked`` replaced by one evaluation a point), alternated
  ``--repeats`` times: the median wall times, their ratio, and whether every fit's
  training chi^2 and the answer are the same.

Figures only, no asserts. BLAS pinned to one thread.

    python benchmarks/stacked_differences.py [--effects rate_independent_hysteresis,...]
        [--seed 3] [--samples-per-cycle 800] [--repeats 5] [--diagnose] [--json]
"""
from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "tests"), str(ROOT / "fmu_src"), str(ROOT)]


def _data(effects, seed, samples_per_cycle):
    from labsim_runs import TEXTBOOK_FORMULATIONS, runs

    return runs({e: 1.0 for e in effects}, seed=seed, noise_um=0.05,
                samples_per_cycle=samples_per_cycle, formulations=TEXTBOOK_FORMULATIONS)


def _problem(data):
    """(evaluator, training batch, base start values) as the diagnosis prepares them."""
    import gmt
    from smeha.diagnose.workflow import _prepared

    _, _, _, _, ev, base0, train, _ = _prepared(data, None, gmt.TransducerParameters())
    return ev, train, base0


def _median_time(fn, repeats):
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times)


def jacobians(ev, train, base0, repeats):
    """Per single candidate: times of one evaluation and of the two Jacobians, and their
    largest difference."""
    from smeha.diagnose import differences
    from smeha.diagnose.candidates import candidates
    from smeha.diagnose.fit import BASE_LOWER, BASE_UPPER, _split, base_factor
    from smeha.diagnose.linearfit import _slices, linear_member

    nb = len(BASE_LOWER)
    factor = base_factor(base0)
    rows = []
    for cand in candidates():
        x0 = cand.starts()[0]
        z = np.concatenate((np.asarray(base0, float) / factor, np.asarray(x0, float)))
        lo = np.concatenate((BASE_LOWER, cand.lower)).astype(float)
        hi = np.concatenate((BASE_UPPER, cand.upper)).astype(float)
        z = np.clip(z, lo, hi)
        steps = differences.scipy_steps(z, lo, hi)

        def one(zz, cand=cand):
            b, xx = _split(zz, nb, base0, factor)
            return ev.residuals(train, b, cand, xx)

        def separate(zs, one=one):
            return np.array([one(zz) for zz in zs])

        def stacked(zs, cand=cand):
            return ev.residuals_stacked(train, [_split(zz, nb, base0, factor) for zz in zs],
                                        cand)

        # a density's weights are linearised apart (smeha.diagnose.linearfit): its
        # columns here are the base's and its nonlinear unknowns'
        lin = linear_member(cand)
        cols = (np.arange(z.size) if lin is None
                else np.concatenate((np.arange(nb), nb + _slices(cand, lin)[1])))
        j_sep = differences.jacobian(separate, z, steps, cols)[0]
        j_stk = differences.jacobian(stacked, z, steps, cols)[0]
        t_one = _median_time(lambda: one(z), repeats)
        t_sep = _median_time(lambda: differences.jacobian(separate, z, steps, cols), repeats)
        t_stk = _median_time(lambda: differences.jacobian(stacked, z, steps, cols), repeats)
        rows.append({"candidate": cand.label, "columns": int(cols.size),
                     "evaluation_ms": 1e3 * t_one, "jacobian_separate_ms": 1e3 * t_sep,
                     "jacobian_stacked_ms": 1e3 * t_stk, "ratio": t_sep / t_stk,
                     "largest_difference": float(np.max(np.abs(j_sep - j_stk)))})
    return rows


def whole(data, repeats):
    """Median wall time of the diagnosis with and without the stacking, and whether the
    two give the same fits."""
    from smeha import diagnose
    from smeha.diagnose.candidates import Evaluator

    stacked = Evaluator.residuals_stacked

    def separate(self, batch, points, cand=None, components=None):
        if components is not None:  # the density's weights: stacked before this change too
            return stacked(self, batch, points, cand, components)
        return np.array([self.residuals(batch, b, cand, x) for b, x in points])

    times = {"stacked": [], "separate": []}
    answers = {}
    for _ in range(repeats):
        for name in ("stacked", "separate"):
            Evaluator.residuals_stacked = stacked if name == "stacked" else separate
            try:
                t = time.perf_counter()
                d = diagnose.diagnose(data, workers=1)
                times[name].append(time.perf_counter() - t)
            finally:
                Evaluator.residuals_stacked = stacked
            answers[name] = (tuple(d.causes), [f.train_chi2 for f in d.fits]
                             + [f.train_chi2 for f in d.combinations])
    med = {k: statistics.median(v) for k, v in times.items()}
    return {"stacked_s": med["stacked"], "separate_s": med["separate"],
            "ratio": med["separate"] / med["stacked"], "causes": list(answers["stacked"][0]),
            "same_fits": answers["stacked"] == answers["separate"]}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--effects", default="rate_independent_hysteresis,eddy_current_diffusion")
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--samples-per-cycle", type=int, default=800)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--diagnose", action="store_true")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    from smeha.pool import one_blas_thread

    data = _data(args.effects.split(","), args.seed, args.samples_per_cycle)
    with one_blas_thread():
        ev, train, base0 = _problem(data)
        out = {"runs": len(train), "jacobians": jacobians(ev, train, base0, args.repeats)}
        if args.diagnose:
            out["diagnose"] = whole(data, max(1, args.repeats // 2))
    if args.json:
        print(json.dumps(out))
        return 0
    print(f"labsim {args.effects}, seed {args.seed}, {args.samples_per_cycle} a period: "
          f"{out['runs']} training runs")
    print(f"{'candidate':52s} {'cols':>4s} {'eval ms':>8s} {'apart ms':>9s} "
          f"{'stacked ms':>10s} {'ratio':>6s} {'max |dJ|':>9s}")
    for r in out["jacobians"]:
        print(f"{r['candidate'][:52]:52s} {r['columns']:4d} {r['evaluation_ms']:8.3f} "
              f"{r['jacobian_separate_ms']:9.3f} {r['jacobian_stacked_ms']:10.3f} "
              f"{r['ratio']:6.2f} {r['largest_difference']:9.2g}")
    if args.diagnose:
        d = out["diagnose"]
        print(f"diagnose, one worker: stacked {d['stacked_s']:.2f} s, one evaluation a point "
              f"{d['separate_s']:.2f} s (ratio {d['ratio']:.2f}); causes {d['causes']}, "
              f"the same fits: {d['same_fits']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
