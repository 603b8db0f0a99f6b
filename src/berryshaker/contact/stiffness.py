"""Contact stiffness from materials and geometry (Hertz theory and its standard joint forms)."""

from __future__ import annotations

import math

STEEL_E = 207e9  # Pa (Flores & Ambrosio 2004 use 207 GPa)
STEEL_NU = 0.3


def effective_modulus(e1, nu1, e2, nu2):
    """Combined elastic modulus E* = 1 / [(1 - nu1^2)/E1 + (1 - nu2^2)/E2] (Pa).

    Parameters
    ----------
    e1, e2 : float
        Young's moduli of the two bodies (Pa), > 0.
    nu1, nu2 : float
        Their Poisson ratios (1), in (-1, 0.5).

    Returns
    -------
    float
        E* (Pa).

    References
    ----------
    K. L. Johnson, *Contact Mechanics*, Cambridge University Press, 1985, ch. 4.
    """
    for name, val in (("E1", e1), ("E2", e2)):
        if not val > 0:
            raise ValueError(f"{name} must be > 0, got {val}")
    for name, val in (("nu1", nu1), ("nu2", nu2)):
        if not -1 < val < 0.5:
            raise ValueError(f"{name} must be in (-1, 0.5), got {val}")
    return 1.0 / ((1 - nu1**2) / e1 + (1 - nu2**2) / e2)


def pin_in_bore_stiffness(e_pin, nu_pin, e_bore, nu_bore, pin_radius, bore_radius):
    """Hertz stiffness K (N/m^1.5) of a pin (journal) in a bore, for F = K delta^1.5.

    Parameters
    ----------
    e_pin, nu_pin, e_bore, nu_bore : float
        Elastic moduli (Pa) and Poisson ratios.
    pin_radius, bore_radius : float
        Journal and bearing radii (m); bore_radius > pin_radius.

    Returns
    -------
    float
        K = (4/3) E* sqrt(R*) (N/m^1.5), R* = R_pin R_bore / (R_bore - R_pin) (conformal contact: the bore is
        concave).

    Notes
    -----
    The sphere-type Hertz law applied to a cylindrical joint, as in Lankarani & Nikravesh (1990) and the
    clearance-joint benchmark of Flores & Ambrosio (2004); for journal 10 mm / bearing 10.5 mm steel it
    gives about 6.9e10 N/m^1.5 (E* = 113.7 GPa, R* = 0.21 m).

    References
    ----------
    P. Flores, J. Ambrosio, "Revolute joints with clearance in multibody systems", Comput. Struct. 82
    (2004) 1359-1369.
    """
    if not bore_radius > pin_radius > 0:
        raise ValueError(f"need bore_radius > pin_radius > 0, got pin {pin_radius} m, bore {bore_radius} m")
    estar = effective_modulus(e_pin, nu_pin, e_bore, nu_bore)
    rstar = pin_radius * bore_radius / (bore_radius - pin_radius)
    return 4.0 / 3.0 * estar * math.sqrt(rstar)


def roller_on_flat_stiffness(length):
    """Steel roller on a flat (or a large-radius groove wall): Palmgren's line-contact law.

    Parameters
    ----------
    length : float
        Effective contact length of the roller (m).

    Returns
    -------
    (K, n) : tuple of float
        F = K delta^n with n = 10/9 and K in N/m^(10/9).

    Notes
    -----
    Palmgren (1959): delta = 3.84e-5 Q^0.9 / l^0.8 with delta in mm, Q in N, l in mm, for steel on
    steel.  Inverting, Q = (delta l^0.8 / 3.84e-5)^(1/0.9); converted to SI here.

    References
    ----------
    A. Palmgren, *Ball and Roller Bearing Engineering*, 3rd ed., Burbank, 1959.
    T. A. Harris, M. N. Kotzalas, *Essential Concepts of Bearing Technology*, 5th ed., 2007.
    """
    if not length > 0:
        raise ValueError(f"roller length must be > 0, got {length}")
    l_mm = length * 1e3
    n = 1.0 / 0.9
    k_mm = (l_mm**0.8 / 3.84e-5) ** n  # N / mm^n
    return k_mm * (1e3) ** n, n
