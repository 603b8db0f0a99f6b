"""The ideal (clearance-free) harvester drive over a cam cycle: cam + push rod + double rocker.

:func:`geometry_vector` packs a :class:`~berryshaker.config.Machine` into a flat float array that the
compiled kernels read; :func:`ideal_state` evaluates the whole mechanism at one cam angle inside
compiled code; :func:`cycle_kinematics` evaluates it on a grid (numpy arrays); :func:`check_machine`
refuses a machine whose linkage cannot assemble, whose cam undercuts or whose push rod self-locks in its guide
(:func:`self_locking_limit`), naming the cam angle.

long module: the groove cam's check, kinematics summary and mid-stroke angles read the same cam-follower
geometry.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from berryshaker.drives.groove_cam.machine import GrooveCamMachine as Machine
from berryshaker.errors import ConfigError, GeometryError
from berryshaker.kinematics.cam import (
    FOLLOWER_LAWS,
    follower_svaj_scalar,
    groove_profile,
    pitch_curve,
    pitch_curve_curvature,
    pressure_angle,
)
from berryshaker.kinematics.linkage import four_bar_scalar, left_comb_scalar, transmission_angle

# indices into the geometry vector
G_LAW, G_H, G_RISE, G_FAR, G_RET, G_S0, G_E, G_LAB, G_XD, G_YD, G_XE, G_YE = range(12)
G_LCD, G_GAMMA, G_LCF, G_LFE, G_BRANCH, G_OMEGA = range(12, 18)
N_GEOMETRY = 18


def geometry_vector(machine: Machine) -> np.ndarray:
    """Flat SI parameter vector of the ideal mechanism for the compiled kernels.

    Parameters
    ----------
    machine : GrooveCamMachine
        The machine description.

    Returns
    -------
    ndarray
        The parameters at the ``G_*`` indices, SI (m, rad, rad/s; the law and the assembly branch as codes).
    """
    c = machine.cam
    d, e = machine.shaft_D, machine.shaft_E
    g = np.zeros(N_GEOMETRY)
    g[G_LAW] = FOLLOWER_LAWS[c.law]
    g[G_H], g[G_RISE], g[G_FAR], g[G_RET] = c.stroke, c.rise_angle, c.far_dwell_angle, c.return_angle
    g[G_S0], g[G_E], g[G_LAB] = c.s0, c.offset, machine.push_rod.length
    g[G_XD], g[G_YD], g[G_XE], g[G_YE] = d[0], d[1], e[0], e[1]
    g[G_LCD], g[G_GAMMA] = machine.rocker.arm_CD, machine.rocker.arm_angle
    g[G_LCF], g[G_LFE], g[G_BRANCH] = machine.four_bar.coupler_CF, machine.four_bar.arm_FE, machine.four_bar.branch
    g[G_OMEGA] = c.speed
    return g


@njit(cache=True)
def ideal_state(phi, g):
    """Ideal mechanism at cam angle phi (constant cam speed g[G_OMEGA]).

    Parameters
    ----------
    phi : float
        Cam angle (rad).
    g : ndarray
        The geometry vector (:func:`geometry_vector`, SI).

    Returns
    -------
    tuple
        (ok, s, v, a, th_D, w_D, a_D, th_4, w_4, a_4, th_E, w_E, a_E): push-rod displacement (m), velocity
        (m/s), acceleration (m/s^2); left comb, coupler and right comb angles (rad), rates (rad/s) and
        accelerations (rad/s^2).  ok is False where the four-bar cannot assemble.
    """
    w = g[G_OMEGA]
    s, s1, s2, s3 = follower_svaj_scalar(phi, int(g[G_LAW]), g[G_H], g[G_RISE], g[G_FAR], g[G_RET])
    v = s1 * w
    a = s2 * w * w
    xb = g[G_S0] + s + g[G_LAB]
    yb = g[G_E]
    th_d, w_d, a_d = left_comb_scalar(xb, yb, g[G_XD], g[G_YD], v, a)
    ok, th4, w4, a4, th_e, we, ae, xf, yf = four_bar_scalar(
        th_d + g[G_GAMMA], w_d, a_d, g[G_XD], g[G_YD], g[G_XE], g[G_YE], g[G_LCD], g[G_LCF], g[G_LFE],
        g[G_BRANCH])
    return ok, s, v, a, th_d, w_d, a_d, th4, w4, a4, th_e, we, ae


@njit(cache=True)
def _cycle_kernel(phi, g, out):
    for i in range(phi.shape[0]):
        ok, s, v, a, th_d, w_d, a_d, th4, w4, a4, th_e, we, ae = ideal_state(phi[i], g)
        out[0, i] = 1.0 if ok else 0.0
        out[1, i] = s
        out[2, i] = v
        out[3, i] = a
        out[4, i] = th_d
        out[5, i] = w_d
        out[6, i] = a_d
        out[7, i] = th4
        out[8, i] = w4
        out[9, i] = a4
        out[10, i] = th_e
        out[11, i] = we
        out[12, i] = ae


@dataclass(frozen=True)
class CycleKinematics:
    """Ideal kinematics of the drive sampled over cam angle (all SI).

    Attributes
    ----------
    phi : ndarray
        Cam angle (rad).
    t : ndarray
        Time at constant cam speed (s).
    s : ndarray
        Push-rod displacement (m).
    ds, d2s, d3s : ndarray
        Its derivatives with respect to the cam angle (m/rad, m/rad^2, m/rad^3).
    v, a, j : ndarray
        Push-rod velocity (m/s), acceleration (m/s^2) and jerk (m/s^3).
    theta_d, omega_d, alpha_d : ndarray
        Left comb (rocker about D) angle (rad), rate (rad/s) and acceleration (rad/s^2).
    theta_4, omega_4, alpha_4 : ndarray
        Coupler CF angle (rad), rate (rad/s) and acceleration (rad/s^2).
    theta_e, omega_e, alpha_e : ndarray
        Right comb (arm about E) angle (rad), rate (rad/s) and acceleration (rad/s^2).
    assembled : ndarray of bool
        Whether the four-bar assembles at each angle.
    pressure_angle : ndarray
        Cam pressure angle (rad).
    curvature : ndarray
        Pitch-curve curvature (1/m).
    transmission_angle : ndarray
        Four-bar transmission angle (rad).
    """

    phi: np.ndarray  # cam angle (rad)
    t: np.ndarray  # time (s) at constant cam speed
    s: np.ndarray  # push-rod displacement (m)
    ds: np.ndarray  # ds/dphi (m/rad)
    d2s: np.ndarray  # d2s/dphi2 (m/rad^2)
    d3s: np.ndarray  # d3s/dphi3 (m/rad^3)
    v: np.ndarray  # push-rod velocity (m/s)
    a: np.ndarray  # acceleration (m/s^2)
    j: np.ndarray  # jerk (m/s^3)
    theta_d: np.ndarray
    omega_d: np.ndarray
    alpha_d: np.ndarray
    theta_4: np.ndarray
    omega_4: np.ndarray
    alpha_4: np.ndarray
    theta_e: np.ndarray
    omega_e: np.ndarray
    alpha_e: np.ndarray
    assembled: np.ndarray  # bool
    pressure_angle: np.ndarray  # rad
    curvature: np.ndarray  # pitch-curve curvature (1/m)
    transmission_angle: np.ndarray  # rad


def cycle_kinematics(machine: Machine, n: int = 3601) -> CycleKinematics:
    """Ideal kinematics of the machine over one cam revolution on ``n`` equally spaced angles.

    Parameters
    ----------
    machine : GrooveCamMachine
        The machine description.
    n : int
        Number of samples over [0, 2 pi] (both ends included).

    Returns
    -------
    CycleKinematics
        The sampled kinematics (SI).
    """
    from berryshaker.kinematics.cam import follower_svaj

    g = geometry_vector(machine)
    c = machine.cam
    phi = np.linspace(0.0, 2 * math.pi, n)
    svaj = follower_svaj(phi, c.stroke, c.rise_angle, c.far_dwell_angle, c.return_angle, c.law)
    out = np.empty((13, n))
    _cycle_kernel(phi, g, out)
    w = c.speed
    return CycleKinematics(
        phi=phi, t=phi / w, s=svaj[0], ds=svaj[1], d2s=svaj[2], d3s=svaj[3],
        v=svaj[1] * w, a=svaj[2] * w**2, j=svaj[3] * w**3,
        theta_d=out[4], omega_d=out[5], alpha_d=out[6],
        theta_4=out[7], omega_4=out[8], alpha_4=out[9],
        theta_e=out[10], omega_e=out[11], alpha_e=out[12],
        assembled=out[0] > 0.5,
        pressure_angle=pressure_angle(svaj[0], svaj[1], c.s0, c.offset),
        curvature=pitch_curve_curvature(svaj[0], svaj[1], svaj[2], c.s0, c.offset),
        transmission_angle=transmission_angle(out[7], out[10]),
    )


def cam_groove(machine: Machine, n: int = 721):
    """Pitch curve and groove walls of the machine's cam in the cam frame (m), closed (last = first).

    Parameters
    ----------
    machine : GrooveCamMachine
        The machine description.
    n : int
        Number of cam angles over one revolution.

    Returns
    -------
    phi : ndarray (n,)
        Cam angles (rad).
    pitch, inner, outer : ndarray (2, n)
        x, y of the pitch curve and the inner and outer groove walls (m).
    """
    from berryshaker.kinematics.cam import follower_svaj

    c = machine.cam
    phi = np.linspace(0.0, 2 * math.pi, n)
    svaj = follower_svaj(phi, c.stroke, c.rise_angle, c.far_dwell_angle, c.return_angle, c.law)
    x, y, _, _ = pitch_curve(phi, svaj[0], svaj[1], c.s0, c.offset)
    inner, outer = groove_profile(phi, svaj[0], svaj[1], c.s0, c.offset, c.roller_radius)
    return phi, np.vstack([x, y]), inner, outer


def groove_profile_at(machine: Machine, phi):
    """The follower's motion at cam angles ``phi`` and the cam's s0 and offset, what
    :func:`berryshaker.kinematics.cam.groove_profile` takes to draw walls at any distance from the pitch curve.

    Parameters
    ----------
    machine : GrooveCamMachine
        The machine description.
    phi : numpy.ndarray
        Cam angles (rad).

    Returns
    -------
    (numpy.ndarray, float, float)
        SVAJ rows (m, m/rad, ...), s0 (m) and the offset e (m).
    """
    from berryshaker.kinematics.cam import follower_svaj

    c = machine.cam
    return follower_svaj(phi, c.stroke, c.rise_angle, c.far_dwell_angle, c.return_angle, c.law), c.s0, c.offset


def mid_stroke_angles(machine: Machine) -> tuple[float, float]:
    """Left and right comb angles (rad) with the push rod at mid-stroke: the swing reference.

    Parameters
    ----------
    machine : GrooveCamMachine
        The machine description.

    Returns
    -------
    (float, float)
        theta_D and theta_E (rad).
    """
    g = geometry_vector(machine)
    xb = g[G_S0] + machine.cam.stroke / 2 + g[G_LAB]
    th_d = math.atan2(g[G_E] - g[G_YD], xb - g[G_XD])
    ok, th4, *_rest = four_bar_scalar(th_d + g[G_GAMMA], 0.0, 0.0, g[G_XD], g[G_YD], g[G_XE], g[G_YE],
                                      g[G_LCD], g[G_LCF], g[G_LFE], g[G_BRANCH])
    th_e = _rest[2]
    if not ok:
        raise GeometryError("the four-bar D-C-F-E cannot assemble with the push rod at mid-stroke")
    return th_d, th_e


def check_machine(machine: Machine, allow_undercut: bool = False) -> CycleKinematics:
    """Check that the machine can be built and run; return its cycle kinematics.

    Parameters
    ----------
    machine : GrooveCamMachine
        The machine description.
    allow_undercut : bool
        Report an undercutting groove instead of refusing it.

    Returns
    -------
    CycleKinematics
        The kinematics over one revolution.

    Raises
    ------
    GeometryError
        The four-bar cannot assemble at some cam angle; the slot would have to pass through D; or the
        groove undercuts (|rho_pitch| <= r_r) and ``allow_undercut`` is False.  The message names the
        first cam angle where it fails.
    ConfigError
        The push rod self-locks in its guide (:func:`check_self_locking`).
    """
    kin = cycle_kinematics(machine)
    if not np.all(kin.assembled):
        i = int(np.argmin(kin.assembled))
        raise GeometryError(
            f"the four-bar D-C-F-E cannot assemble at cam angle {math.degrees(kin.phi[i]):.1f} deg "
            f"(check four_bar.ground_DE, coupler_CF, arm_FE and rocker.arm_CD)")
    sin_tm = np.abs(np.sin(kin.theta_4 - kin.theta_e))
    if np.min(sin_tm) < 1e-3:
        i = int(np.argmin(sin_tm))
        raise GeometryError(
            f"the four-bar reaches a toggle (coupler and right arm aligned) at cam angle "
            f"{math.degrees(kin.phi[i]):.1f} deg; the right comb cannot be driven through it")
    rho_min = 1.0 / np.max(np.abs(kin.curvature))
    if not allow_undercut and rho_min <= machine.cam.roller_radius:
        i = int(np.argmax(np.abs(kin.curvature)))
        raise GeometryError(
            f"the cam groove undercuts at cam angle {math.degrees(kin.phi[i]):.1f} deg: pitch-curve "
            f"radius of curvature {rho_min * 1e3:.2f} mm <= roller radius "
            f"{machine.cam.roller_radius * 1e3:.2f} mm (use a smaller roller, a larger base circle or "
            f"longer rise/return angles)")
    check_self_locking(machine)
    return kin


@dataclass(frozen=True)
class SelfLocking:
    """The self-locking limit of the push rod in its guide (:func:`self_locking_limit`; SI).

    Attributes
    ----------
    mu_limit : float
        Guide friction coefficient (dimensionless) at which the cam can no longer drive the push rod (inf:
        never).
    cam_angle : float
        Cam angle where the limit is lowest (rad).
    pressure_angle : float
        The pressure angle there (rad).
    overhang : float
        Roller A's distance outside the guide there (m; 0: between the bearings).
    guide_length : float
        |x_H - x_G| (m).
    """

    mu_limit: float  # guide friction coefficient at which the cam can no longer drive the push rod (inf: never)
    cam_angle: float  # rad, where the limit is lowest
    pressure_angle: float  # rad, there
    overhang: float  # m, roller A's distance outside the guide there (0: between the bearings)
    guide_length: float  # m, |x_H - x_G|


def self_locking_limit(machine: Machine, n: int = 3601) -> SelfLocking:
    """The guide friction coefficient at which the push rod self-locks (jams) in its linear bearing.

    The cam drives roller A (frame x_A = s0 + s) with a force F along the groove normal, at the pressure angle
    alpha to the push-rod axis (:func:`berryshaker.kinematics.cam.pressure_angle`).  Its axial component
    F cos(alpha) drives the rod; its lateral component F sin(alpha), applied at x_A, is carried by the guide's
    bearings G and H (frame x_G, x_H; guide length L = |x_H - x_G|).  Moments about H and about G give the
    bearing reactions (study eq. 10 with the cam's force alone)::

        R_G = F sin(alpha) (x_A - x_H) / (x_G - x_H),   R_H = F sin(alpha) (x_G - x_A) / (x_G - x_H)

    and Coulomb friction in both bearings resists the motion with mu (|R_G| + |R_H|) =
    mu F |sin(alpha)| k, k = (|x_A - x_G| + |x_A - x_H|) / L (k = 1 with A between the bearings, (L + 2a) / L
    with A an overhang a outside them).  The cam moves the rod only while its axial component exceeds that
    friction, F cos(alpha) > mu k F |sin(alpha)|; since both sides grow with F, no cam force can move the rod
    (it self-locks) once::

        mu >= mu_lim(phi) = L / ((|x_A - x_G| + |x_A - x_H|) |tan(alpha)|)

    This is the classical jamming condition of a translating follower in a guide of length L with overhang a,
    tan(alpha) >= L / (mu (L + 2 a)) (Rothbart, Cam Design Handbook, McGraw-Hill 2004, forces and jamming of
    translating followers; Norton, Design of Machinery, the pressure angle of a translating roller follower),
    written for a contact point on either side of the guide.  The comb's load on roller B (the rocker slot) adds
    friction in proportion to the load, not to the cam force, so it does not move the limit; the rod's inertia
    neither.  The limit of the machine is the lowest over the cam angles at which the push rod moves
    (|ds/dphi| > 0; in a dwell nothing needs to move), the same friction law as the MLSD model's guide
    (:mod:`berryshaker.drives.groove_cam.mlsd`, ``coulomb_friction_kernel`` on |R_G| + |R_H|) and the multibody
    model's prismatic guide with supports G, H.

    Parameters
    ----------
    machine : GrooveCamMachine
        The machine description.
    n : int
        Cam angles over one revolution.

    Returns
    -------
    SelfLocking
        ``mu_limit`` (inf when the pressure angle is zero wherever the rod moves) and where it is reached.
    """
    from berryshaker.kinematics.cam import follower_svaj, pressure_angle

    c = machine.cam
    phi = np.linspace(0.0, 2 * math.pi, n)
    svaj = follower_svaj(phi, c.stroke, c.rise_angle, c.far_dwell_angle, c.return_angle, c.law)
    s, ds = svaj[0], svaj[1]
    alpha = pressure_angle(s, ds, c.s0, c.offset)
    xg, xh = machine.push_rod.bearing_G_x, machine.push_rod.bearing_H_x
    guide = abs(xh - xg)
    xa = c.s0 + s
    k = (np.abs(xa - xg) + np.abs(xa - xh)) / guide
    tan_a = np.abs(np.tan(alpha))
    moving = np.abs(ds) > 1e-9 * max(float(np.max(np.abs(ds))), 1e-300)
    with np.errstate(divide="ignore"):
        lim = np.where(moving & (tan_a > 0.0), 1.0 / (k * tan_a), np.inf)
    i = int(np.argmin(lim))
    over = max(0.0, min(xg, xh) - xa[i], xa[i] - max(xg, xh))
    return SelfLocking(mu_limit=float(lim[i]), cam_angle=float(phi[i]), pressure_angle=float(alpha[i]),
                       overhang=float(over), guide_length=float(guide))


def check_self_locking(machine: Machine) -> SelfLocking:
    """Refuse a push rod that self-locks in its guide (:func:`self_locking_limit`).

    Raises
    ------
    ConfigError
        ``push_rod.friction_coefficient`` is at or above the limit of this geometry; the message names the
        limit, where it is reached and what to change.

    Parameters
    ----------
    machine : GrooveCamMachine
        The machine description.

    Returns
    -------
    SelfLocking
        The limit, when the push rod does not self-lock.
    """
    lock = self_locking_limit(machine)
    mu = machine.push_rod.friction_coefficient
    if mu >= lock.mu_limit:
        where = (f"roller A {lock.overhang * 1e3:.0f} mm outside the guide" if lock.overhang > 0
                 else "roller A between the bearings")
        raise ConfigError(
            f"push_rod.friction_coefficient = {mu:g} self-locks the push rod in its guide: the limit of this "
            f"geometry is {lock.mu_limit:.3g} (pressure angle {math.degrees(lock.pressure_angle):.1f} deg at cam "
            f"angle {math.degrees(lock.cam_angle):.1f} deg, guide G-H {lock.guide_length * 1e3:.0f} mm, {where}); "
            "above it no cam force can move the rod.  Lower the friction coefficient below the limit, lengthen the "
            "guide (push_rod.bearing_G_x, bearing_H_x) or reduce the pressure angle (a larger cam base circle, a "
            "longer rise or return angle, a smaller offset)")
    return lock


#: geometries (:func:`geometry_vector`, roller radius, undercut flag, guide) that passed :func:`check_machine`, for
#: :func:`require_buildable`; cleared when it reaches :data:`BUILDABLE_CACHE_SIZE`
_BUILDABLE: set = set()
BUILDABLE_CACHE_SIZE = 1024


def require_buildable(machine: Machine, allow_undercut: bool = False) -> None:
    """:func:`check_machine` for its errors only, remembered per geometry.

    The check depends on the geometry vector (every length, angle and cam parameter the cycle kinematics read),
    the roller radius and the push rod's guide (friction, bearings: :func:`check_self_locking`) alone; a geometry that passed once is not checked again.  The mechanism and the MLSD
    model of every run call this: a clearance sweep builds thousands of runs of one geometry, and the check
    (3601 cam angles, ~1 ms) was ~1 % of a multibody run.

    Parameters
    ----------
    machine : GrooveCamMachine
        The machine description.
    allow_undercut : bool
        Accept an undercutting groove.

    Raises
    ------
    GeometryError
        As :func:`check_machine`, every time for a geometry that fails.
    """
    rod = machine.push_rod
    key = (geometry_vector(machine).tobytes(), float(machine.cam.roller_radius), bool(allow_undercut),
           float(rod.friction_coefficient), float(rod.bearing_G_x), float(rod.bearing_H_x))
    if key in _BUILDABLE:
        return
    check_machine(machine, allow_undercut=allow_undercut)
    if len(_BUILDABLE) >= BUILDABLE_CACHE_SIZE:
        _BUILDABLE.clear()
    _BUILDABLE.add(key)


def kinematics_summary(machine: Machine, kin: CycleKinematics) -> dict:
    """Engineering summary of the ideal drive (the JSON of ``berryshaker kinematics``).

    Parameters
    ----------
    machine : GrooveCamMachine
        The machine description.
    kin : CycleKinematics
        Its kinematics (:func:`check_machine`).

    Returns
    -------
    dict
        ``cam``, ``combs``, ``linkage`` and ``drive`` sections; units in the key names (``_mm``, ``_deg``,
        ``_m_s``, ``_m_s2``, ``_hz``...).
    """
    c = machine.cam
    th_d0, th_e0 = mid_stroke_angles(machine)
    L = machine.combs.length
    rho_min = 1.0 / float(np.max(np.abs(kin.curvature)))
    summary = {
        "cam": {
            "law": c.law,
            "stroke_mm": float(np.max(kin.s) - np.min(kin.s)) * 1e3,
            "max_velocity_m_s": float(np.max(np.abs(kin.v))),
            "max_acceleration_m_s2": float(np.max(np.abs(kin.a))),
            "max_jerk_m_s3": float(np.max(np.abs(kin.j))),
            "pressure_angle_deg": {"min": float(np.degrees(kin.pressure_angle.min())),
                                   "max": float(np.degrees(kin.pressure_angle.max()))},
            "min_radius_of_curvature_mm": rho_min * 1e3,
            "roller_radius_mm": c.roller_radius * 1e3,
            "undercut": bool(rho_min <= c.roller_radius),
        },
        "combs": {},
        "linkage": {
            "transmission_angle_deg": {"min": float(np.degrees(kin.transmission_angle.min())),
                                       "max": float(np.degrees(kin.transmission_angle.max()))},
            "shaft_D_mm": [v * 1e3 for v in machine.shaft_D],
            "shaft_E_mm": [v * 1e3 for v in machine.shaft_E],
        },
        "drive": {
            "cam_speed_rpm": c.speed * 60 / (2 * math.pi),
            "comb_frequency_hz": c.speed / (2 * math.pi),
        },
    }
    closed = closed_form_peaks(machine)
    if closed:
        summary["cam"]["closed_form"] = closed
    for side, th, w, a, th0 in (("left", kin.theta_d, kin.omega_d, kin.alpha_d, th_d0),
                                ("right", kin.theta_e, kin.omega_e, kin.alpha_e, th_e0)):
        summary["combs"][side] = {
            "swing_deg": {"min": float(np.degrees(np.min(th - th0))), "max": float(np.degrees(np.max(th - th0)))},
            "max_tip_speed_m_s": float(np.max(np.abs(w)) * L),
            "max_tip_acceleration_m_s2": float(np.max(np.hypot(a, w**2)) * L),
            "mid_stroke_angle_deg": math.degrees(th0),
        }
    return summary


#: peak values of P', |P''|, |P'''| for each normalised law (Norton 2009, ch. 3)
_LAW_PEAKS = {
    "3-4-5": (15.0 / 8.0, 10.0 / math.sqrt(3.0), 60.0),
    "cycloidal": (2.0, 2.0 * math.pi, 4.0 * math.pi**2),
    "4-5-6-7": (35.0 / 16.0, 84.0 * math.sqrt(5.0) / 25.0, 52.5),
}


def closed_form_peaks(machine: Machine) -> dict:
    """Closed-form peak push-rod velocity, acceleration, jerk of the follower law (rise and return).

    Parameters
    ----------
    machine : GrooveCamMachine
        The machine description.

    Returns
    -------
    dict
        ``max_velocity_m_s`` (m/s), ``max_acceleration_m_s2`` (m/s^2), ``max_jerk_m_s3`` (m/s^3).
    """
    c = machine.cam
    pv, pa, pj = _LAW_PEAKS[c.law]
    w = c.speed
    d = min(c.rise_angle, c.return_angle)  # the shorter move has the higher peaks
    return {
        "max_velocity_m_s": pv * c.stroke * w / d,
        "max_acceleration_m_s2": pa * c.stroke * w**2 / d**2,
        "max_jerk_m_s3": pj * c.stroke * w**3 / d**3,
    }
