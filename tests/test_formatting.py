"""Numbers for people (present/formatting.py): units read from quantity names, values to the precision
of their standard errors. Expected strings written by hand."""

import math

import pytest

from jointrig.present.formatting import quantity_of, unit_of, with_se


@pytest.mark.parametrize("value, se, text", [
    (59.4107, 0.97587, "59.41 ± 0.98"),          # error to two digits, value to the same decimal
    (0.0299719, 0.000586449, "0.02997 ± 0.00059"),
    (2001.75, 4.51322, "2001.8 ± 4.5"),
    (1566.03, 130.2, "1570 ± 130"),               # errors above 10 round the value's integer digits too
    (5.0, 0.0995, "5.00 ± 0.10"),                 # the error rounds up to the next decade first
    (-0.871649, 0.0382801, "-0.872 ± 0.038"),
    (3.21e-5, 2.3e-7, "(3.210 ± 0.023)e-5"),      # a common power of ten below 1e-3 ...
    (1.2e6, 3.4e4, "(1.200 ± 0.034)e6"),          # ... and at 1e5 and above
    (3.0, math.nan, "3"),                          # no error known: six significant digits
    (2.5, 0.0, "2.5"),
])
def test_value_with_standard_error(value, se, text):
    assert with_se(value, se) == text


@pytest.mark.parametrize("name, quantity, unit", [
    ("J1_kgm2", "J1", "kg m²"), ("c_Nms_per_rad", "c", "N m s/rad"), ("k_Nm_per_rad", "k", "N m/rad"),
    ("gamma_Nm_per_rad3", "gamma", "N m/rad³"), ("quadratic_damping_Nms2_per_rad2", "quadratic_damping", "N m s²/rad²"),
    ("omega_rad_s", "omega", "rad/s"), ("drive_delay_s", "drive_delay", "s"), ("coulomb_torque_Nm", "coulomb_torque", "N m"),
    ("backlash_half_gap_rad", "backlash_half_gap", "rad"), ("u_offset_V", "u_offset", "V"), ("fs_Hz", "fs", "Hz"),
    ("no_unit_here", "no_unit_here", ""),
])
def test_unit_read_from_the_quantity_name(name, quantity, unit):
    assert (quantity_of(name), unit_of(name)) == (quantity, unit)


def test_a_value_without_a_number_is_said_in_words():
    from jointrig.present.formatting import with_se_or

    assert with_se_or(float("nan"), 0.1, "none") == "none" and with_se_or(float("inf"), 1.0, "none") == "none"
    assert with_se_or(1.2345, 0.01, "none") == with_se(1.2345, 0.01)
