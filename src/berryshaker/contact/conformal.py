"""Cylindrical (line) contact laws from geometry and materials: pin in a bore, roller on a groove wall.

The engine's clearance contacts use a power law F = K delta^n.  This module derives K and n from the
journal/bearing radii, the contact length and the materials, instead of assuming a linear spring:

* :func:`line_contact_approach` - Johnson's 2-D (line) contact compression, the reference model of the
  cylindrical-contact review by Pereira, Ramalho & Ambrosio (2011); it gives delta(F) explicitly and is
  inverted numerically by :func:`line_contact_force`.
* :func:`pereira_power_law` - the closed-form power law Pereira et al. (2011) fitted to it.
* :func:`fit_power_law` - a least-squares (log-log) power law over the load range of interest, with its
  worst relative force error reported, so any model can be handed to the engine as (K, n).
* :func:`roller_on_wall_law` - the roller joints of the harvester; the pin in a bore has its own module,
  :mod:`berryshaker.contact.pin_in_bore` (its line-contact law from this module's relation, and the sphere-type
  Hertz law of mechanism files).
* damping helpers that force_laws.py does not expose: hysteresis factors and damping coefficients for a
  coefficient of restitution, and the linear spring-dashpot damping for a restitution.

Sign conventions as in :mod:`berryshaker.contact.force_laws`: penetration delta > 0 in contact (m),
forces are magnitudes (N).  SI throughout.

long module: the line-contact core, its fits and validity checks, the roller law, the materials and the damping
helpers share their checks and constants (the pin-in-bore law, :mod:`berryshaker.contact.pin_in_bore`, imports
them).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from berryshaker.contact.stiffness import STEEL_E, STEEL_NU, effective_modulus
from berryshaker.errors import ConfigError

#: Elastic constants (E in Pa, nu) of the joint materials.  Steel as in Flores & Ambrosio (2004)
#: (207 GPa, 0.3; also the handbook value of Callister, *Materials Science and Engineering*, Table 6.1).
#: Bronze and nylon 6/6 are typical handbook values [typical]: copper alloys 100-120 GPa with nu ~ 0.34;
#: nylon 6/6 1.6-3.8 GPa (dry, room temperature), nu ~ 0.39.  Nylon is viscoelastic and moisture
#: sensitive: treat its stiffness as uncertain by a factor of about 2.
MATERIALS: dict[str, tuple[float, float]] = {
    "steel": (STEEL_E, STEEL_NU),
    "bronze": (110e9, 0.34),
    "nylon": (2.8e9, 0.39),
}


def material_constants(name: str) -> tuple[float, float]:
    """Young's modulus (Pa) and Poisson ratio of a named material from :data:`MATERIALS`.

    Parameters
    ----------
    name : str
        ``"steel"``, ``"bronze"`` or ``"nylon"`` (case-insensitive).

    Returns
    -------
    (E, nu) : tuple of float
        Young's modulus (Pa) and Poisson ratio (dimensionless).

    Raises
    ------
    ConfigError
        Unknown material name (the message lists the known ones).
    """
    key = str(name).strip().lower()
    if key not in MATERIALS:
        raise ConfigError(f"material {name!r} is not known; use one of {sorted(MATERIALS)} "
                          "or give E and nu as a tuple")
    return MATERIALS[key]


def _modulus(mat1, mat2) -> float:
    e1, nu1 = material_constants(mat1) if isinstance(mat1, str) else mat1
    e2, nu2 = material_constants(mat2) if isinstance(mat2, str) else mat2
    return effective_modulus(e1, nu1, e2, nu2)


def _check_pos(**kw):
    for k, v in kw.items():
        if not (np.all(np.isfinite(v)) and np.all(np.asarray(v) > 0)):
            raise ConfigError(f"{k} must be > 0 (SI), got {v}")


# --------------------------------------------------------------------------------------------
def line_contact_approach(force, length, delta_r, e_star):
    """Johnson's line-contact compression delta(F) of two cylinders with parallel axes.

    Parameters
    ----------
    force : array_like
        Normal load F (N), > 0.
    length : float
        Axial contact length L (m).
    delta_r : float
        Radius difference: R_bore - R_pin for a pin in a bore (internal, conformal contact), R1 + R2 for
        two convex cylinders (external contact) (m).  For a cylinder on a flat see
        :func:`roller_on_wall_law` (the flat's reference depth takes this place).
    e_star : float
        Effective modulus E* = [(1 - nu1^2)/E1 + (1 - nu2^2)/E2]^-1 (Pa).

    Returns
    -------
    ndarray
        Approach delta (m):

            delta = F / (pi L E*) * [ ln(4 pi L E* dR / F) - 1 ].

    Notes
    -----
    Johnson (1985, sec. 5.6) gives the compression of a cylinder of radius R under a Hertz line load P
    (per unit length), measured from the contact to the cylinder's centre, as
    P (1 - nu^2)/(pi E) [2 ln(4R/a) - 1], with the Hertz half-width a^2 = 4 P R_eff / (pi E*).  Adding
    the two bodies with equal (1 - nu^2)/E and eliminating a gives the formula above, the form
    Pereira et al. (2011) call Johnson's model and use as their reference for both internal
    (dR = R2 - R1) and external (dR = R1 + R2) contact.  Departure: for dissimilar materials we keep
    the combined E* (as Pereira et al. do) rather than weighting each body's logarithm.

    Valid while the contact stays narrow (a << R) and the load is below :func:`line_contact_load_limit`
    (beyond it d(delta)/dF < 0: the logarithmic model has lost its meaning).  2-D (plane strain),
    aligned axes, frictionless, elastic.

    References
    ----------
    K. L. Johnson, *Contact Mechanics*, Cambridge University Press, 1985, ch. 5.
    C. M. Pereira, A. L. Ramalho, J. A. Ambrosio, "A critical overview of internal and external
    cylinder contact force models", Nonlinear Dyn. 63 (2011) 681-697.
    """
    f = np.asarray(force, float)
    _check_pos(length=length, delta_r=delta_r, e_star=e_star)
    if np.any(f <= 0):
        raise ValueError("force must be > 0")
    c = math.pi * length * e_star
    return f / c * (np.log(4.0 * c * delta_r / f) - 1.0)


def line_contact_compliance(force, length, delta_r, e_star):
    """Tangent compliance d(delta)/dF of :func:`line_contact_approach` (m/N).

    Parameters
    ----------
    force : array_like
        Normal load F (N), > 0.
    length : float
        Contact length L along the axis (m).
    delta_r : float
        Radius difference dR (m): R_bore - R_pin for a pin in a bore, R1 + R2 for two convex cylinders
        (:func:`line_contact_approach`).
    e_star : float
        Combined elastic modulus E* (Pa).

    Returns
    -------
    ndarray
        Compliance (m/N): d(delta)/dF = [ln(4 pi L E* dR / F) - 2] / (pi L E*); its inverse is the tangent stiffness.

    References
    ----------
    Derivative of Johnson's line-contact relation (see :func:`line_contact_approach`).
    """
    f = np.asarray(force, float)
    c = math.pi * length * e_star
    return (np.log(4.0 * c * delta_r / f) - 2.0) / c


def line_contact_load_limit(length, delta_r, e_star):
    """Largest load (N) for which Johnson's line-contact relation is monotone.

    Parameters
    ----------
    length : float
        Contact length L along the axis (m).
    delta_r : float
        Radius difference dR (m): R_bore - R_pin for a pin in a bore, R1 + R2 for two convex cylinders
        (:func:`line_contact_approach`).
    e_star : float
        Combined elastic modulus E* (Pa).

    Returns
    -------
    float
        The load limit (N), F_lim = 4 pi L E* dR / e^2, where d(delta)/dF = 0.  Use the model well below it (the tests and
        :func:`fit_power_law` stay under F_lim / 10).

    References
    ----------
    Follows from :func:`line_contact_compliance`; the limitation is discussed by Pereira et al. (2011).
    """
    return 4.0 * math.pi * length * e_star * delta_r / math.e**2


def line_contact_force(penetration, length, delta_r, e_star):
    """Normal force (N) for a penetration (m): the inverse of :func:`line_contact_approach`.

    Parameters
    ----------
    penetration : array_like
        delta (m); <= 0 gives 0.
    length : float
        Contact length L along the axis (m).
    delta_r : float
        Radius difference dR (m): R_bore - R_pin for a pin in a bore, R1 + R2 for two convex cylinders
        (:func:`line_contact_approach`).
    e_star : float
        Combined elastic modulus E* (Pa).

    Returns
    -------
    ndarray
        Force (N): F with line_contact_approach(F) = delta, solved by Newton's method on ln F (vectorised,
        quadratically convergent; the relation is monotone below :func:`line_contact_load_limit`).

    Raises
    ------
    ValueError
        A penetration beyond the model's range (its load limit).
    """
    d = np.asarray(penetration, float)
    out = np.zeros_like(d)
    mask = d > 0
    if not np.any(mask):
        return out
    dd = d[mask]
    c = math.pi * length * e_star
    flim = line_contact_load_limit(length, delta_r, e_star)
    dmax = flim / c * (np.log(4.0 * c * delta_r / flim) - 1.0)
    if np.any(dd >= dmax):
        raise ValueError(f"penetration {dd.max():.3g} m is beyond the range of Johnson's line-contact model "
                         f"(max {dmax:.3g} m at F = {flim:.3g} N)")
    # start from the linear estimate with the logarithm frozen at a moderate value, then Newton on u = ln F
    u = np.log(np.minimum(dd * c / 5.0, 0.5 * flim))
    for _ in range(60):
        f = np.exp(u)
        g = f / c * (np.log(4.0 * c * delta_r / f) - 1.0) - dd
        dg_du = f * (np.log(4.0 * c * delta_r / f) - 2.0) / c
        step = g / dg_du
        u = np.minimum(u - step, math.log(flim))
        if np.all(np.abs(step) < 1e-14):
            break
    out[mask] = np.exp(u)
    return out


# --------------------------------------------------------------------------------------------
def pereira_power_law(delta_r, length, e_star, internal=True):
    """Pereira, Ramalho & Ambrosio (2011) closed-form cylindrical contact law F = K delta^n.

    Parameters
    ----------
    delta_r : float
        Radial clearance R_bore - R_pin (internal) or R1 + R2 (external) (m).
    length : float
        Contact length L (m).
    e_star : float
        Effective modulus (Pa).
    internal : bool
        Pin-in-bore (True) or convex-convex (False) contact.

    Returns
    -------
    (K, n) : tuple of float
        K in N/m^n (SI) and the exponent n.

    Notes
    -----
    In the paper's units (dR, delta and L in mm, E* in N/mm^2, F in N):

        F = (a dR + b) / dR * L E* delta^n,

    internal: a = 0.965, b = 0.0965, n = Y dR^-0.005 with Y = 1.51 [ln(1000 dR)]^-0.151 for
    0.005 <= dR <= 0.34954 mm and Y = 0.0151 dR + 1.151 for 0.34954 <= dR <= 10 mm;
    external: a = 0.39, b = 0.85, n = 1.094.  Converted here: K_SI = K_mm 1000^n.  The constants are as
    we recall them from the paper (not re-read for this implementation); the test suite therefore
    checks the law against Johnson's relation it was fitted to, which would fail for a misremembered
    constant: for dR = 0.1-0.5 mm, L = 25 mm, steel, they agree within 15 % over 1-20 kN but the power
    law gives 25-35 % less force than Johnson's relation at 10 N (we do not know the load range it was fitted over).

    References
    ----------
    C. M. Pereira, A. L. Ramalho, J. A. Ambrosio, Nonlinear Dyn. 63 (2011) 681-697.
    """
    _check_pos(delta_r=delta_r, length=length, e_star=e_star)
    dr_mm = delta_r * 1e3
    if internal:
        if not 0.005 <= dr_mm <= 10.0:
            raise ConfigError(f"radial clearance {dr_mm:.4g} mm is outside the range of the Pereira et al. "
                              "internal-contact law (0.005-10 mm)")
        a, b = 0.965, 0.0965
        y = 1.51 * math.log(1000.0 * dr_mm) ** -0.151 if dr_mm <= 0.34954 else 0.0151 * dr_mm + 1.151
        n = y * dr_mm**-0.005
    else:
        a, b, n = 0.39, 0.85, 1.094
    k_mm = (a * dr_mm + b) / dr_mm * (length * 1e3) * (e_star * 1e-6)
    return k_mm * 1000.0**n, n


# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class PowerLawFit:
    """A power law F = K delta^n fitted to a contact model over a load range.

    Attributes
    ----------
    stiffness : float
        K (N/m^n).
    exponent : float
        n (dimensionless).
    force_range : tuple of float
        (F_min, F_max) of the fit (N).
    max_relative_error : float
        max |K delta^n - F| / F over the range (on the fitting grid; dimensionless).
    """

    stiffness: float
    exponent: float
    force_range: tuple[float, float]
    max_relative_error: float

    def force(self, penetration):
        """F = K max(delta, 0)^n (N).

        Parameters
        ----------
        penetration : array_like
            delta (m).

        Returns
        -------
        ndarray
            Force (N).
        """
        d = np.maximum(np.asarray(penetration, float), 0.0)
        return self.stiffness * d**self.exponent


def fit_power_law(approach: Callable, force_range=(10.0, 1e4), n_points: int = 200) -> PowerLawFit:
    """Fit F = K delta^n to a contact model delta(F) over a load range.

    Parameters
    ----------
    approach : callable
        delta(F) (m) for an array of forces (N), e.g. a closure over :func:`line_contact_approach`.
    force_range : (float, float)
        Loads to fit over (N).  The default 10 N-10 kN spans the joint forces of the reference machine.
    n_points : int
        Log-spaced sample loads.

    Returns
    -------
    PowerLawFit
        Least squares on ln F = ln K + n ln delta (minimises relative force errors), with the worst
        relative force error over the samples.
    """
    f_lo, f_hi = map(float, force_range)
    if not 0 < f_lo < f_hi:
        raise ConfigError(f"force_range must be 0 < F_min < F_max, got {force_range}")
    f = np.geomspace(f_lo, f_hi, n_points)
    d = np.asarray(approach(f), float)
    if np.any(d <= 0) or np.any(np.diff(d) <= 0):
        raise ValueError("the contact model is not monotone over the force range; narrow the range")
    n, ln_k = np.polyfit(np.log(d), np.log(f), 1)
    k = math.exp(ln_k)
    err = np.max(np.abs(k * d**n - f) / f)
    return PowerLawFit(stiffness=k, exponent=float(n), force_range=(f_lo, f_hi), max_relative_error=float(err))


@dataclass(frozen=True)
class CylinderContactLaw:
    """Force law of one cylindrical joint from geometry and materials (all SI).

    Attributes
    ----------
    length, delta_r, e_star : float
        Contact length (m), radius difference or reference radius used by Johnson's relation (m),
        effective modulus (Pa).
    fit : PowerLawFit
        Power law fitted to Johnson's relation over the load range: what the engine uses (K, n).
    pereira : tuple of float or None
        (K, n) of Pereira et al. (2011) where that law applies, for comparison.
    """

    length: float
    delta_r: float
    e_star: float
    fit: PowerLawFit
    pereira: tuple[float, float] | None

    def approach(self, force):
        """Johnson's delta(F) (m) for this joint.

        Parameters
        ----------
        force : array_like
            Normal load F (N).

        Returns
        -------
        ndarray
            Approach delta (m).
        """
        return line_contact_approach(force, self.length, self.delta_r, self.e_star)

    def force(self, penetration):
        """Johnson's F(delta) (N) for this joint (numerical inverse).

        Parameters
        ----------
        penetration : array_like
            delta (m).

        Returns
        -------
        ndarray
            Force (N).
        """
        return line_contact_force(penetration, self.length, self.delta_r, self.e_star)

    def tangent_stiffness(self, force):
        """Equivalent linear stiffness dF/d(delta) at load F (N/m).

        Parameters
        ----------
        force : array_like
            Normal load F (N).

        Returns
        -------
        ndarray
            Tangent stiffness (N/m).
        """
        return 1.0 / line_contact_compliance(force, self.length, self.delta_r, self.e_star)

    def secant_stiffness(self, force):
        """F / delta(F) at load F (N/m): the linear spring that gives the same penetration at F.

        Parameters
        ----------
        force : array_like
            Normal load F (N).

        Returns
        -------
        ndarray
            Secant stiffness (N/m).
        """
        f = np.asarray(force, float)
        return f / self.approach(f)


def roller_on_wall_law(roller_radius, width, wall_radius=math.inf, roller_material="steel",
                       wall_material="steel", force_range=(10.0, 1e4), flat_reference_depth=None
                       ) -> CylinderContactLaw:
    """Contact law of a roller on a groove or slot wall (line contact).

    Parameters
    ----------
    roller_radius : float
        R1 (m).
    width : float
        Contact length: roller width engaged with the wall (m).
    wall_radius : float
        Radius of curvature of the wall (m): > 0 convex (inner wall of a cam groove), < 0 concave (outer
        wall; |wall_radius| > roller_radius), ``inf`` flat (a straight slot).
    roller_material, wall_material : str or (E, nu)
        Materials.
    force_range : (float, float)
        Load range for the power-law fit (N).
    flat_reference_depth : float, optional
        For a flat wall only: the depth below the surface to which the wall's compression is referred
        (m).  Default 2 * roller_radius [assumed].

    Returns
    -------
    CylinderContactLaw
        Johnson's relation with dR = R1 + R2 (convex), |R2| - R1 (concave) or the reference depth
        (flat), its power-law fit, and (convex only) the Pereira et al. external law.

    Notes
    -----
    In 2-D the compression of a half-plane is unbounded (logarithmic); a flat wall's contribution
    needs a reference depth d.  Writing Johnson's per-body compression for the roller, ln(4 R1/a), and
    for the wall, ln(4 d/a), with a^2 = 4 F R1 / (pi L E*) gives exactly
    :func:`line_contact_approach` with dR = d.  d = 2 R1 makes a steel roller on a flat reproduce
    Palmgren's empirical roller-raceway law (:func:`berryshaker.contact.stiffness.roller_on_flat_stiffness`)
    within a few per cent at 1 kN on 20 mm (tested).  delta depends on d only through ln d: halving or
    doubling d changes the stiffness by about 5 %.

    References
    ----------
    K. L. Johnson, *Contact Mechanics*, 1985, ch. 5; A. Palmgren, *Ball and Roller Bearing
    Engineering*, 1959.
    """
    _check_pos(roller_radius=roller_radius, width=width)
    es = _modulus(roller_material, wall_material)
    per = None
    if math.isinf(wall_radius):
        d = 2.0 * roller_radius if flat_reference_depth is None else flat_reference_depth
        _check_pos(flat_reference_depth=d)
        dr = d
    elif wall_radius > 0:
        dr = roller_radius + wall_radius
        per = pereira_power_law(dr, width, es, internal=False)
    else:
        if not -wall_radius > roller_radius:
            raise ConfigError(f"concave wall radius {-wall_radius} m must exceed the roller radius "
                              f"{roller_radius} m")
        dr = -wall_radius - roller_radius
    if force_range[1] > 0.1 * line_contact_load_limit(width, dr, es):
        raise ConfigError("force_range exceeds a tenth of the line-contact load limit; lower it")
    fit = fit_power_law(lambda f: line_contact_approach(f, width, dr, es), force_range)
    return CylinderContactLaw(length=width, delta_r=dr, e_star=es, fit=fit, pereira=per)


# --------------------------------------------------------------------------------------------
#: hysteresis factors f(e): F = K delta^n [1 + f(e) delta_dot / delta_dot(-)]
_HYSTERESIS = {
    "hunt_crossley": lambda e: 1.5 * (1.0 - e),
    "lankarani_nikravesh": lambda e: 0.75 * (1.0 - e * e),
    "flores": lambda e: 1.6 * (1.0 - e) / e,
}


def hysteresis_factor(restitution, model="flores"):
    """Dimensionless hysteresis factor f(e) of the dissipative power laws.

    Parameters
    ----------
    restitution : array_like
        Coefficient of restitution e (dimensionless), 0 < e <= 1.
    model : {"hunt_crossley", "lankarani_nikravesh", "flores"}
        The law.

    Returns
    -------
    ndarray
        f(e) with F = K delta^n [1 + f(e) delta_dot / delta_dot(-)]: 3(1 - e)/2 (Hunt & Crossley 1975),
        3(1 - e^2)/4 (Lankarani & Nikravesh 1990), 8(1 - e)/(5e) (Flores et al. 2011).  The same factors
        as the laws in :mod:`berryshaker.contact.force_laws`, exposed for the engine and reports.

    References
    ----------
    P. Flores, M. Machado, M. T. Silva, J. M. Martins, "On the continuous contact force models for soft
    materials in multibody dynamics", Multibody Syst. Dyn. 25 (2011) 357-375 (Table 1).
    H. M. Lankarani, P. E. Nikravesh, J. Mech. Des. 112 (1990) 369-376.
    """
    e = np.asarray(restitution, float)
    if np.any((e <= 0) | (e > 1)):
        raise ConfigError(f"coefficient of restitution must be in (0, 1], got {restitution}")
    if model not in _HYSTERESIS:
        raise ConfigError(f"hysteresis model {model!r} unknown; use one of {sorted(_HYSTERESIS)}")
    return _HYSTERESIS[model](e)


def hysteresis_damping_coefficient(stiffness, restitution, impact_velocity, model="flores"):
    """Hysteresis damping coefficient chi = f(e) K / delta_dot(-) (N s / m^(n+1)).

    Parameters
    ----------
    stiffness : float
        K of the power law (N/m^n).
    restitution : float
        e (dimensionless).
    impact_velocity : array_like
        Normal approach speed at contact onset (m/s), > 0.
    model : str
        As in :func:`hysteresis_factor`.

    Returns
    -------
    ndarray
        chi (N s / m^(n+1)), so that F = K delta^n + chi delta^n delta_dot.

    References
    ----------
    Flores et al. (2011), eqs. for the Hunt-Crossley family; Lankarani & Nikravesh (1990).
    """
    v = np.abs(np.asarray(impact_velocity, float))
    if np.any(v <= 0):
        raise ValueError("impact_velocity must be non-zero")
    return hysteresis_factor(restitution, model) * stiffness / v


def linear_damping_for_restitution(stiffness, effective_mass, restitution):
    """Dashpot c (N s/m) that gives a coefficient of restitution e with a linear spring k.

    Parameters
    ----------
    stiffness : float
        k (N/m).
    effective_mass : float
        m1 m2 / (m1 + m2) of the colliding bodies (kg).
    restitution : float
        e (dimensionless), 0 < e <= 1.

    Returns
    -------
    float
        c = 2 zeta sqrt(k m) with zeta = -ln e / sqrt(pi^2 + ln^2 e).

    Notes
    -----
    The half-cycle of a damped oscillator (Kelvin-Voigt contact): the rebound-to-impact velocity ratio
    after one half damped period is exp(-zeta pi / sqrt(1 - zeta^2)), solved for zeta.  Exact when the
    bodies separate at delta = 0 (the force is allowed to pull slightly at the end); with the usual
    no-tension clamp the realised e is somewhat higher.  Useful to read the study's C_i = 2000 N s/m as a
    restitution, and to build an MLSD (linear) law consistent with a Hertz law's dissipation.

    References
    ----------
    Any vibration text (free response of the underdamped single-degree-of-freedom oscillator), e.g.
    S. S. Rao, *Mechanical Vibrations*; the use for contact: Flores et al. (2011), sec. 2.
    """
    _check_pos(stiffness=stiffness, effective_mass=effective_mass)
    e = float(restitution)
    if not 0 < e <= 1:
        raise ConfigError(f"coefficient of restitution must be in (0, 1], got {restitution}")
    le = math.log(e)
    zeta = -le / math.sqrt(math.pi**2 + le * le)
    return 2.0 * zeta * math.sqrt(stiffness * effective_mass)


def restitution_of_linear_damping(stiffness, effective_mass, damping):
    """Coefficient of restitution of a linear spring-dashpot contact (inverse of
    :func:`linear_damping_for_restitution`).

    Parameters
    ----------
    stiffness : float
        k (N/m).
    effective_mass : float
        m1 m2 / (m1 + m2) of the colliding bodies (kg).
    damping : float
        c (N s/m).

    Returns
    -------
    float
        e = exp(-zeta pi / sqrt(1 - zeta^2)), zeta = c / (2 sqrt(k m)); 0 if zeta >= 1 (no rebound).

    References
    ----------
    As :func:`linear_damping_for_restitution`.
    """
    _check_pos(stiffness=stiffness, effective_mass=effective_mass)
    zeta = damping / (2.0 * math.sqrt(stiffness * effective_mass))
    if zeta >= 1.0:
        return 0.0
    return math.exp(-zeta * math.pi / math.sqrt(1.0 - zeta * zeta))
