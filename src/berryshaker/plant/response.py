"""Forced response of the branch by modal superposition (study eq. 15, Duhamel's integral), fruit
harvesting force (eq. 16) and the harvest condition (eq. 17)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from berryshaker.errors import ConfigError
from berryshaker.plant.modes import Modes

#: bond force ranges of eq. 17 [study]: ripe fruit F_a = 0.26-0.30 N, unripe fruit F_b = 1.0-3.6 N
RIPE_BOND_N = (0.26, 0.30)
UNRIPE_BOND_N = (1.0, 3.6)


def modal_response(modes: Modes, t, force, z_force, damping_ratio: float | None = None):
    """Modal coordinates q_k(t), their rates and accelerations under a point force history.

    Parameters
    ----------
    modes : Modes
        Mass-normalised modes.
    t : array_like
        Uniformly spaced times (s), starting at rest.
    force : array_like
        Force at ``z_force`` (N), piecewise linear between the samples.
    z_force : float
        Load position (m from the root).
    damping_ratio : float, optional
        Modal damping ratio xi (default: the branch's).

    Returns
    -------
    q, qd, qdd : ndarray, shape (n_modes, n_t)
        Modal coordinates of the mass-normalised modes (kg^0.5 m), their rates (kg^0.5 m/s) and
        accelerations (kg^0.5 m/s^2).

    Notes
    -----
    Each mode obeys q'' + 2 xi w q' + w^2 q = phi_k(z_F) F(t), whose solution from rest is Duhamel's
    integral q(t) = 1/w_d int_0^t phi_k F(tau) e^{-xi w (t-tau)} sin(w_d (t-tau)) dtau (study eq. 15).  It
    is evaluated exactly for piecewise-linear F by the first-order-hold discretisation of the modal
    state equation (scipy.signal.cont2discrete, method 'foh'), so the step size only has to resolve
    the load.
    """
    t = np.asarray(t, float)
    f = np.asarray(force, float)
    if t.ndim != 1 or t.size < 2 or f.shape != t.shape:
        raise ConfigError("t and force must be 1-D arrays of the same length (>= 2)")
    dt = t[1] - t[0]
    if not np.allclose(np.diff(t), dt, rtol=1e-6, atol=1e-12):
        raise ConfigError("modal_response needs uniformly spaced times")
    from scipy import signal  # here, not at the top: importing scipy.signal takes ~1 s a warm study never needs
    xi = modes.branch.damping_ratio if damping_ratio is None else damping_ratio
    phi = modes.shape_at(z_force)
    n = len(modes.omega)
    q = np.zeros((n, t.size))
    qd = np.zeros_like(q)
    qdd = np.zeros_like(q)
    for k, w in enumerate(modes.omega):
        a = np.array([[0.0, 1.0], [-w * w, -2 * xi * w]])
        b = np.array([[0.0], [1.0]])
        c = np.array([[1.0, 0.0], [0.0, 1.0], [-w * w, -2 * xi * w]])
        d = np.array([[0.0], [0.0], [1.0]])
        sysd = signal.cont2discrete((a, b, c, d), dt, method="foh")
        _, y, _ = signal.dlsim(sysd, phi[k] * f)
        q[k], qd[k], qdd[k] = y[:, 0], y[:, 1], y[:, 2]
    return q, qd, qdd


def deflection(modes: Modes, q, z):
    """Branch deflection f(z, t) = sum_k phi_k(z) q_k(t) (m) (study eq. 15).

    Parameters
    ----------
    modes : Modes
        Mass-normalised modes.
    q : ndarray, shape (n_modes, n_t)
        Modal coordinates (kg^0.5 m), e.g. from :func:`modal_response`.
    z : float or array_like
        Positions along the branch (m from the root).

    Returns
    -------
    ndarray, shape (n_z, n_t)
        Deflection (m).
    """
    return modes.shape_at(np.atleast_1d(z)).T @ q


def fruit_force(modes: Modes, qdd, z_fruit, fruit_mass):
    """Fruit harvesting force F(z_m, t) = m0 d2f/dt2 at the fruit (study eq. 16), N.

    Parameters
    ----------
    modes : Modes
        Mass-normalised modes.
    qdd : ndarray (n_modes, n_t)
        Modal accelerations (kg^0.5 m/s^2).
    z_fruit : float or array_like
        Fruit positions (m from the root).
    fruit_mass : float
        m0 (kg).

    Returns
    -------
    ndarray, shape (n_fruit, n_t)
        The inertial force the stem must transmit to keep the fruit on the branch (N).

    Notes
    -----
    As in the study: the fruit is a point mass rigidly attached to the branch (no stem pendulum), its
    weight (m0 g = 0.018 N for 1.8 g) is not added, and the fruit's mass does not load the branch's
    modes (it is 0.3 % of the reference branch's mass per fruit).
    """
    if not fruit_mass > 0:
        raise ConfigError(f"fruit mass must be > 0, got {fruit_mass}")
    return fruit_mass * (modes.shape_at(np.atleast_1d(z_fruit)).T @ qdd)


@dataclass(frozen=True)
class HarvestVerdict:
    """What a peak fruit force does to ripe and unripe fruit (study eq. 17), :func:`harvest_verdict`.

    Attributes
    ----------
    peak_force_N : float
        The peak fruit force (N).
    ripe : {"picked", "partly picked", "left on the bush"}
        Ripe fruit.
    unripe : {"kept", "partly shed", "shed"}
        Unripe fruit.
    meets_eq17 : bool
        F_a(max) <= F < F_b(min): every ripe fruit off, every unripe fruit kept.
    """

    peak_force_N: float
    ripe: str  # "picked", "partly picked", "left on the bush"
    unripe: str  # "kept", "partly shed", "shed"
    meets_eq17: bool  # F_a(max) <= F <= F_b(min): every ripe fruit off, every unripe fruit kept

    def as_dict(self) -> dict:
        """The verdict as JSON.

        Returns
        -------
        dict
            The four attributes by name.
        """
        return {"peak_force_N": self.peak_force_N, "ripe": self.ripe, "unripe": self.unripe,
                "meets_eq17": self.meets_eq17}


def harvest_verdict(peak_force, ripe_bond=RIPE_BOND_N, unripe_bond=UNRIPE_BOND_N) -> HarvestVerdict:
    """Study eq. 17: F_a <= F <= F_b picks ripe fruit and keeps unripe fruit.

    With the bond ranges F_a in [0.26, 0.30] N and F_b in [1.0, 3.6] N [study]: a ripe fruit is picked
    for certain when F >= 0.30 N, possibly when 0.26 <= F < 0.30, and stays when F < 0.26 N; an unripe
    fruit is kept for certain when F < 1.0 N, possibly shed when 1.0 <= F < 3.6 N, and shed above.

    Parameters
    ----------
    peak_force : float
        Peak fruit force F (N).
    ripe_bond, unripe_bond : (float, float)
        Ranges of the ripe and unripe fruit's bond force, (F_a min, F_a max) and (F_b min, F_b max) (N).

    Returns
    -------
    HarvestVerdict
        What the force does.
    """
    f = float(peak_force)
    ripe = "picked" if f >= ripe_bond[1] else ("partly picked" if f >= ripe_bond[0] else "left on the bush")
    unripe = "kept" if f < unripe_bond[0] else ("partly shed" if f < unripe_bond[1] else "shed")
    return HarvestVerdict(f, ripe, unripe, bool(ripe_bond[1] <= f < unripe_bond[0]))
