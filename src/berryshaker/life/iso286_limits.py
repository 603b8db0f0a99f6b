"""ISO 286 limits: the standard tolerances and fundamental deviations that give a hole or shaft class
("H7", "f7") its limit deviations at a nominal size, and the :class:`ToleranceZone` they bound.

Supported tolerance classes (nominal sizes 0 < D <= 500 mm, grades IT01, IT0, IT1..IT18)
----------------------------------------------------------------------------------------
Holes: A, B, C, D, E, F, G, H, JS, K (IT3..IT8), M, N, P (IT3 and coarser).
Shafts: a, b, c, d, e, f, g, h, js, k, m, n, p.
Others (CD, EF, FG, J, R..ZC and their shaft counterparts) are refused with a :class:`ConfigError`.

Sources
-------
ISO 286-1:2010 (tolerances, deviations and fits; Tables 1-3, Annex A), ISO 286-2:2010 (tables of limit
deviations).  Tabulated values in :mod:`berryshaker.life.iso286_data`; the formulas below reproduce them
within ISO's rounding and are used only as a check.  A fit of two classes is in :mod:`berryshaker.life.fits`.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import berryshaker.life.iso286_data as data
from berryshaker.errors import ConfigError

#: Hole letters this module can evaluate.
HOLE_LETTERS: tuple[str, ...] = ("A", "B", "C", "D", "E", "F", "G", "H", "JS", "K", "M", "N", "P")
#: Shaft letters this module can evaluate.
SHAFT_LETTERS: tuple[str, ...] = ("a", "b", "c", "d", "e", "f", "g", "h", "js", "k", "m", "n", "p")
#: Tolerance grades, finest first.
GRADES: tuple[str, ...] = tuple(data.STANDARD_TOLERANCE_UM)

#: Multipliers of the standard tolerance factor i for IT5..IT18 (ISO 286-1:2010, Table 1 note / Annex).
GRADE_MULTIPLIERS: dict[int, int] = {5: 7, 6: 10, 7: 16, 8: 25, 9: 40, 10: 64, 11: 100, 12: 160, 13: 250,
                                     14: 400, 15: 640, 16: 1000, 17: 1600, 18: 2500}

MAX_NOMINAL_MM = 500.0


# ---------------------------------------------------------------------------------------------------
# size ranges
# ---------------------------------------------------------------------------------------------------
def _check_nominal(nominal_mm: float) -> float:
    try:
        d = float(nominal_mm)
    except (TypeError, ValueError):
        raise ConfigError(f"nominal diameter: expected a number of mm, got {nominal_mm!r}") from None
    if not (math.isfinite(d) and 0.0 < d <= MAX_NOMINAL_MM):
        raise ConfigError(f"nominal diameter: {nominal_mm!r} mm is outside the ISO 286 tables built in "
                          f"(over 0 up to and including {MAX_NOMINAL_MM:g} mm)")
    return d


def _range_index(nominal_mm: float, uppers: tuple[float, ...]) -> int:
    d = _check_nominal(nominal_mm)
    for k, upper in enumerate(uppers):
        if d <= upper:
            return k
    raise AssertionError("unreachable: nominal size checked against the last range bound")


def size_range_mm(nominal_mm: float, intermediate: bool = False) -> tuple[float, float]:
    """ISO 286-1 size range (over a, up to and including b) that contains a nominal size.

    Parameters
    ----------
    nominal_mm : float
        Nominal size D (mm), 0 < D <= 500.
    intermediate : bool
        Use the intermediate ranges (those of the deviations of a, b, c) instead of the main ranges.

    Returns
    -------
    (float, float)
        (a, b) in mm; the first range is reported as (0, 3).
    """
    uppers = data.INTERMEDIATE_RANGE_UPPER_MM if intermediate else data.MAIN_RANGE_UPPER_MM
    k = _range_index(nominal_mm, uppers)
    return (0.0 if k == 0 else float(uppers[k - 1]), float(uppers[k]))


def geometric_mean_size_mm(nominal_mm: float, intermediate: bool = False) -> float:
    """Geometric mean D = sqrt(a b) of the size range containing a nominal size (mm).

    Parameters
    ----------
    nominal_mm : float
        Nominal size (mm), 0 < D <= 500.
    intermediate : bool
        Use the intermediate ranges (those of the deviations of a, b, c) instead of the main ranges.

    Returns
    -------
    float
        sqrt(max(a, 1) b) (mm), (a, b] the range of :func:`size_range_mm`.

    Notes
    -----
    ISO 286-1 evaluates its formulas at the geometric mean of the range; for the first range
    (up to 3 mm) it uses a = 1 mm, so D = sqrt(3).
    """
    a, b = size_range_mm(nominal_mm, intermediate)
    return math.sqrt(max(a, 1.0) * b)


def _grade_key(grade: str | int) -> str:
    key = str(grade).strip().upper().removeprefix("IT")
    if key not in data.STANDARD_TOLERANCE_UM:
        raise ConfigError(f"tolerance grade {grade!r} is not an ISO 286 grade; grades are IT01, IT0, IT1..IT18")
    return key


def _grade_number(key: str) -> float:
    return {"01": -1.0, "0": 0.0}.get(key, float(key) if key.isdigit() else math.nan)


# ---------------------------------------------------------------------------------------------------
# standard tolerances
# ---------------------------------------------------------------------------------------------------
def standard_tolerance_um(grade: str | int, nominal_mm: float) -> float:
    """Standard tolerance ITn (um) of a grade at a nominal size, from the ISO 286-1 table.

    Parameters
    ----------
    grade : str or int
        "IT7", "7", 7, "01", "IT0" ...
    nominal_mm : float
        Nominal size (mm), 0 < D <= 500.

    Returns
    -------
    float
        ITn (um).

    Notes
    -----
    ISO 286-1:2010 Table 1 (IT1..IT18) and Annex A (IT01, IT0).  ISO does not use IT14..IT18 for
    nominal sizes up to 1 mm; those are refused.
    """
    key = _grade_key(grade)
    d = _check_nominal(nominal_mm)
    if _grade_number(key) >= 14 and d <= 1.0:
        raise ConfigError(f"IT{key} is not defined by ISO 286 for nominal sizes up to 1 mm (got {d:g} mm)")
    return float(data.STANDARD_TOLERANCE_UM[key][_range_index(d, data.MAIN_RANGE_UPPER_MM)])


def standard_tolerance_factor_um(nominal_mm: float) -> float:
    """Standard tolerance factor i = 0.45 D^(1/3) + 0.001 D (um), D the range's geometric mean (mm).

    Parameters
    ----------
    nominal_mm : float
        Nominal size (mm), 0 < D <= 500.

    Returns
    -------
    float
        i (um), with D from :func:`geometric_mean_size_mm` (main ranges).

    Notes
    -----
    ISO 286-1:2010 (formula of the standard tolerance factor for sizes up to 500 mm).  ITn = m_n i with
    the multipliers :data:`GRADE_MULTIPLIERS` for IT5..IT18.
    """
    d = geometric_mean_size_mm(nominal_mm)
    return 0.45 * d ** (1.0 / 3.0) + 0.001 * d


def standard_tolerance_formula_um(grade: str | int, nominal_mm: float) -> float:
    """Unrounded ITn (um) from the ISO 286-1 formulas (a check of the table, not a replacement).

    Parameters
    ----------
    grade : str or int
        IT01, IT0 or IT5..IT18 (IT1..IT4 are tabulated only: ISO derives them approximately
        geometrically between IT1 and IT5 and this function refuses them).
    nominal_mm : float
        Nominal size (mm).

    Returns
    -------
    float
        IT01 = 0.3 + 0.008 D, IT0 = 0.5 + 0.012 D, ITn = m_n (0.45 D^(1/3) + 0.001 D) for n >= 5,
        with D the geometric mean of the size range (mm).

    Notes
    -----
    ISO 286-1 rounds these results to the tabulated values with rules that ordinary rounding does not
    reproduce; the tables (:func:`standard_tolerance_um`) are authoritative.
    """
    key = _grade_key(grade)
    d = geometric_mean_size_mm(nominal_mm)
    if key == "01":
        return 0.3 + 0.008 * d
    if key == "0":
        return 0.5 + 0.012 * d
    n = int(key)
    if n not in GRADE_MULTIPLIERS:
        raise ConfigError(f"IT{n}: ISO 286-1 gives no formula for IT1..IT4; use standard_tolerance_um")
    return GRADE_MULTIPLIERS[n] * standard_tolerance_factor_um(nominal_mm)


# ---------------------------------------------------------------------------------------------------
# fundamental deviations
# ---------------------------------------------------------------------------------------------------
def shaft_deviation_formula_um(letter: str, nominal_mm: float) -> float:
    """Unrounded fundamental deviation of a shaft (um) from the ISO 286-1 formulas (a check only).

    Parameters
    ----------
    letter : str
        a, b, c, d, e, f, g (es, negative) or k (grades 4..7), m, n (ei, positive).
    nominal_mm : float
        Nominal size (mm); D is the geometric mean of its size range (intermediate ranges for a, b, c).

    Returns
    -------
    float
        a: -(265 + 1.3 D) for D <= 120, -3.5 D above;  b: -(140 + 0.85 D) for D <= 160, -1.8 D above;
        c: -52 D^0.2 for D <= 40, -(95 + 0.8 D) above;  d: -16 D^0.44;  e: -11 D^0.41;
        f: -5.5 D^0.41;  g: -2.5 D^0.34;  k: +0.6 D^(1/3);  m: +(IT7 - IT6);  n: +5 D^0.34.

    Notes
    -----
    ISO 286-1 (formulas for the fundamental deviations of shafts, sizes up to 500 mm), as quoted in
    design textbooks.  The published tables round these values; :mod:`berryshaker.life.iso286_data`
    holds the published values.  Measured departures from the tables above 3 mm: d, e, f, g, n within
    1 um or 3 %; a within 2.5 %; b within 5 %; c above 40 mm within 2 %, but the quoted c formula for
    D <= 40 mm gives -87/-98/-106 um where the table has -95/-110/-120 (10-18, 18-30, 30-40 mm): the
    table is trusted.
    """
    interm = letter in ("a", "b", "c")
    d = geometric_mean_size_mm(nominal_mm, intermediate=interm)
    if letter == "a":
        return -(265 + 1.3 * d) if d <= 120 else -3.5 * d
    if letter == "b":
        return -(140 + 0.85 * d) if d <= 160 else -1.8 * d
    if letter == "c":
        return -52 * d**0.2 if d <= 40 else -(95 + 0.8 * d)
    powers = {"d": (-16, 0.44), "e": (-11, 0.41), "f": (-5.5, 0.41), "g": (-2.5, 0.34), "n": (5.0, 0.34),
              "k": (0.6, 1.0 / 3.0)}
    if letter in powers:
        coef, expo = powers[letter]
        return coef * d**expo
    if letter == "m":
        return standard_tolerance_um(7, nominal_mm) - standard_tolerance_um(6, nominal_mm)
    raise ConfigError(f"no deviation formula for shaft letter {letter!r}; formulas exist for a b c d e f g k m n")


def _shaft_fundamental_um(letter: str, key: str, d: float) -> tuple[str, float]:
    """("es"|"ei", value) for a shaft letter from the tables."""
    if letter in data.SHAFT_UPPER_DEVIATION_INTERMEDIATE_UM:
        if letter in ("a", "b") and d <= 1.0:
            raise ConfigError(f"shaft/hole letter {letter!r} is not defined by ISO 286 for sizes up to 1 mm")
        k = _range_index(d, data.INTERMEDIATE_RANGE_UPPER_MM)
        return "es", float(data.SHAFT_UPPER_DEVIATION_INTERMEDIATE_UM[letter][k])
    k = _range_index(d, data.MAIN_RANGE_UPPER_MM)
    if letter in data.SHAFT_UPPER_DEVIATION_UM:
        return "es", float(data.SHAFT_UPPER_DEVIATION_UM[letter][k])
    if letter == "k":
        return "ei", float(data.SHAFT_LOWER_DEVIATION_UM["k"][k]) if key in ("4", "5", "6", "7") else 0.0
    return "ei", float(data.SHAFT_LOWER_DEVIATION_UM[letter][k])


def _delta_um(key: str, d: float) -> float:
    """Delta = ITn - IT(n-1) of ISO 286-1 Table 3 (0 up to 3 mm)."""
    n = int(key)
    if d <= 3.0:
        return 0.0
    return standard_tolerance_um(n, d) - standard_tolerance_um(n - 1, d)


def _split_class(designation: str) -> tuple[str, str]:
    m = re.fullmatch(r"\s*([A-Za-z]{1,2})\s*(01|\d{1,2})\s*", designation)
    if not m:
        raise ConfigError(f"tolerance class {designation!r}: expected a letter and a grade, e.g. 'H7' or 'f7'")
    return m.group(1), m.group(2)


def limit_deviations_um(designation: str, nominal_mm: float) -> tuple[float, float]:
    """Upper and lower limit deviations (um) of a hole (upper-case) or shaft (lower-case) class.

    Parameters
    ----------
    designation : str
        Tolerance class, e.g. "H7", "JS6", "K7" (holes) or "f7", "js6", "p6" (shafts).
    nominal_mm : float
        Nominal size (mm), 0 < D <= 500.

    Returns
    -------
    (float, float)
        (upper, lower) deviations in um: (ES, EI) for a hole, (es, ei) for a shaft.

    Notes
    -----
    ISO 286-1:2010 rules: shafts a..h have es = fundamental deviation, ei = es - IT; shafts k..p have
    ei = fundamental deviation, es = ei + IT; js is +/- IT/2 (not rounded to whole micrometres).
    Holes A..H: EI = -es of the same shaft letter (the general rule).  Holes K, M, N up to IT8 and P up to
    IT7: ES = -ei + Delta with Delta = ITn - IT(n-1) (the special rule of Table 3); K above IT8 is
    refused, M above IT8 has ES = -ei, N above IT8 has ES = 0, P above IT7 has ES = -ei.  Up to 3 mm:
    K ES = 0, M ES = -2, N ES = -4, P ES = -6 for every grade.  Special case M6 over 250 up to 315 mm:
    ES = -9 um.  k has ei = 0 outside IT4..IT7.
    """
    letter, key = _split_class(designation)
    d = _check_nominal(nominal_mm)
    is_hole = letter.isupper()
    if letter.upper() != letter and letter.lower() != letter:
        raise ConfigError(f"tolerance class {designation!r}: use upper case for holes (H7) and lower case "
                          "for shafts (f7)")
    supported = HOLE_LETTERS if is_hole else SHAFT_LETTERS
    if letter not in supported:
        raise ConfigError(f"tolerance class {designation!r}: letter {letter!r} is not supported; "
                          f"{'holes' if is_hole else 'shafts'}: {', '.join(supported)}")
    it = standard_tolerance_um(key, d)
    low = letter.lower()
    if low == "js":
        return it / 2.0, -it / 2.0
    if not is_hole:
        which, dev = _shaft_fundamental_um(low, key, d)
        return (dev, dev - it) if which == "es" else (dev + it, dev)
    # holes
    if low in "abcdefgh":
        _, es = _shaft_fundamental_um(low, key, d)
        ei_hole = 0.0 - es  # 0.0 - 0.0 keeps H's EI a positive zero
        return ei_hole + it, ei_hole
    n = _grade_number(key)
    if n < 3:
        raise ConfigError(f"hole class {designation!r}: ISO 286 tabulates Delta only for IT3..IT8; "
                          f"holes K, M, N, P are supported from IT3")
    if letter == "K" and n > 8:
        raise ConfigError(f"hole class {designation!r}: K is supported up to IT8 only")
    k = _range_index(d, data.MAIN_RANGE_UPPER_MM)
    ei_shaft = float(data.SHAFT_LOWER_DEVIATION_UM[low][k])
    limit = 7 if letter == "P" else 8
    if d <= 3.0:
        es_hole = {"K": 0.0, "M": -2.0, "N": -4.0, "P": -6.0}[letter]
    elif letter == "M" and key == "6" and 250.0 < d <= 315.0:
        es_hole = data.M6_250_315_UPPER_DEVIATION_UM
    elif n <= limit:
        es_hole = -ei_shaft + _delta_um(key, d)
    else:
        es_hole = 0.0 if letter == "N" else -ei_shaft
    return es_hole, es_hole - it


# ---------------------------------------------------------------------------------------------------
# tolerance zones
# ---------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ToleranceZone:
    """Limits of one part (hole or shaft) of a fit.

    Attributes
    ----------
    designation : str
        Tolerance class, e.g. "H7" or "f7".
    nominal_mm : float
        Nominal size (mm).
    upper_um, lower_um : float
        Upper and lower limit deviations (um): ES/EI for a hole, es/ei for a shaft.
    is_hole : bool
        True for a hole (internal feature).
    """

    designation: str
    nominal_mm: float
    upper_um: float
    lower_um: float
    is_hole: bool

    @property
    def tolerance_um(self) -> float:
        """Width of the zone (um), the ITn of its grade."""
        return self.upper_um - self.lower_um

    @property
    def max_size(self) -> float:
        """Largest permitted size (m)."""
        return (self.nominal_mm + self.upper_um * 1e-3) * 1e-3

    @property
    def min_size(self) -> float:
        """Smallest permitted size (m)."""
        return (self.nominal_mm + self.lower_um * 1e-3) * 1e-3

    def summary(self) -> dict:
        """JSON-able limits: deviations in um and limit sizes in mm.

        Returns
        -------
        dict
            ``class``, ``upper_deviation_um``, ``lower_deviation_um``, ``tolerance_um`` (um) and
            ``max_size_mm``, ``min_size_mm`` (mm, rounded to 1 nm).
        """
        return {"class": self.designation, "upper_deviation_um": self.upper_um,
                "lower_deviation_um": self.lower_um, "tolerance_um": self.tolerance_um,
                "max_size_mm": round(self.max_size * 1e3, 6), "min_size_mm": round(self.min_size * 1e3, 6)}


def tolerance_zone(designation: str, nominal_mm: float) -> ToleranceZone:
    """The :class:`ToleranceZone` of a hole or shaft class at a nominal size (see :func:`limit_deviations_um`).

    Parameters
    ----------
    designation : str
        Tolerance class: upper case for a hole ("H7"), lower case for a shaft ("f7").
    nominal_mm : float
        Nominal size (mm), 0 < D <= 500.

    Returns
    -------
    ToleranceZone
        Its limit deviations (um) per ISO 286.
    """
    upper, lower = limit_deviations_um(designation, nominal_mm)
    letter, key = _split_class(designation)
    return ToleranceZone(f"{letter}{key}", float(nominal_mm), upper, lower, letter.isupper())
