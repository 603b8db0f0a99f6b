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
doi:10.4025/actascitechnol.v38i1.27344).  The reference machine's stiffness is calibrated (82.3 N/m,
34 Hz; docs/plant.md), the damping ratio 0.10 is taken from the coffee system [assumed]; the
function defaults below are those values.

One-way coupling.  The fruit does not load the branch's modes in this model.  The error of that is
governed by the modal mass ratio mu_k = m0 phi_k(z_m)^2 (phi mass-normalised; 1/phi_k^2 is the
effective mass of mode k at z_m): a rigidly attached mass lowers mode k by about mu_k/2 (Rayleigh
quotient), and a stem oscillator tuned to mode k splits it by about +-sqrt(mu_k)/2 (Den Hartog,
Mechanical Vibrations, tuned absorber).  :func:`modal_mass_ratio` returns mu_k; the test compares the
one-way stem force with the two-way coupled frequency response.
"""

from __future__ import annotations

import math

import numpy as np
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
    """Undamped natural frequency of the fruit on its stem, w_n/2pi = sqrt(k/m0)/2pi (Hz)."""
    m, k, _ = _check(mass, stiffness, 0.0)
    return np.sqrt(k / m) / (2 * math.pi)


def damping_ratio(mass, stiffness, damping):
    """Damping ratio of the fruit on its stem, zeta = c / (2 sqrt(k m0)) (dimensionless)."""
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


def _filter(a, b, c, d, h, u):
    """Exact (first-order-hold) discretisation of a SISO state-space system, run along the last axis
    of ``u`` from rest (second-order sections, scipy.signal.sosfilt)."""
    ad, bd, cd, dd, _ = signal.cont2discrete((a, b, c, d), h, method="foh")
    z, p, g = signal.ss2zpk(ad, bd, cd, dd)
    sos = signal.zpk2sos(z, p, g)
    return signal.sosfilt(sos, u, axis=-1)


def _one(t_step, m, k, c, y, v, acc):
    wn2, two_zw = k / m, c / m
    a = np.array([[0.0, 1.0], [-wn2, -two_zw]])
    if acc is not None:
        # relative coordinates, input y'': states (u, u'); u = x - y; F = -(k u + c u')
        b = np.array([[0.0], [-1.0]])
        u = _filter(a, b, np.array([[1.0, 0.0]]), np.zeros((1, 1)), t_step, acc)
        f = _filter(a, b, np.array([[-k, -c]]), np.zeros((1, 1)), t_step, acc)
        return u, f
    # absolute coordinates, inputs y and y': states (x, x'); F = k (y - x) + c (y' - x')
    out_u = np.zeros(np.broadcast(y, v).shape)
    out_f = np.zeros_like(out_u)
    for inp, col in ((y, 0), (v, 1)):
        b = np.zeros((2, 1))
        b[1, 0] = (k if col == 0 else c) / m
        # relative displacement u = x - y: feedthrough -1 on y
        out_u = out_u + _filter(a, b, np.array([[1.0, 0.0]]), np.array([[-1.0 if col == 0 else 0.0]]), t_step, inp)
        out_f = out_f + _filter(a, b, np.array([[-k, -c]]), np.array([[k if col == 0 else c]]), t_step, inp)
    return out_u, out_f


def stem_response(t, base_displacement=None, base_velocity=None, base_acceleration=None, mass=1.8e-3,
                  stiffness=82.3, damping=0.077):
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

    Returns
    -------
    relative_displacement : ndarray, like the input
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
        return _one(h, float(m), float(k), float(c), y, v, acc)
    ref = acc if acc is not None else np.broadcast_to(y, np.broadcast(y, v).shape)
    ref2 = np.atleast_2d(ref)
    mb, kb, cb = np.broadcast_arrays(m, k, c)
    mb, kb, cb = (np.broadcast_to(np.atleast_1d(x), (ref2.shape[0],)) for x in (mb, kb, cb))
    us, fs = np.zeros(ref2.shape), np.zeros(ref2.shape)
    for i in range(ref2.shape[0]):
        ai = None if acc is None else np.atleast_2d(acc)[i]
        yi = None if acc is not None else np.atleast_2d(np.broadcast_to(y, ref.shape))[i]
        vi = None if acc is not None else np.atleast_2d(np.broadcast_to(v, ref.shape))[i]
        us[i], fs[i] = _one(h, float(mb[i]), float(kb[i]), float(cb[i]), yi, vi, ai)
    return us.reshape(ref.shape), fs.reshape(ref.shape)


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
        mu_k.  One-way coupling (the fruit does not load the branch) shifts mode k by about mu_k / 2
        away from tuning and by about +- sqrt(mu_k) / 2 when the stem is tuned to it.
    """
    phi = modes.shape_at(np.atleast_1d(z))[:, 0]
    return float(mass) * phi**2


def two_way_stem_force_frf(modes, z_force, z_fruit, mass, stiffness, damping, frequencies_hz):
    """Stem force per unit harmonic branch load, with the fruit coupled back to the branch (two-way).

    The branch's modal equations (mass-normalised, modal damping of the branch) and the fruit's
    equation are solved together in the frequency domain for a unit force at z_force:

        (w_k^2 - w^2 + 2 i xi w_k w) q_k = phi_k(z_F) - phi_k(z_m) F_s,     y = sum_k phi_k(z_m) q_k,
        -w^2 m0 x = F_s = (k + i w c)(y - x)     (F_s: stem force on the fruit; -F_s acts on the branch)

    Parameters
    ----------
    modes : Modes
    z_force, z_fruit : float
        Load and fruit positions (m).
    mass, stiffness, damping : float
        m0 (kg), k (N/m), c (N s/m).
    frequencies_hz : array_like
        Excitation frequencies (Hz).

    Returns
    -------
    one_way, two_way : ndarray (complex)
        Stem force amplitude (N per N of branch load) without and with the fruit's reaction on the branch.
    """
    m, k, c = (float(x) for x in _check(mass, stiffness, damping))
    xi = modes.branch.damping_ratio
    pf = modes.shape_at(np.atleast_1d(z_force))[:, 0]
    pm = modes.shape_at(np.atleast_1d(z_fruit))[:, 0]
    wk = modes.omega
    one, two = [], []
    for f in np.atleast_1d(np.asarray(frequencies_hz, float)):
        w = 2 * math.pi * f
        hk = 1.0 / (wk**2 - w**2 + 2j * xi * wk * w)  # modal receptance
        g_mf = np.sum(pm * pf * hk)  # branch receptance fruit <- force point
        g_mm = np.sum(pm * pm * hk)  # branch receptance at the fruit
        ks = k + 1j * w * c
        # fruit: -w^2 m x = ks (y - x)  ->  x = ks y / (ks - w^2 m); stem force on fruit Fs = -w^2 m x
        t_fruit = ks / (ks - w * w * m)
        y1 = g_mf  # one-way: branch unaffected
        one.append(-w * w * m * t_fruit * y1)
        # two-way: the stem pulls the branch with -Fs:  y = g_mf * 1 + g_mm * (-Fs),  Fs = -w^2 m t_fruit y
        y2 = g_mf / (1 - g_mm * w * w * m * t_fruit)
        two.append(-w * w * m * t_fruit * y2)
    return np.array(one), np.array(two)
