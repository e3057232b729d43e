"""Generation times (prints figures; not a test). Run: python -m labsim.timing from tests/."""
from __future__ import annotations

import time

from . import EFFECTS, make_dataset


def _time(repeat: int = 3, **kwargs) -> float:
    best = float("inf")
    for seed in range(repeat):
        start = time.perf_counter()
        make_dataset(seed=seed, **kwargs)
        best = min(best, time.perf_counter() - start)
    return best


def main(formulation: str = "default") -> None:
    make_dataset(frequencies=[50.0], amplitudes=[1.0])  # warm up imports
    cases = [("clean", {})] + [(name, {name: 1.0}) for name in EFFECTS]
    cases.append(("eddy + hysteresis", {"eddy_current_diffusion": 1.0,
                                        "rate_independent_hysteresis": 1.0}))
    cases.append(("delay + saturation", {"transport_delay": 1.0,
                                         "magnetization_saturation": 1.0}))
    print(f"{formulation} formulations: 16 runs x 6 cycles; best of 3 [s]")
    print(f"{'effects':28s} {'800/cycle':>10s} {'800/cycle,transient':>20s} {'50 kHz':>8s}")
    for label, effects in cases:
        common = dict(effects=effects, formulation=formulation)
        a = _time(samples_per_cycle=800, **common)
        b = _time(samples_per_cycle=800, start_in_transient=True, **common)
        c = _time(sample_rate=50e3, **common)
        print(f"{label:28s} {a:10.3f} {b:20.3f} {c:8.3f}")


def textbook() -> None:
    """The formulations after the second ones (README.md, "Textbook formulations")."""
    hyst, eddy, delay = ("rate_independent_hysteresis", "eddy_current_diffusion",
                         "transport_delay")
    cases = [
        ("general Preisach", {hyst: 1.0}, {hyst: "general_preisach"}),
        ("Preisach, bimodal", {hyst: 1.0}, {hyst: "preisach_bimodal"}),
        ("Preisach, Lorentzian", {hyst: 1.0}, {hyst: "preisach_lorentzian"}),
        ("slab on M", {eddy: 1.0}, {eddy: "slab_magnetization"}),
        ("general Preisach + delay", {hyst: 1.0, delay: 1.0}, {hyst: "general_preisach"}),
        ("slab on M + delay", {eddy: 1.0, delay: 1.0}, {eddy: "slab_magnetization"}),
        ("slab on M + general Preisach", {eddy: 1.0, hyst: 1.0},
         {eddy: "slab_magnetization", hyst: "general_preisach"}),
    ]
    print("textbook formulations: 16 runs x 6 cycles; best of 3 [s]")
    print(f"{'effects':28s} {'800/cycle':>10s} {'800/cycle,transient':>20s} {'50 kHz':>8s}")
    for label, effects, forms in cases:
        common = dict(effects=effects, formulations=forms)
        a = _time(samples_per_cycle=800, **common)
        b = _time(samples_per_cycle=800, start_in_transient=True, **common)
        c = _time(sample_rate=50e3, **common)
        print(f"{label:28s} {a:10.3f} {b:20.3f} {c:8.3f}")


if __name__ == "__main__":
    main()
    main("alt")
    textbook()
