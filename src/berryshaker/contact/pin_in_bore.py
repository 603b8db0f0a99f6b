"""Pin-in-bore contact stiffness: the one home of the contact law of a pin (journal) in a bore with clearance.

Two models, genuinely different physics (docs/contact.md sec. 1 and 5):

* :func:`pin_in_bore_law` - Johnson's internal **line** contact of two cylinders with dR = c, fitted to a power law
  F = K delta^n (n ~ 1.1-1.2): the default of every pin-in-bore clearance pair of the machines
  (:func:`berryshaker.contact.pair_law.resolve_pair_contact`);
* :func:`pin_in_bore_stiffness` - the sphere-type **point** contact Hertz law K = 4/3 E* sqrt(R*), n = 1.5, that
  Lankarani & Nikravesh (1990) and Flores & Ambrosio (2004) apply to cylindrical joints: ``contact.stiffness =
  "hertz"`` of a mechanism file's clearance joint (:func:`berryshaker.multibody.compiled.compile_mechanism`).  It
  treats the line as a point and is about 4x too soft for the harvester's pins (docs/contact.md sec. 5).

What they share is computed here once: the effective modulus E* (:func:`berryshaker.contact.stiffness.effective_modulus`),
the conformal radius R* = R_pin R_bore / (R_bore - R_pin) of a pin in a bore (:func:`conformal_radius`) and the
load at which the Hertz half-width of the line contact, a^2 = 4 F R* / (pi L E*), reaches the validity limit
:data:`ARC_LIMIT` of the pin radius (:func:`arc_limit_load`, which both :func:`pin_in_bore_law` and the pairs' fit
range, :func:`berryshaker.contact.pair_law.fit_range_for`, use).  SI throughout.
"""

from __future__ import annotations

import math

from berryshaker.contact.conformal import (
    CylinderContactLaw,
    _check_pos,
    _modulus,
    fit_power_law,
    line_contact_approach,
    line_contact_load_limit,
    pereira_power_law,
)
from berryshaker.contact.stiffness import effective_modulus
from berryshaker.errors import ConfigError

#: the largest Hertz half-width of a pin's line contact, as a fraction of the pin radius, for which Johnson's
#: narrow-contact relation is used (a contact arc of about 40 deg)
ARC_LIMIT = 0.35


def conformal_radius(pin_radius, bore_radius):
    """Equivalent radius R* = R_pin R_bore / (R_bore - R_pin) of a pin in a bore (conformal: the bore is concave).

    Parameters
    ----------
    pin_radius, bore_radius : float
        Journal and bearing radii (m); bore_radius > pin_radius.

    Returns
    -------
    float
        R* (m).
    """
    return pin_radius * bore_radius / (bore_radius - pin_radius)


def arc_limit_load(pin_radius, radial_clearance, length, e_star, arc=ARC_LIMIT):
    """The load (N) at which the Hertz half-width of a pin's line contact reaches ``arc`` x R_pin.

    Parameters
    ----------
    pin_radius : float
        R_pin (m).
    radial_clearance : float
        c = R_bore - R_pin (m).
    length : float
        Engaged axial length L (m).
    e_star : float
        Effective modulus E* (Pa).
    arc : float
        Half-width as a fraction of the pin radius (dimensionless); default :data:`ARC_LIMIT`.

    Returns
    -------
    float
        F_arc = arc^2 R_pin^2 pi L E* c / (4 R_pin (R_pin + c)) (N), from a^2 = 4 F R_pin R_bore / (pi L E* c).
    """
    r1, dr = pin_radius, radial_clearance
    return arc**2 * r1**2 * math.pi * length * e_star * dr / (4.0 * r1 * (r1 + dr))


