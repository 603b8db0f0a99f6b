"""Peak stem loads of fruit on compliant pedicels over a branch motion: the largest stem-force magnitude and the
largest pull-shear load ratios over time, for a table of positions x fruit masses, in one compiled pass over the
motion with no force series stored (the virtual harvest's stem-force tables, berryshaker.harvest.virtual).  The
oscillator and its discretisation are berryshaker.plant.pedicel.oscillator's.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from berryshaker.errors import ConfigError
from berryshaker.plant.pedicel.miner import MINER_EXPONENTS, REVERSAL_GATE, _equivalent, _finish, _register
from berryshaker.plant.pedicel.oscillator import GRAVITY, _check, _uniform_step, discretise_foh


def peak_stem_force(t, lateral, axial, mass, stiffness=10.0, damping=0.027, weight=True):
    """Largest stem-force magnitude over time of fruit of several masses at several places on the branch.

    The model of :func:`~berryshaker.plant.pedicel.oscillator.stem_response` in absolute coordinates, in both
    directions (the branch's lateral motion and its axial foreshortening each drive the pedicel's oscillator),
    combined as in ``berryshaker.harvest.coupled.stem_forces``: |F| = hypot(F_lateral, F_axial + m0 g).  Only the
    maximum over time is kept, so a table of many positions x masses (the virtual harvest's envelope) costs one
    pass over the motion with no force series stored.

    Parameters
    ----------
    t : ndarray (n_t,)
        Uniformly spaced times (s); the fruit starts at rest relative to the branch at t[0].
    lateral, axial : tuple of ndarray (n_z, n_t)
        Branch displacement (m) and velocity (m/s) at each fruit position, lateral and axial.
    mass : array_like (n_mass,)
        Fruit masses m0 (kg).
    stiffness, damping : float
        Pedicel stiffness k (N/m) and damping c (N s/m).
    weight : bool
        Add the fruit's weight m0 g to the axial force (upright branch, axis vertical).

    Returns
    -------
    ndarray (n_z, n_mass)
        max_t |F| (N).

    Notes
    -----
    For each mass the two-input system (inputs y, y'; state x, x'; output F = k (y - x) + c (y' - x')) is
    discretised exactly for a first-order hold (``scipy.signal.cont2discrete``, the discretisation of
    :func:`~berryshaker.plant.pedicel.oscillator.stem_response`) and run as a state-space recursion from rest,
    x[i+1] = A_d x[i] + B_d u[i], F[i] = C_d x[i] + D_d u[i], compiled (numba); the same zero-state response as
    the second-order sections of :func:`~berryshaker.plant.pedicel.oscillator.stem_response`, equal to
    round-off (tested).
    """
    return peak_stem_loads(t, lateral, axial, mass, stiffness, damping, weight)[:, :, 0]


def peak_stem_loads(t, lateral, axial, mass, stiffness=10.0, damping=0.027, weight=True, strengths=(),
                    exponents=()):
    """Peak stem-force magnitude and peak pull-shear load ratios of fruit on compliant pedicels.

    The stem force of :func:`peak_stem_force`, resolved by its mode of loading: the pedicel of a berry on an
    upright branch hangs along the branch axis, so the axial component F_ax + m0 g (tension > 0) pulls the fruit
    along its pedicel and the lateral component F_lat bends and shears it across.  A fruit of mean pull strength
    P and mean shear strength S is loaded to the ratio

        g(t) = sqrt( (max(F_ax + m0 g, 0) / P)^2 + (F_lat / S)^2 ),

    an elliptical pull-shear interaction (the quadratic failure criterion of combined loading; pull alone
    breaks at P, shear alone at S, as the two test modes of Kong et al. 2014 measure them; the interaction's
    form is [assumed]: no blueberry test under combined loading is known to us).  A fruit whose own strengths
    are s P and s S comes off when its Miner-Basquin equivalent load ratio g_eq(beta) = (sum_i g_i^beta)^(1/beta)
    over the load cycles i of g(t) reaches s (berryshaker.plant.pedicel.miner, eq. 1; Miner 1945, Basquin 1910;
    beta -> inf: max_t g, the peak-only law).  Compression along the pedicel does not load the abscission zone in
    pull.

    Parameters
    ----------
    t : ndarray (n_t,)
        Uniformly spaced times (s); the fruit starts at rest relative to the branch at t[0].
    lateral, axial : tuple of ndarray (n_z, n_t)
        Branch displacement (m) and velocity (m/s) at each fruit position, lateral and axial.
    mass : array_like (n_mass,)
        Fruit masses m0 (kg).
    stiffness, damping : float
        Pedicel stiffness k (N/m) and damping c (N s/m).
    weight : bool
        Add the fruit's weight m0 g to the axial force (upright branch, axis vertical).
    strengths : sequence of (float, float)
        Mean pull and shear strengths (P, S) (N) of each fruit class (e.g. ripe, unripe).
    exponents : sequence of float
        Basquin exponents beta (dimensionless, > 0) at which to accumulate g_eq (none: the peaks only).

    Returns
    -------
    ndarray (n_z, n_mass, 1 + n_strengths (1 + n_exponents))
        [..., 0]: max_t |F| (N); [..., 1 + s]: max_t g for strengths s; [..., 1 + n_s + s n_k + k]: g_eq of
        strengths s at exponents[k] (dimensionless).

    References
    ----------
    Kong, Y., et al. (2014).  Journal of Northeast Agricultural University 45(4): blueberry fruit detachment by
    pull along the pedicel and by shear across it (docs/harvest.md, "Bond").
    Miner, M.A. (1945).  Cumulative damage in fatigue.  J. Appl. Mech. 12: A159-A164.
    Basquin, O.H. (1910).  The exponential law of endurance tests.  Proc. ASTM 10: 625-630.
    """
    h = _uniform_step(t)
    masses = np.atleast_1d(np.asarray(mass, float))
    m, k, c = _check(masses, stiffness, damping)
    k, c = float(k), float(c)
    y, v = (np.ascontiguousarray(x, dtype=float) for x in lateral)
    ya, va = (np.ascontiguousarray(x, dtype=float) for x in axial)
    if not (y.shape == v.shape == ya.shape == va.shape and y.ndim == 2 and y.shape[1] == len(t)):
        raise ConfigError("peak_stem_force needs lateral and axial (displacement, velocity) arrays of shape "
                          "(positions, len(t))")
    st = np.asarray(strengths, float).reshape(-1, 2)
    if np.any(~(st > 0)):
        raise ConfigError(f"pull and shear strengths must be > 0 N, got {strengths}")
    ad, bd = np.zeros((len(m), 2, 2)), np.zeros((len(m), 2, 2))
    cd, dd = np.zeros((len(m), 2)), np.zeros((len(m), 2))
    for j, mj in enumerate(m):
        a = np.array([[0.0, 1.0], [-k / mj, -c / mj]])
        b = np.array([[0.0, 0.0], [k / mj, c / mj]])
        ad[j], bd[j], cdj, ddj = discretise_foh(a, b, np.array([[-k, -c]]), np.array([[k, c]]), h)
        cd[j], dd[j] = cdj[0], ddj[0]
    ex = np.ascontiguousarray(np.asarray(exponents, float).reshape(-1))
    if np.any(~(ex > 0)):
        raise ConfigError(f"Miner exponents must be > 0, got {exponents}")
    out = np.zeros((y.shape[0], len(m), 1 + len(st) * (1 + ex.size)))
    # before the branch moves the oscillators rest (state 0, every sample the same): one such sample gives the same
    # maxima and reversals as all of them (tested), so the pass starts at the last sample of rest
    moving = np.flatnonzero(np.any(y != 0, axis=0) | np.any(v != 0, axis=0) | np.any(ya != 0, axis=0)
                            | np.any(va != 0, axis=0))
    first = max(int(moving[0]) - 1, 0) if moving.size else max(y.shape[1] - 1, 0)
    if first:
        y, v, ya, va = (np.ascontiguousarray(x[:, first:]) for x in (y, v, ya, va))
    _peak_stem_force_kernel(ad, bd, cd, dd, y, v, ya, va, m * GRAVITY if weight else np.zeros(len(m)),
                            np.ascontiguousarray(1.0 / st[:, 0]), np.ascontiguousarray(1.0 / st[:, 1]), ex,
                            REVERSAL_GATE, out)
    return out


def compile_peak_stem_force() -> None:
    """Compile (or load from numba's on-disk cache) the kernel of :func:`peak_stem_force`: one call on four
    samples of a branch at rest.  Lets an idle process compile it before the runs that need it."""
    rest = np.zeros((1, 4))
    peak_stem_loads(np.arange(4) * 1e-4, (rest, rest), (rest, rest), [1.8e-3], strengths=[(0.47, 0.23)],
                    exponents=MINER_EXPONENTS)


@njit(cache=True)
def _peak_stem_force_kernel(ad, bd, cd, dd, y, v, ya, va, weight, inv_pull, inv_shear, exponents, gate, out):
    """out[i, j, 0] = max over time of |(F_lat, F_ax + weight[j])|, out[i, j, 1 + s] = max over time of the
    pull-shear load ratio g_s of :func:`peak_stem_loads` and out[i, j, 1 + n_s + s n_k + k] its Miner-Basquin
    equivalent at exponents[k] (berryshaker.plant.pedicel.miner) for the discretised oscillators (mass j at
    position i; the maxima are taken on the squares).

    Time outermost, positions innermost: at each time the positions' inputs are gathered into contiguous rows and
    every (mass, position) oscillator advances one step, the positions side by side, then the load ratios and the
    reversal count read the forces kept in rows (each oscillator's arithmetic is that of its own recursion, so the
    numbers do not depend on the order or the loops' split)."""
    n_z, n_t = y.shape
    n_m = ad.shape[0]
    n_s = inv_pull.shape[0]
    n_k = exponents.shape[0]
    half = 0.5 * exponents
    x0, x1, w0, w1 = np.zeros((n_m, n_z)), np.zeros((n_m, n_z)), np.zeros((n_m, n_z)), np.zeros((n_m, n_z))
    best = np.zeros((n_m, 1 + n_s, n_z))
    rising = np.ones((n_m, n_s, n_z), dtype=np.bool_)
    cand, last, pm = np.zeros((n_m, n_s, n_z)), np.zeros((n_m, n_s, n_z)), np.zeros((n_m, n_s, n_z))
    sums = np.zeros((n_m, n_s, n_z, n_k))
    u0r, u1r, s0r, s1r = np.empty(n_z), np.empty(n_z), np.empty(n_z), np.empty(n_z)
    lat, pull = np.empty(n_z), np.empty(n_z)
    g2r = np.empty((n_s, n_z))
    for n in range(n_t):
        for i in range(n_z):
            u0r[i], u1r[i], s0r[i], s1r[i] = y[i, n], v[i, n], ya[i, n], va[i, n]
        for j in range(n_m):
            c0, c1, d0, d1 = cd[j, 0], cd[j, 1], dd[j, 0], dd[j, 1]
            a00, a01, a10, a11 = ad[j, 0, 0], ad[j, 0, 1], ad[j, 1, 0], ad[j, 1, 1]
            b00, b01, b10, b11 = bd[j, 0, 0], bd[j, 0, 1], bd[j, 1, 0], bd[j, 1, 1]
            wt = weight[j]
            p0r, p1r, q0r, q1r, b0r = x0[j], x1[j], w0[j], w1[j], best[j, 0]
            for i in range(n_z):  # the oscillators: no inner loop, no branch (a select), so it runs in SIMD lanes
                u0, u1, s0, s1 = u0r[i], u1r[i], s0r[i], s1r[i]
                p0, p1, q0, q1 = p0r[i], p1r[i], q0r[i], q1r[i]
                f_lat = c0 * p0 + c1 * p1 + d0 * u0 + d1 * u1
                f_ax = c0 * q0 + c1 * q1 + d0 * s0 + d1 * s1 + wt
                f2 = f_lat * f_lat + f_ax * f_ax
                b = b0r[i]
                b0r[i] = f2 if f2 > b else b
                lat[i] = f_lat
                pull[i] = f_ax if f_ax > 0.0 else 0.0
                p0r[i] = a00 * p0 + a01 * p1 + b00 * u0 + b01 * u1
                p1r[i] = a10 * p0 + a11 * p1 + b10 * u0 + b11 * u1
                q0r[i] = a00 * q0 + a01 * q1 + b00 * s0 + b01 * s1
                q1r[i] = a10 * q0 + a11 * q1 + b10 * s0 + b11 * s1
            for s in range(n_s):  # the load ratios of each strength class
                ip, ish = inv_pull[s], inv_shear[s]
                bs, gs2 = best[j, 1 + s], g2r[s]
                for i in range(n_z):
                    gp, gs = pull[i] * ip, lat[i] * ish
                    g2 = gp * gp + gs * gs
                    b = bs[i]
                    bs[i] = g2 if g2 > b else b
                    gs2[i] = g2
            if n_k:  # the reversal count (berryshaker.plant.pedicel.miner; branches: out of the oscillators' loop)
                for s in range(n_s):
                    for i in range(n_z):
                        g2, c = g2r[s, i], cand[j, s, i]
                        if rising[j, s, i]:
                            if g2 > c:
                                cand[j, s, i] = g2
                            elif g2 < c * (1.0 - gate):
                                _register(c, j, s, i, pm, sums, half)
                                last[j, s, i] = c
                                rising[j, s, i] = False
                                cand[j, s, i] = g2
                        elif g2 < c:
                            cand[j, s, i] = g2
                        elif g2 > c + gate * last[j, s, i]:
                            rising[j, s, i] = True
                            cand[j, s, i] = g2
    for j in range(n_m):
        for i in range(n_z):
            for s in range(1 + n_s):
                out[i, j, s] = math.sqrt(best[j, s, i])
            if n_k:
                for s in range(n_s):
                    _finish(j, s, i, rising, cand, pm, sums, half)
                    for k in range(n_k):
                        out[i, j, 1 + n_s + s * n_k + k] = _equivalent(pm[j, s, i], sums[j, s, i, k], exponents[k])
