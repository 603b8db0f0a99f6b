"""Strict quantity parsing (berryshaker.units): no expression evaluation, correct revolutions, clear refusals.

Expected values are closed forms (1 rev = 2 pi rad, 1 min = 60 s, 1 deg = pi/180 rad), not numbers from a run.
"""

from __future__ import annotations

import math
import re

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from berryshaker.errors import ConfigError
from berryshaker.units import (
    DIMENSIONS,
    ENGINEERING_FACTORS,
    PLAUSIBLE,
    ValueSpec,
    format_quantity,
    parse_quantity,
    parse_unit,
    parse_value_list,
    plausibility_warning,
    plausible_range,
)

TWO_PI = 2.0 * math.pi


# --- regressions from the issue -------------------------------------------------------------------------------

def test_power_tower_is_refused_not_evaluated():
    # pint's Quantity("9**9**9 mm") tries to compute 9**387420489 and hangs; here it is a grammar error.
    with pytest.raises(ConfigError, match=r"cam.stroke: cannot read '9\*\*9\*\*9 mm'"):
        parse_quantity("9**9**9 mm", "length", "cam.stroke")
    for text in ("9**9**9", "1 m**9**9", "2**3 mm", "1 m^99", "(1+1) mm", "1 mm * 1000", "__import__('os') m"):
        with pytest.raises(ConfigError):
            parse_quantity(text, "length")


@pytest.mark.parametrize("text", ["2 Hz", "2 1/s", "2/s", "2 s^-1", "2 s**-1", "2 rps", "2 rev/s", "120 rpm",
                                  "120 r/min", "120 rev/min", "120 1/min", "4 pi rad/s", "720 deg/s"])
def test_revolution_units_for_angular_speed(text):
    # "2 Hz" used to become 2 rad/s (19.1 r/min); it means 2 rev/s = 4 pi rad/s
    assert parse_quantity(text, "angular_speed") == pytest.approx(2 * TWO_PI, rel=1e-14)


def test_rad_per_second_is_taken_as_written():
    assert parse_quantity("2 rad/s", "angular_speed") == pytest.approx(2.0, rel=1e-15)
    assert parse_quantity(2.0, "angular_speed") == 2.0  # plain number: SI rad/s


def test_frequency_dimension_is_cycles_per_second():
    assert parse_quantity("2 Hz", "frequency") == pytest.approx(2.0)
    assert parse_quantity("120 rpm", "frequency") == pytest.approx(2.0)
    assert parse_quantity("4 pi rad/s", "frequency") == pytest.approx(2.0)


def test_angle_strings_need_a_unit():
    with pytest.raises(ConfigError, match=r"cam.rise_angle: '180' has no unit; give a unit, e.g. '180 deg'"):
        parse_quantity("180", "angle", "cam.rise_angle")
    assert parse_quantity("180 deg", "angle") == pytest.approx(math.pi, rel=1e-15)
    assert parse_quantity("180°", "angle") == pytest.approx(math.pi, rel=1e-15)
    assert parse_quantity("0.5 turn", "angle") == pytest.approx(math.pi, rel=1e-15)
    assert parse_quantity(math.pi, "angle") == math.pi  # plain number stays radians
    with pytest.raises(ConfigError, match="wrong kind of unit"):
        parse_quantity("5 %", "angle")  # dimensionless in pint, but not an angle


def test_length_strings_need_a_unit_plain_numbers_are_si():
    with pytest.raises(ConfigError, match="has no unit"):
        parse_quantity("0.25", "length")
    assert parse_quantity(0.003, "length") == 0.003
    assert parse_quantity(3, "length") == 3.0


def test_dimensionless_numbers_and_percent():
    assert parse_quantity("5 %", "dimensionless") == pytest.approx(0.05, rel=1e-15)
    assert parse_quantity("0.3", "dimensionless") == 0.3
    assert parse_quantity(0.9, "dimensionless") == 0.9
    with pytest.raises(ConfigError, match="wrong kind of unit"):
        parse_quantity("5 deg", "dimensionless")


