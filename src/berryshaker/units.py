"""Strict, unit-aware reading of every quantity a user types ("0.25 mm", "120 rpm", "1.1 GPa", "30 m/min").

Inside berryshaker every number is SI (m, kg, s, rad, N).  Machine files and the command line give every
dimensional value as a string "number unit"; a bare number is an error there (``units_required``: the message
shows the fix, ``speed = "120 rpm"``), and only dimensionless values (coefficients, fractions, counts, ratios)
are plain numbers.  Inside the package (descriptions rebuilt from their SI dump) a plain number is SI.  This
module is the one entry point for every field, option and sheet cell:

* :func:`parse_quantity` reads one value, checks its physical dimension and returns an SI float;
  :func:`check_limits` and :data:`LIMITS` bound it to what berryshaker can compute with.
* :func:`parse_value_list` reads sweep / command-line value lists (``0.1..0.3mm``, ``100,120,140rpm``,
  ``0.25mm+-0.05mm``) into a :class:`ValueSpec`.
* :data:`PLAUSIBLE`, :func:`plausible_range` and :func:`plausibility_warning` flag values that are orders
  of magnitude away from anything a harvester drive has (a unit slip such as metres for millimetres).
* :func:`format_quantity` and :data:`ENGINEERING_FACTORS` print SI values in engineering units.

Safety rules (issue "never compute on a misread input"):

* No expression evaluation.  A string is accepted only as ``[sign] decimal-number [exponent] [unit]`` where
  the unit is unit names joined by ``*``, ``/``, ``·`` or spaces, with small integer powers (``^2``, ``**-1``,
  ``²``) and at most one level of parentheses.  No decimal comma ("1,5 kW" is refused, not read as 15 kW).  The grammar is checked by a tokeniser here; pint (a maintained
  units library) is only asked to look up single unit *names* (``ureg.Unit("mm")``), never to evaluate the
  raw text, so ``"9**9**9 mm"`` is refused at once instead of hanging.  Input length is bounded.
* Only linear (multiplicative) units are accepted: offset and logarithmic units (degC, dB) are refused.
* Angles and angular speeds: pint treats the radian as dimensionless, so "2 Hz" (= 2/s) would silently become
  2 rad/s.  Here, for an ``angular_speed``, a unit without an angle in it (``Hz``, ``1/s``, ``s^-1``, ``1/min``)
  counts **revolutions** per time, like ``rps`` and ``rpm``: "2 Hz" is 2 rev/s = 4 pi rad/s.  ``rad/s`` and
  ``deg/s`` are taken as written.  An ``angle`` string must carry an angle unit ("180 deg", "3.1 rad",
  "0.5 turn"); "180" alone is refused.  A plain number (not a string) given inside the package stays SI
  (rad, rad/s); in a machine file it is refused (``units_required``).
* ``dimensionless`` takes plain numbers and percentages ("5 %" -> 0.05).

long module: the strict quantity grammar, the dimension table and the value-list parser are one parser; splitting would separate the grammar from its only users.
"""

from __future__ import annotations

import functools
import math
import numbers
import re
import sys
from dataclasses import dataclass

