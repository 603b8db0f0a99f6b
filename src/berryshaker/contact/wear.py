"""Sliding wear of clearance joints: Archard's law and its use for a pin in a bore.

Archard's law: the volume worn away is proportional to the normal load and the sliding distance and
inversely proportional to the hardness of the softer surface, V = k F s / H.  Per unit time and per unit
area it reads dh/dt = k p v_s / H.  Everything here is SI: N, m, m/s, Pa, s, m^3.  ``k`` is the
DIMENSIONLESS wear coefficient; ``k / H`` (m^2/N = m^3/(N m)) is the dimensional wear factor that
bearing catalogues quote, usually in mm^3/(N m) (1 mm^3/(N m) = 1e-9 m^2/N).

References
----------
J. F. Archard, "Contact and rubbing of flat surfaces", J. Appl. Phys. 24 (1953) 981-988.
I. M. Hutchings, "Tribology: Friction and Wear of Engineering Materials", Edward Arnold (1992), ch. 5.
E. Rabinowicz, "Friction and Wear of Materials", 2nd ed., Wiley (1995).
P. Flores, "Modeling and simulation of wear in revolute clearance joints in multibody systems",
Mech. Mach. Theory 44 (2009) 1211-1222.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy.integrate import cumulative_trapezoid

from berryshaker.errors import ConfigError

#: 1 kgf/mm^2 (the unit of Vickers hardness numbers) in Pa.
KGF_PER_MM2 = 9.80665e6


def _positive(value, name: str, allow_zero: bool = False) -> np.ndarray:
    arr = np.asarray(value, dtype=float)
    bad = ~np.isfinite(arr) | ((arr < 0) if allow_zero else (arr <= 0))
    if np.any(bad):
        raise ConfigError(f"{name}: must be {'>= 0' if allow_zero else '> 0'} and finite, got {value!r}")
    return arr


def archard_wear_volume_rate(normal_force, sliding_speed, wear_coefficient, hardness):
    """Archard wear volume rate dV/dt = k |F| |v_s| / H (m^3/s).

    Parameters
    ----------
    normal_force : array_like
        Normal contact force F (N); its magnitude is used.
    sliding_speed : array_like
        Relative sliding speed v_s at the contact (m/s); its magnitude is used.
    wear_coefficient : float or array_like
        Dimensionless wear coefficient k (>= 0).
    hardness : float or array_like
        Hardness H of the softer surface (Pa, > 0).

    Returns
    -------
    numpy.ndarray
        dV/dt in m^3/s, broadcast over the inputs.

    Notes
    -----
    Archard (1953): V = k F s / H with s the sliding distance; differentiated in time with ds/dt = |v_s|.
    """
    k = _positive(wear_coefficient, "wear coefficient k", allow_zero=True)
    h = _positive(hardness, "hardness H")
    return k * np.abs(np.asarray(normal_force, float)) * np.abs(np.asarray(sliding_speed, float)) / h


def archard_wear_depth_rate(pressure, sliding_speed, wear_coefficient, hardness):
    """Archard wear depth rate dh/dt = k p |v_s| / H (m/s).

    Parameters
    ----------
    pressure : array_like
        Contact pressure p (Pa, >= 0; negative values mean no contact and give 0).
    sliding_speed : array_like
        Sliding speed v_s (m/s); its magnitude is used.
    wear_coefficient : float
        Dimensionless wear coefficient k.
    hardness : float
        Hardness H of the softer surface (Pa).

    Returns
    -------
    numpy.ndarray
        dh/dt in m/s.

    Notes
    -----
    Archard's law per unit area (dV = dh dA, dF = p dA), the local form used for wear in revolute
    clearance joints by Flores (2009).
    """
    k = _positive(wear_coefficient, "wear coefficient k", allow_zero=True)
    h = _positive(hardness, "hardness H")
    p = np.clip(np.asarray(pressure, float), 0.0, None)
    return k * p * np.abs(np.asarray(sliding_speed, float)) / h


def _series(force, sliding_speed, t):
    t = np.asarray(t, float)
    f = np.asarray(force, float)
    v = np.asarray(sliding_speed, float)
    if t.ndim != 1 or t.size < 2:
        raise ConfigError(f"wear: time series needs at least two samples, got shape {t.shape}")
    if f.shape != t.shape or v.shape != t.shape:
        raise ConfigError(f"wear: force {f.shape}, sliding speed {v.shape} and time {t.shape} must have the "
                          "same 1-D shape")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(f)) and np.all(np.isfinite(v))):
        raise ConfigError("wear: time, force and sliding speed must be finite")
    if np.any(np.diff(t) <= 0):
        raise ConfigError("wear: time must be strictly increasing")
    return f, v, t


def archard_wear_volume(force, sliding_speed, t, wear_coefficient, hardness):
    """Cumulative Archard wear volume V(t) = int_0^t k |F| |v_s| / H dt (m^3), trapezoid rule.

    Parameters
    ----------
    force, sliding_speed : array_like, shape (n,)
        Normal force (N) and sliding speed (m/s) samples at the times ``t``.
    t : array_like, shape (n,)
        Strictly increasing times (s).
    wear_coefficient : float
        Dimensionless k.
    hardness : float
        H (Pa).

    Returns
    -------
    numpy.ndarray, shape (n,)
        Worn volume from t[0] (0 at t[0]), non-decreasing, m^3.

    Notes
    -----
    Archard (1953).  The integral is the trapezoid rule on the samples (exact for piecewise-linear
    |F v_s|); impacts shorter than the sample spacing are only as well resolved as the series is.
    """
    f, v, t = _series(force, sliding_speed, t)
    rate = archard_wear_volume_rate(f, v, wear_coefficient, hardness)
    return cumulative_trapezoid(rate, t, initial=0.0)


def archard_wear_depth(force, sliding_speed, t, wear_coefficient, hardness, contact_area):
    """Cumulative Archard wear depth h(t) = int k (|F| / A) |v_s| / H dt (m) for a known contact area.

    Parameters
    ----------
    force, sliding_speed, t : array_like, shape (n,)
        Normal force (N), sliding speed (m/s), strictly increasing time (s).
    wear_coefficient : float
        Dimensionless k.
    hardness : float
        H (Pa).
    contact_area : float
        Area A (m^2) over which the worn volume is spread (uniform pressure p = F / A).  For a roller
        running along a groove flank, the flank area swept by the roller (track length x width).

    Returns
    -------
    numpy.ndarray, shape (n,)
        Depth from t[0] (m), non-decreasing.  For constant F, v_s: h = k p v_s t / H exactly.

    Notes
    -----
    Archard's law with uniform pressure over A: h = V / A.
    """
    a = float(_positive(contact_area, "contact area"))
    return archard_wear_volume(force, sliding_speed, t, wear_coefficient, hardness) / a


LoadDirection = Literal["fixed", "rotating"]


def pin_in_bore_clearance_growth(force, sliding_speed, t, wear_coefficient, hardness, pin_diameter,
                                 bearing_length, load_direction: LoadDirection = "fixed"):
    """Growth of the RADIAL clearance of a pin in a bore from Archard wear (m, cumulative).

    Parameters
    ----------
    force, sliding_speed, t : array_like, shape (n,)
        Normal contact force (N), sliding speed at the contact (m/s), strictly increasing time (s).
    wear_coefficient : float
        Dimensionless k of the pair (wear attributed to the softer part, usually the bush).
    hardness : float
        Hardness H of the softer part (Pa).
    pin_diameter : float
        d (m).
    bearing_length : float
        Axial length L of the contact (m).
    load_direction : {"fixed", "rotating"}
        "fixed": the load keeps one direction relative to the worn part; returns the depth at the most
        loaded point (conservative).  "rotating": the load direction sweeps the whole circumference
        uniformly; returns the circumferential mean depth.

    Returns
    -------
    numpy.ndarray, shape (n,)
        Clearance growth from t[0] (m); non-decreasing.

    Notes
    -----
    "fixed" -- worn-in conformal contact: a rigid pin sinking by delta into the bore removes a local
    normal depth delta cos(theta) over the loaded half |theta| < pi/2; with the local Archard law
    dh/dt = k p v_s / H this needs p = p_max cos(theta), and the load balance
    F = int p cos(theta) (d/2) L dtheta gives p_max = 4 F / (pi d L), so
    d(delta)/dt = 4 k F v_s / (pi H d L).
    "rotating" -- non-conformal contact whose location covers the circumference uniformly: the volume
    k F v_s / H is spread over pi d L, so dh/dt = k F v_s / (pi H d L), a quarter of the fixed value.
    Departures: Flores (2009) accumulates the local depth at each instantaneous contact point (Hertz /
    Persson pressure) and obtains a non-uniform, oval bore; here the wear is either concentrated in the
    one loaded direction or uniform, and the initial non-conformal wear-in (faster than either) is not
    modelled.  Pin wear is not separated from bush wear: k describes the pair.
    """
    d = float(_positive(pin_diameter, "pin diameter"))
    length = float(_positive(bearing_length, "bearing length"))
    volume = archard_wear_volume(force, sliding_speed, t, wear_coefficient, hardness)
    if load_direction == "fixed":
        return volume * 4.0 / (math.pi * d * length)
    if load_direction == "rotating":
        return volume / (math.pi * d * length)
    raise ConfigError(f"load_direction {load_direction!r}: choose 'fixed' (most loaded point, conservative) "
                      "or 'rotating' (uniform over the circumference)")


@dataclass(frozen=True)
class MaterialPair:
    """Wear data of a sliding pair.

    Attributes
    ----------
    name : str
        Key in :data:`MATERIAL_PAIRS`.
    description : str
        The pair and the test condition.
    wear_coefficient : float
        Dimensionless Archard k (nominal value).
    hardness : float
        Hardness H of the softer member (Pa).
    wear_coefficient_range : (float, float)
        Plausible range of k for design studies (dimensionless).
    source : str
        Where the numbers come from; "[assumed]" marks values that are engineering assumptions.
    assumed : bool
        True when k (or H) is not a cited measurement.
    lubricated : bool
        True for a greased or oil-lubricated pair: its slow impacts are damped by the squeeze film, so the contact
        laws keep the published hysteresis law at every speed (no restitution velocity, docs/contact.md sec. 6.4).
    """

    name: str
    description: str
    wear_coefficient: float
    hardness: float
    wear_coefficient_range: tuple[float, float]
    source: str
    assumed: bool
    lubricated: bool = False

    @property
    def wear_factor(self) -> float:
        """Dimensional wear factor K = k / H (m^2/N = m^3 per N per m of sliding)."""
        return self.wear_coefficient / self.hardness


_ARCHARD_1953 = ("Archard (1953) J. Appl. Phys. 24:981, Table 1 (pin on tool-steel ring, unlubricated, "
                 "3.9 N, 1.8 m/s); see also Hutchings (1992) Tribology, ch. 5")

#: Material pairs with Archard coefficients.  Cited values are dry laboratory values (Archard 1953);
#: lubricated and bush values are marked assumed -- measure them (pin-on-disc or bush test) for a design.
MATERIAL_PAIRS: dict[str, MaterialPair] = {
    p.name: p for p in (
        MaterialPair("mild-steel-dry", "mild steel on mild steel, unlubricated", 7e-3, 186 * KGF_PER_MM2,
                     (1e-3, 1e-2), _ARCHARD_1953, False),
        MaterialPair("hardened-steel-dry", "hardened tool steel on tool steel, unlubricated", 1.3e-4,
                     850 * KGF_PER_MM2, (1e-5, 1e-3), _ARCHARD_1953, False),
        MaterialPair("brass-on-steel-dry", "60/40 leaded brass on tool steel, unlubricated", 6e-4,
                     95 * KGF_PER_MM2, (1e-4, 1e-3), _ARCHARD_1953, False),
        MaterialPair("ptfe-on-steel-dry", "PTFE (unfilled) on tool steel, unlubricated", 2.5e-5,
                     5 * KGF_PER_MM2, (1e-5, 1e-4), _ARCHARD_1953, False),
        MaterialPair("polyethylene-on-steel-dry", "polyethylene on tool steel, unlubricated", 1.3e-7,
                     1.7 * KGF_PER_MM2, (1e-8, 1e-6), _ARCHARD_1953, False),
        MaterialPair("steel-steel-lubricated", "steel pin in steel eye, greased / boundary lubricated",
                     1e-7, 2.0e9, (1e-9, 1e-6),
                     "[assumed] order of magnitude: lubrication lowers k by several decades relative to dry "
                     "contact (Rabinowicz 1995; Hutchings 1992); H of a through-hardened steel ~2 GPa", True, True),
        MaterialPair("steel-on-bronze-greased", "hardened steel pin in a greased bronze bush", 1e-6, 1.0e9,
                     (1e-7, 1e-5),
                     "[assumed] between the lubricated-steel and dry-brass values; H of a bearing bronze "
                     "~1 GPa", True, True),
        MaterialPair("steel-on-nylon-dry", "steel pin in an unlubricated nylon (PA) bush", 1e-6, 1.0e8,
                     (1e-7, 1e-5),
                     "[assumed] of the order of the dry polymer values above; H of nylon ~0.1 GPa", True),
    )
}


def material_pair(name: str) -> MaterialPair:
    """Look up a :class:`MaterialPair` by name, with the list of names in the error.

    Parameters
    ----------
    name : str
        A key of ``MATERIAL_PAIRS``, e.g. "steel-steel-lubricated".

    Returns
    -------
    MaterialPair
        Its Archard data.
    """
    try:
        return MATERIAL_PAIRS[name]
    except KeyError:
        raise ConfigError(f"unknown material pair {name!r}; known pairs: {', '.join(MATERIAL_PAIRS)}") from None


#: abrasive wear of a greased joint with soil and plant debris in it (dimensionless Archard k: nominal, range)
#: [assumed]: a diluted three-body abrasion; dry three-body abrasion has k ~ 1e-4..1e-3 and two-body ~1e-3..1e-2
#: (Rabinowicz 1995, ch. 6; Hutchings 1992, sec. 6.2: three-body about an order of magnitude below two-body), and
#: grease that holds the debris and a seal that keeps most of it out lower it by about a decade
ABRASIVE_WEAR = (3e-5, (1e-5, 1e-4))


def wear_scale(material_pair: str) -> float:
    """The faster wear mode's Archard k over the pair's nominal (lubricated) k: max(k, k_abrasive) / k.

    Parameters
    ----------
    material_pair : str
        Key of :data:`berryshaker.contact.wear.MATERIAL_PAIRS`.

    Returns
    -------
    float
        The factor (>= 1, dimensionless).
    """
    k0 = MATERIAL_PAIRS[material_pair].wear_coefficient
    return max(k0, ABRASIVE_WEAR[0]) / k0