@pytest.mark.parametrize("bad", [True, False, None, [1.0], {"v": 1}, (1,), b"1 mm", float("nan"), float("inf"),
                                 -math.inf, 10**400])
def test_non_numbers_and_non_finite_are_refused_naming_the_field(bad):
    with pytest.raises(ConfigError) as exc:
        parse_quantity(bad, "length", "cam.stroke")
    msg = str(exc.value)
    assert msg.startswith("cam.stroke: ") and "'0.25 mm'" in msg


@pytest.mark.parametrize("text,needle", [
    ("", "empty value"),
    ("nan mm", "must start with a number"),
    ("inf mm", "must start with a number"),
    ("1e999 mm", "not a finite number"),
    ("1e308 km", "too large"),
    ("1e-320 mm", "too small"),
    ("0,25 mm", "decimal point"),
    ("1 " + "m*" * 40 + "m", "too long"),
    ("1 ((m))", "one level of parentheses"),
    ("1 (m", "missing ')'"),
    ("1 m)", "unmatched ')'"),
    ("1 m^0", "power 0"),
    ("20 degC", "offset or logarithmic"),
    ("3 parsecs-ish", "unexpected character '-'"),
    ("80 bogounits", "unknown unit 'bogounits'"),
])
def test_bad_strings_give_a_clear_message(text, needle):
    with pytest.raises(ConfigError) as exc:
        parse_quantity(text, "length", "f")
    assert needle in str(exc.value) and str(exc.value).startswith("f: ")


def test_wrong_dimension_says_what_was_given_and_what_is_expected():
    with pytest.raises(ConfigError) as exc:
        parse_quantity("0.25 mm", "stiffness", "clearance.A.stiffness")
    msg = str(exc.value)
    assert msg.startswith("clearance.A.stiffness: '0.25 mm' has the wrong kind of unit")
    assert "[length]" in msg and "N/m" in msg
    with pytest.raises(ConfigError, match="value: "):  # default field; config strips this prefix
        parse_quantity("3 kg", "length")


@pytest.mark.parametrize("text,dimension,si", [
    ("0.25 mm", "length", 2.5e-4), ("250 um", "length", 2.5e-4), ("250 µm", "length", 2.5e-4),
    ("-40 mm", "length", -0.04), ("+1.2e3 mm", "length", 1.2), (".5 m", "length", 0.5), ("5. m", "length", 5.0),
    ("1.1 GPa", "pressure", 1.1e9), ("30 m/min", "speed", 0.5), ("1.8 km/h", "speed", 0.5),
    ("0.0176 kg*m^2", "inertia", 0.0176), ("0.0176 kg m²", "inertia", 0.0176), ("176 kg·cm^2", "inertia", 0.0176),
    ("2000 N*s/m", "damping", 2000.0), ("2000 N s/m", "damping", 2000.0), ("2 N*s/mm", "damping", 2000.0),
    ("200 N*m/rad", "torsional_stiffness", 200.0), ("200 N*m", "torsional_stiffness", 200.0),
    ("20 N*m*s/rad", "torsional_damping", 20.0), ("850 kg/m^3", "density", 850.0),
    ("0.85 g/cm^3", "density", 850.0), ("850 kg/(m*m*m)", "density", 850.0), ("1.8 g", "mass", 1.8e-3),
    ("9.81 m/s**2", "acceleration", 9.81), ("2 h", "time", 7200.0), ("5 ms", "time", 5e-3),
    ("1.5 kW", "power", 1500.0), ("3 kJ", "energy", 3000.0), ("15 N*m", "torque", 15.0),
])
def test_engineering_units_convert_to_si(text, dimension, si):
    assert parse_quantity(text, dimension) == pytest.approx(si, rel=1e-14)


def test_parse_unit():
    assert parse_unit("mm", "length") == pytest.approx(1e-3)
    assert parse_unit("Hz", "angular_speed") == pytest.approx(TWO_PI)
    assert parse_unit("", "dimensionless") == 1.0
    with pytest.raises(ConfigError):
        parse_unit("", "length")


