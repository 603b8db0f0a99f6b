"""Printing SI values in engineering units (kept explicit so output never depends on pint)."""

from __future__ import annotations

import math

_TWO_PI = 2.0 * math.pi


def format_quantity(value_si: float, unit: str, digits: int = 6) -> str:
    """Format an SI value in an engineering unit, e.g. ``format_quantity(0.00025, "mm") -> "0.25 mm"``.

    Parameters
    ----------
    value_si : float
        The value (SI units of the unit's dimension).
    unit : str
        A key of :data:`ENGINEERING_FACTORS`.
    digits : int
        Significant digits.

    Returns
    -------
    str
        ``"<number> <unit>"``.
    """
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
    """A relative tolerance as people write it: ``1e-5``, not ``1e-05``.

    Parameters
    ----------
    rtol : float
        The tolerance (1).

    Returns
    -------
    str
        One significant digit in exponent form.
    """
    return f"{rtol:.0e}".replace("e-0", "e-").replace("e+0", "e+")