def pin_in_bore_stiffness(e_pin, nu_pin, e_bore, nu_bore, pin_radius, bore_radius):
    """Hertz stiffness K (N/m^1.5) of a pin (journal) in a bore, for F = K delta^1.5 (sphere-type point contact).

    Parameters
    ----------
    e_pin, nu_pin, e_bore, nu_bore : float
        Elastic moduli (Pa) and Poisson ratios.
    pin_radius, bore_radius : float
        Journal and bearing radii (m); bore_radius > pin_radius.

    Returns
    -------
    float
        K = (4/3) E* sqrt(R*) (N/m^1.5), R* = R_pin R_bore / (R_bore - R_pin) (:func:`conformal_radius`).

    Notes
    -----
    The sphere-type Hertz law applied to a cylindrical joint, as in Lankarani & Nikravesh (1990) and the
    clearance-joint benchmark of Flores & Ambrosio (2004); for journal 10 mm / bearing 10.5 mm steel it
    gives about 6.9e10 N/m^1.5 (E* = 113.7 GPa, R* = 0.21 m).  The line-contact law of the same joint is
    :func:`pin_in_bore_law`.

    References
    ----------
    P. Flores, J. Ambrosio, "Revolute joints with clearance in multibody systems", Comput. Struct. 82
    (2004) 1359-1369.
    """
    if not bore_radius > pin_radius > 0:
        raise ValueError(f"need bore_radius > pin_radius > 0, got pin {pin_radius} m, bore {bore_radius} m")
    estar = effective_modulus(e_pin, nu_pin, e_bore, nu_bore)
    return 4.0 / 3.0 * estar * math.sqrt(conformal_radius(pin_radius, bore_radius))


def pin_in_bore_law(pin_radius, radial_clearance, length, pin_material="steel", bore_material="steel",
                    force_range=(10.0, 1e4)) -> CylinderContactLaw:
    """Contact law of a pin (journal) in a bore with radial clearance: internal, conformal line contact.

    Parameters
    ----------
    pin_radius : float
        R_pin (m).
    radial_clearance : float
        c = R_bore - R_pin (m).
    length : float
        Engaged axial length (m).
    pin_material, bore_material : str or (E, nu)
        Names in :data:`berryshaker.contact.conformal.MATERIALS` or explicit (Pa, -) pairs.
    force_range : (float, float)
        Load range for the power-law fit (N).

    Returns
    -------
    CylinderContactLaw
        Johnson's relation with dR = c, its power-law fit, and the Pereira et al. (2011) law.

    Notes
    -----
    Johnson's relation depends on the radii only through dR = c (the pin radius drops out once the
    Hertz half-width is eliminated); it is a non-conformal (narrow-contact) theory, so the pin radius
    bounds its validity: the half-width a = sqrt(4 F R* / (pi L E*)) should stay well below R_pin.
    A ``ConfigError`` is raised if a/R_pin > :data:`ARC_LIMIT` (a contact arc of about 40 deg) at the top of
    the force range (:func:`arc_limit_load`); use a conformal model (Persson 1964) there - not implemented here.
    The sphere-type Hertz law of the same joint is :func:`pin_in_bore_stiffness`.

    References
    ----------
    K. L. Johnson, *Contact Mechanics*, 1985, ch. 5; Pereira et al., Nonlinear Dyn. 63 (2011) 681-697.
    """
    _check_pos(pin_radius=pin_radius, radial_clearance=radial_clearance, length=length)
    es = _modulus(pin_material, bore_material)
    f_hi = force_range[1]
    f_arc = arc_limit_load(pin_radius, radial_clearance, length, es)
    if f_hi > f_arc:
        ratio = ARC_LIMIT * math.sqrt(f_hi / f_arc)  # a / R_pin at f_hi (a grows as sqrt(F))
        raise ConfigError(f"pin-in-bore contact at {f_hi:g} N: half-width {ratio * pin_radius * 1e3:.3g} mm is "
                          f"{ratio:.2f} of the pin radius; the line-contact (non-conformal) "
                          "model does not apply - lower the force range or use a conformal model")
    if f_hi > 0.1 * line_contact_load_limit(length, radial_clearance, es):
        raise ConfigError("force_range exceeds a tenth of the line-contact load limit; lower it")
    fit = fit_power_law(lambda f: line_contact_approach(f, length, radial_clearance, es), force_range)
    try:
        per = pereira_power_law(radial_clearance, length, es, internal=True)
    except ConfigError:
        per = None
    return CylinderContactLaw(length=length, delta_r=radial_clearance, e_star=es, fit=fit, pereira=per)