# --- value lists ----------------------------------------------------------------------------------------------

@pytest.mark.parametrize("text,dimension,kind,si,unit", [
    ("0.1..0.3mm", "length", "range", (1e-4, 3e-4), "mm"),
    ("0.1mm..0.3mm", "length", "range", (1e-4, 3e-4), "mm"),
    ("0.1 mm .. 0.03 cm", "length", "range", (1e-4, 3e-4), "cm"),
    ("60..180rpm", "angular_speed", "range", (TWO_PI, 3 * TWO_PI), "rpm"),
    ("-10..10 deg", "angle", "range", (-math.pi / 18, math.pi / 18), "deg"),
    ("100,120,140rpm", "angular_speed", "levels", tuple(x * TWO_PI / 60 for x in (100, 120, 140)), "rpm"),
    ("100rpm,120rpm", "angular_speed", "levels", (100 * TWO_PI / 60, 2 * TWO_PI), "rpm"),
    ("100rpm, 2 Hz", "angular_speed", "levels", (100 * TWO_PI / 60, 2 * TWO_PI), "Hz"),
    ("0.25mm+-0.05mm", "length", "normal", (2.5e-4, 5e-5), "mm"),
    ("0.25+-0.05 mm", "length", "normal", (2.5e-4, 5e-5), "mm"),
    ("0.25 ± 0.05 mm", "length", "normal", (2.5e-4, 5e-5), "mm"),
    ("0.1,0.2,0.3", "dimensionless", "levels", (0.1, 0.2, 0.3), ""),
])
def test_value_list_syntax(text, dimension, kind, si, unit):
    spec = parse_value_list(text, dimension, "--param x")
    assert isinstance(spec, ValueSpec) and spec.kind == kind and spec.unit == unit
    assert spec.values == pytest.approx(si, rel=1e-14)
    assert spec.in_unit()[-1] == pytest.approx(spec.values[-1] / parse_unit(unit or "", dimension) if unit
                                               else spec.values[-1])


@pytest.mark.parametrize("text,needle", [
    ("100,120kg", "item '120kg'"),  # the wrong-dimension item is named
    ("100rpm,120kg", "item '120kg'"),
    ("100,120,100rpm", "levels must be distinct"),
    ("100rpm,1.6666666666666667 Hz,120rpm", "levels must be distinct"),  # same speed in two units
    ("180..60rpm", "needs LO < HI"),
    ("60..60rpm", "needs LO < HI"),
    ("120+--5 rpm", "standard deviation must be >= 0"),
    ("100rpm,120", "last item has no unit"),
    ("100,120", "has no unit"),
    ("60...180rpm", "two dots"),
    ("60..120..180rpm", "one '..'"),
    ("100,,120rpm", "an item is empty"),
    ("fast..faster", "does not start with a number"),
    ("9**9**9..1 rpm", "cannot read"),
    ("1," * 200 + "2 rpm", "too long"),
])
def test_value_list_refusals(text, needle):
    with pytest.raises(ConfigError) as exc:
        parse_value_list(text, "angular_speed", "--param cam.speed")
    assert needle in str(exc.value) and str(exc.value).startswith("--param cam.speed: ")


def test_value_list_item_error_names_the_item():
    with pytest.raises(ConfigError, match=r"^f: item '120kg': '120 kg' has the wrong kind of unit \(it measures \[mass\]\)"):
        parse_value_list("100rpm,120kg,140rpm", "angular_speed", "f")


# --- plausibility ---------------------------------------------------------------------------------------------

def test_plausible_ranges_cover_every_dimension_and_the_reference_values():
    assert set(PLAUSIBLE) == set(DIMENSIONS)
    for dim in DIMENSIONS:
        lo, hi = plausible_range(dim)
        assert 0.0 <= lo < hi
    # values of the reference machine (reference.toml) and the slider-crank example are plausible
    for value, dim in [(0.08, "length"), (0.25e-3, "length"), (4 * math.pi, "angular_speed"),
                       (5000 * TWO_PI / 60, "angular_speed"), (1.1e9, "pressure"), (207e9, "pressure"),
                       (1e8, "stiffness"), (2000.0, "damping"), (0.0176, "inertia"), (1.8e-3, "mass"),
                       (850.0, "density"), (2 * math.pi / 3, "angle"), (0.0, "angle"), (0.3, "dimensionless")]:
        assert plausibility_warning(value, dim, "f") is None, (value, dim)


