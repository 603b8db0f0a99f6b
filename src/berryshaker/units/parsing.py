"""The strict quantity grammar and the dimension table: one value or one unit, read into SI
(see :mod:`berryshaker.units` for the rules)."""

from __future__ import annotations

import functools
import math
import numbers
import re
import sys

from berryshaker.errors import ConfigError
from berryshaker.units.formatting import _TWO_PI, ENGINEERING_FACTORS, format_quantity

#: dimension name -> (pint dimensionality string, SI unit name used in messages and printing)
DIMENSIONS: dict[str, tuple[str, str]] = {
    "length": ("[length]", "m"),
    "angle": ("", "rad"),
    "angular_speed": ("1/[time]", "rad/s"),
    "frequency": ("1/[time]", "Hz"),
    "speed": ("[length]/[time]", "m/s"),
    "acceleration": ("[length]/[time]**2", "m/s^2"),
    "mass": ("[mass]", "kg"),
    "inertia": ("[mass]*[length]**2", "kg*m^2"),
    "stiffness": ("[mass]/[time]**2", "N/m"),
    "damping": ("[mass]/[time]", "N*s/m"),
    "torsional_stiffness": ("[mass]*[length]**2/[time]**2", "N*m/rad"),
    "torsional_damping": ("[mass]*[length]**2/[time]", "N*m*s/rad"),
    "pressure": ("[mass]/[length]/[time]**2", "Pa"),
    "density": ("[mass]/[length]**3", "kg/m^3"),
    "force": ("[mass]*[length]/[time]**2", "N"),
    "torque": ("[mass]*[length]**2/[time]**2", "N*m"),
    "energy": ("[mass]*[length]**2/[time]**2", "J"),
    "power": ("[mass]*[length]**2/[time]**3", "W"),
    "time": ("[time]", "s"),
    "dimensionless": ("", "1"),
}

#: dimension -> examples of accepted strings, quoted in error messages
EXAMPLES: dict[str, str] = {
    "length": "'0.25 mm', '80 mm', '1.2 m'",
    "angle": "'180 deg', '3.14 rad', '0.5 turn'",
    "angular_speed": "'120 rpm', '120 r/min', '2 Hz' (= rev/s), '12.6 rad/s'",
    "frequency": "'2 Hz', '120 rpm', '12.6 rad/s'",
    "speed": "'30 m/min', '0.5 m/s', '1.8 km/h'",
    "acceleration": "'9.81 m/s^2'",
    "mass": "'1.8 g', '2.0 kg'",
    "inertia": "'0.0176 kg*m^2', '25 kg*cm^2'",
    "stiffness": "'1e8 N/m', '50 kN/mm'",
    "damping": "'2000 N*s/m'",
    "torsional_stiffness": "'200 N*m/rad'",
    "torsional_damping": "'20 N*m*s/rad'",
    "pressure": "'1.1 GPa', '3 MPa'",
    "density": "'850 kg/m^3', '0.85 g/cm^3'",
    "force": "'1.0 N', '2 kN'",
    "torque": "'15 N*m'",
    "energy": "'3 J', '1 kJ'",
    "power": "'750 W', '1.5 kW'",
    "time": "'10 s', '5 ms', '2 h'",
    "dimensionless": "'0.3', '5 %'",
}

#: dimension -> unit used when a value is quoted back to the user (keys of :data:`ENGINEERING_FACTORS`)
DISPLAY_UNITS: dict[str, str] = {
    "length": "mm", "angle": "deg", "angular_speed": "rpm", "frequency": "Hz", "speed": "m/s",
    "acceleration": "m/s^2", "mass": "kg", "inertia": "kg*m^2", "stiffness": "N/m", "damping": "N*s/m",
    "torsional_stiffness": "N*m/rad", "torsional_damping": "N*m*s/rad", "pressure": "Pa",
    "density": "kg/m^3", "force": "N", "torque": "N*m", "energy": "J", "power": "W", "time": "s",
    "dimensionless": "1",
}

#: longest string accepted by :func:`parse_quantity`, and by :func:`parse_value_list`
MAX_QUANTITY_CHARS = 64
MAX_LIST_CHARS = 256
#: largest power allowed on a unit name ("m^3", "s**-2")
MAX_UNIT_POWER = 4

