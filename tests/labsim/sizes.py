"""How much each effect changes the signals: the figures quoted in README.md.

The change is the RMS over the record of the difference between the noiseless displacement
(or flux density) with and without the effect, each with its mean removed (measured data are
relative), at the same drive phases and times, after the transients.
"""
from __future__ import annotations

import math

import numpy as np

from .constants import Transducer
from .effects import EFFECTS, FORMULATIONS, EffectSet
from .transducer import simulate


def effect_size(effects, frequency: float = 100.0, current_amplitude: float = 1.0,
                cycles: float = 6, points_per_cycle: int = 400,
                formulation: str = "default", formulations=None) -> dict:
    """RMS change of y [m] and of B [T] caused by ``effects`` ({name: strength}) in the
    given formulation ("default" or "alt"; ``formulations``: per effect, as in
    ``make_dataset``), and the third-harmonic fractions |X_3| / |X_1| of y and B with the
    effects."""
    device = Transducer()
    period = 1.0 / frequency
    clean = simulate(device, frequency, current_amplitude, 0.0, EffectSet(), transient=False)
    other = simulate(device, frequency, current_amplitude, 0.0,
                     EffectSet.from_strengths(effects, formulation, formulations),
                     transient=False)
    start = max(clean.settle_time, other.settle_time)
    start = math.ceil(start / period) * period
    t = start + np.arange(int(cycles * points_per_cycle)) * period / points_per_cycle
    y0, y1 = clean.displacement(t), other.displacement(t)
    b0, b1 = clean.flux.evaluate(t), other.flux.evaluate(t)
    return {
        "displacement_rms": _rms(y1 - y0),
        "flux_rms": _rms(b1 - b0),
        "displacement_rms_clean": _rms(y0),
        "flux_rms_clean": _rms(b0),
        "displacement_third": _third(y1, cycles),
        "flux_third": _third(b1, cycles),
    }


def _third(x: np.ndarray, cycles: float) -> float:
    """|X_3| / |X_1| over a whole number of periods."""
    spectrum = np.abs(np.fft.rfft(x))
    return float(spectrum[3 * int(cycles)] / spectrum[int(cycles)])


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean((x - x.mean()) ** 2)))


def table(frequency: float = 100.0, current_amplitude: float = 1.0,
          formulation: str = "default") -> str:
    """A text table of the effect sizes at strength 1."""
    rows = [f"effect at strength 1, {formulation} formulations ({frequency:g} Hz, "
            f"{current_amplitude:g} A): RMS change of y [um], of B [mT]"]
    for name in EFFECTS:
        size = effect_size({name: 1.0}, frequency, current_amplitude, formulation=formulation)
        y_um, b_mt = size["displacement_rms"] * 1e6, size["flux_rms"] * 1e3
        rows.append(f"{name:30s} {y_um:7.3f} {b_mt:8.4f}")
    return "\n".join(rows)


def textbook_table() -> str:
    """Sizes of the formulations after the second ones (README.md, "Textbook formulations"):
    RMS change of y [um] and B [mT] at 100 Hz 1 A, 5 Hz 1 A and 200 Hz 0.6 A, and the
    third-harmonic fractions of B and y with the effect at 100 Hz, 1 A and 0.6 A."""
    rows = ["formulation: dy, dB at 100 Hz 1 A | 5 Hz 1 A | 200 Hz 0.6 A; "
            "B3/B1, y3/y1 at 100 Hz 1 A | 0.6 A"]
    for name, forms in FORMULATIONS.items():
        for form in list(forms)[2:]:
            choice = {name: form}
            cells = []
            for f, amp in ((100.0, 1.0), (5.0, 1.0), (200.0, 0.6)):
                size = effect_size({name: 1.0}, f, amp, formulations=choice)
                cells.append(f"{size['displacement_rms'] * 1e6:.2f} um, "
                             f"{size['flux_rms'] * 1e3:.2f} mT")
            thirds = []
            for amp in (1.0, 0.6):
                size = effect_size({name: 1.0}, 100.0, amp, formulations=choice)
                thirds.append(f"{size['flux_third']:.3f}, {size['displacement_third']:.3f}")
            rows.append(f"{form:24s} " + " | ".join(cells) + " ; " + " | ".join(thirds))
    return "\n".join(rows)


if __name__ == "__main__":
    for form in ("default", "alt"):
        print(table(formulation=form))
        print(table(5.0, formulation=form))
        print(table(200.0, 0.6, formulation=form))
    print(textbook_table())
