"""Kinematics of the crank-rocker double rocker over one crank revolution.

Crank pin P = r (cos phi, sin phi), phi = phi0 - omega t (clockwise).  The rocker pin R closes the triangle
P-R-D: |R - P| = l (rod), |R - D| = b (arm DR); with u = (D - P)/|D - P|, n = u rotated by +90 deg,
a = (l^2 - b^2 + |D - P|^2) / (2 |D - P|) and h = sqrt(l^2 - a^2), R = P + a u + s h n (s = assembly).  The
left comb angle is theta_D = arg(R - D) - arm_R_angle; the right comb follows from the four-bar D-C-F-E with
the left arm at theta_D + arm_angle (:func:`berryshaker.kinematics.linkage.four_bar_position`, docs/study.md
eq. 3 as corrected).  Rates are periodic finite differences on a fine angle grid (second order).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from berryshaker.errors import GeometryError
from berryshaker.kinematics.linkage import four_bar_position, transmission_angle


@dataclass(frozen=True)
class CrankRockerKinematics:
    """Ideal kinematics of the crank-rocker drive sampled over crank angle (SI).

    Attributes
    ----------
    phi : ndarray
        Crank angle turned since t = 0 (rad; the crank turns clockwise, so this is minus its angle).
    t : ndarray
        Time at constant crank speed (s).
    theta_r : ndarray
        Direction of the rod from the crank pin P to the rocker pin R (rad).
    theta_d, omega_d, alpha_d : ndarray
        Left comb (rocker about D) angle (rad), rate (rad/s) and acceleration (rad/s^2).
    theta_4 : ndarray
        Coupler CF angle (rad).
    theta_e, omega_e, alpha_e : ndarray
        Right comb (arm about E) angle (rad), rate (rad/s) and acceleration (rad/s^2).
    assembled : ndarray of bool
        Whether the rod reaches the rocker and the four-bar assembles at each sample.
    rod_transmission_angle : ndarray
        Angle at R between the rod R->P and the rocker arm R->D (rad, 0..pi; see :func:`rod_transmission_angle`).
    transmission_angle : ndarray
        Transmission angle of the four-bar D-C-F-E (rad).
    """

    phi: np.ndarray  # crank angle turned since t = 0 (rad; the crank turns clockwise)
    t: np.ndarray  # time (s)
    theta_r: np.ndarray  # rod direction P->R (rad)
    theta_d: np.ndarray
    omega_d: np.ndarray
    alpha_d: np.ndarray
    theta_4: np.ndarray
    theta_e: np.ndarray
    omega_e: np.ndarray
    alpha_e: np.ndarray
    assembled: np.ndarray
    rod_transmission_angle: np.ndarray  # angle at R between the rod R->P and the rocker arm R->D (rad, 0..pi)
    transmission_angle: np.ndarray  # four-bar D-C-F-E (rad)


def rocker_position(phi, machine):
    """Rocker pin R (m) and left comb angle theta_D (rad) at crank angle(s) phi; NaN where the rod cannot
    reach (the triangle P-R-D does not close).

    Parameters
    ----------
    phi : float or array_like
        Crank angle(s) from the x axis (rad; counter-clockwise positive).
    machine : CrankRockerMachine
        The machine description (crank radius, rod length, rocker arm and shaft D, assembly branch).

    Returns
    -------
    rx, ry : ndarray
        Rocker pin R (m), NaN where the rod cannot reach.
    px, py : ndarray
        Crank pin P (m).
    theta_d : ndarray
        Left comb angle theta_D = arg(R - D) - ``rocker.arm_R_angle`` (rad), NaN where the rod cannot reach.
    """
    phi = np.atleast_1d(np.asarray(phi, float))
    r, l_rod = machine.crank.radius, machine.rod.length
    ro = machine.rocker
    b = ro.arm_R
    px, py = r * np.cos(phi), r * np.sin(phi)
    dx, dy = ro.shaft_D_x - px, ro.shaft_D_y - py
    dist = np.hypot(dx, dy)
    ux, uy = dx / dist, dy / dist
    a = (l_rod**2 - b**2 + dist**2) / (2 * dist)
    h2 = l_rod**2 - a**2
    ok = h2 >= 0
    h = np.sqrt(np.where(ok, h2, np.nan))
    s = ro.assembly
    rx = px + a * ux - s * h * uy
    ry = py + a * uy + s * h * ux
    theta_d = np.arctan2(ry - ro.shaft_D_y, rx - ro.shaft_D_x) - ro.arm_R_angle
    return rx, ry, px, py, theta_d


def rod_transmission_angle(px, py, rx, ry, xd, yd):
    """Transmission angle of the crank-rocker (rad, 0..pi): the angle at the rocker pin R between the rod R->P
    and the rocker arm R->D, not folded (90 deg is ideal; near 0 or 180 deg the rod toggles with the arm).

    Computed from the directions (atan2 of the cross and dot products), so it is the same as the law of
    cosines on the triangle P-R-D, cos mu = (l^2 + b^2 - |PD|^2) / (2 l b), at every crank angle.

    Parameters
    ----------
    px, py : float or ndarray
        Crank pin P (m).
    rx, ry : float or ndarray
        Rocker pin R (m).
    xd, yd : float
        Rocker shaft D (m).

    Returns
    -------
    float or ndarray
        The transmission angle mu (rad, 0..pi).
    """
    ax, ay = px - rx, py - ry
    bx, by = xd - rx, yd - ry
    return np.abs(np.arctan2(ax * by - ay * bx, ax * bx + ay * by))


def _d_dt(y, dt):
    return (np.roll(y, -1) - np.roll(y, 1)) / (2 * dt)


def cycle_kinematics(machine, n: int = 3600) -> CrankRockerKinematics:
    """Ideal kinematics over one crank revolution on ``n`` equally spaced times.

    Parameters
    ----------
    machine : CrankRockerMachine
        The machine description.
    n : int
        Number of samples over the revolution (rates by periodic central differences).

    Returns
    -------
    CrankRockerKinematics
        The kinematics; samples where the linkage does not assemble are NaN and ``assembled`` False.
    """
    w = machine.crank.speed
    period = 2 * math.pi / w
    t = np.arange(n) * period / n
    phi = -w * t
    rx, ry, px, py, th_d = rocker_position(phi, machine)
    ok = np.isfinite(th_d)
    xd, yd = machine.shaft_D
    th4, th_e = four_bar_position(th_d + machine.rocker.arm_angle, machine.shaft_D, machine.shaft_E,
                                  machine.rocker.arm_CD, machine.four_bar.coupler_CF, machine.four_bar.arm_FE,
                                  machine.four_bar.branch)
    ok &= np.isfinite(th_e)
    dt = period / n
    th_d_u, th_e_u = np.unwrap(th_d), np.unwrap(th_e)
    om_d, om_e = _d_dt(th_d_u, dt), _d_dt(th_e_u, dt)
    al_d = (np.roll(th_d_u, -1) - 2 * th_d_u + np.roll(th_d_u, 1)) / dt**2
    al_e = (np.roll(th_e_u, -1) - 2 * th_e_u + np.roll(th_e_u, 1)) / dt**2
    th_rod = np.arctan2(ry - py, rx - px)
    mu = rod_transmission_angle(px, py, rx, ry, xd, yd)
    return CrankRockerKinematics(-phi, t, th_rod, th_d, om_d, al_d, th4, th_e, om_e, al_e, ok,
                                 mu, transmission_angle(th4, th_e))


def check_machine(machine, allow_undercut: bool = False) -> CrankRockerKinematics:
    """Check that the crank-rocker can run through a whole revolution; return its kinematics.

    Parameters
    ----------
    machine : CrankRockerMachine
        The machine description.
    allow_undercut : bool
        Ignored (there is no cam); accepted for the drive interface.

    Returns
    -------
    CrankRockerKinematics
        The kinematics over one revolution (:func:`cycle_kinematics`, 3600 samples).

    Raises
    ------
    GeometryError
        The rod cannot reach the rocker at some crank angle (not a crank-rocker: Grashof's condition fails),
        the four-bar cannot assemble, or either linkage passes a toggle.  ``allow_undercut`` is ignored (there
        is no cam).
    """
    kin = cycle_kinematics(machine)
    if not np.all(kin.assembled):
        i = int(np.argmin(kin.assembled))
        raise GeometryError(f"the crank-rocker cannot assemble at crank angle {math.degrees(-kin.phi[i]) % 360:.1f} "
                            "deg: the rod cannot reach the rocker (check crank.radius, rod.length, rocker.arm_R and "
                            "the position of shaft D: the crank must be the shortest link, Grashof)")
    mu = kin.rod_transmission_angle
    if np.min(np.minimum(mu, math.pi - mu)) < math.radians(5):
        raise GeometryError("the rod and the rocker arm come within 5 deg of alignment (toggle); change the "
                            "geometry")
    sin_tm = np.abs(np.sin(kin.theta_4 - kin.theta_e))
    if np.min(sin_tm) < 1e-3:
        raise GeometryError("the four-bar reaches a toggle (coupler and right arm aligned)")
    return kin


def mid_stroke_angles(machine) -> tuple[float, float]:
    """Left and right comb angles (rad) at the middle of the left comb's swing: the swing reference.

    Parameters
    ----------
    machine : CrankRockerMachine
        The machine description.

    Returns
    -------
    (float, float)
        theta_D halfway between its extremes over a revolution, and theta_E of the four-bar there (rad).

    Raises
    ------
    GeometryError
        The four-bar D-C-F-E cannot assemble at mid-swing.
    """
    kin = cycle_kinematics(machine, 1440)
    th = np.unwrap(kin.theta_d)
    th_mid = 0.5 * (th.min() + th.max())
    _, th_e = four_bar_position(th_mid + machine.rocker.arm_angle, machine.shaft_D, machine.shaft_E,
                                machine.rocker.arm_CD, machine.four_bar.coupler_CF, machine.four_bar.arm_FE,
                                machine.four_bar.branch)
    if not np.isfinite(th_e[0]):
        raise GeometryError("the four-bar D-C-F-E cannot assemble at mid-swing")
    return float(th_mid), float(th_e[0])


def kinematics_summary(machine, kin: CrankRockerKinematics) -> dict:
    """Engineering summary of the ideal drive (the JSON of ``berryshaker kinematics``).

    Parameters
    ----------
    machine : CrankRockerMachine
        The machine description.
    kin : CrankRockerKinematics
        Its kinematics (:func:`check_machine`).

    Returns
    -------
    dict
        ``drive_specific`` (formatted text), ``crank``, ``combs`` (per side: swing about mid-stroke, maximum tip
        speed and acceleration), ``linkage`` and ``drive`` sections; units in the key names (``_mm``, ``_deg``,
        ``_m_s``, ``_m_s2``, ``_rpm``, ``_hz``).
    """
    th_d0, th_e0 = mid_stroke_angles(machine)
    L = machine.combs.length
    w = machine.crank.speed
    out = {
        "drive_specific": {
            "drive": "crank + connecting rod + double rocker",
            "crank radius": f"{machine.crank.radius * 1e3:.2f} mm",
            "rod length": f"{machine.rod.length * 1e3:.1f} mm",
            "rod-rocker transmission angle": f"{math.degrees(kin.rod_transmission_angle.min()):.1f} .. "
                                             f"{math.degrees(kin.rod_transmission_angle.max()):.1f} deg",
        },
        "crank": {"radius_mm": machine.crank.radius * 1e3, "rod_length_mm": machine.rod.length * 1e3,
                  "rod_transmission_angle_deg": {"min": float(np.degrees(kin.rod_transmission_angle.min())),
                                                 "max": float(np.degrees(kin.rod_transmission_angle.max()))}},
        "combs": {},
        "linkage": {
            "transmission_angle_deg": {"min": float(np.degrees(kin.transmission_angle.min())),
                                       "max": float(np.degrees(kin.transmission_angle.max()))},
            "shaft_D_mm": [v * 1e3 for v in machine.shaft_D],
            "shaft_E_mm": [v * 1e3 for v in machine.shaft_E],
        },
        "drive": {"shaft_speed_rpm": w * 60 / (2 * math.pi), "cam_speed_rpm": w * 60 / (2 * math.pi),
                  "comb_frequency_hz": w / (2 * math.pi)},
    }
    for side, th, om, al, th0 in (("left", kin.theta_d, kin.omega_d, kin.alpha_d, th_d0),
                                  ("right", kin.theta_e, kin.omega_e, kin.alpha_e, th_e0)):
        rel = np.angle(np.exp(1j * (th - th0)))
        out["combs"][side] = {
            "swing_deg": {"min": float(np.degrees(rel.min())), "max": float(np.degrees(rel.max()))},
            "max_tip_speed_m_s": float(np.max(np.abs(om)) * L),
            "max_tip_acceleration_m_s2": float(np.max(np.hypot(al, om**2)) * L),
            "mid_stroke_angle_deg": math.degrees(th0),
        }
    return out
