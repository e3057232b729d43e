"""Time of ``smeha losses`` over MagNet's ten ferrites (read, fit three laws, predict, score).

Prints the seconds per material and in total; the target is at most 120 s for all ten
on a 2-core machine. Run: ``nice -n 10 python benchmarks/losses_speed.py``.
"""
import time

from smeha.coreloss import measurements, study
from smeha.coreloss import MATERIALS


def main():
    start = time.perf_counter()
    results = []
    for material in MATERIALS:
        t0 = time.perf_counter()
        data = measurements.read_magnet(material)
        t1 = time.perf_counter()
        results.append(study.run(data))
        t2 = time.perf_counter()
        print(f"{material:5s} rows {len(data):6d}  read {t1 - t0:5.2f} s  fit+predict "
              f"{t2 - t1:5.2f} s")
    study.summary(results)
    print(f"all ten materials: {time.perf_counter() - start:.1f} s (target <= 120 s)")


if __name__ == "__main__":
    main()
