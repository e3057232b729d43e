"""The report's one line of what each cause explains and what remains.

Reference: the line's specified form, "transport_delay explains 78 % of the held-out excess;
22 % remains unexplained (...)"; shares below 1 % keep two significant digits, so that a
remainder outside noise is never printed as "0 %".
"""
from __future__ import annotations

from smeha.diagnose.remainder import summary

SIG = {"chi2_share": {"y": 0.6, "B": 0.4}, "harmonic_share": {"y": {"odd": 0.5}},
       "branch_asymmetry": 0.0, "frequency_exponent": None, "amplitude_exponent": None}


def test_the_line_names_each_share_and_the_remainder():
    line = summary({"transport_delay": 0.78}, 0.22, SIG, True)
    assert line == ("transport_delay explains 78 % of the held-out excess; 22 % remains "
                    "unexplained (odd harmonics of y)")


def test_a_small_remainder_outside_noise_is_not_zero_per_cent():
    line = summary({"mechanical_resonance": 0.5946, "eddy_current_diffusion": 0.4052},
                   1.9e-4, SIG, True)
    assert line.startswith("mechanical_resonance and eddy_current_diffusion explain 59 % and "
                           "41 % of the held-out excess; 0.019 % remains unexplained")
    assert summary({"transport_delay": 1.0}, 0.0, SIG, False).endswith("the rest is within noise")