from berryshaker.errors import ConfigError

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
_TWO_PI = 2.0 * math.pi
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
    tokens = []
    pos = 0
    while pos < len(text):
        m = _UNIT_TOKEN.match(text, pos)
        if m is None:
            hint = " (use a decimal point, not a comma)" if text[pos] == "," else ""
            raise _UnitSyntaxError(f"unexpected character {text[pos]!r}{hint}")
        if m.lastgroup != "space":
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
    """The dimension (a key of :data:`DIMENSIONS`) of a unit written by a user, or None when the text is not
    one unit of the strict grammar (no expression evaluation, at most :data:`MAX_QUANTITY_CHARS` characters)
    or measures nothing berryshaker knows.  ``"mm"`` -> ``"length"``, ``"rpm"`` -> ``"angular_speed"``,
    ``"%"`` -> ``"dimensionless"``; ``"9**9**9"``, ``"kW*1000"`` -> None.
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


@dataclass(frozen=True)
class ValueSpec:
    """Values for a sweep or a command-line option, read by :func:`parse_value_list`.

    Attributes
    ----------
    kind : str
        ``"range"`` (values = (lo, hi), lo < hi), ``"levels"`` (distinct values, in the order given) or
        ``"normal"`` (values = (mean, sd), sd >= 0; for Monte Carlo tolerances).
    values : tuple of float
        SI values.
    unit : str
        Display unit as the user wrote it (the last unit given), ``""`` for a unitless dimensionless list.
    unit_si : float
        SI value of one ``unit``, so ``values[i] / unit_si`` is in the user's unit.
    dimension : str
        The dimension the values were checked against.
    """

    kind: str
    values: tuple[float, ...]
    unit: str
    unit_si: float
    dimension: str

    def in_unit(self) -> tuple[float, ...]:
        """The values in the display unit (e.g. mm, rpm)."""
        return tuple(v / self.unit_si for v in self.values)


def parse_value_list(text: str, dimension: str, field: str = "value") -> ValueSpec:
    """Read a range, a list of levels or a mean +- sd, with units, into SI values.

    Accepted forms: ``0.1..0.3mm``, ``0.1mm..0.3mm``, ``60..180rpm`` (range, LO < HI); ``100,120,140rpm``,
    ``100rpm,120rpm`` (levels, distinct); ``0.25mm+-0.05mm``, ``0.25+-0.05 mm``, ``0.25 ± 0.05 mm`` (normal,
    SD >= 0).  A unit may be written on every item or only on the last one (the others take it); units of the
    same dimension may be mixed (each item is converted).  Every item is read by :func:`parse_quantity`.

    Parameters
    ----------
    text : str
        The list, at most :data:`MAX_LIST_CHARS` characters.
    dimension : str
        One of :data:`DIMENSIONS`.
    field : str
        Name used at the start of error messages (e.g. ``"--param cam.speed"``).

    Returns
    -------
    ValueSpec

    Raises
    ------
    ConfigError
        Unreadable text, an item of the wrong dimension (the item is named), duplicate levels, LO >= HI,
        a negative SD, or a unit on some items but not on the last.
    """
    _check_dimension(dimension)
    forms = "LO..HI unit, V1,V2,... unit or MEAN+-SD unit"
    if not isinstance(text, str):
        raise ConfigError(f"{field}: expected text such as {forms}, got {_short(text)}")
    s = text.strip()
    if not s:
        raise ConfigError(f"{field}: empty value; expected {forms}")
    if len(s) > MAX_LIST_CHARS:
        raise ConfigError(f"{field}: value too long ({len(s)} characters, at most {MAX_LIST_CHARS})")
    s = s.replace("±", "+-")
    if "..." in s:
        raise ConfigError(f"{field}: cannot read {text!r}; a range is LO..HI (two dots), e.g. '0.1..0.3 mm'")
    if ".." in s:
        kind, items = "range", s.split("..")
        if len(items) != 2:
            raise ConfigError(f"{field}: cannot read {text!r}; a range has one '..', e.g. '0.1..0.3 mm'")
    elif "+-" in s:
        kind, items = "normal", s.split("+-")
        if len(items) != 2:
            raise ConfigError(f"{field}: cannot read {text!r}; expected MEAN+-SD, e.g. '0.25+-0.05 mm'")
    else:
        kind, items = "levels", s.split(",")
    items = [it.strip() for it in items]
    if any(not it for it in items):
        raise ConfigError(f"{field}: cannot read {text!r}: an item is empty; expected {forms}")
    split = []
    for it in items:
        parts = _split_number(it)
        if parts is None:
            raise ConfigError(f"{field}: item {it!r} of {text!r} does not start with a number; expected {forms}")
        split.append(parts)
    unit = split[-1][1]
    if not unit and any(u for _, u in split):
        raise ConfigError(f"{field}: in {text!r} the last item has no unit; write the unit on every item "
                          f"or only once at the end, e.g. '100,120,140 rpm'")
    values = [0.0] * len(items)
    # items that carry their own unit first, so a wrong unit is reported on the item where it was written
    order = sorted(range(len(items)), key=lambda i: not split[i][1])
    for i in order:
        num, u = split[i]
        values[i] = parse_quantity(f"{num} {u or unit}".strip(), dimension, f"{field}: item {items[i]!r}")
    unit_si = parse_unit(unit, dimension, f"{field}: unit {unit!r}")
    if kind == "range" and not values[0] < values[1]:
        raise ConfigError(f"{field}: the range {text!r} needs LO < HI")
    if kind == "normal" and not values[1] >= 0.0:
        raise ConfigError(f"{field}: in {text!r} the standard deviation must be >= 0")
    if kind == "levels":
        for i, a in enumerate(values):
            for j in range(i):
                if math.isclose(a, values[j], rel_tol=1e-12, abs_tol=0.0):
                    raise ConfigError(f"{field}: levels must be distinct; {items[i]!r} repeats {items[j]!r}")
    return ValueSpec(kind, tuple(values), unit, unit_si, dimension)


#: SI magnitudes (lo, hi) that a value may plausibly have in a harvester drive model.  Deliberately wide
#: (several orders of magnitude around usual values); a value outside is most likely a unit slip.
#: angular_speed reaches 10000 rpm so the Flores & Ambrosio slider-crank benchmark (5000 rpm) passes.
PLAUSIBLE: dict[str, tuple[float, float]] = {
    "length": (1e-6, 10.0),  # 1 um .. 10 m
    "angle": (1e-5, 4.0 * math.pi),  # 0.0006 deg .. two turns
    "angular_speed": (0.1 * _TWO_PI / 60.0, 1e4 * _TWO_PI / 60.0),  # 0.1 .. 10000 rpm
    "frequency": (1e-3, 1e5),  # Hz
    "speed": (1e-4, 100.0),  # m/s
    "acceleration": (1e-3, 1e6),  # m/s^2
    "mass": (1e-5, 1e4),  # 10 mg .. 10 t
    "inertia": (1e-9, 1e4),  # kg m^2
    "stiffness": (1.0, 1e12),  # N/m
    "damping": (0.0, 1e7),  # N s/m
    "torsional_stiffness": (1e-3, 1e9),  # N m/rad
    "torsional_damping": (0.0, 1e6),  # N m s/rad
    "pressure": (1e5, 1e12),  # Pa (moduli: fruit tissue .. steel)
    "density": (10.0, 3e4),  # kg/m^3
    "force": (1e-4, 1e7),  # N
    "torque": (1e-4, 1e6),  # N m
    "energy": (1e-9, 1e9),  # J
    "power": (1e-3, 1e7),  # W
    "time": (1e-9, 1e9),  # s (1 ns .. 30 years)
    "dimensionless": (0.0, 1e4),
}


#: SI magnitudes (lo, hi) berryshaker accepts at all for a nonzero value of each dimension (zero passes where
#: the field allows it).  Much wider than :data:`PLAUSIBLE` (a value outside PLAUSIBLE is only a warning), and
#: narrow enough that nothing downstream overflows or loses every digit: a 1e308 m diameter, a 1e-300 kg mass
#: are refused where they are read (the field named), not met as overflow, LAPACK noise or NaN in a result.
LIMITS: dict[str, tuple[float, float]] = {
    "length": (1e-6, 100.0),  # 1 um .. 100 m
    "angle": (1e-9, 20.0 * math.pi),  # .. ten turns
    "angular_speed": (1e-6, 1e6 * _TWO_PI / 60.0),  # .. 1 000 000 rpm
    "frequency": (1e-6, 1e9),  # Hz
    "speed": (1e-9, 1e4),  # m/s
    "acceleration": (1e-6, 1e9),  # m/s^2
    "mass": (1e-9, 1e6),  # 1 ug .. 1000 t
    "inertia": (1e-15, 1e6),  # kg m^2
    "stiffness": (1e-6, 1e15),  # N/m
    "damping": (1e-9, 1e12),  # N s/m
    "torsional_stiffness": (1e-9, 1e12),  # N m/rad
    "torsional_damping": (1e-9, 1e9),  # N m s/rad
    "pressure": (1e-3, 1e13),  # Pa (a 10 TPa modulus is ten times diamond's)
    "density": (1e-3, 1e5),  # kg/m^3
    "force": (1e-9, 1e9),  # N
    "torque": (1e-9, 1e9),  # N m
    "energy": (1e-12, 1e12),  # J
    "power": (1e-6, 1e9),  # W
    "time": (1e-12, 1e10),  # s (1 ps .. 300 years)
    "dimensionless": (0.0, 1e9),
}


def check_limits(value_si: float, dimension: str, field: str = "value", lower: bool = True) -> float:
    """``value_si`` if it is finite and zero or within :data:`LIMITS` of ``dimension`` (by magnitude).

    ``lower=False`` checks only the upper limit (values computed inside the package, where a torque table
    may pass within 1e-12 N m of zero; what a user types is checked both ways).

    Raises
    ------
    ConfigError
        Not finite, or outside the limits; the message names the field, the value and the accepted range
        in engineering units.
    """
    _check_dimension(dimension)
    v = float(value_si)
    if not math.isfinite(v):
        raise ConfigError(f"{field}: {_short(value_si)} is not a finite number")
    lo, hi = LIMITS[dimension]
    if v == 0.0 or (lo <= abs(v) or not lower) and abs(v) <= hi:
        return v
    unit = DISPLAY_UNITS[dimension]

    def show(x: float) -> str:
        if unit == "1":
            return f"{x:.3g}"
        shown = format_quantity(x, unit, 3)
        return shown if math.isfinite(x / ENGINEERING_FACTORS[unit]) else f"{x:.3g} {DIMENSIONS[dimension][1]}"

    side = "large" if abs(v) > hi else "small"
    raise ConfigError(f"{field}: {show(v)} is too {side} for {_noun(dimension)} (berryshaker accepts "
                      f"{show(lo)} .. {show(hi)}); check the number and its unit")


def plausible_range(dimension: str) -> tuple[float, float]:
    """(lo, hi) SI magnitudes plausible for ``dimension`` in a harvester drive (see :data:`PLAUSIBLE`)."""
    _check_dimension(dimension)
    return PLAUSIBLE[dimension]


def plausibility_warning(value_si: float, dimension: str, field: str = "value") -> str | None:
    """A warning when ``|value_si|`` lies outside :func:`plausible_range` (zero is never flagged), else None.

    The message names the field, the value and the range in engineering units, and hints at the likely slip
    (a wrong unit, or a factor of 1000 from a missing/extra prefix).
    """
    lo, hi = plausible_range(dimension)
    v = abs(float(value_si))
    if not math.isfinite(v):
        return f"{field}: {value_si!r} is not a finite number"
    if v == 0.0 or (lo <= v <= hi):
        return None
    unit = DISPLAY_UNITS[dimension]
    show = (lambda x: format_quantity(x, unit, 3)) if unit != "1" else (lambda x: f"{x:.3g}")
    side = "large" if v > hi else "small"
    msg = (f"{field}: {show(value_si)} is implausibly {side} for {_noun(dimension)} in a harvester drive "
           f"(usual range {show(lo)} .. {show(hi)})")
    if dimension == "angle" and v > hi:
        msg += "; check the unit, e.g. '180 deg' rather than '180 rad'"
    elif dimension == "length" and v > hi:
        msg += "; check the unit, e.g. '80 mm' rather than '80 m'"
    elif any(lo <= v * f <= hi for f in (1e-3, 1e3, 1e-6, 1e6)):
        msg += "; check the unit (a factor of 1000 or 10^6 would bring it into range)"
    else:
        msg += "; check the number and its unit"
    return msg


def format_quantity(value_si: float, unit: str, digits: int = 6) -> str:
    """Format an SI value in an engineering unit, e.g. ``format_quantity(0.00025, "mm") -> "0.25 mm"``."""
    factor = ENGINEERING_FACTORS[unit]
    return f"{value_si / factor:.{digits}g} {unit}"


#: SI value of one engineering unit, used for printing (kept explicit so output never depends on pint).
#: "Hz" is a *frequency* unit here (1/s); an angular speed is printed in "rpm", "rev/s" or "rad/s".
ENGINEERING_FACTORS: dict[str, float] = {
    "m": 1.0,
    "cm": 1e-2,
    "mm": 1e-3,
    "um": 1e-6,
    "µm": 1e-6,
    "km": 1e3,
    "deg": math.pi / 180.0,
    "rad": 1.0,
    "turn": _TWO_PI,
    "rpm": _TWO_PI / 60.0,
    "r/min": _TWO_PI / 60.0,
    "rev/s": _TWO_PI,
    "rad/s": 1.0,
    "Hz": 1.0,
    "m/s": 1.0,
    "m/min": 1.0 / 60.0,
    "km/h": 1.0 / 3.6,
    "m/s^2": 1.0,
    "kg": 1.0,
    "g": 1e-3,
    "kg*m^2": 1.0,
    "N/m": 1.0,
    "N/mm": 1e3,
    "N*s/m": 1.0,
    "N*m/rad": 1.0,
    "N*m*s/rad": 1.0,
    "Pa": 1.0,
    "kPa": 1e3,
    "MPa": 1e6,
    "GPa": 1e9,
    "kg/m^3": 1.0,
    "g/cm^3": 1000.0,
    "N": 1.0,
    "kN": 1e3,
    "N*m": 1.0,
    "J": 1.0,
    "kJ": 1e3,
    "W": 1.0,
    "kW": 1e3,
    "s": 1.0,
    "ms": 1e-3,
    "min": 60.0,
    "h": 3600.0,
    "%": 1e-2,
    "1": 1.0,
}


def format_tolerance(rtol: float) -> str:
    """A relative tolerance as people write it: ``1e-5``, not ``1e-05``."""
    return f"{rtol:.0e}".replace("e-0", "e-").replace("e+0", "e+")
