"""Powered driveline: closed forms (Kloss, Euler-Eytelwein, worm efficiency), reflection, and the 2-DOF model."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pydantic import ValidationError

from berryshaker.drives.driveline import (
    DrivelineSpec,
    EngineCurve,
    InductionMotor,
    WormSpec,
    belt_torque,
    capstan_force_limit,
    induction_breakdown,
    kloss_torque,
    mesh_acceleration,
    motor_torque,
    reflect_to_cam,
    simulate_two_inertia,
    steady_state_speed,
    worm_efficiencies,
)
from berryshaker.errors import SimulationError


def test_kloss_through_rated_point_and_breakdown():
    m = InductionMotor()
    t_r, t_b, s_b = induction_breakdown(m)
    ws = m.synchronous_speed
    assert t_r == pytest.approx(1500.0 / (ws * 0.95))
    assert float(kloss_torque(ws * (1 - m.rated_slip), ws, t_b, s_b)) == pytest.approx(t_r, rel=1e-12)
    s = np.linspace(1e-4, 1.0, 200001)
    t = kloss_torque(ws * (1 - s), ws, t_b, s_b)
    assert t.max() == pytest.approx(t_b, rel=1e-9)
    assert s[np.argmax(t)] == pytest.approx(s_b, abs=1e-4)
    assert s_b > m.rated_slip  # rated point on the stable branch
    assert float(kloss_torque(ws, ws, t_b, s_b)) == 0.0
    assert float(kloss_torque(1.01 * ws, ws, t_b, s_b)) < 0  # generating


def test_worm_efficiency_reduces_to_screw_form_and_self_locks():
    lam, f = math.radians(10.0), 0.08
    ef, eb = worm_efficiencies(WormSpec(lead_angle=lam, friction_coefficient=f, normal_pressure_angle=0.0))
    phi = math.atan(f)
    assert ef == pytest.approx(math.tan(lam) / math.tan(lam + phi), rel=1e-12)
    assert eb == pytest.approx(math.tan(lam - phi) / math.tan(lam), rel=1e-12)
    # self-locking exactly when f >= cos(phi_n) tan(lambda)
    pn = math.radians(20.0)
    f_lock = math.cos(pn) * math.tan(math.radians(4.0))
    _, eb_lock = worm_efficiencies(WormSpec(lead_angle=math.radians(4.0), friction_coefficient=1.01 * f_lock))
    _, eb_free = worm_efficiencies(WormSpec(lead_angle=math.radians(4.0), friction_coefficient=0.99 * f_lock))
    assert eb_lock < 0 < eb_free


def test_capstan_limit_is_euler_eytelwein():
    t0, mu, theta = 300.0, 0.3, math.radians(170.0)
    fe = capstan_force_limit(t0, mu, theta)
    assert (t0 + fe / 2) / (t0 - fe / 2) == pytest.approx(math.exp(mu * theta), rel=1e-12)
    beta = math.radians(38.0)
    fv = capstan_force_limit(t0, mu, theta, beta)
    assert (t0 + fv / 2) / (t0 - fv / 2) == pytest.approx(math.exp(mu / math.sin(beta / 2) * theta))


def test_reflection_preserves_energy_and_power():
    spec = DrivelineSpec()
    red = reflect_to_cam(spec)
    b = spec.belt
    w_c = 12.0
    w_m = red.ratio * w_c
    assert 0.5 * spec.motor.rotor_inertia * w_m**2 == pytest.approx(0.5 * red.rotor_inertia * w_c**2)
    # belt potential energy: stretch s = psi * r_n * N at two spans of EA/span
    psi = 1e-4
    s = psi * b.driven_radius * spec.cvt_ratio * spec.worm.ratio
    assert 0.5 * (2 * b.axial_stiffness / b.span_length) * s**2 == pytest.approx(0.5 * red.torsional_stiffness * psi**2)
    # torque curve: same power at both scales
    assert float(red.rotor_torque(w_c)) * w_c == pytest.approx(float(motor_torque(spec, w_m)) * w_m)


def test_belt_power_balance_and_slip():
    red = reflect_to_cam(DrivelineSpec())
    rng = np.random.default_rng(3)
    psi = rng.uniform(-1.5, 1.5, 200) * red.slip_torque / red.torsional_stiffness
    w_r, w_c = rng.uniform(10, 14, 200), rng.uniform(10, 14, 200)
    tb, rate, creep, slip = belt_torque(red, psi, w_r, w_c)
    lhs = tb * (w_r - w_c)
    rhs = red.torsional_stiffness * psi * rate + red.torsional_damping * rate**2 + tb * (creep + slip)
    np.testing.assert_allclose(lhs, rhs, rtol=1e-9, atol=1e-9)
    over = np.abs(red.torsional_stiffness * psi) >= red.slip_torque
    growing = (w_r - w_c - creep) * np.sign(psi) > 0
    assert np.all(rate[over & growing] == 0.0)
    assert np.all(np.abs(tb[over & growing]) == np.abs(red.torsional_stiffness * psi[over & growing]))


def test_self_locking_worm_never_returns_power():
    spec = DrivelineSpec(worm=WormSpec(lead_angle=math.radians(3.0), friction_coefficient=0.1))
    red = reflect_to_cam(spec)
    assert red.eta_back < 0
    tb = np.linspace(0.0, 40.0, 41)
    _, t_in, _ = mesh_acceleration(red, tb, -5.0 * np.ones_like(tb))
    assert np.all(t_in >= 0)  # the motor side always drives: power never flows back


def test_steady_state_balances_torque():
    spec = DrivelineSpec()
    red = reflect_to_cam(spec)
    ss = steady_state_speed(spec, 20.0)
    assert float(red.rotor_torque(ss.motor_speed / red.ratio)) == pytest.approx(ss.belt_torque, rel=1e-9)
    assert ss.belt_torque == pytest.approx(20.0 / red.eta_forward)
    assert ss.cam_speed * 30 / math.pi == pytest.approx(120.0, abs=1.0)  # the reference setting
    _, _, s_b = induction_breakdown(spec.motor)
    slip = 1 - ss.motor_speed / spec.motor.synchronous_speed
    assert 0 < slip < s_b  # stable branch
    with pytest.raises(SimulationError, match="stall|slips"):
        steady_state_speed(spec, 400.0)


def test_engine_governor():
    eng = EngineCurve(speeds=["1000 rpm", "2000 rpm", "3600 rpm"], torques=[10.0, 12.0, 10.0],
                      governed_speed="3000 rpm", droop=0.05, rotor_inertia="0.02 kg*m^2")
    spec = DrivelineSpec(motor=eng)
    w = np.array([500.0, 2000.0, 3000.0, 3150.0, 3300.0]) * math.pi / 30
    t = motor_torque(spec, w)
    assert t[0] == 0.0 and t[1] == pytest.approx(12.0) and t[3] == pytest.approx(0.0, abs=1e-9)
    assert t[2] == pytest.approx(float(np.interp(w[2], eng.speeds, eng.torques)))
    assert t[4] == 0.0


def test_spec_units_and_errors():
    spec = DrivelineSpec.model_validate({"motor": {"kind": "induction", "rated_power": "2 kW",
                                                   "synchronous_speed": "1000 rpm"},
                                         "cam_inertia": "0.0176 kg*m^2"})
    assert spec.motor.rated_power == pytest.approx(2000.0)
    assert spec.motor.synchronous_speed == pytest.approx(1000 * math.pi / 30)
    with pytest.raises(ValidationError, match="rated_power"):
        DrivelineSpec.model_validate({"motor": {"kind": "induction", "rated_power": "2 m"}})
    with pytest.raises(ValidationError, match="bogus"):
        DrivelineSpec.model_validate({"bogus": 1})
    with pytest.raises(ValidationError, match="both"):
        WormSpec(efficiency_forward=0.8)


# ------------------------------------------------------------------------------------------------
def _load(mean, amp):
    return lambda phi: mean + amp * np.sin(2 * phi)


def test_energy_audit_closes():
    run = simulate_two_inertia(DrivelineSpec(), _load(20.0, 60.0), revolutions=2)  # load goes negative
    e = run.energy
    assert e["relative_residual"] < 1e-6
    assert e["gear_loss"] > 0 and e["belt_dissipation"] > 0 and e["load_work"] > 0


def test_ripple_grows_with_load_amplitude():
    ripples = [simulate_two_inertia(DrivelineSpec(), _load(20.0, a), revolutions=2).ripple for a in (0.0, 15.0, 45.0)]
    assert ripples[0] < 1e-8
    assert ripples[0] < ripples[1] < ripples[2]


def test_stiff_belt_and_large_motor_recover_imposed_speed():
    spec = DrivelineSpec()
    stiff = spec.model_copy(update={
        "belt": spec.belt.model_copy(update={"axial_stiffness": 1e7, "pretension": 5000.0}),
        "motor": InductionMotor(rated_power=1e5, rated_slip=0.002, rotor_inertia=0.5)})
    run = simulate_two_inertia(stiff, _load(20.0, 30.0), revolutions=2)
    imposed = stiff.motor.synchronous_speed / reflect_to_cam(stiff).ratio
    assert run.ripple < 1e-4
    assert run.speed_mean == pytest.approx(imposed, rel=1e-4)
    soft = simulate_two_inertia(spec, _load(20.0, 30.0), revolutions=2)
    assert soft.ripple > 100 * run.ripple
