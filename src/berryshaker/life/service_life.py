"""A joint's service life by the mechanisms that set it (docs/life.md, "Life by mechanism").

From a joint's clearance response (:class:`berryshaker.life.clearance_response.ClearanceResponse`: its
static-equivalent load and its Archard growth rate at the material pair's nominal k, each re-evaluated by the
multibody engine on a grid of clearances from the new fit to the service limit) and the joint's geometry,
:func:`joint_life` gives the hours from the new machine's clearance to the first of:

* **wear by mode**: the clearance reaches the service limit (:func:`berryshaker.life.service.service_limit`) under
  lubricated (mild) wear, k of the pair's range (:data:`berryshaker.contact.wear.MATERIAL_PAIRS`), and under
  abrasive field wear by soil and plant debris in the joint, k of
  :data:`berryshaker.contact.wear.ABRASIVE_WEAR` [assumed].  The growth
  rate scales with k / H (Archard 1953); the hours as 1 / k, so each mode's interval is its k range.
* **contact fatigue** (:mod:`berryshaker.life.contact_fatigue`): the Hertz pressure of the static-equivalent load
  reaches the pair's shakedown limit.  This is the clearance-impact-wear loop (Flores 2009; Mukras et al. 2010):
  the wear opens the clearance, the engine's loads at the larger clearance are harder and the conformal radius of a
  pin in its bore shrinks, so the pressure rises with the hours until the surface no longer shakes down; the
  hours to that clearance come from the faster wear mode.
* **rolling-bearing fatigue** (a roller pair with ``dynamic_load_rating``): ISO 281's basic rating life, its
  damage summed over the hours as the clearance (and with it the roller's load) grows (Palmgren-Miner).

The governing mechanism is the one that ends the life first at its central value; the interval is that
mechanism's and names its dominant uncertainty.  An interval beyond the machine's design life
(:data:`DESIGN_LIFE_H`) is not stated as hours: it reads "> 20,000 h: no wear-out in the machine's life".
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from berryshaker.contact.wear import ABRASIVE_WEAR
from berryshaker.records import JsonRecord, optional

#: the machine's design life (operating hours) [assumed]: no interval beyond it is stated as a number
DESIGN_LIFE_H = 20000.0


@dataclass(frozen=True)
class MechanismLife(JsonRecord):
    """The hours one mechanism gives a joint (from its new clearance).

    Attributes
    ----------
    mechanism : str
        "lubricated wear", "abrasive wear", "contact fatigue" or "rolling-bearing fatigue (ISO 281)".
    hours : float or None
        Central value (h); None: the mechanism does not end the life (below its endurance, limit not reached).
    lo, hi : float or None
        Its interval (h) over the dominant uncertainty (infinite: beyond reach).
    uncertainty : str
        The dominant uncertainty of the interval.
    note : str
        What it rests on (the numbers behind it).
    """

    mechanism: str
    hours: float | None
    lo: float | None
    hi: float | None
    uncertainty: str
    note: str


@dataclass(frozen=True)
class JointLife(JsonRecord):
    """One joint's service life: its governing mechanism, the interval, each mechanism's hours.

    Attributes
    ----------
    joint : str
        Pair name.
    start_mm : float
        The new machine's clearance it starts from (mm; radial for a pin, free travel for a roller).
    start_from : str
        Where that comes from (the fit on the drawing, or the described size).
    limit_mm : float
        The service limit (mm).
    limit_rule : str
        The rule that sets it (:data:`berryshaker.life.service.SERVICE_RULE`).
    governing : str
        The mechanism that ends the life first.
    hours : float or None
        Its central value (h); None: beyond every mechanism's reach.
    lo, hi : float or None
        Its interval (h).
    uncertainty : str
        The interval's dominant uncertainty.
    reads : str
        The interval as the report states it: hours within the design life, else "> 20,000 h: no wear-out in the
        machine's life".
    mechanisms : list of MechanismLife
        Every mechanism's hours.
    design_life_h : float
        The machine's design life (h).
    pressure_MPa : float, optional
        The contact pressure of the static-equivalent load at the new clearance (MPa).
    endurance_MPa : float, optional
        The pair's shakedown limit (MPa).
    """

    joint: str
    start_mm: float
    start_from: str
    limit_mm: float
    limit_rule: str
    governing: str
    hours: float | None
    lo: float | None
    hi: float | None
    uncertainty: str
    reads: str
    mechanisms: list[MechanismLife]
    design_life_h: float = DESIGN_LIFE_H
    pressure_MPa: float | None = optional()
    endurance_MPa: float | None = optional()


def reads(hours: float | None, lo: float | None, hi: float | None, design_life: float = DESIGN_LIFE_H) -> str:
    """How an interval is stated: never a number beyond the design life.

    Parameters
    ----------
    hours, lo, hi : float or None
        Central value and interval (h); None or beyond the design life: not reached in it.
    design_life : float
        The machine's design life (h).

    Returns
    -------
    str
        "4,300 h [1,300 .. 13,000]", "12,000 h [3,800 .. > 20,000]" or "> 20,000 h: no wear-out in the machine's
        life".
    """
    def big(x):
        return x is None or not math.isfinite(x) or x > design_life

    if big(hours):
        if lo is not None and not big(lo):
            return f"> {design_life:,.0f} h [{lo:,.0f} .. > {design_life:,.0f}]: wear-out unlikely in the machine's life"
        return f"> {design_life:,.0f} h: no wear-out in the machine's life"
    return (f"{hours:,.0f} h [{lo:,.0f} .. " + (f"> {design_life:,.0f}" if big(hi) else f"{hi:,.0f}") + "]")


def _hours_at(response, c0: float, c1: float, scale: float) -> float:
    """Hours for the clearance to grow from c0 to c1 (m) at ``scale`` x the response's nominal growth rate."""
    from berryshaker.life.clearance_response import LIFE_CAP_H

    h = response.hours_to(c0, c1)
    return math.inf if h >= LIFE_CAP_H else h / scale


