"""Parameters: Table 2 defaults, derived E^H, validation messages, immutability."""
from __future__ import annotations

import dataclasses
import math
import re

import pytest

import gmt


def test_defaults_are_table_2(params, table2):
    # Reference: paper, Table 2, converted to SI (mm, mm^2, kA/m) and typed in conftest.
    # Same decimal literals on both sides, so equality is exact up to the last bit;
    # rel=1e-15 only absorbs a different spelling of the same number (10e-3 vs 0.010).
    for name, value in vars(table2).items():
        assert getattr(params, name) == pytest.approx(value, rel=1e-15), name


def test_youngs_modulus_is_20_gpa(params, table2):
    # Table 2 gives K, not E^H: K = E^H A_r / L fits Table 2 to four digits with
    # E^H = 20 GPa.
    a_r = math.pi * table2.rod_diameter ** 2 / 4.0
    assert f"{20e9 * a_r / table2.rod_length:.3e}" == "1.963e+07"  # Table 2's K, 4 digits
    # The package derives E^H = K L / A_r (same formula, by hand here):
    assert params.youngs_modulus == pytest.approx(
        table2.stiffness * table2.rod_length / a_r, rel=1e-12)
    # K has four significant digits: +-0.0005e7 / 1.963e7 = 2.5e-4 relative, and
    # E^H = 19.995 GPa sits at that edge; 3e-4 allows it and nothing coarser.
    assert params.youngs_modulus == pytest.approx(20e9, rel=3e-4)


def test_derived_geometry(params, table2):
    # A_r = pi d^2/4 (eq 28), V = A_r L (eqs 6-14), H per ampere = N/(k_f L) (eq 1).
    a_r = math.pi * 0.010 ** 2 / 4.0
    assert params.rod_area == pytest.approx(a_r, rel=1e-14)
    assert params.rod_volume == pytest.approx(a_r * 0.080, rel=1e-14)
    assert params.field_per_ampere == pytest.approx(1300.0 / (1.1 * 0.080), rel=1e-14)


def _message(exc_info):
    return str(exc_info.value)


@pytest.mark.parametrize("name, value, shown, allowed", [
    ("rod_length", -0.08, "-0.08", "(0, inf)"),
    ("rod_length", 0.0, "0", "(0, inf)"),
    ("rod_diameter", -0.01, "-0.01", "(0, inf)"),
    ("rod_diameter", 0.0, "0", "(0, inf)"),
    ("coil_turns", 0.0, "0", "(0, inf)"),
    ("coil_turns", -1300.0, "-1300", "(0, inf)"),
    # the paper says n from 1.5 to 2.5; the package accepts [1, 3] (parameters.py)
    ("steinmetz_exponent", 3.5, "3.5", "[1, 3]"),
    ("steinmetz_exponent", 0.9, "0.9", "[1, 3]"),
    ("rod_length", math.nan, "nan", "(0, inf)"),
    ("stiffness", math.nan, "nan", "(0, inf)"),
])
def test_bad_transducer_parameter(name, value, shown, allowed):
    with pytest.raises(gmt.ParameterError) as exc:
        gmt.TransducerParameters(**{name: value})
    msg = _message(exc)
    assert name in msg and f"= {shown}" in msg and allowed in msg, msg


def test_steinmetz_range_edges_accepted():
    # The paper's stated range 1.5-2.5 lies inside the accepted [1, 3]; edges included.
    for n in (1.0, 1.5, 2.5, 3.0):
        assert gmt.TransducerParameters(steinmetz_exponent=n).steinmetz_exponent == n


@pytest.mark.parametrize("kwargs, name, shown, allowed", [
    ({"frequency": 0.0}, "frequency", "0", "(0, 1000]"),
    ({"frequency": -50.0}, "frequency", "-50", "(0, 1000]"),
    ({"frequency": math.nan}, "frequency", "nan", "(0, 1000]"),
    ({"current_amplitude": 0.0}, "current_amplitude", "0", "(0, 100]"),
    ({"current_amplitude": -1.0}, "current_amplitude", "-1", "(0, 100]"),
])
def test_bad_excitation(kwargs, name, shown, allowed):
    with pytest.raises(gmt.ParameterError) as exc:
        gmt.Excitation(**kwargs)
    msg = _message(exc)
    assert name in msg and f"= {shown}" in msg and allowed in msg, msg


