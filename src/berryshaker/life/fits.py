"""ISO 286 limits and fits: from a drawing's "H7/f7" at a nominal diameter to the clearance of a joint.

A new machine leaves the shop with the clearance of its running fits (tens of micrometres); wear takes
it towards the study's levels (0.1-0.75 mm).  This module turns a fit designation into the limits of
hole and shaft, the clearance range and a statistical distribution of the clearance within it.

Clearance convention
--------------------
Fit tables give the DIAMETRAL clearance: hole diameter minus shaft diameter.  The pin-in-bore joints
of the harvester (pairs C and F, :class:`berryshaker.config.ClearancePair`) use the RADIAL clearance
(bore radius minus pin radius) = diametral / 2.  :class:`Fit` therefore carries both:
``clearance_min``/``clearance_max`` (diametral, m) and ``radial_clearance_min``/``radial_clearance_max``
(m).  For a roller in a groove (pairs A and B) the free travel across the groove is the diametral value
(groove width minus roller diameter).

The limits of a hole or shaft class (ISO 286 tolerances and deviations) are in :mod:`berryshaker.life.iso286_limits`;
its public names are importable from here too.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, replace
from typing import Literal

import numpy as np

from berryshaker.errors import ConfigError
from berryshaker.life.iso286_limits import (  # noqa: F401  (the limits' public names, re-exported)
    GRADE_MULTIPLIERS,
    GRADES,
    HOLE_LETTERS,
    MAX_NOMINAL_MM,
    SHAFT_LETTERS,
    ToleranceZone,
    geometric_mean_size_mm,
    limit_deviations_um,
    shaft_deviation_formula_um,
    size_range_mm,
    standard_tolerance_factor_um,
    standard_tolerance_formula_um,
    standard_tolerance_um,
    tolerance_zone,
)

Distribution = Literal["uniform", "uniform-parts", "normal"]
DISTRIBUTIONS: tuple[str, ...] = ("uniform", "uniform-parts", "normal")


def _truncated_normal(rng: np.random.Generator, n: int, lo: float, hi: float, cp: float) -> np.ndarray:
    from scipy.stats import truncnorm

    if hi <= lo:
        return np.full(n, lo)
    sd = (hi - lo) / (6.0 * cp)
    half = (hi - lo) / 2.0 / sd  # = 3 cp
    return truncnorm.rvs(-half, half, loc=(lo + hi) / 2.0, scale=sd, size=n, random_state=rng)


@dataclass(frozen=True)
class Fit:
    """A fit between a hole and a shaft, or an explicit clearance range, with a clearance distribution.

    Attributes
    ----------
    designation : str
        "H7/f7" or the range text ("0.02..0.06 mm").
    nominal_mm : float or None
        Nominal diameter (mm); None for an explicit range.
    hole, shaft : ToleranceZone or None
        Part limits; None for an explicit range.
    clearance_min, clearance_max : float
        DIAMETRAL clearance limits (m): hole size minus shaft size; negative is interference.
        ``clearance_min`` = min hole - max shaft, ``clearance_max`` = max hole - min shaft.
    distribution : str
        "uniform" (clearance uniform between the limits), "uniform-parts" (each part's size uniform in
        its zone, independent; the clearance is then trapezoidal) or "normal" (each part normal, centred
        in its zone with standard deviation = tolerance / (6 Cp), independent, truncated at its limits
        because out-of-tolerance parts are rejected at inspection).
    cp : float or None
        Process capability index Cp for "normal" (dimensionless).
    """

    designation: str
    nominal_mm: float | None
    hole: ToleranceZone | None
    shaft: ToleranceZone | None
    clearance_min: float
    clearance_max: float
    distribution: Distribution = "uniform"
    cp: float | None = None

    @property
    def kind(self) -> str:
        """"clearance" (min clearance >= 0), "interference" (max clearance <= 0) or "transition"."""
        if self.clearance_min >= 0.0:
            return "clearance"
        if self.clearance_max <= 0.0:
            return "interference"
        return "transition"

    @property
    def basis(self) -> str:
        """"hole" (hole H), "shaft" (shaft h), "hole and shaft" (H/h), "none" or "explicit range"."""
        if self.hole is None or self.shaft is None:
            return "explicit range"
        h = self.hole.designation[0] == "H"
        s = self.shaft.designation[0] == "h"
        return {(True, True): "hole and shaft", (True, False): "hole", (False, True): "shaft"}.get((h, s), "none")

    @property
    def radial_clearance_min(self) -> float:
        """Smallest RADIAL clearance (m) = clearance_min / 2 (the harvester's pin-in-bore ``size``)."""
        return self.clearance_min / 2.0

    @property
    def radial_clearance_max(self) -> float:
        """Largest RADIAL clearance (m) = clearance_max / 2."""
        return self.clearance_max / 2.0

    @property
    def clearance_mean(self) -> float:
        """Mean diametral clearance (m) of the distribution (the middle of the limits: every built-in
        distribution is symmetric about it)."""
        return 0.5 * (self.clearance_min + self.clearance_max)

    def with_distribution(self, distribution: Distribution, cp: float | None = None) -> Fit:
        """A copy with another clearance distribution (validated as in :func:`parse_fit`).

        Parameters
        ----------
        distribution : {"uniform", "uniform-parts", "normal"}
            Clearance distribution (see :class:`Fit`); "uniform-parts" needs hole and shaft classes.
        cp : float, optional
            Process capability index Cp (dimensionless), required for "normal".

        Returns
        -------
        Fit
            The same limits with the new distribution.

        Raises
        ------
        ConfigError
            An unknown distribution, "normal" without cp > 0, or "uniform-parts" for an explicit range.
        """
        _check_distribution(distribution, cp, explicit=self.hole is None)
        return replace(self, distribution=distribution, cp=cp)

    def sample(self, n: int, rng: np.random.Generator | int | None = None) -> np.ndarray:
        """Draw n DIAMETRAL clearances (m) from the fit's distribution.

        Parameters
        ----------
        n : int
            Number of assemblies.
        rng : numpy Generator, int seed or None
            Random source.

        Returns
        -------
        numpy.ndarray
            Shape (n,), diametral clearances in m, all within [clearance_min, clearance_max].

        Notes
        -----
        "normal": hole size ~ N(mid, T_h / (6 Cp)) and shaft size ~ N(mid, T_s / (6 Cp)), independent,
        each truncated at its limits; clearance = hole - shaft.  For an explicit range the clearance
        itself is normal, centred, with sd = (max - min) / (6 Cp), truncated at the limits.  The
        centred-process assumption (Cpk = Cp) is ours; real processes drift (Cpk < Cp).
        """
        gen = np.random.default_rng(rng)
        n = int(n)
        if self.distribution == "uniform":
            return gen.uniform(self.clearance_min, self.clearance_max, n)
        if self.hole is None or self.shaft is None:  # explicit range, normal
            return _truncated_normal(gen, n, self.clearance_min, self.clearance_max, float(self.cp))
        if self.distribution == "uniform-parts":
            hole = gen.uniform(self.hole.min_size, self.hole.max_size, n)
            shaft = gen.uniform(self.shaft.min_size, self.shaft.max_size, n)
        else:
            hole = _truncated_normal(gen, n, self.hole.min_size, self.hole.max_size, float(self.cp))
            shaft = _truncated_normal(gen, n, self.shaft.min_size, self.shaft.max_size, float(self.cp))
        return hole - shaft

    def sample_radial(self, n: int, rng: np.random.Generator | int | None = None) -> np.ndarray:
        """Draw n RADIAL clearances (m) = :meth:`sample` / 2.

        Parameters
        ----------
        n : int
            Number of assemblies.
        rng : numpy Generator, int seed or None
            Random source.

        Returns
        -------
        numpy.ndarray
            Shape (n,), radial clearances in m, within [radial_clearance_min, radial_clearance_max].
        """
        return self.sample(n, rng) / 2.0


def _check_distribution(distribution: str, cp: float | None, explicit: bool) -> None:
    if distribution not in DISTRIBUTIONS:
        raise ConfigError(f"clearance distribution {distribution!r}: choose one of {', '.join(DISTRIBUTIONS)}")
    cp_ok = isinstance(cp, (int, float)) and math.isfinite(cp) and cp > 0
    if distribution == "normal" and not cp_ok:
        raise ConfigError(f"clearance distribution 'normal' needs a process capability cp > 0 "
                          f"(e.g. cp=1.33), got {cp!r}")
    if distribution == "uniform-parts" and explicit:
        raise ConfigError("clearance distribution 'uniform-parts' needs hole and shaft classes; an explicit "
                          "clearance range has no parts: use 'uniform' or 'normal'")


_FIT_RE = re.compile(r"^\s*(?:(?:Ø|ø|⌀|d\s*=?)?\s*(?P<size>\d+(?:\.\d*)?)\s*(?:mm)?\s+)?"
                     r"(?P<hole>[A-Za-z]{1,2}\s*(?:01|\d{1,2}))\s*/\s*(?P<shaft>[A-Za-z]{1,2}\s*(?:01|\d{1,2}))\s*$")
_RANGE_RE = re.compile(r"^\s*(?P<lo>[-+]?\d+(?:\.\d*)?(?:[eE][-+]?\d+)?)\s*\.\.\s*"
                       r"(?P<hi>[-+]?\d+(?:\.\d*)?(?:[eE][-+]?\d+)?)\s*(?P<unit>[^\d\s.][^\s]*)?\s*$")


def iso_fit(hole: str, shaft: str, nominal_mm: float, distribution: Distribution = "uniform",
            cp: float | None = None) -> Fit:
    """The :class:`Fit` of a hole class and a shaft class at a nominal diameter.

    Parameters
    ----------
    hole : str
        Hole class, upper case: "H7", "F8", "JS7", "K7"...
    shaft : str
        Shaft class, lower case: "f7", "h6", "g6", "p6"...
    nominal_mm : float
        Nominal diameter (mm), 0 < D <= 500.
    distribution, cp
        Clearance distribution (see :class:`Fit`).

    Returns
    -------
    Fit
        Limits per ISO 286-1/-2; clearance_min = EI - es, clearance_max = ES - ei (diametral, m).
    """
    if not hole[:1].isupper():
        raise ConfigError(f"fit {hole}/{shaft}: the hole class comes first and is upper case (e.g. H7/f7)")
    if not shaft[:1].islower():
        raise ConfigError(f"fit {hole}/{shaft}: the shaft class comes second and is lower case (e.g. H7/f7)")
    hz, sz = tolerance_zone(hole, nominal_mm), tolerance_zone(shaft, nominal_mm)
    _check_distribution(distribution, cp, explicit=False)
    cmin = (hz.lower_um - sz.upper_um) * 1e-6
    cmax = (hz.upper_um - sz.lower_um) * 1e-6
    return Fit(f"{hz.designation}/{sz.designation}", float(nominal_mm), hz, sz, cmin, cmax, distribution, cp)


def clearance_range_fit(clearance_min: float, clearance_max: float, distribution: Distribution = "uniform",
                        cp: float | None = None, designation: str | None = None) -> Fit:
    """A :class:`Fit` from explicit DIAMETRAL clearance limits (m), without part classes.

    Parameters
    ----------
    clearance_min, clearance_max : float
        Diametral clearance limits (m), finite, min <= max.
    distribution : {"uniform", "normal"}
        Clearance distribution within the limits (see :class:`Fit`).
    cp : float, optional
        Process capability index Cp (dimensionless), required for "normal".
    designation : str, optional
        Text kept as the fit's designation (default "MIN..MAX mm").

    Returns
    -------
    Fit
        A fit without hole, shaft or nominal size.

    Raises
    ------
    ConfigError
        Non-finite limits, min > max, or an invalid distribution.
    """
    lo, hi = float(clearance_min), float(clearance_max)
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise ConfigError(f"clearance range: limits must be finite, got {clearance_min!r}..{clearance_max!r}")
    if hi < lo:
        raise ConfigError(f"clearance range: the lower limit {lo * 1e3:g} mm exceeds the upper "
                          f"{hi * 1e3:g} mm; write it as MIN..MAX")
    _check_distribution(distribution, cp, explicit=True)
    text = designation or f"{lo * 1e3:g}..{hi * 1e3:g} mm"
    return Fit(text, None, None, None, lo, hi, distribution, cp)


def parse_fit(text: str, nominal_mm: float | None = None, *, distribution: Distribution = "uniform",
              cp: float | None = None) -> Fit:
    """Parse a fit designation or an explicit diametral clearance range.

    Parameters
    ----------
    text : str
        "H7/f7" (then ``nominal_mm`` is required), "20 H7/f7", "Ø20 H7/f7", "F8/h7" (shaft basis), or an
        explicit DIAMETRAL clearance range with a unit: "0.02..0.06 mm", "20..60 um".
    nominal_mm : float, optional
        Nominal diameter (mm), if not in the text.
    distribution : {"uniform", "uniform-parts", "normal"}
        Clearance distribution (see :class:`Fit`).
    cp : float, optional
        Process capability index (dimensionless), required for "normal".

    Returns
    -------
    Fit
        The ISO fit (:func:`iso_fit`) or the explicit range (:func:`clearance_range_fit`).

    Raises
    ------
    ConfigError
        Unreadable text, unsupported class, size outside (0, 500] mm, missing or conflicting size.
    """
    if not isinstance(text, str) or not text.strip():
        raise ConfigError(f"fit: expected a designation such as 'H7/f7' or a range such as '0.02..0.06 mm', "
                          f"got {text!r}")
    m = _RANGE_RE.match(text)
    if m:
        from berryshaker.units import parse_quantity

        unit = m.group("unit")
        if not unit:
            raise ConfigError(f"fit range {text!r} needs a unit, e.g. '0.02..0.06 mm'")
        unit = unit.replace("µ", "u").replace("μ", "u")
        lo = parse_quantity(f"{m.group('lo')} {unit}", "length", field="fit range")
        hi = parse_quantity(f"{m.group('hi')} {unit}", "length", field="fit range")
        return clearance_range_fit(lo, hi, distribution, cp, designation=text.strip())
    m = _FIT_RE.match(text)
    if not m:
        raise ConfigError(f"fit {text!r}: expected HOLE/SHAFT such as 'H7/f7' (optionally preceded by the "
                          f"nominal diameter in mm, '20 H7/f7') or a clearance range such as '0.02..0.06 mm'")
    size = m.group("size")
    if size is not None:
        if nominal_mm is not None and not math.isclose(float(size), float(nominal_mm)):
            raise ConfigError(f"fit {text!r}: nominal diameter given twice ({size} mm and {nominal_mm} mm)")
        nominal_mm = float(size)
    if nominal_mm is None:
        raise ConfigError(f"fit {text!r}: no nominal diameter; write e.g. '20 H7/f7' or pass nominal_mm")
    hole = m.group("hole").replace(" ", "")
    shaft = m.group("shaft").replace(" ", "")
    return iso_fit(hole, shaft, nominal_mm, distribution, cp)


def fit_summary(fit: Fit) -> dict:
    """JSON-able description of a fit.

    Parameters
    ----------
    fit : Fit
        The fit to describe.

    Returns
    -------
    dict
        ``designation``, ``nominal_mm``, ``kind``, ``basis``, ``hole`` and ``shaft`` (deviations in um,
        limit sizes in mm; None for an explicit range), ``clearance_min_mm`` / ``clearance_max_mm`` /
        ``clearance_mean_mm`` (DIAMETRAL, as read in fit tables), ``clearance_min_um`` /
        ``clearance_max_um``, ``radial_clearance_min_mm`` / ``radial_clearance_max_mm`` (RADIAL = diametral
        / 2, the harvester's pin-in-bore ``size``), ``distribution``, ``cp`` and a ``convention`` note.
    """
    return {
        "designation": fit.designation,
        "nominal_mm": fit.nominal_mm,
        "kind": fit.kind,
        "basis": fit.basis,
        "hole": fit.hole.summary() if fit.hole else None,
        "shaft": fit.shaft.summary() if fit.shaft else None,
        "clearance_min_mm": round(fit.clearance_min * 1e3, 7),
        "clearance_max_mm": round(fit.clearance_max * 1e3, 7),
        "clearance_mean_mm": round(fit.clearance_mean * 1e3, 7),
        "clearance_min_um": round(fit.clearance_min * 1e6, 4),
        "clearance_max_um": round(fit.clearance_max * 1e6, 4),
        "radial_clearance_min_mm": round(fit.radial_clearance_min * 1e3, 7),
        "radial_clearance_max_mm": round(fit.radial_clearance_max * 1e3, 7),
        "distribution": fit.distribution,
        "cp": fit.cp,
        "convention": "clearance_* are diametral (hole diameter - shaft diameter); radial_clearance_* = "
                      "diametral / 2 is the pin-in-bore clearance 'size' of the machine description",
    }