#: unit names pint does not know, mapped to the pint name (revolution shorthands used on harvester drives)
UNIT_ALIASES: dict[str, str] = {"r": "revolution", "rev": "revolution", "revs": "revolution"}

_NUMBER = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
_UNIT_TOKEN = re.compile(
    r"(?P<space>\s+)|(?P<name>[A-Za-z_µμΩ]+|°|%)|(?P<pow>\*\*|\^)|(?P<mul>[*·⋅])|(?P<div>/)"
    r"|(?P<lp>\()|(?P<rp>\))|(?P<int>[+-]?[0-9]+)|(?P<sup>⁻?[⁰¹²³⁴⁵⁶⁷⁸⁹]+)"
)
_SUPERSCRIPT = str.maketrans("⁻⁰¹²³⁴⁵⁶⁷⁸⁹", "-0123456789")
# base units pint may leave in a dimensionless result; only the radian is meaningful here
_PHYSICAL_BASE = {"meter", "kilogram", "second", "radian"}


@functools.lru_cache(maxsize=1)
def _registry():
    """The shared pint unit registry (created once; pint is imported lazily)."""
    import pint

    ureg = pint.UnitRegistry()
    return ureg


def _short(value: object, limit: int = 40) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _check_dimension(dimension: str) -> None:
    if dimension not in DIMENSIONS:
        raise ValueError(f"unknown dimension {dimension!r}; known: {', '.join(DIMENSIONS)}")


def _noun(dimension: str) -> str:
    words = "dimensionless number" if dimension == "dimensionless" else dimension.replace("_", " ")
    return ("an " if words[0] in "aeiou" else "a ") + words


def _expected(dimension: str) -> str:
    return f"expected {_noun(dimension)}, e.g. {EXAMPLES[dimension]}"


class _UnitSyntaxError(Exception):
    """Internal: the unit text does not follow the grammar or is unknown (message says why)."""


class _WrongKindError(_UnitSyntaxError):
    """Internal: a valid unit of another dimension (message says what it measures)."""


def _tokenise_unit(text: str) -> list[tuple[str, str]]:
    tokens: list[tuple[str, str]] = []
    pos = 0
    while pos < len(text):
        m = _UNIT_TOKEN.match(text, pos)
        if m is None:
            hint = " (use a decimal point, not a comma)" if text[pos] == "," else ""
            raise _UnitSyntaxError(f"unexpected character {text[pos]!r}{hint}")
        if m.lastgroup is not None and m.lastgroup != "space":
            tokens.append((m.lastgroup, m.group()))
        pos = m.end()
    return tokens


def _parse_unit_tokens(tokens: list[tuple[str, str]]) -> tuple[tuple[str, int], ...]:
    """Unit grammar -> sorted (name, power) pairs.

    unit   := ["1"] "/" term_list | term_list
    term_list := factor (("*" | "·" | "/" | juxtaposition) factor)*      (left to right)
    factor := (name | "(" term_list ")") [("^" | "**") int | superscript]  (parentheses: one level)
    """
    n = len(tokens)
    pos = 0

    def peek() -> str | None:
        return tokens[pos][0] if pos < n else None

    def exponent() -> int:
        nonlocal pos
        kind = peek()
        if kind == "pow":
            pos += 1
            if peek() != "int":
                raise _UnitSyntaxError("a power must be a small whole number, e.g. 'm^3' or 's**-1'")
            text = tokens[pos][1]
        elif kind == "sup":
            text = tokens[pos][1].translate(_SUPERSCRIPT)
        else:
            return 1
        pos += 1
        p = int(text)
        if p == 0 or abs(p) > MAX_UNIT_POWER:
            raise _UnitSyntaxError(f"power {text} not allowed (use a whole number from 1 to {MAX_UNIT_POWER}, "
                                   f"or its negative)")
        return p

    def factor(depth: int) -> dict[str, int]:
        nonlocal pos
        kind = peek()
        if kind == "name":
            out = {tokens[pos][1]: 1}
            pos += 1
        elif kind == "lp":
            if depth >= 1:
                raise _UnitSyntaxError("at most one level of parentheses")
            pos += 1
            out = term_list(depth + 1)
            if peek() != "rp":
                raise _UnitSyntaxError("missing ')'")
            pos += 1
        else:
            got = "end of text" if kind is None else repr(tokens[pos][1])
            raise _UnitSyntaxError(f"expected a unit name at {got}")
        p = exponent()
        return {k: v * p for k, v in out.items()}

    def term_list(depth: int, sign: int = 1) -> dict[str, int]:
        nonlocal pos
        out: dict[str, int] = {}
        while True:
            for k, v in factor(depth).items():
                out[k] = out.get(k, 0) + sign * v
            kind = peek()
            if kind is None or kind == "rp":
                return out
            if kind == "mul":
                sign = 1
                pos += 1
            elif kind == "div":
                sign = -1
                pos += 1
            elif kind in ("name", "lp"):
                sign = 1  # "kg m^2", "N s/m"
            else:
                raise _UnitSyntaxError(f"unexpected {tokens[pos][1]!r}")

    if n > 1 and tokens[0] == ("int", "1") and tokens[1][0] == "div":
        pos = 1  # "1/s", "120 1/min"
    lead = 1
    if peek() == "div":
        lead = -1  # "2/s": the number is the numerator
        pos += 1
    powers = term_list(0, lead)
    if pos != n:
        raise _UnitSyntaxError("unmatched ')'" if tokens[pos][0] == "rp" else f"unexpected {tokens[pos][1]!r}")
    return tuple(sorted((k, v) for k, v in powers.items() if v != 0))


