"""Normal contact force laws for clearance joints.

Each law is a scalar compiled kernel (``*_kernel``, numba ``njit``: called with scalars from compiled code, the
engine's and the reduced model's) plus a Python wrapper with keyword defaults and the documentation, which
broadcasts over numpy arrays through a ufunc built from the kernel at its first call (:func:`broadcasting`).
(The kernels were eager numba ufuncs before: building their six ufunc wrappers cost ~0.15 s of every
process's import, the study's and each worker's, for arrays only tests and users pass.  The kernels keep the
ufuncs' numpy error model: a division by zero gives inf or nan, as before, instead of raising inside the engine.)
Sign convention: ``delta`` is the penetration (m, > 0 in contact), ``delta_dot`` its rate (m/s, > 0 while
the bodies approach).  Every law returns the magnitude of the repulsive normal force (N): zero for
``delta <= 0``, and never negative (a dissipative law that would pull during restitution gives 0).
"""

from __future__ import annotations

import functools

import numpy as np
from numba import float64, njit, vectorize


@functools.cache
def broadcasting(kernel, n_args: int):
    """The numpy ufunc of scalar kernel ``kernel`` (an ``njit`` function of ``n_args`` float64 arguments
    returning float64): broadcasts its arguments like any ufunc.  Built (compiled) at the first call per kernel
    and process, not cached on disk (its cache entry would share the kernel's own).

    Parameters
    ----------
    kernel : numba dispatcher
        The scalar kernel (its ``py_func`` is vectorised).
    n_args : int
        Number of its arguments.

    Returns
    -------
    numpy.ufunc
        The broadcasting function.
    """
    return vectorize([float64(*([float64] * n_args))])(kernel.py_func)


# --------------------------------------------------------------------------------------------
@njit(cache=True, error_model="numpy")
def mlsd_kernel(r, r_dot, stiffness, damping):
    """Kernel of :func:`mlsd` (scalars, for compiled code).

    Parameters
    ----------
    r, r_dot : float
        Deformation beyond the clearance (m) and its rate (m/s).
    stiffness, damping : float
        K_i (N/m) and C_i (N s/m).

    Returns
    -------
    float
        |F_i| (N).
    """
    if r <= 0.0:
        return 0.0
    f = stiffness * r + damping * r_dot
    return f if f > 0.0 else 0.0


def mlsd(r, r_dot, stiffness, damping):
    """Massless-link spring-damper clearance force (study eq. 8, consistent reading).

    Parameters
    ----------
    r : array_like
        Deformation of the massless link beyond the clearance, r_i - c_i (m).  <= 0: the joint is open.
    r_dot : array_like
        Its rate (m/s).
    stiffness : float
        K_i (N/m).
    damping : float
        C_i (N s/m).

    Returns
    -------
    ndarray
        |F_i| = max(0, K_i r + C_i r_dot) where r > 0, else 0 (N).

    Notes
    -----
    The study prints |F_i| = K_i r_i(t) + C_i r_dot_i(t) with r_i the length of the massless rod that
    replaces the clearance.  Read literally (r_i = the whole link, about the clearance size c_i) it gives
    a force K_i c_i with no load at all.  Here the spring acts on the deformation r_i - c_i, compression
    only (see docs/mlsd.md).  This is the linear "spring-dashpot" law of the continuous-contact family
    (Dubowsky & Freudenstein 1971; Flores et al. 2008, sec. 3).

    References
    ----------
    S. Dubowsky, F. Freudenstein, "Dynamic analysis of mechanical systems with clearances, Part 1",
    J. Eng. Ind. 93 (1971) 305-309.
    """
    return broadcasting(mlsd_kernel, 4)(np.asarray(r, float), np.asarray(r_dot, float), float(stiffness), float(damping))


