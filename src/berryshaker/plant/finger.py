"""Comb fingers with their own compliance: a nylon rod bent as a cantilever, in series with the local
Hertz contact of nylon on wood, turned into the linear IMPACT stiffness of the comb-branch contact.

Cantilever (Euler-Bernoulli, end load at the striking section, e.g. Roark's Formulas for Stress and
Strain, Table 8.1 case 1a; Timoshenko & Gere, Mechanics of Materials):

    k_f = 3 E_f I / L^3,        I = pi d^4 / 64.

Hertz contact of the round finger on the round branch crossing at right angles (Johnson, Contact
Mechanics, 1985, sec. 4.2: two cylinders crossed at 90 deg with radii R1, R2 are a sphere of radius
sqrt(R1 R2) on a plane, exact for R1 = R2, an approximation otherwise):

    F = (4/3) E* sqrt(R) delta^(3/2),   1/E* = (1 - nu_f^2)/E_f + (1 - nu_w^2)/E_w,   R = sqrt(R_f R_b),

linearised at a reference force F0: k_H = dF/d delta = (3/2) K_H^(2/3) F0^(1/3).  In series:
k = 1 / (1/k_f + 1/k_H).  With the default geometry the cantilever is three orders of magnitude softer
than the Hertz contact, so the linearisation point hardly matters (returned, so it can be checked).

Departures: the finger's own mass is left out (a massless spring between the comb and the branch; the
first bending mode of a 12 mm x 200 mm PA6 finger is about 60 Hz, well above the drive and the
fruit-stem frequency; returned as first_mode_hz), shear
deformation is neglected (L/d = 17), and the wood's transverse modulus is a rough [assumed] value.
"""

from __future__ import annotations

import math

from berryshaker.errors import ConfigError


def cantilever_stiffness(elastic_modulus: float, diameter: float, free_length: float) -> float:
    """End-load bending stiffness of a round cantilever rod, k = 3 E I / L^3 with I = pi d^4/64 (N/m).

    Parameters
    ----------
    elastic_modulus : float
        E (Pa).
    diameter : float
        d (m).
    free_length : float
        L, clamp to the load (m).

    Returns
    -------
    float
        k (N/m).
    """
    for name, v in (("elastic_modulus", elastic_modulus), ("diameter", diameter), ("free_length", free_length)):
        if not v > 0:
            raise ConfigError(f"plant.contact.finger.{name} must be > 0, got {v}")
    i = math.pi * diameter**4 / 64.0
    return 3.0 * elastic_modulus * i / free_length**3


def hertz_crossed_cylinders(e1: float, nu1: float, d1: float, e2: float, nu2: float, d2: float) -> float:
    """Hertz constant K (N/m^1.5) of two round bars crossed at right angles, F = K delta^1.5.

    K = (4/3) E* sqrt(R), R = sqrt(R1 R2) (Johnson 1985, sec. 4.2), 1/E* = (1-nu1^2)/E1 + (1-nu2^2)/E2.

    Parameters
    ----------
    e1, e2 : float
        Young's moduli of the bars (Pa).
    nu1, nu2 : float
        Their Poisson ratios (1).
    d1, d2 : float
        Their diameters (m).

    Returns
    -------
    float
        K (N/m^1.5).
    """
    estar = 1.0 / ((1 - nu1**2) / e1 + (1 - nu2**2) / e2)
    r = math.sqrt(d1 / 2 * d2 / 2)
    return 4.0 / 3.0 * estar * math.sqrt(r)


def finger_contact(finger, branch_diameter: float) -> dict:
    """Effective linear contact stiffness of one finger on the branch.

    Parameters
    ----------
    finger : berryshaker.plant.spec.FingerSpec
        Finger geometry and materials.
    branch_diameter : float
        Branch diameter at the struck station (m).

    Returns
    -------
    dict
        cantilever_N_m (k_f), hertz_K_N_m1_5 (K_H), hertz_linear_N_m (k_H at the reference force),
        series_stiffness_N_m (k, the IMPACT stiffness with exponent 1), first_mode_hz (finger, clamped-free,
        1.8751^2/(2 pi L^2) sqrt(E I / (rho A)) with rho = 1140 kg/m^3, PA6, for the massless-finger check).
    """
    kf = cantilever_stiffness(finger.elastic_modulus, finger.diameter, finger.free_length)
    kh = hertz_crossed_cylinders(finger.elastic_modulus, finger.poisson_ratio, finger.diameter,
                                 finger.wood_transverse_modulus, finger.wood_poisson_ratio, branch_diameter)
    kh_lin = 1.5 * kh ** (2.0 / 3.0) * finger.reference_force ** (1.0 / 3.0)
    k = 1.0 / (1.0 / kf + 1.0 / kh_lin)
    i = math.pi * finger.diameter**4 / 64
    a = math.pi * finger.diameter**2 / 4
    f1 = 1.8751**2 / (2 * math.pi * finger.free_length**2) * math.sqrt(finger.elastic_modulus * i / (1140.0 * a))
    return {"cantilever_N_m": kf, "hertz_K_N_m1_5": kh, "hertz_linear_N_m": kh_lin, "series_stiffness_N_m": k,
            "first_mode_hz": f1}