@functools.lru_cache(maxsize=1024)
def _unit_si(powers: tuple[tuple[str, int], ...], dimension: str) -> float:
    """SI value of one unit (given as name powers) for ``dimension``; raises _UnitSyntaxError with the reason."""
    want = DIMENSIONS[dimension][0]
    ureg = _registry()
    unit = ureg.Unit("")
    for name, p in powers:
        try:
            unit = unit * ureg.Unit(UNIT_ALIASES.get(name, name)) ** p
        except Exception:  # noqa: BLE001 - pint raises several types for unknown names
            raise _UnitSyntaxError(f"unknown unit {name!r}") from None
    try:
        one = ureg.Quantity(1.0, unit).to_base_units()
        two = ureg.Quantity(2.0, unit).to_base_units()
        dims_ok = unit.dimensionality == ureg.get_dimensionality(want)
    except Exception as exc:  # noqa: BLE001 - offset/logarithmic units refuse conversion
        raise _UnitSyntaxError(f"unit {unit} cannot be used here ({exc})") from None
    factor = float(one.magnitude)
    if not (math.isfinite(factor) and factor > 0 and math.isclose(float(two.magnitude), 2.0 * factor,
                                                                   rel_tol=1e-12)):
        raise _UnitSyntaxError(f"unit {unit} is not a plain multiple of an SI unit (offset or logarithmic)")
    if not dims_ok:
        raise _WrongKindError(f"it measures {unit.dimensionality}")
    base = dict(one._units)
    odd = sorted(set(base) - _PHYSICAL_BASE)
    if odd:
        raise _UnitSyntaxError(f"unit {unit} counts {', '.join(odd)}, not a physical quantity")
    rad = base.get("radian", 0)
    if dimension == "angle":
        if rad != 1:
            raise _WrongKindError("it has no angle unit")
    elif dimension == "angular_speed":
        if rad == 0:
            factor *= _TWO_PI  # Hz, 1/s, s^-1, 1/min: revolutions per time
        elif rad != 1:
            raise _WrongKindError(f"angle power {rad}")
    elif dimension == "frequency":
        if rad == 1:
            factor /= _TWO_PI  # rpm, rad/s -> cycles per second
        elif rad != 0:
            raise _WrongKindError(f"angle power {rad}")
    elif dimension in ("torsional_stiffness", "torsional_damping"):
        if rad not in (0, -1):  # "N*m/rad" and "N*m" both in use
            raise _WrongKindError(f"angle power {rad}")
    elif rad != 0:
        raise _WrongKindError("an angle unit does not belong here")
    return factor


def _split_number(text: str) -> tuple[str, str] | None:
    """``"0.25 mm"`` -> ``("0.25", "mm")``; None when the text does not start with a decimal number."""
    m = _NUMBER.match(text)
    if m is None:
        return None
    return m.group(), text[m.end():].strip()