def joint_life(response, geometry, start: float, limit: float, start_from: str, rating: float | None = None,
               design_life: float = DESIGN_LIFE_H) -> JointLife:
    """A joint's service life by mechanism (module docstring).

    Parameters
    ----------
    response : ClearanceResponse
        The joint's static-equivalent load (N) and growth rate at the nominal k (m/h) against its clearance (m).
    geometry : JointGeometry
        The joint's diameter, bearing length, material pair (:func:`berryshaker.life.joint_loads.joint_geometry`).
    start : float
        The new machine's clearance (m).
    limit : float
        The service limit (m).
    start_from : str
        Where ``start`` comes from.
    rating : float, optional
        The roller bearing's basic dynamic load rating C (N); None: not a rolling bearing.
    design_life : float
        The machine's design life (h).

    Returns
    -------
    JointLife
        The governing mechanism, its interval and every mechanism's hours.
    """
    from berryshaker.contact.wear import MATERIAL_PAIRS
    from berryshaker.life.contact_fatigue import (
        basic_rating_life,
        clearance_at_pressure,
        contact_pressure,
        pair_modulus,
        reliability_factor,
        shakedown_pressure,
    )
    from berryshaker.life.service import SERVICE_RULE

    mp = MATERIAL_PAIRS[geometry.material_pair]
    k0, (k_lo, k_hi) = mp.wear_coefficient, mp.wear_coefficient_range
    ka, (ka_lo, ka_hi) = ABRASIVE_WEAR
    tag = "[assumed]" if mp.assumed else "[published]"
    mechs = []

    def wear(name, k, lo_k, hi_k, src):
        h = _hours_at(response, start, limit, k / k0)
        return MechanismLife(name, _finite(h), _finite(h * k / hi_k), _finite(h * k / lo_k),
                             f"Archard k {lo_k:.0e}..{hi_k:.0e} ({src}; hours scale as 1/k)",
                             f"grows from {start * 1e3:.3g} to the limit {limit * 1e3:.3g} mm at k {k:.0e} on the "
                             "engine's loads at each clearance")

    mild = wear("lubricated wear", k0, k_lo, k_hi, f"{geometry.material_pair} {tag}")
    abrasive = wear("abrasive wear", ka, ka_lo, ka_hi, "field debris [assumed]")
    mechs += [mild, abrasive]
    fastest = min((mild, abrasive), key=_hours)
    scale = (ka if fastest is abrasive else k0) / k0
    lo_k, hi_k = (ka_lo, ka_hi) if fastest is abrasive else (k_lo, k_hi)
    k_nom = ka if fastest is abrasive else k0
    pressure = endurance = None
    try:
        e_star = pair_modulus(geometry.material_pair)
    except Exception:  # a polymer pair without elastic constants: no Hertz check
        e_star = None
    if e_star is not None:
        endurance = shakedown_pressure(mp.hardness)
        force = response.force
        pressure = contact_pressure(float(force(start)), geometry.is_pin, geometry.diameter, geometry.bearing_length,
                                    start, e_star)
        c_f = clearance_at_pressure(endurance, lambda c: float(force(c)), geometry.is_pin, geometry.diameter,
                                    geometry.bearing_length, e_star, start, limit)
        if c_f is None:
            p_lim = contact_pressure(float(force(limit)), geometry.is_pin, geometry.diameter,
                                     geometry.bearing_length, limit, e_star)
            mechs.append(MechanismLife("contact fatigue", None, None, None, "-",
                                       f"Hertz pressure {pressure / 1e6:.0f} MPa new, {p_lim / 1e6:.0f} MPa at the limit: "
                                       f"below the shakedown limit {endurance / 1e6:.0f} MPa (no fatigue limit)"))
        else:
            h = 0.0 if c_f <= start else _hours_at(response, start, c_f, scale)
            mechs.append(MechanismLife("contact fatigue", _finite(h), _finite(h * k_nom / hi_k), _finite(h * k_nom / lo_k),
                                       f"the wear rate to {c_f * 1e3:.3g} mm: {fastest.uncertainty}",
                                       f"the static-equivalent load's Hertz pressure reaches the shakedown limit "
                                       f"{endurance / 1e6:.0f} MPa at {c_f * 1e3:.3g} mm "
                                       f"(new: {pressure / 1e6:.0f} MPa)"))
    if rating is not None and response.rolling_load is not None:
        # damage per hour 1 / L10h(c) as the clearance grows at the governing wear rate (Palmgren-Miner)
        hours = np.linspace(0.0, min(_hours(fastest), 10 * design_life), 400)
        c = response.grow(start, hours * scale)  # dc/dh = scale r(c): the nominal growth at scale x the hours
        load = np.interp(c, response.clearance, response.rolling_load)
        turns = np.interp(c, response.clearance, response.roller_rev_per_h)
        l10h = np.array([basic_rating_life(rating, p) * 1e6 / max(n, 1e-12) for p, n in zip(load, turns)])
        damage = np.concatenate([[0.0], np.cumsum(np.diff(hours) / l10h[1:])])
        h = float(np.interp(1.0, damage, hours)) if damage[-1] >= 1.0 else math.inf
        a50 = reliability_factor(0.5)
        mechs.append(MechanismLife("rolling-bearing fatigue (ISO 281)", _finite(h), _finite(h), _finite(a50 * h),
                                   f"the bearing's life dispersion: L10 (90 % reliability) .. L50 = {a50:.2f} x L10 "
                                   "(ISO 281:2007 sec. 9.2, reliability factor a1)",
                                   f"C {rating / 1e3:.3g} kN, P {float(load[0]):.0f} N new, "
                                   f"{float(turns[0]):.3g} rev/h"))
    gov = min(mechs, key=_hours)
    return JointLife(geometry.name, start * 1e3, start_from, limit * 1e3, SERVICE_RULE, gov.mechanism,
                     _finite(gov.hours), _finite(gov.lo), _finite(gov.hi), gov.uncertainty,
                     reads(gov.hours, gov.lo, gov.hi, design_life), mechs, design_life,
                     None if pressure is None else pressure / 1e6, None if endurance is None else endurance / 1e6)


def _hours(m: MechanismLife) -> float:
    return math.inf if m.hours is None else m.hours


def _finite(x):
    return float(x) if x is not None and math.isfinite(x) else None