def test_plausibility_warns_on_unit_slips():
    msg = plausibility_warning(180.0, "angle", "cam.rise_angle")  # degrees typed as a plain (radian) number
    assert msg.startswith("cam.rise_angle: ") and "'180 deg'" in msg
    msg = plausibility_warning(80.0, "length", "cam.base_radius")  # mm typed as a plain (metre) number
    assert "implausibly large" in msg and "'80 mm'" in msg
    msg = plausibility_warning(1.1e-3, "pressure", "branch.elastic_modulus")  # "1.1 GPa" typed as "1.1 mPa"
    assert "implausibly small" in msg
    assert "factor of 1000" in plausibility_warning(1.8e-9, "mass", "fruit.mass")  # "1.8 ug" for "1.8 g"... x1e6
    assert plausibility_warning(-0.05, "length", "f") is None  # sign is config's business, magnitude is fine


# --- printing -------------------------------------------------------------------------------------------------

def test_format_quantity_and_factors():
    assert format_quantity(2.5e-4, "mm") == "0.25 mm"
    assert format_quantity(4 * math.pi, "rpm") == "120 rpm"
    for unit in ("um", "Hz", "N*m", "W", "J", "h"):
        assert unit in ENGINEERING_FACTORS
    # every printable unit that parse_quantity also reads gives the same SI factor
    dims = {"m": "length", "cm": "length", "mm": "length", "um": "length", "km": "length", "deg": "angle",
            "rad": "angle", "turn": "angle", "rpm": "angular_speed", "r/min": "angular_speed",
            "rev/s": "angular_speed", "rad/s": "angular_speed", "Hz": "frequency", "m/min": "speed",
            "km/h": "speed", "g": "mass", "N/mm": "stiffness", "GPa": "pressure", "g/cm^3": "density",
            "kN": "force", "N*m": "torque", "kJ": "energy", "kW": "power", "ms": "time", "min": "time",
            "h": "time", "%": "dimensionless", "kg*m^2": "inertia", "N*m*s/rad": "torsional_damping"}
    for unit, dim in dims.items():
        assert parse_unit(unit, dim) == pytest.approx(ENGINEERING_FACTORS[unit], rel=1e-14), unit


# --- properties -----------------------------------------------------------------------------------------------

@settings(max_examples=300, deadline=None)
@given(st.text(max_size=80), st.sampled_from(sorted(DIMENSIONS)))
def test_any_text_gives_a_finite_float_or_a_config_error(text, dimension):
    try:
        out = parse_quantity(text, dimension, "f")
    except ConfigError as exc:
        assert str(exc).startswith("f: ")
    else:
        assert isinstance(out, float) and math.isfinite(out)


@settings(max_examples=300, deadline=None)
@given(st.from_regex(r"\A[-+]?[0-9]{1,4}(\.[0-9]{0,3})?(e-?[0-9])? ?(mm|m|kg|s|N|rpm|Hz|deg|rad|%)"
                     r"([*/ ·](mm|m|kg|s|N|rad)(\^-?[1-4])?){0,3}\Z"),
       st.sampled_from(sorted(DIMENSIONS)))
def test_grammar_like_text_gives_a_finite_float_or_a_config_error(text, dimension):
    """A refusal names the field; a value is the number times what the unit alone gives (linear: no offset, no
    unit applied twice or to the exponent)."""
    try:
        out = parse_quantity(text, dimension, "f")
    except ConfigError as exc:
        assert str(exc).startswith("f: ")
        return
    assert math.isfinite(out)
    number = re.match(r"[-+]?[0-9]+(\.[0-9]*)?(e-?[0-9])?", text).group()
    per_unit = parse_quantity("1 " + text[len(number):].strip(), dimension, "f")
    assert out == pytest.approx(float(number) * per_unit, rel=1e-12, abs=0.0), (text, dimension)


