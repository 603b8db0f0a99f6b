"""Contact fatigue of a clearance joint: the Hertz pressure of its sizing load against the pair's endurance, and the
basic rating life of ISO 281 where the pair is a rolling bearing (docs/life.md, "Life by mechanism").

* **Pressure** (:func:`contact_pressure`): the line contact of a cylinder on a cylinder, Hertz's peak pressure
  p0 = sqrt(F' E* / (pi R')) with F' = F / L the load per length and 1/R' = 1/R1 + 1/R2 (Johnson 1985, eq. 4.45;
  a concave bore has R2 < 0).  A pin in a bore of radial clearance c: R1 = d/2, R2 = -(d/2 + c), so
  R' = R1 (R1 + c) / c -- the pressure grows as the joint wears (p0 ~ sqrt(c) at a given load): the wear loop's
  route to fatigue.  A conformal contact whose Hertz half-width reaches the pin's size is bounded below by the
  worn-in cosine distribution p_max = 4 F / (pi d L) (docs/life.md sec. 2, "Pin in a bore"): the larger of the two
  is taken.  A roller on a groove flank or slot wall: R' = d/2 (a flat wall; the cam flank's own curvature is
  left out, a departure that underestimates p0 on a convex flank and overestimates it on a concave one).
* **Endurance** (:func:`shakedown_pressure`): the elastic shakedown limit of a line contact, p0 = 4 k (Johnson
  1985, sec. 9.2: frictionless line contact of an elastic-perfectly plastic solid; with traction coefficients
  below 0.25 the limit stays within 10 % of it), with the shear yield stress k = Y / sqrt(3) (von Mises) and
  Y = H / 3 from the softer member's hardness (Tabor 1951).  Below it every load cycle is elastic after the first
  and the surface does not accumulate plastic strain: no contact-fatigue life limit.  Checked against an
  independent number: hardened steel (H = 2 GPa) gives 1.54 GPa, ISO 281:2007's 1.5 GPa contact stress at the
  fatigue load limit of bearing steel (sec. 9.3.3) (tests/life/test_contact_fatigue.py).
* **Rolling bearing** (:func:`basic_rating_life`): a roller pair whose description gives the roller bearing's
  basic dynamic load rating ``dynamic_load_rating`` C is a rolling bearing (a track roller, cam follower): its
  basic rating life is L10 = (C / P)^p million revolutions (ISO 281:2007 eq. 1; p = 10/3 for roller bearings,
  3 for ball bearings), P the mean equivalent load over its revolutions (:func:`rolling_equivalent_load`).
"""

from __future__ import annotations

import math

import numpy as np

from berryshaker.errors import ConfigError

#: load-life exponent of ISO 281:2007 (eq. 1): roller bearings (needle track rollers, cam followers) and ball
#: bearings
ISO281_EXPONENT = {"roller": 10.0 / 3.0, "ball": 3.0}
#: ISO 281:2007 sec. 9.3.3: the contact stress of bearing steel at its fatigue load limit (Pa): the independent
#: check of :func:`shakedown_pressure` for hardened steel
ISO281_FATIGUE_STRESS = 1.5e9
#: materials of the material pairs without a line-contact law in berryshaker.contact.pair_law (pin, bush)
_EXTRA_MATERIALS = {"steel-on-nylon-dry": ("steel", "nylon"), "ptfe-on-steel-dry": ("steel", "nylon"),
                    "polyethylene-on-steel-dry": ("steel", "nylon")}


def pair_modulus(material_pair: str) -> float:
    """E* of a material pair (Pa): E* = 1 / [(1 - nu1^2)/E1 + (1 - nu2^2)/E2] (Johnson 1985, ch. 4) with the
    constants of :data:`berryshaker.contact.conformal.MATERIALS`.

    Parameters
    ----------
    material_pair : str
        Key of :data:`berryshaker.contact.wear.MATERIAL_PAIRS`.

    Returns
    -------
    float
        E* (Pa).

    Raises
    ------
    ConfigError
        A pair without elastic constants.
    """
    from berryshaker.contact.conformal import material_constants
    from berryshaker.contact.pair_law import ELASTIC_MATERIALS
    from berryshaker.contact.stiffness import effective_modulus

    mats = ELASTIC_MATERIALS.get(material_pair) or _EXTRA_MATERIALS.get(material_pair)
    if mats is None:
        raise ConfigError(f"material_pair {material_pair!r} has no elastic constants for its contact pressure")
    (e1, n1), (e2, n2) = (material_constants(m) for m in mats)
    return effective_modulus(e1, n1, e2, n2)


