"""Tangential (friction) force laws."""

from __future__ import annotations

import numpy as np
from numba import njit

from berryshaker.contact.force_laws import broadcasting


@njit(cache=True, error_model="numpy")
def coulomb_friction_kernel(v_t, normal_force, mu, v0, v1):
    """Kernel of :func:`coulomb_friction` (scalar, for compiled code; arrays go through the wrapper).

    Parameters
    ----------
    v_t : float
        Relative tangential (sliding) velocity (m/s).
    normal_force : float
        Normal force (N); its magnitude is used.
    mu : float
        Coefficient of friction (1).
    v0, v1 : float
        Velocities of the regularised transition (m/s), 0 <= v0 < v1.

    Returns
    -------
    float
        Friction force F_t (N), opposite to ``v_t``.
    """
    av = abs(v_t)
    if av <= v0:
        return 0.0
    if av >= v1:
        cd = 1.0
    else:
        cd = (av - v0) / (v1 - v0)
    f = mu * cd * abs(normal_force)
    return -f if v_t > 0.0 else f


def coulomb_friction(v_t, normal_force, mu, v0=1e-4, v1=1e-3):
    """Coulomb friction with Ambrosio's velocity-regularised transition.

    Parameters
    ----------
    v_t : array_like
        Relative tangential (sliding) velocity (m/s).
    normal_force : array_like
        Normal force magnitude (N).
    mu : float
        Coefficient of friction (1).
    v0, v1 : float
        Below |v_t| = v0 no friction (avoids the sticking discontinuity); full Coulomb friction above v1
        (m/s); linear in between.

    Returns
    -------
    ndarray
        F_t = -mu c_d |F_N| sign(v_t) (N), c_d the dynamic correction factor.

    References
    ----------
    J. Ambrosio, "Impact of rigid and flexible multibody systems: deformation description and contact
    models", in *Virtual Nonlinear Multibody Systems*, NATO Sci. Ser. 103 (2003) 57-81.
    """
    if not (0 <= v0 < v1):
        raise ValueError(f"need 0 <= v0 < v1, got v0={v0}, v1={v1}")
    return broadcasting(coulomb_friction_kernel, 5)(np.asarray(v_t, float), np.asarray(normal_force, float), float(mu),
                                   float(v0), float(v1))


def viscous_friction(v_t, coefficient):
    """Viscous friction F_t = -c v_t.

    Parameters
    ----------
    v_t : array_like
        Relative tangential (sliding) velocity (m/s).
    coefficient : float
        Viscous coefficient c (N s/m).

    Returns
    -------
    ndarray
        Friction force F_t (N).
    """
    return -float(coefficient) * np.asarray(v_t, float)