# --------------------------------------------------------------------------------------------
@njit(cache=True, error_model="numpy")
def hertz_kernel(delta, stiffness, exponent):
    """Kernel of :func:`hertz` (scalars, for compiled code).

    Parameters
    ----------
    delta : float
        Penetration (m).
    stiffness : float
        K (N/m^n).
    exponent : float
        n (dimensionless).

    Returns
    -------
    float
        Force (N).
    """
    if delta <= 0.0:
        return 0.0
    return stiffness * delta**exponent


def hertz(delta, stiffness, exponent=1.5):
    """Hertz elastic contact force F = K delta^n.

    Parameters
    ----------
    delta : array_like
        Penetration (m).
    stiffness : float
        K (N/m^n), e.g. from :func:`berryshaker.contact.pin_in_bore.pin_in_bore_stiffness`.
    exponent : float
        n (dimensionless); 1.5 for point (Hertz) contact and the usual choice for journal bearings.

    Returns
    -------
    ndarray
        Force (N).  Purely elastic: a simulated impact returns all its energy (tested).

    References
    ----------
    K. L. Johnson, *Contact Mechanics*, Cambridge University Press, 1985, ch. 4.
    """
    return broadcasting(hertz_kernel, 3)(np.asarray(delta, float), float(stiffness), float(exponent))


# --------------------------------------------------------------------------------------------
@njit(cache=True, error_model="numpy")
def hysteresis_kernel(delta, delta_dot, impact_velocity, stiffness, factor, exponent):
    """F = K delta^n (1 + factor * delta_dot / impact_velocity), clamped >= 0 (shared by HC, LN, Flores).

    Parameters
    ----------
    delta, delta_dot : float
        Penetration (m) and its rate (m/s, > 0 approaching).
    impact_velocity : float
        The velocity the hysteresis factor divides by (m/s); floored at 1e-12 m/s.
    stiffness : float
        K (N/m^n).
    factor : float
        The law's hysteresis factor, e.g. 3(1 - e)/2 for Hunt-Crossley (dimensionless).
    exponent : float
        n (dimensionless).

    Returns
    -------
    float
        Force (N), >= 0.
    """
    if delta <= 0.0:
        return 0.0
    v0 = abs(impact_velocity)
    if v0 < 1e-12:
        v0 = 1e-12
    f = stiffness * delta**exponent * (1.0 + factor * delta_dot / v0)
    return f if f > 0.0 else 0.0


def _hysteresis_velocity(impact_velocity, restitution_velocity):
    """max(|v_imp|, v_ref) (m/s): the velocity the hysteresis factor divides by (docs/contact.md sec. 6.4)."""
    if not restitution_velocity >= 0:
        raise ValueError(f"restitution_velocity must be >= 0 m/s, got {restitution_velocity}")
    return np.maximum(np.abs(np.asarray(impact_velocity, float)), float(restitution_velocity))


def _check_e(restitution):
    e = np.asarray(restitution, float)
    if np.any((e <= 0) | (e > 1)):
        raise ValueError(f"coefficient of restitution must be in (0, 1], got {restitution}")
    return e