def effective_radius(is_pin: bool, diameter: float, clearance: float) -> float:
    """Effective radius R' of the contact (m): 1/R' = 1/R1 + 1/R2 (Johnson 1985, sec. 4.2).

    Parameters
    ----------
    is_pin : bool
        A pin in a bore (concave bore of radius d/2 + c) or a roller on a flat wall.
    diameter : float
        Pin or roller diameter d (m).
    clearance : float
        Radial clearance c of a pin (m; unused for a roller).

    Returns
    -------
    float
        R' (m): R1 (R1 + c) / c for a pin (infinite at c = 0), d/2 for a roller.
    """
    r1 = diameter / 2.0
    if not is_pin:
        return r1
    return math.inf if clearance <= 0 else r1 * (r1 + clearance) / clearance


def contact_pressure(force, is_pin: bool, diameter: float, length: float, clearance: float, e_star: float):
    """Peak contact pressure of a joint under a normal force (Pa).

    Hertz's line contact p0 = sqrt(F E* / (pi L R')) (Johnson 1985, eq. 4.45, with the load per length F/L), R' of
    :func:`effective_radius`; for a pin at least the worn-in conformal maximum 4 F / (pi d L) (the cosine
    distribution over the loaded half, docs/life.md sec. 2).

    Parameters
    ----------
    force : float or array_like
        Normal force (N).
    is_pin : bool
        Pin in a bore (True) or roller on a wall.
    diameter : float
        Pin or roller diameter (m).
    length : float
        Contact length: bush length or roller width (m).
    clearance : float
        Radial clearance of a pin (m).
    e_star : float
        Effective modulus E* (Pa).

    Returns
    -------
    float or numpy.ndarray
        Peak pressure (Pa).
    """
    f = np.asarray(force, float)
    r = effective_radius(is_pin, diameter, clearance)
    hertz = np.sqrt(f * e_star / (math.pi * length * r)) if math.isfinite(r) else np.zeros_like(f)
    p = np.maximum(hertz, 4.0 * f / (math.pi * diameter * length)) if is_pin else hertz
    return float(p) if p.ndim == 0 else p


def shakedown_pressure(hardness: float) -> float:
    """Elastic shakedown limit of a line contact (Pa): p0 = 4 k, k = Y / sqrt(3), Y = H / 3.

    Johnson (1985), sec. 9.2 (frictionless line contact, elastic-perfectly plastic material); Tabor (1951) for
    H ~ 3 Y.  Hardened steel, H = 2 GPa: 1.54 GPa (ISO 281's 1.5 GPa for bearing steel, :data:`ISO281_FATIGUE_STRESS`);
    bearing bronze, H = 1 GPa: 0.77 GPa.

    Parameters
    ----------
    hardness : float
        Hardness of the softer member (Pa).

    Returns
    -------
    float
        The limit (Pa).

    References
    ----------
    K. L. Johnson, *Contact Mechanics*, Cambridge University Press, 1985, sec. 9.2.  D. Tabor, *The Hardness of
    Metals*, Clarendon Press, 1951.
    """
    return 4.0 * (hardness / 3.0) / math.sqrt(3.0)


