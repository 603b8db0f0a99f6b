"""Sweep and command-line value lists (``0.1..0.3mm``, ``100,120,140rpm``, ``0.25mm+-0.05mm``) read into SI values."""

from __future__ import annotations

import math
from dataclasses import dataclass

from berryshaker.errors import ConfigError
from berryshaker.units.parsing import (
    MAX_LIST_CHARS,
    _check_dimension,
    _short,
    _split_number,
    parse_quantity,
    parse_unit,
)


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
        """The values in the display unit (e.g. mm, rpm).

        Returns
        -------
        tuple of float
            ``values[i] / unit_si``: in the units of ``unit``, the display unit.
        """
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
        The kind of list, its SI values, the display unit and the dimension.

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