def hunt_crossley(delta, delta_dot, stiffness, restitution, exponent=1.5, *, impact_velocity=None,
                  restitution_velocity=0.0):
    """Hunt-Crossley dissipative contact force.

    Parameters
    ----------
    delta, delta_dot : array_like
        Penetration (m) and its rate (m/s, > 0 approaching).
    stiffness : float
        K (N/m^n).
    restitution : float
        Coefficient of restitution e (dimensionless, 0 < e <= 1).
    exponent : float
        n (dimensionless).
    impact_velocity : float
        Normal approach velocity at the onset of this impact, delta_dot(-) (m/s).  Required: the
        hysteresis factor that reproduces a given e depends on it (as for Lankarani-Nikravesh and
        Flores); a simulation records it when contact starts.
    restitution_velocity : float
        v_ref (m/s): impacts slower than v_ref get the damping of an impact at v_ref (Hunt & Crossley's
        material-constant hysteresis, e -> 1 as v -> 0; docs/contact.md sec. 6.4).  0: the published law.

    Returns
    -------
    ndarray
        F = K delta^n [1 + 3(1 - e)/2 * delta_dot / max(delta_dot(-), v_ref)], >= 0 (N).

    Notes
    -----
    Hysteresis factor chi = 3 K (1 - e) / (2 delta_dot(-)) (Hunt & Crossley 1975, in the form tabulated
    by Flores et al. 2011, Table 1).  Derived for e close to 1; for lower e it dissipates less than
    asked (the effective e it produces is reported by the tests).

    References
    ----------
    K. H. Hunt, F. R. E. Crossley, "Coefficient of restitution interpreted as damping in vibroimpact",
    J. Appl. Mech. 42 (1975) 440-445.
    P. Flores, M. Machado, M. T. Silva, J. M. Martins, "On the continuous contact force models for soft
    materials in multibody dynamics", Multibody Syst. Dyn. 25 (2011) 357-375.
    """
    if impact_velocity is None:
        raise ValueError("hunt_crossley needs impact_velocity (the normal approach velocity when contact began)")
    e = _check_e(restitution)
    v0 = _hysteresis_velocity(impact_velocity, restitution_velocity)
    return broadcasting(hysteresis_kernel, 6)(np.asarray(delta, float), np.asarray(delta_dot, float), v0,
                             float(stiffness), 1.5 * (1.0 - e), float(exponent))


def lankarani_nikravesh(delta, delta_dot, impact_velocity, stiffness, restitution, exponent=1.5,
                        restitution_velocity=0.0):
    """Lankarani-Nikravesh dissipative contact force.

    Parameters
    ----------
    delta, delta_dot : array_like
        Penetration (m), its rate (m/s, > 0 approaching).
    impact_velocity : array_like
        delta_dot(-), normal approach velocity at contact onset (m/s).
    stiffness : float
        K (N/m^n).
    restitution : float
        e (dimensionless), valid for e close to 1.
    exponent : float
        n (dimensionless).
    restitution_velocity : float
        v_ref (m/s), as in :func:`hunt_crossley`; 0: the published law.

    Returns
    -------
    ndarray
        F = K delta^n [1 + 3(1 - e^2)/4 * delta_dot / max(delta_dot(-), v_ref)], >= 0 (N).

    References
    ----------
    H. M. Lankarani, P. E. Nikravesh, "A contact force model with hysteresis damping for impact
    analysis of multibody systems", J. Mech. Des. 112 (1990) 369-376.
    """
    e = _check_e(restitution)
    v0 = _hysteresis_velocity(impact_velocity, restitution_velocity)
    return broadcasting(hysteresis_kernel, 6)(np.asarray(delta, float), np.asarray(delta_dot, float), v0,
                             float(stiffness), 0.75 * (1.0 - e * e), float(exponent))


def flores(delta, delta_dot, impact_velocity, stiffness, restitution, exponent=1.5, restitution_velocity=0.0):
    """Flores et al. (2011) dissipative contact force, valid over the whole range of restitution.

    Parameters
    ----------
    delta, delta_dot : array_like
        Penetration (m), its rate (m/s, > 0 approaching).
    impact_velocity : array_like
        delta_dot(-), normal approach velocity at contact onset (m/s).
    stiffness : float
        K (N/m^n).
    restitution : float
        e (dimensionless, 0 < e <= 1).
    exponent : float
        n (dimensionless).
    restitution_velocity : float
        v_ref (m/s), as in :func:`hunt_crossley`; 0: the published law.

    Returns
    -------
    ndarray
        F = K delta^n [1 + 8(1 - e)/(5 e) * delta_dot / max(delta_dot(-), v_ref)], >= 0 (N); v_ref =
        ``restitution_velocity`` (m/s) as in :func:`hunt_crossley`.

    References
    ----------
    P. Flores, M. Machado, M. T. Silva, J. M. Martins, Multibody Syst. Dyn. 25 (2011) 357-375.
    """
    e = _check_e(restitution)
    v0 = _hysteresis_velocity(impact_velocity, restitution_velocity)
    return broadcasting(hysteresis_kernel, 6)(np.asarray(delta, float), np.asarray(delta_dot, float), v0,
                             float(stiffness), 1.6 * (1.0 - e) / e, float(exponent))


