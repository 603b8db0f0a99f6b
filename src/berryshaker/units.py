"""Unit-aware parsing of engineering quantities ("0.25 mm", "120 rpm", "1.1 GPa", "30 m/min").

Inside berryshaker every number is SI (m, kg, s, rad, N).  Config files and the command line may give a
plain number (taken as SI) or a string with a unit, which is converted here with `pint`
(a maintained units library, so that "N*s/m", "kg m^2" or "GPa" need no hand-written table).  The
expected physical dimension of each field is checked, so "0.25 mm" for a stiffness is refused with a
clear message.
"""

from __future__ import annotations

import functools
import math
import re

from berryshaker.errors import ConfigError

#: dimension name -> (pint dimensionality string, SI unit name used in messages and printing)
DIMENSIONS: dict[str, tuple[str, str]] = {
    "length": ("[length]", "m"),
    "angle": ("", "rad"),
    "angular_speed": ("1/[time]", "rad/s"),
    "speed": ("[length]/[time]", "m/s"),
    "mass": ("[mass]", "kg"),
    "inertia": ("[mass]*[length]**2", "kg*m^2"),
    "stiffness": ("[mass]/[time]**2", "N/m"),
    "damping": ("[mass]/[time]", "N*s/m"),
    "torsional_stiffness": ("[mass]*[length]**2/[time]**2", "N*m/rad"),
    "torsional_damping": ("[mass]*[length]**2/[time]", "N*m*s/rad"),
    "pressure": ("[mass]/[length]/[time]**2", "Pa"),
    "density": ("[mass]/[length]**3", "kg/m^3"),
    "force": ("[mass]*[length]/[time]**2", "N"),
    "time": ("[time]", "s"),
    "dimensionless": ("", "1"),
}

_REV_PER_MIN = re.compile(r"\br\s*/\s*min\b")


@functools.lru_cache(maxsize=1)
def _registry():
    import pint

    ureg = pint.UnitRegistry()
    return ureg


def parse_quantity(value: object, dimension: str, field: str = "value") -> float:
    """Convert a plain SI number or a string with a unit into an SI float.

    Parameters
    ----------
    value : float, int or str
        ``0.00025`` (SI), ``"0.25 mm"``, ``"120 rpm"``, ``"120 r/min"``, ``"1.1 GPa"``...
    dimension : str
        One of :data:`DIMENSIONS` (``"length"``, ``"angle"``, ``"angular_speed"``...).
    field : str
        Name of the field, used in error messages.

    Returns
    -------
    float
        The value in SI units (m, rad, rad/s, kg, N/m, ...).

    Raises
    ------
    ConfigError
        Unknown unit, wrong dimension, or a value that is not a finite number.
    """
    if isinstance(value, bool):
        raise ConfigError(f"{field}: expected a number or a string with a unit, got {value!r}")
    if isinstance(value, (int, float)):
        out = float(value)
    elif isinstance(value, str):
        text = _REV_PER_MIN.sub("rpm", value.strip())
        if not text:
            raise ConfigError(f"{field}: empty value")
        ureg = _registry()
        try:
            q = ureg.Quantity(text)
        except Exception as exc:  # pint raises several error types for bad units
            raise ConfigError(f"{field}: cannot read {value!r} as a quantity ({exc})") from None
        want, si = DIMENSIONS[dimension]
        if not isinstance(q, ureg.Quantity):
            q = ureg.Quantity(float(q), "")
        want_dim = ureg.Quantity(1, "") if not want else None
        have = q.dimensionality
        target = ureg.get_dimensionality(want) if want else want_dim.dimensionality
        if have != target:
            raise ConfigError(
                f"{field}: {value!r} has the wrong kind of unit; expected {dimension} (e.g. in {si})"
            )
        try:
            out = float(q.to_base_units().magnitude)
        except Exception as exc:
            raise ConfigError(f"{field}: cannot convert {value!r} to SI ({exc})") from None
    else:
        raise ConfigError(f"{field}: expected a number or a string with a unit, got {value!r}")
    if not math.isfinite(out):
        raise ConfigError(f"{field}: {value!r} is not a finite number")
    return out


def format_quantity(value_si: float, unit: str, digits: int = 6) -> str:
    """Format an SI value in an engineering unit, e.g. ``format_quantity(0.00025, "mm") -> "0.25 mm"``."""
    factor = ENGINEERING_FACTORS[unit]
    return f"{value_si / factor:.{digits}g} {unit}"


#: SI value of one engineering unit, used for printing (kept explicit so output never depends on pint)
ENGINEERING_FACTORS: dict[str, float] = {
    "m": 1.0,
    "mm": 1e-3,
    "deg": math.pi / 180.0,
    "rad": 1.0,
    "rpm": 2.0 * math.pi / 60.0,
    "rad/s": 1.0,
    "m/s": 1.0,
    "m/min": 1.0 / 60.0,
    "kg": 1.0,
    "g": 1e-3,
    "kg*m^2": 1.0,
    "N/m": 1.0,
    "N*s/m": 1.0,
    "N*m/rad": 1.0,
    "N*m*s/rad": 1.0,
    "GPa": 1e9,
    "MPa": 1e6,
    "kg/m^3": 1.0,
    "g/cm^3": 1000.0,
    "N": 1.0,
    "s": 1.0,
    "1": 1.0,
}
