"""How large or small a value may be: :data:`LIMITS` (refused outside) and :data:`PLAUSIBLE` (a warning outside:
most likely a unit slip)."""

from __future__ import annotations

import math

from berryshaker.errors import ConfigError
from berryshaker.units.formatting import _TWO_PI, ENGINEERING_FACTORS, format_quantity
from berryshaker.units.parsing import DIMENSIONS, DISPLAY_UNITS, _check_dimension, _noun, _short

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

    Parameters
    ----------
    value_si : float
        The value (SI units of ``dimension``).
    dimension : str
        One of :data:`~berryshaker.units.DIMENSIONS`.
    field : str
        Name used at the start of the error message.
    lower : bool
        Check the lower limit too.

    Returns
    -------
    float
        ``value_si`` (SI units of ``dimension``).

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
    """The SI magnitudes plausible for ``dimension`` in a harvester drive (see :data:`PLAUSIBLE`).

    Parameters
    ----------
    dimension : str
        One of :data:`~berryshaker.units.DIMENSIONS`.

    Returns
    -------
    tuple of float
        (lo, hi), SI units of ``dimension``.
    """
    _check_dimension(dimension)
    return PLAUSIBLE[dimension]


def plausibility_warning(value_si: float, dimension: str, field: str = "value") -> str | None:
    """A warning when ``|value_si|`` lies outside :func:`plausible_range` (zero is never flagged).

    The message names the field, the value and the range in engineering units, and hints at the likely slip
    (a wrong unit, or a factor of 1000 from a missing/extra prefix).

    Parameters
    ----------
    value_si : float
        The value (SI units of ``dimension``).
    dimension : str
        One of :data:`~berryshaker.units.DIMENSIONS`.
    field : str
        Name used at the start of the message.

    Returns
    -------
    str or None
        The warning, or None for a plausible value.
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