# --------------------------------------------------------------------------------------------
@njit(cache=True, error_model="numpy")
def adams_step_kernel(x, x0, h0, x1, h1):
    """Kernel of :func:`adams_step` (scalars, for compiled code).

    Parameters
    ----------
    x, x0, x1 : float
        The variable and the ends of the step (any unit, the same for the three).
    h0, h1 : float
        The values before and after the step, in their unit.

    Returns
    -------
    float
        STEP(x, x0, h0, x1, h1), in the unit of h0 and h1.
    """
    if x <= x0:
        return h0
    if x >= x1:
        return h1
    d = (x - x0) / (x1 - x0)
    return h0 + (h1 - h0) * d * d * (3.0 - 2.0 * d)


def adams_step(x, x0, h0, x1, h1):
    """The cubic STEP function of MSC ADAMS: h0 for x <= x0, h1 for x >= x1, and
    h0 + (h1 - h0) D^2 (3 - 2 D) with D = (x - x0)/(x1 - x0) in between.

    Parameters
    ----------
    x : array_like
        The variable, in any unit.
    x0, x1 : float
        The ends of the step, in the unit of x (x0 < x1).
    h0, h1 : float
        The values before and after the step (any unit, the same for both).

    Returns
    -------
    ndarray
        The step, in the unit of h0 and h1.

    References
    ----------
    MSC Software, *Adams Solver: Function reference*, "STEP".
    """
    return broadcasting(adams_step_kernel, 5)(np.asarray(x, float), float(x0), float(h0), float(x1), float(h1))


@njit(cache=True, error_model="numpy")
def impact_kernel(x, x_dot, x1, k, e, cmax, d):
    """Kernel of :func:`impact` (scalars, for compiled code).

    Parameters
    ----------
    x, x_dot : float
        Distance variable (m) and its rate (m/s).
    x1 : float
        Free length (m).
    k : float
        Stiffness (N/m^e).
    e : float
        Force exponent (dimensionless).
    cmax : float
        Maximum damping coefficient (N s/m).
    d : float
        Penetration of full damping (m).

    Returns
    -------
    float
        Force (N), >= 0.
    """
    if x >= x1:
        return 0.0
    f = k * (x1 - x) ** e - adams_step_kernel(x, x1 - d, cmax, x1, 0.0) * x_dot
    return f if f > 0.0 else 0.0


def impact(x, x_dot, x1, k, e, cmax, d):
    """The IMPACT function of MSC ADAMS (used by the study's multibody run).

    Parameters
    ----------
    x : array_like
        Distance variable (m); contact when x < x1.
    x_dot : array_like
        Its time derivative (m/s); negative while approaching.
    x1 : float
        Free length: distance at which contact begins (m).
    k : float
        Stiffness (N/m^e).
    e : float
        Force exponent (dimensionless, > 0; 1.5 for Hertz-like contact).
    cmax : float
        Maximum damping coefficient (N s/m).
    d : float
        Penetration at which the full damping cmax is reached (m).

    Returns
    -------
    ndarray
        0 for x >= x1; otherwise max(0, k (x1 - x)^e - STEP(x, x1 - d, cmax, x1, 0) * x_dot) (N).

    Notes
    -----
    The damping coefficient ramps from 0 at first touch to cmax at penetration d with the cubic STEP,
    so the force is continuous at contact onset.  ADAMS documents the force as never negative.

    References
    ----------
    MSC Software, *Adams Solver: Function reference*, "IMPACT".
    """
    return broadcasting(impact_kernel, 7)(np.asarray(x, float), np.asarray(x_dot, float), float(x1), float(k), float(e),
                         float(cmax), float(d))