def bare_number_message(value: float, dimension: str, key: str, unit: str | None = None) -> str:
    """The error for a bare number where a unit is required, with the fix: ``speed = "120 rpm"``.

    The example keeps the number and takes ``unit`` (default: the dimension's display unit,
    :data:`DISPLAY_UNITS`); the SI reading that berryshaker 0.x made of it is shown beside, so an old file's
    author sees both readings.

    Parameters
    ----------
    value : float
        The bare number as written (1: no unit).
    dimension : str
        One of :data:`DIMENSIONS`.
    key : str
        The field's name in the file (``speed``).
    unit : str, optional
        The unit of the example (default: the dimension's display unit).

    Returns
    -------
    str
        The message (without the field's prefix).
    """
    unit = unit or DISPLAY_UNITS[dimension]
    si = DIMENSIONS[dimension][1]
    number = f"{float(value):.6g}"
    text = f"{number} is a bare number; give a unit, e.g. {key} = \"{number} {unit}\""
    if unit in ENGINEERING_FACTORS and ENGINEERING_FACTORS[unit] != 1.0 and math.isfinite(float(value)):
        text += (f" (berryshaker 0.x read a bare number as SI: {number} {si} = "
                 f"\"{format_quantity(float(value), unit)}\")")
    return text


def parse_quantity(value: object, dimension: str, field: str = "value", units_required: bool = False) -> float:
    """Convert a plain SI number or a string "number unit" into an SI float, strictly.

    Parameters
    ----------
    value : int, float or str
        A plain number is taken as SI (m, rad, rad/s, kg, ...) unless ``units_required``.  A string is
        ``[sign]number[exponent] [unit]``,
        e.g. ``"0.25 mm"``, ``"120 rpm"``, ``"120 r/min"``, ``"2 Hz"``, ``"1.1 GPa"``, ``"1e8 N/m"``,
        ``"0.0176 kg*m^2"``, ``"5 %"``.  No arithmetic is evaluated; at most :data:`MAX_QUANTITY_CHARS` chars.
    dimension : str
        One of :data:`DIMENSIONS` (``"length"``, ``"angle"``, ``"angular_speed"``...).
    field : str
        Name of the field, used at the start of every error message (``"cam.stroke: ..."``).
    units_required : bool
        Refuse a plain number other than 0 for every dimension except ``dimensionless`` (what a user wrote in
        a machine file, a sheet or on the command line: a bare ``120`` for a speed is not silently 120 rad/s;
        a bare 0 is zero in every unit).

    Returns
    -------
    float
        The finite value in SI units.  For ``angular_speed`` a unit without an angle in it (Hz, 1/s, s^-1)
        means revolutions per time: ``"2 Hz"`` -> 2 * 2 pi rad/s.  For ``frequency`` (SI unit Hz = 1/s) an
        angular unit is divided by 2 pi: ``"120 rpm"`` -> 2 Hz.

    Raises
    ------
    ConfigError
        Not a number or a string (bool, list, dict, None), NaN or infinity, text that is not "number unit",
        an unknown or non-linear unit, a unit of another dimension, a string without a unit where one is
        needed (every dimension except ``dimensionless``), a bare number where ``units_required``, or a value
        that over/underflows in SI.
    """
    _check_dimension(dimension)
    if isinstance(value, bool) or not isinstance(value, (numbers.Real, str)):
        plain = "" if units_required else f" or a plain number in SI ({DIMENSIONS[dimension][1]})"
        raise ConfigError(f"{field}: got {_short(value)} ({type(value).__name__}); {_expected(dimension)}{plain}")
    if not isinstance(value, str):
        try:
            out = float(value)
        except (OverflowError, ValueError, TypeError):
            out = math.nan
        if not math.isfinite(out):
            raise ConfigError(f"{field}: {_short(value)} is not a finite number; {_expected(dimension)}")
        if units_required and dimension != "dimensionless" and out != 0.0:  # a bare 0 is 0 in every unit
            raise ConfigError(f"{field}: {bare_number_message(out, dimension, field.rsplit('.', 1)[-1])}")
        return out
    text = value.strip()
    if not text:
        raise ConfigError(f"{field}: empty value; {_expected(dimension)}")
    if len(text) > MAX_QUANTITY_CHARS:
        raise ConfigError(f"{field}: {_short(value)} is too long ({len(text)} characters, at most "
                          f"{MAX_QUANTITY_CHARS}); {_expected(dimension)}")
    split = _split_number(text)
    if split is None:
        raise ConfigError(f"{field}: cannot read {value!r}: it must start with a number; {_expected(dimension)}")
    number_text, unit_text = split
    number = float(number_text)
    if not math.isfinite(number):
        raise ConfigError(f"{field}: {value!r} is not a finite number; {_expected(dimension)}")
    if number == 0.0 and re.search(r"[1-9]", re.split(r"[eE]", number_text)[0]):  # "1e-999": not zero, but 0.0
        raise ConfigError(f"{field}: {value!r} is too small to represent (underflow: it would be read as 0); "
                          f"{_expected(dimension)}")
    if not unit_text:
        if dimension != "dimensionless":
            raise ConfigError(f"{field}: {value!r} has no unit; give a unit, e.g. {EXAMPLES[dimension]}")
        return number
    try:
        factor = _unit_si(_parse_unit_tokens(_tokenise_unit(unit_text)), dimension)
    except _WrongKindError as exc:
        raise ConfigError(f"{field}: {value!r} has the wrong kind of unit ({exc}); "
                          f"{_expected(dimension)}") from None
    except _UnitSyntaxError as exc:
        raise ConfigError(f"{field}: cannot read {value!r}: {exc}; {_expected(dimension)}") from None
    out = number * factor
    if not math.isfinite(out):
        raise ConfigError(f"{field}: {value!r} is too large to represent in SI; {_expected(dimension)}")
    if number != 0.0 and abs(out) < sys.float_info.min:
        raise ConfigError(f"{field}: {value!r} is too small to represent in SI (underflow); "
                          f"{_expected(dimension)}")
    return out


