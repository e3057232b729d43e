"""Time of ``smeha losses`` over MagNet's ten ferrites (read, fit three laws, predict, score).

    python benchmarks/losses_speed.py [--materials N87,3C90,...] [--json]

Prints the seconds per material and in total; the target is at most 120 s for all ten
on a 2-core machine. Run beside nothing else (or ``nice -n 10`` and read the figures as
upper bounds).
"""
import argparse
import json
import os
import time

from smeha.coreloss import MATERIALS, measurements, study


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--materials", default=",".join(MATERIALS),
                    help="comma-separated MagNet materials (default: all ten)")
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = ap.parse_args(argv)
    names = [m for m in args.materials.split(",") if m]
    unknown = sorted(set(names) - set(MATERIALS))
    if unknown:
        ap.error(f"unknown material(s) {unknown}; choose from {list(MATERIALS)}")
    start = time.perf_counter()
    rows = {}
    for material in names:
        t0 = time.perf_counter()
        data = measurements.read_magnet(material)
        t1 = time.perf_counter()
        study.run(data)
        t2 = time.perf_counter()
        rows[material] = {"rows": len(data), "read_s": t1 - t0, "fit_predict_s": t2 - t1}
        if not args.json:
            print(f"{material:5s} rows {len(data):6d}  read {t1 - t0:5.2f} s  fit+predict "
                  f"{t2 - t1:5.2f} s")
    total = time.perf_counter() - start
    if args.json:
        print(json.dumps({"materials": rows, "total_s": total,
                          "load_average": os.getloadavg()}))
        return
    print(f"{len(names)} materials: {total:.1f} s (target <= 120 s for all ten); "
          f"load average {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
