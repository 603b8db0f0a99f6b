"""The contact law of one clearance pair, resolved from its geometry and materials (docs/contact.md sec. 6).

A clearance pair of a machine description names its kind (pin in a bore, roller in a groove, roller in a
slot), its size, the pin or roller diameter, the contact length and a material pair.  Unless the
description gives the stiffness itself, :func:`resolve_pair_contact` turns these into the force law the
engines use:

* the elastic part F = K delta^n is the power law fitted (:func:`~berryshaker.contact.conformal.fit_power_law`)
  to Johnson's line-contact relation of the two cylinders (:func:`~berryshaker.contact.pin_in_bore.pin_in_bore_law`
  for a pin, :func:`~berryshaker.contact.conformal.roller_on_wall_law` for a roller), over the load range
  :data:`FIT_FORCE_RANGE` of the reference machine's joints;
* the dissipation is a hysteresis law (default :data:`DEFAULT_LAW`, Lankarani & Nikravesh 1990) with the
  pair's coefficient of restitution, so no viscous coefficient or damping ramp is needed.  The restitution
  applies at impact speeds from the pair's restitution velocity up; slower impacts get the damping of an impact
  at that speed (Hunt & Crossley's material-constant hysteresis, restitution rising to 1 as the speed falls to 0;
  docs/contact.md sec. 6.4).  Default (:func:`default_restitution_velocity`): the materials' yield velocity
  (:func:`yield_velocity`) for a dry pair; for a lubricated one :data:`LUBRICATED_RESTITUTION_VELOCITY`, a
  numerical floor of the published law below which the results are shown independent of it.

Every resolved value carries a provenance tag: ``derived`` (computed here), ``assumed`` (a documented
default), or the tag of the description's own line (``study``, ``assumed``, ``default`` if untagged).
SI throughout.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import lru_cache

from berryshaker.contact.conformal import (
    CylinderContactLaw,
    line_contact_load_limit,
    material_constants,
    roller_on_wall_law,
)
from berryshaker.contact.pin_in_bore import arc_limit_load, pin_in_bore_law
from berryshaker.contact.stiffness import effective_modulus
from berryshaker.errors import ConfigError

#: the law of a pair that gives no law and no stiffness: hysteresis damping of Lankarani & Nikravesh (1990),
#: the usual law of clearance-joint studies for metal contact with e close to 1 (Flores & Ambrosio 2004)
DEFAULT_LAW = "lankarani_nikravesh"
#: the law of a pair that gives its stiffness but no law (berryshaker 0.1.0 and 0.2 files): the ADAMS IMPACT
#: function with exponent 1, as those versions used, so such files keep their results
LEGACY_LAW = "impact"
#: restitution velocity v_ref of the hysteresis laws (m/s) [assumed] for a pair whose materials have no
#: :func:`yield_velocity` (no hardness in berryshaker.contact.wear): the yield velocity of mild steel, rounded
DEFAULT_RESTITUTION_VELOCITY = 0.05
#: restitution velocity v_ref of a lubricated pair (m/s) [derived: convergence test]: a numerical regularisation of
#: the published hysteresis law, not a material property.  Impacts slower than this (about 7 % of the reference
#: harvester's, which close at down to 1 um/s as a pin settles into its bore) get the damping of an impact at
#: 1 mm/s instead of one ~1/v_imp, whose eigenvalue held the explicit integrator at h ~ 0.1 us for up to 10^6 steps
#: when the settled pin was later loaded without separating.  The statistics a user sees do not depend on it: from
#: v_ref = 0 (the published law) to 1 mm/s, harvester-run force statistics (30 clearance sets) and coupled
#: drive-past fruit forces and harvest indexes (12 replicates) show no difference beyond the replicates' noise;
#: from 3 mm/s up the 95th percentiles of the collision forces rise (benchmarks/studies/impact_velocity_floor_study.py).
#: tests/contact/test_pair_law_velocity_floor.py checks this value against a 10x smaller one and fails at 10 mm/s.
LUBRICATED_RESTITUTION_VELOCITY = 1.0e-3
#: density of the pin or roller (kg/m^3) in the yield velocity: steel [typical]
PIN_DENSITY = 7850.0
#: loads over which the power law is fitted to Johnson's relation (N) [assumed]: they span the collision
#: forces of both reference machines with steel contact (docs/contact.md sec. 6)
FIT_FORCE_RANGE = (100.0, 2.0e4)
#: load at which the equivalent linear stiffness of the law is reported (N) [assumed]
OPERATING_LOAD = 1.0e3
#: pin or roller diameter when ``diameter`` is not given (m) [assumed] (the same as berryshaker.life)
DEFAULT_DIAMETER = 0.020
#: contact length when ``bearing_length`` is not given (m) [assumed] (the same as berryshaker.life)
DEFAULT_BEARING_LENGTH = 0.020
#: material pair when ``material_pair`` is not given [assumed] (the same as berryshaker.life)
DEFAULT_MATERIAL_PAIR = "steel-on-bronze-greased"

#: elastic materials (pin or roller, bore or wall) of the wear material pairs of
#: :data:`berryshaker.contact.wear.MATERIAL_PAIRS`; the polymer pairs are absent on purpose: a steel pin in
#: a polymer bush is a conformal contact outside Johnson's narrow-contact relation (give K and n instead)
ELASTIC_MATERIALS: dict[str, tuple[str, str]] = {
    "mild-steel-dry": ("steel", "steel"),
    "hardened-steel-dry": ("steel", "steel"),
    "brass-on-steel-dry": ("steel", "bronze"),  # 60/40 brass E ~ 100 GPa, as bronze within 10 % [typical]
    "steel-steel-lubricated": ("steel", "steel"),
    "steel-on-bronze-greased": ("steel", "bronze"),
}


@dataclass(frozen=True)
class PairGeometry:
    """What the contact law of a clearance pair depends on (SI), with the [assumed] defaults filled in.

    Attributes
    ----------
    kind : str
        ``"pin-in-bore"``, ``"roller-in-groove"`` or ``"roller-in-slot"``.
    size : float
        Radial clearance (pin) or free travel across the groove or slot (roller) (m).
    diameter : float
        Pin or roller diameter (m).
    length : float
        Axial contact length: bush length or roller width (m).
    material_pair : str
        Key of :data:`ELASTIC_MATERIALS`.
    wall_radius : float
        Roller pairs: radius of curvature of the wall (m): > 0 convex, < 0 concave, ``inf`` flat.
    assumed : tuple of str
        The fields filled in with the defaults of this module.
    """

    kind: str
    size: float
    diameter: float
    length: float
    material_pair: str
    wall_radius: float = math.inf
    assumed: tuple[str, ...] = ()


def pair_geometry(kind, size, diameter=None, bearing_length=None, material_pair=None,
                  wall_radius=math.inf) -> PairGeometry:
    """:class:`PairGeometry` of a clearance pair, filling in :data:`DEFAULT_DIAMETER`,
    :data:`DEFAULT_BEARING_LENGTH` and :data:`DEFAULT_MATERIAL_PAIR` where a value is ``None``.

    Parameters
    ----------
    kind : str
        "pin-in-bore", "roller-in-groove" or "roller-in-slot".
    size : float
        Clearance size (m, :doc:`/nomenclature`).
    diameter : float, optional
        Pin or roller diameter (m).
    bearing_length : float, optional
        Contact length along the axis (m).
    material_pair : str, optional
        Key of :data:`ELASTIC_MATERIALS`.
    wall_radius : float
        Radius of curvature of the wall a roller runs on (m); inf for a straight slot or a pin.

    Returns
    -------
    PairGeometry
        The geometry, with the names of the values assumed.
    """
    given = {"diameter": diameter, "bearing_length": bearing_length, "material_pair": material_pair}
    assumed = [k for k, v in given.items() if v is None]
    diameter = DEFAULT_DIAMETER if diameter is None else diameter
    bearing_length = DEFAULT_BEARING_LENGTH if bearing_length is None else bearing_length
    material_pair = DEFAULT_MATERIAL_PAIR if material_pair is None else material_pair
    return PairGeometry(kind, float(size), float(diameter), float(bearing_length), str(material_pair),
                        float(wall_radius), tuple(assumed))


def fit_range_for(geom: PairGeometry, force_range=FIT_FORCE_RANGE) -> tuple[float, float]:
    """The load range (N) Johnson's relation can be fitted over for this pair: ``force_range`` with its top
    lowered to the model's limits where needed.

    Parameters
    ----------
    geom : PairGeometry
        The pair's geometry and materials.
    force_range : (float, float)
        The loads wanted (N).

    Returns
    -------
    (F_min, F_max)
        The loads (N).  F_max = min(force_range[1], F_lim / 10, F_arc): F_lim = 4 pi L E* dR / e^2 is where the logarithmic
        relation stops being monotone (:func:`~berryshaker.contact.conformal.line_contact_load_limit`) and, for
        a pin, F_arc the load at which the Hertz half-width reaches 0.35 R_pin (a contact arc of about 40 deg,
        a^2 = 4 F R1 R2 / (pi L E* c), :func:`~berryshaker.contact.pin_in_bore.arc_limit_load`), the validity
        limits :func:`~berryshaker.contact.pin_in_bore.pin_in_bore_law` enforces.  Small clearances (conformal
        contact) lower F_max; forces above it are extrapolated by the power law.
    """
    m1, m2 = _materials(geom)
    es = effective_modulus(*m1, *m2)
    r1 = geom.diameter / 2
    f_lo, f_hi = map(float, force_range)
    if geom.kind == "pin-in-bore":
        dr = geom.size
        f_arc = arc_limit_load(r1, dr, geom.length, es)
        f_hi = min(f_hi, 0.999 * f_arc)
    elif math.isinf(geom.wall_radius):
        dr = 2.0 * r1
    else:
        dr = r1 + geom.wall_radius if geom.wall_radius > 0 else -geom.wall_radius - r1
    f_hi = min(f_hi, 0.0999 * line_contact_load_limit(geom.length, dr, es))
    if not f_hi > 3.0 * f_lo:
        raise ConfigError(f"the line-contact model of this {geom.kind} pair (size {geom.size * 1e3:g} mm) holds only "
                          f"below {f_hi:.3g} N; give stiffness and exponent explicitly")
    return f_lo, f_hi


def _materials(geom: PairGeometry):
    if geom.material_pair not in ELASTIC_MATERIALS:
        raise ConfigError(f"material_pair {geom.material_pair!r} has no elastic line-contact law (known: "
                          f"{', '.join(sorted(ELASTIC_MATERIALS))}); for a polymer bush give stiffness and "
                          "exponent explicitly")
    a, b = ELASTIC_MATERIALS[geom.material_pair]
    return material_constants(a), material_constants(b)


def geometric_contact_law(geom: PairGeometry, force_range=FIT_FORCE_RANGE) -> CylinderContactLaw:
    """Johnson's line-contact law of a clearance pair and its power-law fit (docs/contact.md sec. 1-2).

    The result is a function of the (frozen) geometry and the load range alone and is immutable, so it is kept
    for the last :data:`CONTACT_LAW_CACHE_SIZE` of them: a machine's pairs are resolved when its description is
    validated and again when its mechanism is built (a fit costs ~0.2 ms; a sweep point did it 8 times).

    Parameters
    ----------
    geom : PairGeometry
        The pair; ``size`` > 0 for a pin (the radial clearance is Johnson's dR).
    force_range : (float, float)
        Loads to fit over (N), narrowed by :func:`fit_range_for`.

    Returns
    -------
    CylinderContactLaw
        Pin in bore: dR = c (internal contact, :func:`~berryshaker.contact.pin_in_bore.pin_in_bore_law`).
        Roller in a groove: the wall of radius ``wall_radius`` (convex inner wall of a cam groove > 0).
        Roller in a slot: a flat wall, compression referred to a depth 2 R_roller
        (:func:`~berryshaker.contact.conformal.roller_on_wall_law`).

    References
    ----------
    K. L. Johnson, *Contact Mechanics*, 1985, ch. 5; C. M. Pereira, A. L. Ramalho, J. A. Ambrosio,
    Nonlinear Dyn. 63 (2011) 681-697.
    """
    return _geometric_contact_law(geom, tuple(float(f) for f in force_range))


#: how many resolved geometric laws :func:`geometric_contact_law` keeps (a few per machine description)
CONTACT_LAW_CACHE_SIZE = 256


@lru_cache(maxsize=CONTACT_LAW_CACHE_SIZE)
def _geometric_contact_law(geom: PairGeometry, force_range: tuple[float, float]) -> CylinderContactLaw:
    m1, m2 = _materials(geom)
    rng = fit_range_for(geom, force_range)
    if geom.kind == "pin-in-bore":
        if not geom.size > 0:
            raise ConfigError("a pin-in-bore pair with zero clearance is an ideal joint: it has no contact law")
        return pin_in_bore_law(geom.diameter / 2, geom.size, geom.length, m1, m2, rng)
    if geom.kind in ("roller-in-groove", "roller-in-slot"):
        return roller_on_wall_law(geom.diameter / 2, geom.length, geom.wall_radius, m1, m2, rng)
    raise ConfigError(f"unknown clearance pair kind {geom.kind!r}")


@dataclass(frozen=True)
class PairContact:
    """The contact law a clearance pair runs with, every parameter resolved (SI) and tagged.

    Attributes
    ----------
    law : str
        Name in :mod:`berryshaker.contact.laws`.
    stiffness, exponent : float
        K (N/m^n) and n of the elastic part F = K delta^n.
    damping : float
        Viscous coefficient (``mlsd``) or cmax (``impact``), N s/m; 0 where the law does not use it.
    damping_depth : float
        Penetration at which ``impact`` reaches full damping (m).
    restitution : float
        Coefficient of restitution of the hysteresis laws (dimensionless).
    tags : dict
        Provenance tag per parameter (``derived``, ``assumed``, ``study``, ``default``, ...).
    geometry : PairGeometry or None
        What the law was derived from (None: the description gave the stiffness).
    fit_force_range : (float, float) or None
        Loads of the power-law fit (N).
    fit_error : float or None
        Worst relative force error of the fit over that range (dimensionless).
    tangent_stiffness, secant_stiffness : float
        dF/d(delta) and F/delta of the law at :data:`OPERATING_LOAD` (N/m): the linear springs it compares with.
    restitution_velocity : float
        v_ref of the hysteresis laws (m/s): ``restitution`` holds from this impact speed up
        (:func:`berryshaker.contact.laws.hysteresis_velocity`); 0 where the law does not use it.
    """

    law: str
    stiffness: float
    exponent: float
    damping: float
    damping_depth: float
    restitution: float
    tags: dict = field(default_factory=dict)
    geometry: PairGeometry | None = None
    fit_force_range: tuple[float, float] | None = None
    fit_error: float | None = None
    tangent_stiffness: float = float("nan")
    secant_stiffness: float = float("nan")
    restitution_velocity: float = 0.0

    def engine_contact(self) -> dict:
        """The ``contact`` table of a clearance joint of :mod:`berryshaker.multibody.spec` (SI).

        Returns
        -------
        dict
            law, stiffness (N/m^n), exponent, damping (N s/m), damping_depth (m), restitution,
            restitution_velocity (m/s).
        """
        return dict(law=self.law, stiffness=self.stiffness, exponent=self.exponent, damping=self.damping,
                    damping_depth=self.damping_depth, restitution=self.restitution,
                    restitution_velocity=self.restitution_velocity)

    def uses(self, parameter: str) -> bool:
        """True if the law reads ``parameter`` (a key of :data:`berryshaker.contact.laws.LAW_PARAMETERS`).

        Parameters
        ----------
        parameter : str
            The parameter, e.g. "damping".

        Returns
        -------
        bool
            Whether the law uses it.
        """
        from berryshaker.contact.laws import get_law

        return parameter in get_law(self.law).uses


def yield_velocity(material_pair: str) -> float:
    """Impact speed at which the softer member of a material pair starts to yield (m/s): the restitution velocity
    v_ref of the pair's hysteresis law when the description gives none (docs/contact.md sec. 6.4).

    Parameters
    ----------
    material_pair : str
        Key of :data:`ELASTIC_MATERIALS` that also has a hardness in
        :data:`berryshaker.contact.wear.MATERIAL_PAIRS`.

    Returns
    -------
    float
        V_Y = sqrt(26 Y (Y/E*)^4 / rho) (m/s), Johnson's impact velocity at first yield of a sphere striking a
        flat (K. L. Johnson, *Contact Mechanics*, 1985, sec. 11.4: rho V_Y^2 / Y = 26 (Y/E*)^4; 0.14 m/s for
        steel with Y = 1 GPa), with Y = H/3 the yield stress of the softer member from its hardness (D. Tabor,
        *The Hardness of Metals*, 1951), E* of the pair, rho = :data:`PIN_DENSITY`.  Steel in steel (H = 2 GPa):
        0.051 m/s; steel in bearing bronze (H = 1 GPa): 0.018 m/s.

    Notes
    -----
    Below V_Y an impact is elastic and loses only the material's hysteresis, which vanishes with the speed
    (restitution -> 1); above it plastic work makes the restitution nearly constant, falling slowly with the
    speed (Johnson sec. 11.4).  V_Y is therefore the lowest speed at which a constant restitution e can hold, and
    the hysteresis laws use e from V_Y up (Hunt & Crossley's material-constant hysteresis below).  Departure: the
    formula is that of a sphere, used here for cylinders in line contact, as the order of the speed at which
    yield starts (the line contact's yield speed depends on the joint's effective mass as well).

    Raises
    ------
    ConfigError
        A material pair without elastic constants or hardness.
    """
    from berryshaker.contact.wear import MATERIAL_PAIRS

    if material_pair not in ELASTIC_MATERIALS or material_pair not in MATERIAL_PAIRS:
        raise ConfigError(f"material_pair {material_pair!r} has no yield velocity (needs elastic constants and a "
                          "hardness); give restitution_velocity explicitly")
    m1, m2 = (material_constants(m) for m in ELASTIC_MATERIALS[material_pair])
    es = effective_modulus(*m1, *m2)
    y = MATERIAL_PAIRS[material_pair].hardness / 3.0
    return math.sqrt(26.0 * y * (y / es) ** 4 / PIN_DENSITY)


def default_restitution_velocity(material_pair: str) -> tuple[float, str]:
    """Restitution velocity v_ref (m/s) of a pair whose description gives none, and its provenance tag.

    * a lubricated pair (``MaterialPair.lubricated``: greased or oiled): :data:`LUBRICATED_RESTITUTION_VELOCITY`
      (1 mm/s), the published hysteresis law at every speed that matters.  A slow approach through a lubricant is
      damped by the squeeze film, and the restitution of such "wet" impacts *falls* towards 0 as the speed falls
      (Davis, Serayssol & Hinch 1986, J. Fluid Mech. 163:479; Gondret, Lance & Petit 2002, Phys. Fluids 14:643:
      no rebound below a Stokes number of about 10), so a restitution rising to 1 below the yield velocity would be
      the wrong trend.  The published law's damping, which grows as the impact speed falls, has the right trend
      (not the squeeze film's magnitude, which is not modelled).  Its damping coefficient ~1/v_imp is bounded at
      1 mm/s, a numerical regularisation below which the statistics are shown independent of the value
      (tests/contact/test_pair_law_velocity_floor.py, benchmarks/studies/impact_velocity_floor_study.py); tag ``derived``.
    * a dry pair with elastic constants and hardness: :func:`yield_velocity`; tag ``derived``.
    * any other pair: :data:`DEFAULT_RESTITUTION_VELOCITY`; tag ``assumed``.

    Parameters
    ----------
    material_pair : str
        The pair's materials, a key of :data:`ELASTIC_MATERIALS`.

    Returns
    -------
    (float, str)
        v_ref (m/s) and its tag.
    """
    from berryshaker.contact.wear import MATERIAL_PAIRS

    pair = MATERIAL_PAIRS.get(material_pair)
    if pair is not None and pair.lubricated:
        return LUBRICATED_RESTITUTION_VELOCITY, "derived"
    try:
        return yield_velocity(material_pair), "derived"
    except ConfigError:
        return DEFAULT_RESTITUTION_VELOCITY, "assumed"


def _at_load(k, n, load):
    """(tangent, secant) stiffness (N/m) of F = K delta^n at load F: delta = (F/K)^(1/n)."""
    d = (load / k) ** (1.0 / n)
    return n * load / d, load / d


def resolve_pair_contact(law, geom: PairGeometry, stiffness=None, exponent=None, damping=None,
                         damping_depth=1e-5, restitution=0.9, tags=None, field_prefix="clearance",
                         restitution_velocity=None) -> PairContact:
    """Resolve the contact law of a clearance pair (docs/contact.md sec. 6).

    Parameters
    ----------
    law : str
        Registered law name.
    geom : PairGeometry
        The pair's geometry and materials (used when ``stiffness`` is None).
    stiffness, exponent : float or None
        Given by the description (K in N/m^n, n); None: from geometry.  A given stiffness without an exponent
        has n = 1 (the linear springs of 0.1.0 files).  An exponent without a stiffness is refused.
    damping : float or None
        N s/m; required by the laws that use it (``mlsd``, ``impact``).
    damping_depth : float
        Penetration at which ``impact`` reaches full damping (m).
    restitution : float
        Coefficient of restitution of the hysteresis laws (dimensionless).
    tags : dict, optional
        Provenance of the description's own values, per parameter name.
    field_prefix : str
        ``clearance.<pair>`` for error messages.
    restitution_velocity : float or None
        v_ref of the hysteresis laws (m/s); None: :func:`default_restitution_velocity` (the yield velocity of a
        dry material pair or :data:`LUBRICATED_RESTITUTION_VELOCITY` of a lubricated one, ``derived``;
        :data:`DEFAULT_RESTITUTION_VELOCITY`, ``assumed``, for materials without a yield velocity).

    Returns
    -------
    PairContact
        Geometry: K and n of the power law fitted to Johnson's relation (:func:`geometric_contact_law`),
        ``derived``.  For the linear law ``mlsd`` with no stiffness: the secant stiffness at
        :data:`OPERATING_LOAD`, n = 1 (``derived``).

    Raises
    ------
    ConfigError
        Missing damping for a viscous law, an exponent without stiffness, or a geometry outside the model.
    """
    from berryshaker.contact.laws import get_law

    tags = dict(tags or {})
    spec = get_law(law)
    out_tags = {"law": tags.get("law", "default")}
    geometry = fit_rng = fit_err = None
    if stiffness is None:
        if exponent is not None:
            raise ConfigError(f"{field_prefix}.exponent is set but stiffness is not: give both, or neither (then K "
                              "and n come from the pair's geometry and materials)")
        cl = geometric_contact_law(geom)
        geometry, fit_rng, fit_err = geom, cl.fit.force_range, cl.fit.max_relative_error
        if law == "mlsd":  # a linear law: the secant stiffness at the operating load
            k, n = float(cl.secant_stiffness(OPERATING_LOAD)), 1.0
        else:
            k, n = cl.fit.stiffness, cl.fit.exponent
        out_tags.update(stiffness="derived", exponent="derived")
    else:
        k = float(stiffness)
        n = 1.0 if exponent is None else float(exponent)
        out_tags.update(stiffness=tags.get("stiffness", "default"),
                        exponent=tags.get("exponent", "default"))
    if "damping" in spec.uses:
        if damping is None:
            raise ConfigError(f"{field_prefix}.damping: the {law!r} law needs a damping coefficient (N s/m), e.g. "
                              f"damping = \"2000 N*s/m\"; or use law = \"{DEFAULT_LAW}\" (restitution only)")
        c = float(damping)
        out_tags["damping"] = tags.get("damping", "default")
    else:
        c = 0.0
    out_tags["damping_depth"] = tags.get("damping_depth", "default")
    out_tags["restitution"] = tags.get("restitution", "default")
    if "restitution_velocity" in spec.uses:
        if restitution_velocity is None:
            v_ref, out_tags["restitution_velocity"] = default_restitution_velocity(geom.material_pair)
        else:
            v_ref = float(restitution_velocity)
            out_tags["restitution_velocity"] = tags.get("restitution_velocity", "default")
        if not v_ref >= 0.0:
            raise ConfigError(f"{field_prefix}.restitution_velocity must be >= 0 m/s (0: the restitution at every "
                              f"impact speed), got {v_ref}")
    else:
        v_ref = 0.0
        out_tags["restitution_velocity"] = "not used"
    kt, ks = _at_load(k, n, OPERATING_LOAD)
    return PairContact(law=law, stiffness=k, exponent=n, damping=c, damping_depth=float(damping_depth),
                       restitution=float(restitution), tags=out_tags, geometry=geometry, fit_force_range=fit_rng,
                       fit_error=fit_err, tangent_stiffness=kt, secant_stiffness=ks, restitution_velocity=v_ref)