def test_imaginary_mu_real_low_flux_density(params):
    # Eq 20: mu' = sqrt((B_m/(mu_0 H_m))^2 - mu''^2) is imaginary when
    # B_m < mu_0 mu'' H_m. With mu'' imposed (the paper's identification scan,
    # 0 to 10) at mu'' = 5 and H_m = 14773 A/m, that is B_m < 0.0928 T, so a
    # measured B_m of 0.05 T is too low.
    with pytest.raises(gmt.ParameterError) as exc:
        gmt.operating_point(params, gmt.Excitation(50.0, 1.0, 0.05), mu_imag=5.0)
    msg = _message(exc)
    assert "eq 20" in msg or "imaginary" in msg, msg
    assert "flux_density_amplitude" in msg and "0.05" in msg, msg


def test_imaginary_mu_real_high_flux_density(params):
    # With mu'' from the losses (eq 16) the failure is at the other end: the
    # losses grow as B_m^2 f while |mu| grows as B_m, so at 50 Hz and 1 A a
    # B_m of 0.5 T gives, by hand, mu'' = 71.0 > |mu| = 26.9 (eq 16 vs eq 19).
    with pytest.raises(gmt.ParameterError) as exc:
        gmt.operating_point(params, gmt.Excitation(50.0, 1.0, 0.5))
    msg = _message(exc)
    assert "eq 20" in msg or "imaginary" in msg, msg


def test_bad_drive_parameters():
    with pytest.raises(gmt.ParameterError) as exc:
        gmt.DriveParameters(branch_rule="upward")
    assert "branch_rule" in _message(exc) and "upward" in _message(exc)
    assert "control" in _message(exc) and "demand" in _message(exc)
    with pytest.raises(gmt.ParameterError) as exc:
        gmt.DriveParameters(current_limit=-1.0)
    msg = _message(exc)
    assert "current_limit" in msg and "= -1" in msg and "(0, 100]" in msg, msg


def test_parameter_error_is_value_error():
    # errors.py: ParameterError(GmtError, ValueError), so generic callers can catch it.
    assert issubclass(gmt.ParameterError, ValueError)
    assert issubclass(gmt.ParameterError, gmt.GmtError)


@pytest.mark.parametrize("obj, field", [
    (gmt.TransducerParameters(), "rod_length"),
    (gmt.Excitation(), "frequency"),
    (gmt.DriveParameters(), "branch_rule"),
])
def test_frozen(obj, field):
    with pytest.raises(dataclasses.FrozenInstanceError):
        setattr(obj, field, getattr(obj, field))


def test_replace_revalidates(params):
    assert params.replace(rod_length=0.1).rod_length == 0.1
    with pytest.raises(gmt.ParameterError):
        params.replace(rod_length=-1.0)


def test_eq20_message_names_a_range_that_works(params):
    # mu'' from the losses (eq 16) grows faster with B_m than B_m/(mu_0 H_m)
    # does, so eq 20 is real only below some B_max. A message that names an
    # allowed range must name one that works: inside it the operating point is
    # valid, just above it eq 20 fails again.
    with pytest.raises(gmt.ParameterError) as exc:
        gmt.operating_point(params, gmt.Excitation(1000.0, 1.0, 0.0255))
    bmax = float(re.search(r"allowed range \(0, ([0-9.eE+-]+)\) T", str(exc.value)).group(1))
    assert 0.01 < bmax < 0.0255
    gmt.operating_point(params, gmt.Excitation(1000.0, 1.0, 0.99 * bmax))
    with pytest.raises(gmt.ParameterError):
        gmt.operating_point(params, gmt.Excitation(1000.0, 1.0, 1.01 * bmax))
