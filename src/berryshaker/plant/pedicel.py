"""Fruit on a stem: the fruit as a mass m0 on a compliant pedicel, base-excited by the branch at z_m.

The study (eq. 16) takes the fruit harvesting force as m0 times the branch acceleration at the fruit,
i.e. a fruit rigidly fixed to the branch.  A real berry hangs on a pedicel a few mm long whose bending
compliance makes the fruit-stem system an oscillator with its own natural frequency; the classical
linear model of fruit-stem dynamics in vibratory harvesting is a (double) pendulum with torsion
springs, Cooke, J.R. & Rand, R.H. (1969), "Vibratory fruit harvesting: a linear theory of fruit-stem
dynamics", J. Agric. Eng. Res. 14(3), 195-209.  Here each in-plane direction is a single-degree-of-
freedom base-excited oscillator (mass m0, stem stiffness k, stem damping c):

    m0 x'' + c (x' - y') + k (x - y) = 0,        y(t): branch motion at z_m, x(t): the fruit,

equivalently, with the relative motion u = x - y,

    u'' + 2 zeta w_n u' + w_n^2 u = -y'',        w_n = sqrt(k/m0), zeta = c / (2 sqrt(k m0)).

The stem force (the force the pedicel exerts on the fruit, what must stay below the bond of eq. 17) is

    F = k (y - x) + c (y' - x') = -(k u + c u') = m0 x''.

As k -> inf the fruit follows the branch, u -> 0 and F -> m0 y'': the study's eq. 16 is the rigid-stem
limit (tested).  For harmonic base motion Y e^{i w t} the steady stem force is (e.g. Rao, Mechanical
Vibrations, base excitation; Thomson, Theory of Vibration with Applications)

    |F| / (m0 w^2 Y) = sqrt(1 + (2 zeta r)^2) / sqrt((1 - r^2)^2 + (2 zeta r)^2),    r = w / w_n,

the displacement transmissibility (tested against the time-domain solution below).

Parameters of the pedicel (docs/plant.md).  No measured blueberry fruit-stem frequency is known to us;
the nearest measured system of the same fruit size is the coffee fruit-stem system, natural
frequencies 11.6 Hz (ripe) and 13.3 Hz (green), equivalent stiffness 8.6 and 7.1 N/m, damping
coefficient 0.025 and 0.029 N s/m, i.e. damping ratio about 0.1 (Villibor, Santos, Queiroz, Khoury &
Pinto 2016, "Determination of modal properties of the coffee fruit-stem system using high speed digital
video and digital image processing", Acta Scientiarum. Technology 38(1),
doi:10.4025/actascitechnol.v38i1.27344).  We take k = 10 N/m and c = 0.027 N s/m (11.9 Hz, damping
ratio 0.10 for 1.8 g) [assumed, by analogy]; the function defaults below are those values.

One-way coupling.  The fruit does not load the branch's modes in this model.  The error of that is
governed by the modal mass ratio mu_k = m0 phi_k(z_m)^2 (phi mass-normalised; 1/phi_k^2 is the
effective mass of mode k at z_m): a rigidly attached mass lowers mode k by about mu_k/2 (Rayleigh
quotient), and a stem oscillator tuned to mode k splits it by about +-sqrt(mu_k)/2 (Den Hartog,
Mechanical Vibrations, tuned absorber).  :func:`modal_mass_ratio` returns mu_k; the test compares the
one-way stem force with the two-way coupled frequency response.

long module: the fruit-stem oscillator's closed forms, its compiled peak pass over a branch motion and its two-way
coupling checks share the same discretisation and parameters.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from numba import njit
from scipy import signal

from berryshaker.errors import ConfigError

#: standard gravity (m/s^2)
GRAVITY = 9.80665


def _check(mass, stiffness, damping):
    m, k, c = (np.asarray(v, float) for v in (mass, stiffness, damping))
    if np.any(~(m > 0)):
        raise ConfigError(f"fruit mass must be > 0 kg, got {mass}")
    if np.any(~(k > 0)):
        raise ConfigError(f"pedicel stiffness must be > 0 N/m, got {stiffness} (plant.fruit.pedicel.stiffness)")
    if np.any(~(c >= 0)):
        raise ConfigError(f"pedicel damping must be >= 0 N s/m, got {damping} (plant.fruit.pedicel.damping)")
    return m, k, c


def natural_frequency(mass, stiffness):
    """Undamped natural frequency of the fruit on its stem, w_n/2pi = sqrt(k/m0)/2pi (Hz).

    Parameters
    ----------
    mass : float or array_like
        Fruit mass m0 (kg), > 0.
    stiffness : float or array_like
        Pedicel stiffness k (N/m), > 0.

    Returns
    -------
    ndarray
        sqrt(k/m0)/2pi (Hz), broadcast over the inputs (0-d for scalars).

    Raises
    ------
    ConfigError
        A mass or stiffness is not > 0.
    """
    m, k, _ = _check(mass, stiffness, 0.0)
    return np.sqrt(k / m) / (2 * math.pi)


def damping_ratio(mass, stiffness, damping):
    """Damping ratio of the fruit on its stem, zeta = c / (2 sqrt(k m0)) (dimensionless).

    Parameters
    ----------
    mass : float or array_like
        Fruit mass m0 (kg), > 0.
    stiffness : float or array_like
        Pedicel stiffness k (N/m), > 0.
    damping : float or array_like
        Pedicel damping c (N s/m), >= 0.

    Returns
    -------
    ndarray
        zeta (dimensionless), broadcast over the inputs (0-d for scalars).

    Raises
    ------
    ConfigError
        A mass or stiffness is not > 0, or a damping is negative.
    """
    m, k, c = _check(mass, stiffness, damping)
    return c / (2 * np.sqrt(k * m))


def force_transmissibility(frequency_ratio, zeta):
    """Steady stem-force amplitude over the rigid-stem force, |F| / (m0 w^2 Y).

    Parameters
    ----------
    frequency_ratio : array_like
        r = w / w_n, excitation over stem natural frequency (dimensionless).
    zeta : float
        Stem damping ratio.

    Returns
    -------
    ndarray
        sqrt(1 + (2 zeta r)^2) / sqrt((1 - r^2)^2 + (2 zeta r)^2) (closed form of the base-excited
        single-degree-of-freedom oscillator; Thomson, Theory of Vibration with Applications, sec. 3.5).
        1 at r -> 0 (the rigid-stem eq. 16), about 1/(2 zeta) at r = 1, falling as ~ 2 zeta / r for r >> 1.
    """
    r = np.asarray(frequency_ratio, float)
    return np.sqrt(1 + (2 * zeta * r) ** 2) / np.sqrt((1 - r * r) ** 2 + (2 * zeta * r) ** 2)


def _uniform_step(t):
    t = np.asarray(t, float)
    if t.ndim != 1 or len(t) < 2:
        raise ConfigError("stem_response needs a 1-D time vector with at least two samples")
    dt = np.diff(t)
    h = float(np.mean(dt))
    if not h > 0 or np.max(np.abs(dt - h)) > 1e-6 * h:
        raise ConfigError("stem_response needs uniformly sampled times (resample the base motion first)")
    return h


def _frozen(x) -> tuple:
    """A hashable copy of a real array (shape and float64 bytes)."""
    if np.iscomplexobj(x):
        raise ValueError("discretise_foh: the state-space matrices must be real")
    x = np.ascontiguousarray(x, dtype=float)
    return x.shape, x.tobytes()


def _thawed(frozen) -> np.ndarray:
    """A fresh (writable) array from :func:`_frozen`."""
    shape, data = frozen
    return np.frombuffer(data, dtype=float).reshape(shape).copy()


@functools.lru_cache(maxsize=512)
def _foh_frozen(a, b, c, d, h: float) -> tuple:
    """:func:`discretise_foh` on frozen matrices (the remembered form)."""
    out = signal.cont2discrete(tuple(_thawed(x) for x in (a, b, c, d)), h, method="foh")[:4]
    return tuple(_frozen(x) for x in out)


def discretise_foh(a, b, c, d, h: float) -> tuple[np.ndarray, ...]:
    """(A_d, B_d, C_d, D_d): ``scipy.signal.cont2discrete((a, b, c, d), h, method="foh")``, remembered.

    The same oscillators (fruit masses, pedicel stiffness and damping, output step) are discretised again in every
    replicate run of a virtual test, each a matrix exponential (~1 ms); the memory returns the same numbers
    (fresh arrays) without recomputing them.

    Parameters
    ----------
    a, b, c, d : array_like
        Real continuous-time state-space matrices (the units of the system they describe).
    h : float
        Sampling step (s).

    Returns
    -------
    tuple of ndarray
        A_d, B_d, C_d, D_d of the first-order-hold discretisation (fresh, writable arrays; the units of
        the system they describe).

    Raises
    ------
    ValueError
        A matrix is complex.
    """
    return tuple(_thawed(x) for x in _foh_frozen(*(_frozen(x) for x in (a, b, c, d)), float(h)))


@functools.lru_cache(maxsize=512)
def _sos_frozen(a, b, c, d, h: float) -> tuple:
    """Second-order sections of the discretised system, frozen (:func:`_filter`'s remembered form)."""
    ad, bd, cd, dd = discretise_foh(*(_thawed(x) for x in (a, b, c, d)), h)
    z, p, g = signal.ss2zpk(ad, bd, cd, dd)
    return _frozen(signal.zpk2sos(z, p, g))


def _filter(a, b, c, d, h, u):
    """Exact (first-order-hold) discretisation of a SISO state-space system, run along the last axis
    of ``u`` from rest (second-order sections, scipy.signal.sosfilt; the sections are remembered per system and
    step, :func:`discretise_foh`)."""
    sos = _thawed(_sos_frozen(*(_frozen(x) for x in (a, b, c, d)), float(h)))
    return signal.sosfilt(sos, u, axis=-1)


def _one(t_step, m, k, c, y, v, acc, displacement=True):
    wn2, two_zw = k / m, c / m
    a = np.array([[0.0, 1.0], [-wn2, -two_zw]])
    if acc is not None:
        # relative coordinates, input y'': states (u, u'); u = x - y; F = -(k u + c u')
        b = np.array([[0.0], [-1.0]])
        u = _filter(a, b, np.array([[1.0, 0.0]]), np.zeros((1, 1)), t_step, acc) if displacement else None
        f = _filter(a, b, np.array([[-k, -c]]), np.zeros((1, 1)), t_step, acc)
        return u, f
    # absolute coordinates, inputs y and y': states (x, x'); F = k (y - x) + c (y' - x')
    out_u = np.zeros(np.broadcast(y, v).shape) if displacement else None
    out_f = np.zeros(np.broadcast(y, v).shape)
    for inp, col in ((y, 0), (v, 1)):
        b = np.zeros((2, 1))
        b[1, 0] = (k if col == 0 else c) / m
        # relative displacement u = x - y: feedthrough -1 on y
        if displacement:
            out_u = out_u + _filter(a, b, np.array([[1.0, 0.0]]), np.array([[-1.0 if col == 0 else 0.0]]), t_step,
                                    inp)
        out_f = out_f + _filter(a, b, np.array([[-k, -c]]), np.array([[k if col == 0 else c]]), t_step, inp)
    return out_u, out_f


def stem_response(t, base_displacement=None, base_velocity=None, base_acceleration=None, mass=1.8e-3,
                  stiffness=10.0, damping=0.027, displacement=True):
    """Relative displacement and stem force of fruit on compliant pedicels under a given branch motion.

    Parameters
    ----------
    t : ndarray (n_t,)
        Uniformly spaced times (s).  The fruit starts at rest relative to the branch at t[0].
    base_displacement, base_velocity : ndarray (..., n_t), optional
        Branch motion y (m), y' (m/s) at the fruit, one row per fruit.  Used when no acceleration is
        given (absolute-coordinate form, exact for piecewise-linear y and y').
    base_acceleration : ndarray (..., n_t), optional
        Branch acceleration y'' (m/s^2) at the fruit.  When given it drives the relative-coordinate form
        u'' + 2 zeta w_n u' + w_n^2 u = -y'' (exact for piecewise-linear y''), and the other two are
        not needed.
    mass : float or ndarray (n_rows,)
        Fruit mass m0 (kg).
    stiffness : float or ndarray (n_rows,)
        Pedicel stiffness k (N/m).
    damping : float or ndarray (n_rows,)
        Pedicel damping c (N s/m).
    displacement : bool
        Also compute the relative displacement (False: it is returned as None and costs nothing).

    Returns
    -------
    relative_displacement : ndarray, like the input, or None
        u = x - y (m), the pedicel's deflection.
    stem_force : ndarray, like the input
        F = k (y - x) + c (y' - x') = m0 x'' (N), the force the pedicel exerts on the fruit in this
        direction; F -> m0 y'' as k -> inf (study eq. 16).

    Notes
    -----
    Exact discretisation (scipy.signal.cont2discrete, first-order hold) run as second-order sections
    (scipy.signal.sosfilt), so many rows with the same (m0, k, c) are filtered in one call; rows with
    their own parameters are filtered row by row.  Linear small-deflection model (Cooke & Rand 1969,
    linearised); departures: no pendulum geometry (the stem's bending and swing are lumped in k), no
    rotary inertia of the berry.
    """
    h = _uniform_step(t)
    if base_acceleration is None and (base_displacement is None or base_velocity is None):
        raise ConfigError("stem_response needs base_acceleration, or both base_displacement and base_velocity")
    acc = None if base_acceleration is None else np.asarray(base_acceleration, float)
    y = None if acc is not None else np.asarray(base_displacement, float)
    v = None if acc is not None else np.asarray(base_velocity, float)
    m, k, c = _check(mass, stiffness, damping)
    if m.ndim == k.ndim == c.ndim == 0:
        return _one(h, float(m), float(k), float(c), y, v, acc, displacement)
    ref = acc if acc is not None else np.broadcast_to(y, np.broadcast(y, v).shape)
    ref2 = np.atleast_2d(ref)
    mb, kb, cb = np.broadcast_arrays(m, k, c)
    mb, kb, cb = (np.broadcast_to(np.atleast_1d(x), (ref2.shape[0],)) for x in (mb, kb, cb))
    us, fs = np.zeros(ref2.shape), np.zeros(ref2.shape)
    for i in range(ref2.shape[0]):
        ai = None if acc is None else np.atleast_2d(acc)[i]
        yi = None if acc is not None else np.atleast_2d(np.broadcast_to(y, ref.shape))[i]
        vi = None if acc is not None else np.atleast_2d(np.broadcast_to(v, ref.shape))[i]
        ui, fs[i] = _one(h, float(mb[i]), float(kb[i]), float(cb[i]), yi, vi, ai, displacement)
        if displacement:
            us[i] = ui
    return (us.reshape(ref.shape) if displacement else None), fs.reshape(ref.shape)


def peak_stem_force(t, lateral, axial, mass, stiffness=10.0, damping=0.027, weight=True):
    """Largest stem-force magnitude over time of fruit of several masses at several places on the branch.

    The model of :func:`stem_response` in absolute coordinates, in both directions (the branch's lateral motion
    and its axial foreshortening each drive the pedicel's oscillator), combined as in
    ``berryshaker.harvest.coupled.stem_forces``: |F| = hypot(F_lateral, F_axial + m0 g).  Only the maximum over
    time is kept, so a table of many positions x masses (the virtual harvest's envelope) costs one pass over the
    motion with no force series stored.

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
    :func:`stem_response`) and run as a state-space recursion from rest, x[i+1] = A_d x[i] + B_d u[i],
    F[i] = C_d x[i] + D_d u[i], compiled (numba); the same zero-state response as :func:`stem_response`'s
    second-order sections, equal to round-off (tested).
    """
    return peak_stem_loads(t, lateral, axial, mass, stiffness, damping, weight)[:, :, 0]


def peak_stem_loads(t, lateral, axial, mass, stiffness=10.0, damping=0.027, weight=True, strengths=()):
    """Peak stem-force magnitude and peak pull-shear load ratios of fruit on compliant pedicels.

    The stem force of :func:`peak_stem_force`, resolved by its mode of loading: the pedicel of a berry on an
    upright branch hangs along the branch axis, so the axial component F_ax + m0 g (tension > 0) pulls the fruit
    along its pedicel and the lateral component F_lat bends and shears it across.  A fruit of mean pull strength
    P and mean shear strength S is loaded to the ratio

        g(t) = sqrt( (max(F_ax + m0 g, 0) / P)^2 + (F_lat / S)^2 ),

    an elliptical pull-shear interaction (the quadratic failure criterion of combined loading; pull alone
    breaks at P, shear alone at S, as the two test modes of Kong et al. 2014 measure them; the interaction's
    form is [assumed]: no blueberry test under combined loading is known to us).  A fruit whose own strengths
    are s P and s S comes off when max_t g >= s (berryshaker.harvest.virtual).  Compression along the pedicel
    does not load the abscission zone in pull.

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

    Returns
    -------
    ndarray (n_z, n_mass, 1 + n_strengths)
        [..., 0]: max_t |F| (N); [..., 1 + s]: max_t g for strengths s (dimensionless).

    References
    ----------
    Kong, Y., et al. (2014).  Journal of Northeast Agricultural University 45(4): blueberry fruit detachment by
    pull along the pedicel and by shear across it (docs/harvest.md, "Bond").
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
    out = np.zeros((y.shape[0], len(m), 1 + len(st)))
    _peak_stem_force_kernel(ad, bd, cd, dd, y, v, ya, va, m * GRAVITY if weight else np.zeros(len(m)),
                            np.ascontiguousarray(1.0 / st[:, 0]), np.ascontiguousarray(1.0 / st[:, 1]), out)
    return out


def compile_peak_stem_force() -> None:
    """Compile (or load from numba's on-disk cache) the kernel of :func:`peak_stem_force`: one call on four
    samples of a branch at rest.  Lets an idle process compile it before the runs that need it."""
    rest = np.zeros((1, 4))
    peak_stem_loads(np.arange(4) * 1e-4, (rest, rest), (rest, rest), [1.8e-3], strengths=[(0.47, 0.23)])


@njit(cache=True)
def _peak_stem_force_kernel(ad, bd, cd, dd, y, v, ya, va, weight, inv_pull, inv_shear, out):
    """out[i, j, 0] = max over time of |(F_lat, F_ax + weight[j])| and out[i, j, 1 + s] = max over time of the
    pull-shear load ratio g_s of :func:`peak_stem_loads` for the discretised oscillators (mass j at position i;
    the maxima are taken on the squares).

    Time outermost, positions innermost: at each time the positions' inputs are gathered into contiguous rows and
    every (mass, position) oscillator advances one step, the positions side by side (the loop vectorises; each
    oscillator's arithmetic is that of its own recursion, so the numbers do not depend on the order)."""
    n_z, n_t = y.shape
    n_m = ad.shape[0]
    n_s = inv_pull.shape[0]
    x0, x1, w0, w1 = np.zeros((n_m, n_z)), np.zeros((n_m, n_z)), np.zeros((n_m, n_z)), np.zeros((n_m, n_z))
    best = np.zeros((n_m, n_z, 1 + n_s))
    u0r, u1r, s0r, s1r = np.empty(n_z), np.empty(n_z), np.empty(n_z), np.empty(n_z)
    for n in range(n_t):
        for i in range(n_z):
            u0r[i], u1r[i], s0r[i], s1r[i] = y[i, n], v[i, n], ya[i, n], va[i, n]
        for j in range(n_m):
            c0, c1, d0, d1 = cd[j, 0], cd[j, 1], dd[j, 0], dd[j, 1]
            a00, a01, a10, a11 = ad[j, 0, 0], ad[j, 0, 1], ad[j, 1, 0], ad[j, 1, 1]
            b00, b01, b10, b11 = bd[j, 0, 0], bd[j, 0, 1], bd[j, 1, 0], bd[j, 1, 1]
            wt = weight[j]
            for i in range(n_z):
                u0, u1, s0, s1 = u0r[i], u1r[i], s0r[i], s1r[i]
                p0, p1, q0, q1 = x0[j, i], x1[j, i], w0[j, i], w1[j, i]
                f_lat = c0 * p0 + c1 * p1 + d0 * u0 + d1 * u1
                f_ax = c0 * q0 + c1 * q1 + d0 * s0 + d1 * s1 + wt
                f2 = f_lat * f_lat + f_ax * f_ax
                b = best[j, i, 0]
                best[j, i, 0] = f2 if f2 > b else b
                pull = f_ax if f_ax > 0.0 else 0.0
                for s in range(n_s):
                    gp, gs = pull * inv_pull[s], f_lat * inv_shear[s]
                    g2 = gp * gp + gs * gs
                    b = best[j, i, 1 + s]
                    best[j, i, 1 + s] = g2 if g2 > b else b
                x0[j, i] = a00 * p0 + a01 * p1 + b00 * u0 + b01 * u1
                x1[j, i] = a10 * p0 + a11 * p1 + b10 * u0 + b11 * u1
                w0[j, i] = a00 * q0 + a01 * q1 + b00 * s0 + b01 * s1
                w1[j, i] = a10 * q0 + a11 * q1 + b10 * s0 + b11 * s1
    for j in range(n_m):
        for i in range(n_z):
            for s in range(1 + n_s):
                out[i, j, s] = math.sqrt(best[j, i, s])


def modal_mass_ratio(modes, z, mass):
    """Fruit mass over the effective mass of each branch mode at the fruit, mu_k = m0 phi_k(z)^2.

    Parameters
    ----------
    modes : berryshaker.plant.modes.Modes
        Mass-normalised modes (1/phi_k(z)^2 is the effective mass of mode k at z, kg).
    z : float
        Fruit position (m from the root).
    mass : float
        Fruit mass m0 (kg).

    Returns
    -------
    ndarray (n_modes,)
        mu_k (dimensionless).  One-way coupling (the fruit does not load the branch) shifts mode k by about mu_k / 2
        away from tuning and by about +- sqrt(mu_k) / 2 when the stem is tuned to it.
    """
    phi = modes.shape_at(np.atleast_1d(z))[:, 0]
    return float(mass) * phi**2


def two_way_stem_force_frf(modes, z_force, z_fruit, mass, stiffness, damping, frequencies_hz, modes_one_way=None):
    """Stem force per unit harmonic branch load, one-way and with the fruit coupled back (two-way).

    The branch's modal equations (mass-normalised, modal damping ratio xi of the branch) and the fruit's
    equations are solved together in the frequency domain for a unit force at z_force:

        (w_k^2 - w^2 + 2 i xi w_k w) q_k = phi_k(z_F) - sum_j phi_k(z_j) F_j,    y_j = sum_k phi_k(z_j) q_k,
        -w^2 m0 x_j = F_j = (k + i w c)(y_j - x_j)     (F_j: stem force on fruit j; -F_j acts on the branch)

    Parameters
    ----------
    modes : Modes
        Branch modes of the two-way solution (without fruit masses).
    z_force : float
        Load position (m).
    z_fruit : float or array_like
        Fruit positions (m); every fruit has the same m0, k, c.
    mass, stiffness, damping : float
        m0 (kg), k (N/m), c (N s/m).
    frequencies_hz : array_like
        Excitation frequencies (Hz).
    modes_one_way : Modes, optional
        Modes used for the one-way answer (e.g. :func:`fruit_loaded_modes`); default ``modes``.

    Returns
    -------
    one_way, two_way : ndarray (n_fruit, n_freq), complex
        Stem force (N per N of branch load) without and with the fruits' reaction on the branch.
    """
    m, k, c = (float(x) for x in _check(mass, stiffness, damping))
    zs = np.atleast_1d(np.asarray(z_fruit, float))
    mo = modes if modes_one_way is None else modes_one_way

    def receptances(md, w):
        hk = 1.0 / (md.omega**2 - w**2 + 2j * md.branch.damping_ratio * md.omega * w)
        pf = md.shape_at(np.atleast_1d(z_force))[:, 0]
        pm = md.shape_at(zs)  # (n_modes, n_fruit)
        return (pm * (pf * hk)[:, None]).sum(axis=0), (pm.T * hk) @ pm

    one, two = [], []
    for f in np.atleast_1d(np.asarray(frequencies_hz, float)):
        w = 2 * math.pi * f
        ks = k + 1j * w * c
        t_fruit = ks / (ks - w * w * m)  # x = t_fruit y;  F = -w^2 m x
        g1, _ = receptances(mo, w)
        one.append(-w * w * m * t_fruit * g1)
        g_f, g_mm = receptances(modes, w)
        y = np.linalg.solve(np.eye(len(zs)) - g_mm * (w * w * m * t_fruit), g_f)
        two.append(-w * w * m * t_fruit * y)
    return np.array(one).T, np.array(two).T


def fruit_loaded_modes(modes, z_fruit, masses):
    """Branch modes with fruit masses attached rigidly at z_fruit (Rayleigh-Ritz on the unloaded modes).

    M' = I + sum_j m_j phi(z_j) phi(z_j)^T in the unloaded modal coordinates, K = diag(omega^2);
    the generalised eigenproblem K v = omega'^2 M' v (scipy.linalg.eigh) gives the loaded frequencies
    and shapes psi = v^T phi, mass-normalised with respect to the branch plus the fruit.  The low-
    frequency limit of a fruit on its stem (it moves with the branch below the stem frequency): used
    so that the branch carries its fruit when the fruit is not light against the modes' effective
    mass at its position (:func:`modal_mass_ratio`).

    Parameters
    ----------
    modes : Modes
        Mass-normalised branch modes without fruit.
    z_fruit : float or array_like
        Fruit positions (m from the root).
    masses : float or array_like
        Fruit masses (kg), one per position or one for all.

    Returns
    -------
    Modes
        Same branch, the loaded frequencies and shapes (dense samples), method noted.
    """
    from dataclasses import replace

    from scipy import linalg

    zs = np.atleast_1d(np.asarray(z_fruit, float))
    ms = np.broadcast_to(np.asarray(masses, float), zs.shape)
    phi = modes.shape_at(zs)  # (n_modes, n_fruit)
    mm = np.eye(len(modes.omega)) + (phi * ms) @ phi.T
    vals, vecs = linalg.eigh(np.diag(modes.omega**2), mm)
    shapes = vecs.T @ modes.shapes
    sign = np.where(shapes[:, -1] < 0, -1.0, 1.0)
    return replace(modes, omega=np.sqrt(vals), shapes=shapes * sign[:, None],
                   method=modes.method + f" + {len(zs)} fruit masses attached (Rayleigh-Ritz)")


@dataclass(frozen=True)
class FruitBranchModes:
    """Undamped modes of a branch carrying fruit on compliant stems (two-way coupled), mass-normalised.

    ``modes`` holds the frequencies and the branch part of each combined mode (dense samples, so
    ``modes.shape_at(z)`` is the branch deflection per unit modal coordinate); ``fruit`` (n_modes,
    n_fruit) the fruit displacement per unit modal coordinate.

    Attributes
    ----------
    modes : Modes
        The combined modes' frequencies and their branch part (1/sqrt(kg), mass-normalised).
    fruit : ndarray (n_modes, n_fruit)
        Fruit displacement of each combined mode per unit modal coordinate (1/sqrt(kg)).
    z_fruit : ndarray (n_fruit,)
        Fruit positions (m from the root).
    mass : float
        Fruit mass m0 (kg).
    stiffness : float
        Pedicel stiffness k (N/m).
    damping : float
        Pedicel damping c (N s/m).
    damping_ratios : ndarray (n_modes,)
        Modal damping ratio of each combined mode, diag(V^T C V) / (2 omega), off-diagonal terms dropped
        (dimensionless).
    """

    modes: object  # berryshaker.plant.modes.Modes (branch part of the combined modes)
    fruit: np.ndarray
    z_fruit: np.ndarray
    mass: float
    stiffness: float
    damping: float
    damping_ratios: np.ndarray  # per combined mode: diag(V^T C V) / (2 omega) (off-diagonal terms dropped)

    def stem_force(self, eta, etad):
        """Lateral stem force on each fruit (N), (n_fruit, n_t): k (y - x) + c (y' - x') from the modal
        displacements ``eta`` and velocities ``etad`` (n_t, n_modes).

        Parameters
        ----------
        eta : ndarray (n_t, n_modes)
            Modal coordinates of the combined modes (sqrt(kg) m).
        etad : ndarray (n_t, n_modes)
            Their rates (sqrt(kg) m/s).

        Returns
        -------
        ndarray (n_fruit, n_t)
            Stem force on each fruit (N): the force the pedicel exerts on the fruit.
        """
        rel = self.modes.shape_at(self.z_fruit) - self.fruit  # (n_modes, n_fruit): y - x per unit eta
        return (self.stiffness * (eta @ rel) + self.damping * (etad @ rel)).T


def fruit_branch_modes(modes, z_fruit, mass, stiffness, damping=0.0) -> FruitBranchModes:
    """Modes of the branch with fruit on stems attached (Rayleigh-Ritz on the branch's own modes).

    Coordinates: the branch's mass-normalised modal coordinates q (n) and the fruit displacements x_j.
    With phi_j = phi(z_j) (n-vector)::

        M = diag(I_n, m0 I),
        K = [[diag(omega^2) + k sum_j phi_j phi_j^T,  -k phi_j],
             [-k phi_j^T,                              k     ]],

    scipy.linalg.eigh(K, M) gives n + n_fruit modes normalised to V^T M V = I, so the combined system
    drops into the engine's modal body unchanged: each mode's force from a contact at z_c is
    phi(z_c)^T V_q F.  Exact two-way coupling of the linear fruit-stem-branch system (the fruit's
    reaction loads the branch).  Damping: the physical damping matrix C (the branch's modal damping
    2 xi omega_k on q, the stem dampers c between fruit and branch) is not diagonalised by V; the
    combined modes get zeta_r = (V^T C V)_rr / (2 omega_r), the off-diagonal terms dropped (light
    damping; on the reference branch this keeps the stem-force frequency-response peaks within 3 %
    of the exact two-way answer, a single ratio for all modes misses them by up to 44 %).

    Parameters
    ----------
    modes : Modes
        Branch modes without fruit.
    z_fruit : array_like
        Fruit positions (m).
    mass, stiffness : float
        m0 (kg), k (N/m), same for every fruit.
    damping : float
        Stem c (N s/m), used for the stem force.

    Returns
    -------
    FruitBranchModes
        The n + n_fruit combined modes (branch part, fruit part, modal damping ratios) and the fruit's
        parameters.

    Raises
    ------
    ConfigError
        The mass or stiffness is not > 0, or the damping is negative.
    """
    from dataclasses import replace

    from scipy import linalg

    m, k, c = (float(x) for x in _check(mass, stiffness, damping))
    zs = np.atleast_1d(np.asarray(z_fruit, float))
    n, nf = len(modes.omega), len(zs)
    phi = modes.shape_at(zs)  # (n, nf)
    kk = np.zeros((n + nf, n + nf))
    kk[:n, :n] = np.diag(modes.omega**2) + k * phi @ phi.T
    kk[:n, n:] = -k * phi
    kk[n:, :n] = -k * phi.T
    kk[n:, n:] = k * np.eye(nf)
    mm = np.diag(np.concatenate([np.ones(n), np.full(nf, m)]))
    vals, vecs = linalg.eigh(kk, mm)
    cc = np.zeros_like(kk)
    cc[:n, :n] = np.diag(2 * modes.branch.damping_ratio * modes.omega) + c * phi @ phi.T
    cc[:n, n:] = -c * phi
    cc[n:, :n] = -c * phi.T
    cc[n:, n:] = c * np.eye(nf)
    zeta = np.einsum("ir,ij,jr->r", vecs, cc, vecs) / (2 * np.sqrt(vals))
    shapes = vecs[:n].T @ modes.shapes
    sign = np.where(np.abs(shapes[:, -1]) > 0, np.sign(shapes[:, -1]), 1.0)
    loaded = replace(modes, omega=np.sqrt(vals), shapes=shapes * sign[:, None],
                     method=modes.method + f" + {nf} fruit on stems (two-way, Rayleigh-Ritz)")
    return FruitBranchModes(loaded, (vecs[n:] * sign).T, zs, m, k, c, zeta)