def parse_unit(unit: str, dimension: str, field: str = "unit") -> float:
    """SI value of one ``unit`` of ``dimension`` (``parse_unit("mm", "length") -> 0.001``), same rules as
    :func:`parse_quantity`; ``""`` is allowed only for ``dimensionless`` (-> 1.0).

    Parameters
    ----------
    unit : str
        A unit of the strict grammar.
    dimension : str
        One of :data:`DIMENSIONS`.
    field : str
        Name used at the start of error messages.

    Returns
    -------
    float
        The SI value of one ``unit`` (SI units of ``dimension``).

    Raises
    ------
    ConfigError
        Unknown unit or one of another dimension.
    """
    _check_dimension(dimension)
    if not isinstance(unit, str):
        raise ConfigError(f"{field}: expected a unit name, got {_short(unit)}")
    if not unit.strip() and dimension == "dimensionless":
        return 1.0
    return parse_quantity(f"1 {unit.strip()}", dimension, field)


def unit_dimension(unit: str) -> str | None:
    """The dimension of a unit written by a user.

    ``"mm"`` -> ``"length"``, ``"rpm"`` -> ``"angular_speed"``, ``"%"`` -> ``"dimensionless"``; ``"9**9**9"``,
    ``"kW*1000"`` -> None.

    Parameters
    ----------
    unit : str
        The unit's text.

    Returns
    -------
    str or None
        A key of :data:`DIMENSIONS`, or None when the text is not one unit of the strict grammar (no expression
        evaluation, at most :data:`MAX_QUANTITY_CHARS` characters) or measures nothing berryshaker knows.
    """
    if not isinstance(unit, str) or not unit.strip() or len(unit) > MAX_QUANTITY_CHARS:
        return None
    for dim in DIMENSIONS:
        try:
            parse_unit(unit, dim)
        except ConfigError:
            continue
        return dim
    return None


def unit_factor(unit: str, target: str, field: str = "unit") -> float:
    """How many ``target`` one ``unit`` is (``unit_factor("cm", "mm") -> 10``), by the strict grammar.

    Parameters
    ----------
    unit : str
        The unit given.
    target : str
        The unit wanted.
    field : str
        Name used at the start of error messages.

    Returns
    -------
    float
        The factor (1): a value in ``unit`` times it is the value in ``target``.

    Raises
    ------
    ConfigError
        Either text is not a unit, or the two measure different things; the message names ``field``.
    """
    if unit.strip() == target.strip():
        return 1.0
    dim = unit_dimension(target)
    if dim is None:
        raise ConfigError(f"{field}: {_short(target)} is not a unit berryshaker reads")
    try:
        return parse_unit(unit, dim, field) / parse_unit(target, dim, field)
    except ConfigError:
        raise ConfigError(f"{field}: unit {_short(unit)} cannot be read as {_short(target)} "
                          f"({_noun(dim)}); write the value in {target}") from None
