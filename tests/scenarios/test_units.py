import math

import pytest

from tissuempm.scenarios.units import UnitError, parse_quantity, unit_scale


@pytest.mark.parametrize(
    ("text", "unit", "expected"),
    [
        ("50 mm", "m", 0.05),
        ("150 m/s", "m/s", 150.0),
        ("2.1 kPa", "Pa", 2100.0),
        ("46 GPa", "Pa", 46e9),
        ("11340 kg/m^3", "kg/m^3", 11340.0),
        ("1.1 g/cm^3", "kg/m^3", 1100.0),
        ("2 ms", "s", 2e-3),
        ("5us", "s", 5e-6),
        ("5 µs", "s", 5e-6),
        ("1 min", "s", 60.0),
        ("180 deg", "rad", math.pi),
        ("-9.81 m/s^2", "m/s^2", -9.81),
        ("1e-3 m", "mm", 1.0),  # expected unit need not be SI base
        ("0.1 mm/ms", "m/s", 0.1),
        ("10 %", "1", 0.1),
        ("3", "m", 3.0),  # a bare number string is SI
        ("100 1/s", "1/s", 100.0),
        ("2 N*m", "J", 2.0),
    ],
)
def test_parse(text, unit, expected):
    assert parse_quantity(text, unit) == pytest.approx(expected, rel=1e-12)


def test_numbers_pass_through_as_si():
    assert parse_quantity(0.25, "m") == 0.25
    assert parse_quantity(3, "Pa") == 3.0


@pytest.mark.parametrize(
    ("value", "unit", "match"),
    [
        ("50 mm", "s", "wrong unit"),
        ("2 kPa", "m", "wrong unit"),
        ("fast", "m/s", "cannot read"),
        ("3 furlong", "m", "unknown unit"),
        (True, "m", "not a quantity"),
        ([1, 2], "m", "not a number"),
        ("1 kmin", "s", "unknown unit"),  # no prefixes on min/h/deg
    ],
)
def test_errors(value, unit, match):
    with pytest.raises(UnitError, match=match):
        parse_quantity(value, unit)


def test_dimensions():
    # Pa = kg m^-1 s^-2; density kg m^-3
    assert unit_scale("kPa") == (1e3, (1, -1, -2, 0))
    s, d = unit_scale("g/cm^3")
    assert s == pytest.approx(1e3) and d == (1, -3, 0, 0)