def clearance_at_pressure(pressure: float, force_of, is_pin: bool, diameter: float, length: float,
                          e_star: float, lo: float, hi: float) -> float | None:
    """Smallest clearance in [lo, hi] (m) at which the contact pressure of the load ``force_of(c)`` reaches
    ``pressure`` (bisection on a grid of 200 points), or None where it stays below.

    Parameters
    ----------
    pressure : float
        The pressure to reach (Pa).
    force_of : callable
        Clearance (m) -> sizing load (N).
    is_pin : bool
        Pin in a bore or roller.
    diameter, length : float
        Pin or roller diameter and contact length (m).
    e_star : float
        Effective modulus (Pa).
    lo, hi : float
        The clearance range (m).

    Returns
    -------
    float or None
        The clearance (m), ``lo`` when already reached there, None when not within the range.
    """
    c = np.linspace(lo, hi, 200)
    p = np.array([contact_pressure(force_of(x), is_pin, diameter, length, x, e_star) for x in c])
    above = np.nonzero(p >= pressure)[0]
    if not above.size:
        return None
    i = int(above[0])
    if i == 0:
        return float(lo)
    # linear between the bracketing grid points
    return float(np.interp(pressure, [p[i - 1], p[i]], [c[i - 1], c[i]]))


def rolling_equivalent_load(t, force, rolling_speed, diameter: float, exponent: float = ISO281_EXPONENT["roller"]):
    """Mean equivalent load of a roller over its revolutions and its revolutions per operating hour.

    P_m = (int F^p |v| dt / int |v| dt)^(1/p): ISO 281:2007's mean load of a variable load, each load weighted by
    the revolutions made under it (dN = |v| dt / (pi d)); Harris and Kotzalas (2006), *Rolling Bearing Analysis*,
    ch. 9.

    Parameters
    ----------
    t : numpy.ndarray
        Times (s).
    force : numpy.ndarray
        Radial load on the roller (N).
    rolling_speed : numpy.ndarray
        Rolling speed of the roller on its track (m/s).
    diameter : float
        Roller diameter (m).
    exponent : float
        Load-life exponent p (dimensionless).

    Returns
    -------
    (float, float)
        P_m (N; the mean force where the roller does not turn) and revolutions per hour (1/h).
    """
    t, f, v = (np.asarray(x, float) for x in (t, force, rolling_speed))
    v = np.abs(v)
    dist = float(np.trapezoid(v, t))
    span = float(t[-1] - t[0]) if t.size > 1 else 0.0
    if dist <= 0 or span <= 0:
        return float(np.mean(np.abs(f))) if f.size else 0.0, 0.0
    pm = (float(np.trapezoid(np.abs(f) ** exponent * v, t)) / dist) ** (1.0 / exponent)
    return pm, dist / (math.pi * diameter) / span * 3600.0


def basic_rating_life(rating: float, load: float, kind: str = "roller") -> float:
    """ISO 281:2007 basic rating life L10 = (C / P)^p (millions of revolutions; eq. 1).

    Parameters
    ----------
    rating : float
        Basic dynamic load rating C (N).
    load : float
        Equivalent dynamic load P (N).
    kind : {"roller", "ball"}
        The bearing's rolling elements (p = 10/3 or 3).

    Returns
    -------
    float
        L10 (10^6 revolutions, dimensionless count); infinite for P = 0.

    Raises
    ------
    ConfigError
        Unknown ``kind`` or a rating that is not positive.
    """
    if kind not in ISO281_EXPONENT:
        raise ConfigError(f"rolling bearing kind {kind!r}: use one of {', '.join(ISO281_EXPONENT)}")
    if not rating > 0:
        raise ConfigError(f"dynamic_load_rating must be > 0 N, got {rating}")
    return math.inf if load <= 0 else (rating / load) ** ISO281_EXPONENT[kind]


def reliability_factor(reliability: float) -> float:
    """ISO 281:2007 sec. 9.2 life modification factor for reliability: a1 = 0.95 (ln(1/R) / ln(1/0.9))^(2/3) + 0.05
    (the Weibull dispersion of bearing lives with slope 1.5, and a minimum life 0.05 L10).

    Parameters
    ----------
    reliability : float
        Reliability R (0 < R < 1; 0.9 gives 1).

    Returns
    -------
    float
        a1 (dimensionless): 1 at R = 0.9, 3.38 at R = 0.5 (the median life).
    """
    if not 0.0 < reliability < 1.0:
        raise ConfigError(f"reliability must be between 0 and 1, got {reliability}")
    return 0.95 * (math.log(1.0 / reliability) / math.log(1.0 / 0.9)) ** (2.0 / 3.0) + 0.05
