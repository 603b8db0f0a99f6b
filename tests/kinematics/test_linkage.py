"""Double rocker (study eq. 3): loop closure, analytic rates vs finite differences, swing, transmission."""

import math

import numpy as np
import pytest

from berryshaker.drives.groove_cam.kinematics import check_machine, cycle_kinematics, mid_stroke_angles


def test_vector_loops_close_to_machine_precision(machine):
    k = cycle_kinematics(machine, 3601)
    xd, yd = machine.shaft_D
    xe, ye = machine.shaft_E
    c = machine.cam
    # loop 1 (ideal joints): roller B lies on the slot line through D at angle theta_D
    xb = c.s0 + k.s + machine.push_rod.length
    yb = c.offset
    cross = np.cos(k.theta_d) * (yb - yd) - np.sin(k.theta_d) * (xb - xd)
    assert np.max(np.abs(cross)) < 1e-15
    # loop 2: D + l_CD e^{i thC} + l_CF e^{i th4} - l_FE e^{i thE} - E = 0
    thc = k.theta_d + machine.rocker.arm_angle
    z = (xd + 1j * yd + machine.rocker.arm_CD * np.exp(1j * thc)
         + machine.four_bar.coupler_CF * np.exp(1j * k.theta_4)
         - machine.four_bar.arm_FE * np.exp(1j * k.theta_e) - (xe + 1j * ye))
    assert np.max(np.abs(z)) < 1e-14


def test_analytic_rates_match_finite_differences(machine):
    n = 72001
    k = cycle_kinematics(machine, n)
    t = k.t
    for th, w, a in ((k.theta_d, k.omega_d, k.alpha_d), (k.theta_4, k.omega_4, k.alpha_4),
                     (k.theta_e, k.omega_e, k.alpha_e)):
        w_fd = np.gradient(th, t)
        a_fd = np.gradient(w, t)
        np.testing.assert_allclose(w_fd[2:-2], w[2:-2], atol=1e-4 * np.abs(w).max())
        np.testing.assert_allclose(a_fd[2:-2], a[2:-2], atol=2e-3 * np.abs(a).max())


def test_reference_swing_and_transmission_angle(machine):
    """Left swing = atan((h/2)/drop) = atan(20/120) = 9.46 deg (geometry of docs/study.md sec. 6);
    right swing about 8.7 deg and transmission angle 80-98 deg (docs/study.md sec. 6)."""
    k = check_machine(machine)
    d0, e0 = mid_stroke_angles(machine)
    left = np.degrees(k.theta_d - d0)
    assert left.max() == pytest.approx(math.degrees(math.atan(20 / 120)), abs=1e-9)
    assert left.min() == pytest.approx(-math.degrees(math.atan(20 / 120)), abs=1e-9)
    right = np.degrees(k.theta_e - e0)
    assert 8.5 < right.max() < 9.0 and -9.0 < right.min() < -8.5
    mu = np.degrees(k.transmission_angle)
    assert 80.0 <= mu.min() and mu.max() <= 98.5


def test_crank_rocker_transmission_angle_is_the_unfolded_law_of_cosines_angle():
    """The rod-rocker transmission angle is the angle at R between rod and rocker arm, 0..180 deg (not folded
    to 0..90): law of cosines on the triangle crank pin P - rocker pin R - shaft D, an independent closed form."""
    from pathlib import Path

    from berryshaker.config import load_machine
    from berryshaker.drives.crank_rocker.kinematics import cycle_kinematics as cr_kinematics
    from berryshaker.drives.crank_rocker.kinematics import kinematics_summary

    m = load_machine(Path(__file__).parents[2] / "examples" / "crank_rocker_harvester.toml")
    k = cr_kinematics(m, 720)
    phi = -k.phi  # the crank pin angle
    px, py = m.crank.radius * np.cos(phi), m.crank.radius * np.sin(phi)
    xd, yd = m.shaft_D
    l_rod, b = m.rod.length, m.rocker.arm_R
    pd2 = (xd - px) ** 2 + (yd - py) ** 2
    mu = np.degrees(np.arccos((l_rod**2 + b**2 - pd2) / (2 * l_rod * b)))
    np.testing.assert_allclose(np.degrees(k.rod_transmission_angle), mu, atol=1e-9)
    assert mu.max() > 100.0 and mu.min() > 80.0  # the example passes 90 deg: a folded angle would hide it
    ta = kinematics_summary(m, k)["crank"]["rod_transmission_angle_deg"]
    assert ta["min"] == pytest.approx(80.1, abs=0.05) and ta["max"] == pytest.approx(100.5, abs=0.05)