@settings(max_examples=300, deadline=None)
@given(st.floats(allow_nan=False, allow_infinity=False))
def test_millimetre_round_trip_is_exact(x):
    text = f"{x!r} mm"
    if x != 0.0 and abs(x) * 1e-3 < 2.2250738585072014e-308:
        with pytest.raises(ConfigError, match="too small"):  # would underflow to a subnormal in metres
            parse_quantity(text, "length")
        return
    si = parse_quantity(text, "length")
    back = si / ENGINEERING_FACTORS["mm"]
    assert back == pytest.approx(x, rel=1e-12, abs=0.0)


def test_format_tolerance_writes_tolerances_as_people_do():
    from berryshaker.units import format_tolerance

    assert [format_tolerance(x) for x in (1e-5, 1e-7, 1e-10, 3e-3)] == ["1e-5", "1e-7", "1e-10", "3e-3"]


# ---- issue #42: nothing silently misread -------------------------------------------------------------------
def test_units_required_refuses_bare_numbers_with_the_fix():
    from berryshaker.units import bare_number_message

    with pytest.raises(ConfigError, match=r'cam.speed: 120 is a bare number; give a unit, e.g. speed = "120 rpm" '
                                          r'\(berryshaker 0.x read a bare number as SI: 120 rad/s = "1145.92 rpm"\)'):
        parse_quantity(120, "angular_speed", "cam.speed", units_required=True)
    assert parse_quantity(120, "angular_speed", "cam.speed") == 120.0  # inside the package: SI
    assert parse_quantity(0, "length", "engagement", units_required=True) == 0.0  # 0 in every unit
    assert parse_quantity(0.3, "dimensionless", "mu", units_required=True) == 0.3
    assert bare_number_message(1.8, "mass", "mass", "g").startswith('1.8 is a bare number; give a unit, e.g. '
                                                                    'mass = "1.8 g"')


@pytest.mark.parametrize("text,needle", [("1,5 kW", "not a comma"), ("1.5 kW * 1000", "expected a unit name"),
                                         ("1.5 kW*1000", "expected a unit name"), ("9**9**9 W", "expected a unit")])
def test_decimal_comma_and_arithmetic_are_refused(text, needle):
    with pytest.raises(ConfigError, match=needle):
        parse_quantity(text, "power", "rated_power")


def test_limits_name_the_field_and_the_range():
    from berryshaker.units import LIMITS, check_limits

    assert check_limits(0.08, "length", "cam.base_radius") == 0.08
    assert check_limits(0.0, "length", "x") == 0.0
    with pytest.raises(ConfigError, match=r"clearance.C.diameter: 1e\+308 m is too large for a length "
                                          r"\(berryshaker accepts 0.001 mm .. 1e\+05 mm\)"):
        check_limits(1e308, "length", "clearance.C.diameter")
    with pytest.raises(ConfigError, match="too small"):
        check_limits(1e-300, "mass", "m")
    assert check_limits(1e-300, "torque", "t", lower=False) == 1e-300  # computed inside: upper limit only
    with pytest.raises(ConfigError, match="not a finite number"):
        check_limits(math.nan, "length", "x")
    assert all(0 <= lo < hi < math.inf for lo, hi in LIMITS.values())


def test_unit_dimension_and_factor_use_the_strict_grammar():
    from berryshaker.units import unit_dimension, unit_factor

    assert unit_dimension("mm") == "length" and unit_dimension("rpm") == "angular_speed"
    assert unit_dimension("%") == "dimensionless"
    for bad in ("9**9**9", "mm*1000", "m**9", "(m", "", "x" * 100):
        assert unit_dimension(bad) is None
    assert unit_factor("cm", "mm") == pytest.approx(10.0)
    assert unit_factor("mm", "mm") == 1.0
    with pytest.raises(ConfigError, match="cannot be read as 'mm'"):
        unit_factor("kg", "mm", "row 2")
