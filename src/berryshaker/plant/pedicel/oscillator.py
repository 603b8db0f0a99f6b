"""The fruit-stem oscillator: the fruit as a mass m0 on a compliant pedicel, base-excited by the branch at z_m.

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

This module holds the oscillator's parameters and closed forms (natural frequency, damping ratio, force
transmissibility) and its time-domain response to a given branch motion (:func:`stem_response`, an exact
first-order-hold discretisation, :func:`discretise_foh`).
"""

from __future__ import annotations

import functools
import math

import numpy as np

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
    from scipy import signal  # here, not at the top: importing scipy.signal takes ~1 s a warm study never needs
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
    from scipy import signal  # here, not at the top: importing scipy.signal takes ~1 s a warm study never needs
    z, p, g = signal.ss2zpk(ad, bd, cd, dd)
    return _frozen(signal.zpk2sos(z, p, g))


def _filter(a, b, c, d, h, u):
    """Exact (first-order-hold) discretisation of a SISO state-space system, run along the last axis
    of ``u`` from rest (second-order sections, scipy.signal.sosfilt; the sections are remembered per system and
    step, :func:`discretise_foh`)."""
    sos = _thawed(_sos_frozen(*(_frozen(x) for x in (a, b, c, d)), float(h)))
    from scipy import signal  # here, not at the top: importing scipy.signal takes ~1 s a warm study never needs
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
