"""Powered driveline: engine/motor -> belt -> CVT -> worm reducer -> cam, so cam speed is a state.

Everything is reflected to the cam shaft (``reflect_to_cam``), which makes the multibody integration one
extra rotor body with a torque-speed curve, a torsional spring-damper (the belt, with creep and a gross
slip cap) and a ratio coupling with direction-dependent efficiency (CVT + worm) into the cam::

    rotor   J_r w_r'        = T_r(w_r) - T_b                     (T_b: belt torque at cam scale)
    belt    T_b = k_t psi + c_t psi',  psi' = w_r - w_c - creep(T_b) w_r  (0 while slipping)
    mesh    J_s a = T_b - T_in,  J_c a = T_out - T_L,  T_in = h(T_out) T_out
            h = 1/eta_f (T_out >= 0, forward) or eta_b (T_out < 0, back-driven)

with J_s the driven pulley/CVT/worm inertia reflected to the cam and J_c the cam (+ follower train).
Angular speeds are positive in the drive direction; the model assumes the cam keeps turning forward.
See docs/driveline.md.

long module: the driveline's spec, component laws (motor, belt, CVT, worm), reflection to the cam and the two-inertia check model belong together as one documented model.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Annotated, Literal

import numpy as np
from pydantic import Field, model_validator

from berryshaker.errors import SimulationError
from berryshaker.quantity_fields import (
    AngularSpeed,
    Coefficient,
    Inertia,
    Length,
    PositiveAngle,
    StrictModel,
    quantity_validator,
)

#: a power, read by the one strict parser ("1.5 kW", "750 W"; "1,5 kW" and "1.5 kW * 1000" are refused)
Power = Annotated[float, quantity_validator("power", "kW"), Field(gt=0, json_schema_extra={"display": "kW"})]
Torque = Annotated[float, quantity_validator("torsional_stiffness"), Field(json_schema_extra={"display": "N*m"})]
Force = Annotated[float, quantity_validator("force"), Field(gt=0, json_schema_extra={"display": "N"})]
Fraction = Annotated[float, quantity_validator("dimensionless"), Field(gt=0, le=1, json_schema_extra={"display": "1"})]
Ratio = Annotated[float, quantity_validator("dimensionless"), Field(gt=0, le=1000, json_schema_extra={"display": "1"})]


# ------------------------------------------------------------------------------------------------
class InductionMotor(StrictModel):
    """Three-phase induction motor described by its nameplate and Kloss' formula."""

    kind: Literal["induction"] = "induction"
    rated_power: Power = 1500.0  # W [assumed]
    synchronous_speed: AngularSpeed = 1500.0 * math.pi / 30.0  # rad/s, 4-pole 50 Hz [assumed]
    rated_slip: Fraction = 0.05  # [assumed]
    breakdown_ratio: Annotated[float, Field(gt=1, le=10)] = 2.5  # T_breakdown / T_rated [assumed]
    rotor_inertia: Inertia = 0.0045  # kg m^2, rotor + driver pulley [assumed]


class EngineCurve(StrictModel):
    """Internal-combustion engine: full-load torque table plus a proportional governor.

    Above ``governed_speed`` the governor cuts the torque linearly to zero at
    governed_speed (1 + droop) (high idle).  Below the first table speed the engine stalls (torque 0).
    Motoring (negative) torque is not modelled.
    """

    kind: Literal["engine"] = "engine"
    speeds: list[Annotated[float, quantity_validator("angular_speed")]]  # rad/s, increasing
    torques: list[Torque]  # N m at full load
    governed_speed: AngularSpeed
    droop: Annotated[float, Field(gt=0, le=0.5)] = 0.05
    rotor_inertia: Inertia  # kg m^2, crank + flywheel + driver pulley

    @model_validator(mode="after")
    def _table(self):
        _check_table(self.speeds, self.torques)
        return self


class TableCurve(StrictModel):
    """Any drive given as a torque-speed table (linear interpolation, end values held outside)."""

    kind: Literal["table"] = "table"
    speeds: list[Annotated[float, quantity_validator("angular_speed")]]
    torques: list[Torque]
    rotor_inertia: Inertia

    @model_validator(mode="after")
    def _table(self):
        _check_table(self.speeds, self.torques)
        return self


def _check_table(speeds, torques):
    if len(speeds) < 2 or len(speeds) != len(torques):
        raise ValueError("speeds and torques need the same length (>= 2)")
    if np.any(np.diff(speeds) <= 0):
        raise ValueError("speeds must increase")


class BeltSpec(StrictModel):
    """Friction belt (flat or V) between the prime mover and the CVT."""

    driver_radius: Length = 0.050  # m, pitch radius on the motor [assumed]
    driven_radius: Length = 0.075  # m [assumed]
    axial_stiffness: Force = 1.0e5  # EA, N per unit strain [assumed]
    span_length: Length = 0.40  # m, free span [assumed]
    pretension: Force = 300.0  # N per span at rest [assumed]
    friction_coefficient: Coefficient = 0.30  # [assumed]
    groove_angle: Annotated[float, quantity_validator("angle"), Field(ge=0, lt=math.pi)] = math.radians(38.0)  # 0 = flat
    wrap_angle: PositiveAngle = math.radians(170.0)  # on the smaller pulley [assumed]
    damping_ratio: Annotated[float, Field(ge=0, lt=1)] = 0.05  # of the belt torsional mode [assumed]


class WormSpec(StrictModel):
    """Worm reducer: ratio and efficiency from lead angle and friction (Shigley) or given directly."""

    ratio: Ratio = 8.0  # worm speed / wheel speed [assumed]
    lead_angle: PositiveAngle | None = math.radians(15.0)  # [assumed]
    normal_pressure_angle: Annotated[float, quantity_validator("angle"), Field(ge=0, lt=math.pi / 2)] = math.radians(20.0)
    friction_coefficient: Coefficient = 0.05  # [assumed]
    efficiency_forward: Fraction | None = None  # overrides the lead-angle formula
    efficiency_back: Annotated[float, Field(le=1)] | None = None  # <= 0: self-locking

    @model_validator(mode="after")
    def _given(self):
        if (self.efficiency_forward is None) != (self.efficiency_back is None):
            raise ValueError("give both efficiency_forward and efficiency_back, or neither (lead angle used)")
        if self.efficiency_forward is None and self.lead_angle is None:
            raise ValueError("give lead_angle, or efficiency_forward and efficiency_back")
        return self


class DrivelineSpec(StrictModel):
    """Drive of the groove cam: prime mover, belt, CVT, worm reducer, cam inertia (all SI).

    Defaults [assumed] make 120 r/min at the cam from a 1500 r/min (synchronous) motor:
    belt 1.5 x CVT 1.0 x worm 8 = 12.  J_O = 0.0176 kg m^2 [study].
    """

    motor: InductionMotor | EngineCurve | TableCurve = Field(default_factory=InductionMotor,
                                                              discriminator="kind")
    belt: BeltSpec = BeltSpec()
    cvt_ratio: Ratio = 1.03  # input speed / output speed; set for ~120 r/min at 20 N m [assumed]
    cvt_efficiency: Fraction = 0.90  # both directions [assumed]
    worm: WormSpec = WormSpec()
    input_inertia: Inertia = 0.002  # kg m^2 at the driven-pulley shaft (pulley + CVT + worm) [assumed]
    cam_inertia: Inertia = 0.0176  # J_O, kg m^2 [study]


# ------------------------------------------------------------------------------------------------
def kloss_torque(omega, synchronous_speed, breakdown_torque, breakdown_slip):
    """Induction-motor torque from Kloss' formula.

    Parameters
    ----------
    omega : array_like
        Shaft speed (rad/s).
    synchronous_speed : float
        omega_s (rad/s).
    breakdown_torque : float
        T_b, the pull-out torque (N m).
    breakdown_slip : float
        s_b, the slip at T_b (dimensionless).

    Returns
    -------
    ndarray
        T = 2 T_b / (s/s_b + s_b/s), s = (omega_s - omega)/omega_s (N m); written as
        2 T_b s s_b / (s^2 + s_b^2), smooth through s = 0 and negative (generating) above omega_s.

    Notes
    -----
    Kloss' formula follows from the steady-state equivalent circuit with the stator resistance
    neglected; it is the standard approximation of drive-engineering texts.  Departures: no stator
    resistance, no current-displacement (deep-bar) effects, so the starting torque it gives is not a
    catalogue value; use it between standstill-free operation and a little above synchronous speed.

    References
    ----------
    M. Kloss (1905), as given e.g. in W. Leonhard, *Control of Electrical Drives*, 3rd ed., Springer,
    2001 (steady-state torque of the induction motor).
    """
    s = (synchronous_speed - np.asarray(omega, float)) / synchronous_speed
    return 2.0 * breakdown_torque * s * breakdown_slip / (s * s + breakdown_slip * breakdown_slip)


def induction_breakdown(motor: InductionMotor) -> tuple[float, float, float]:
    """Rated torque, breakdown torque and breakdown slip of an induction motor.

    Parameters
    ----------
    motor : InductionMotor
        The motor's rating (power, synchronous speed, rated slip, breakdown ratio lambda).

    Returns
    -------
    (T_rated, T_b, s_b) : tuple of float
        Torques (N m) and slip (dimensionless): T_rated = P / (omega_s (1 - s_r)); T_b = lambda T_rated; s_b = s_r (lambda + sqrt(lambda^2 - 1)),
        the Kloss curve through the rated point on its stable branch.

    References
    ----------
    Kloss' formula (see :func:`kloss_torque`) solved for s_b at the rated point.
    """
    lam = motor.breakdown_ratio
    t_r = motor.rated_power / (motor.synchronous_speed * (1.0 - motor.rated_slip))
    s_b = motor.rated_slip * (lam + math.sqrt(lam * lam - 1.0))
    return t_r, lam * t_r, s_b


def motor_torque(spec: DrivelineSpec, omega_motor):
    """Prime-mover torque at its own shaft (N m) for shaft speeds omega_motor (rad/s), vectorised.

    Parameters
    ----------
    spec : DrivelineSpec
        The driveline (its motor).
    omega_motor : array_like
        Motor speed (rad/s).

    Returns
    -------
    ndarray
        induction: Kloss (:func:`kloss_torque`); engine: full-load table, limited by the governor line
        T(omega_g) (omega_g (1 + droop) - omega)/(omega_g droop) and zero below the table's first
        speed; table: linear interpolation with end values held.

    References
    ----------
    Kloss' formula; the governor line is the usual proportional (droop) governor characteristic.
    """
    m = spec.motor
    w = np.asarray(omega_motor, float)
    if isinstance(m, InductionMotor):
        _, t_b, s_b = induction_breakdown(m)
        return kloss_torque(w, m.synchronous_speed, t_b, s_b)
    t = np.interp(w, m.speeds, m.torques)
    if isinstance(m, EngineCurve):
        t_g = float(np.interp(m.governed_speed, m.speeds, m.torques))
        gov = t_g * (m.governed_speed * (1.0 + m.droop) - w) / (m.governed_speed * m.droop)
        t = np.clip(np.minimum(t, gov), 0.0, None)
        t = np.where(w < m.speeds[0], 0.0, t)
    return t


def worm_efficiencies(worm: WormSpec) -> tuple[float, float]:
    """Forward (worm driving) and back-driving (wheel driving) efficiencies of a worm set.

    Parameters
    ----------
    worm : WormSpec
        Lead angle lambda, normal pressure angle phi_n and friction coefficient f.

    Returns
    -------
    (eta_forward, eta_back) : tuple of float
        Efficiencies (dimensionless): eta_f = (cos phi_n - f tan lambda)/(cos phi_n + f cot lambda),
        eta_b = (cos phi_n - f cot lambda)/(cos phi_n + f tan lambda);  eta_b <= 0 means self-locking
        (f >= cos phi_n tan lambda).  For phi_n = 0 they reduce to tan(lambda)/tan(lambda + phi) and
        tan(lambda - phi)/tan(lambda), phi = atan f.  Given efficiencies override the formula.

    References
    ----------
    R. G. Budynas, J. K. Nisbett, *Shigley's Mechanical Engineering Design*, McGraw-Hill
    (worm gearing: force analysis and efficiency).
    """
    if worm.efficiency_forward is not None:
        return float(worm.efficiency_forward), float(worm.efficiency_back)
    lam, f, pn = worm.lead_angle, worm.friction_coefficient, worm.normal_pressure_angle
    eta_f = (math.cos(pn) - f * math.tan(lam)) / (math.cos(pn) + f / math.tan(lam))
    eta_b = (math.cos(pn) - f / math.tan(lam)) / (math.cos(pn) + f * math.tan(lam))
    return eta_f, eta_b


def capstan_force_limit(pretension, friction_coefficient, wrap_angle, groove_angle=0.0):
    """Largest effective belt pull F_e = T1 - T2 before gross slip (N).

    Parameters
    ----------
    pretension : float
        Static tension T0 of each span (N).
    friction_coefficient : float
        mu, belt on pulley (dimensionless).
    wrap_angle : float
        theta, the wrap on the smaller pulley (rad).
    groove_angle : float
        beta, the V-groove angle (rad); 0 for a flat belt.

    Returns
    -------
    float
        The limit (N): F_max = 2 T0 tanh(mu' theta / 2) with mu' = mu / sin(beta/2) for a V-belt of groove angle beta
        (mu' = mu for a flat belt), from Euler-Eytelwein T1/T2 = exp(mu' theta) and T1 + T2 = 2 T0.

    Notes
    -----
    Centrifugal tension is neglected (belt speed here < 10 m/s).  Since F_max < 2 T0 the slack side
    stays taut up to slip, so both spans carry load and the belt stiffness is 2 EA / span.

    References
    ----------
    Euler-Eytelwein (capstan) equation, e.g. Shigley's *Mechanical Engineering Design* (flexible
    mechanical elements: flat and V belts).
    """
    mu = friction_coefficient / math.sin(groove_angle / 2.0) if groove_angle > 0 else friction_coefficient
    return 2.0 * pretension * math.tanh(mu * wrap_angle / 2.0)


# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ReflectedDriveline:
    """The driveline seen from the cam shaft (all SI, cam-angle scale).

    Attributes
    ----------
    ratio : float
        Motor speed / cam speed without creep, R = (r_n / r_d) i_cvt i_worm (dimensionless).
    rotor_inertia : float
        J_r = J_motor R^2 (kg m^2): the extra rotor body.
    shaft_inertia : float
        J_s = J_input (i_cvt i_worm)^2 (kg m^2): the driven pulley, CVT and worm, rigid with the cam through the
        mesh.
    cam_inertia : float
        J_c (kg m^2).
    torsional_stiffness, torsional_damping : float
        Belt k_t = (2 EA / span) (r_n N)^2 (N m/rad), c_t = 2 zeta sqrt(k_t J_r J_cs/(J_r + J_cs)).
    slip_torque : float
        Belt torque at which the belt slips (N m, cam scale): F_max r_n N.
    creep_compliance : float
        Creep fraction per unit belt torque, 1 / (EA r_n N) (1/(N m)): the driven side runs slower by
        this fraction times T_b.
    eta_forward, eta_back : float
        Efficiency of CVT x worm when driving the cam, and when the cam drives back (dimensionless; <= 0
        self-locking).
    spec : DrivelineSpec
        The source description (for the torque curve).
    """

    ratio: float
    rotor_inertia: float
    shaft_inertia: float
    cam_inertia: float
    torsional_stiffness: float
    torsional_damping: float
    slip_torque: float
    creep_compliance: float
    eta_forward: float
    eta_back: float
    spec: DrivelineSpec

    def rotor_torque(self, omega_rotor):
        """Prime-mover torque at cam scale, R T_m(R omega_r) (N m), for rotor speeds at cam scale (rad/s).

        Parameters
        ----------
        omega_rotor : array_like
            Rotor speed at cam scale (rad/s).

        Returns
        -------
        ndarray
            Torque at cam scale (N m).
        """
        return self.ratio * motor_torque(self.spec, self.ratio * np.asarray(omega_rotor, float))


def reflect_to_cam(spec: DrivelineSpec) -> ReflectedDriveline:
    """Reflect the driveline to the cam shaft.

    Parameters
    ----------
    spec : DrivelineSpec
        The driveline description.

    Returns
    -------
    ReflectedDriveline
        Inertias scale with the square of the speed ratio, torques and stiffnesses as described in
        :class:`ReflectedDriveline`; efficiencies eta_f = eta_cvt eta_worm,f, eta_b = eta_cvt eta_worm,b
        (a self-locking worm keeps eta_b <= 0).

    Notes
    -----
    Standard reflection of a geared train to one shaft (kinetic and potential energies preserved).  The
    belt damping is set from a damping ratio of the two-inertia belt mode (J_r against J_s + J_c).

    References
    ----------
    Any machine-dynamics text, e.g. Shigley's *Mechanical Engineering Design* (belt drives), with
    :func:`capstan_force_limit` and :func:`worm_efficiencies`.
    """
    b = spec.belt
    n_after = spec.cvt_ratio * spec.worm.ratio
    arm = b.driven_radius * n_after  # m of belt per rad of cam
    ratio = b.driven_radius / b.driver_radius * n_after
    j_r = spec.motor.rotor_inertia * ratio**2
    j_s = spec.input_inertia * n_after**2
    j_cs = j_s + spec.cam_inertia
    k_t = 2.0 * b.axial_stiffness / b.span_length * arm**2
    c_t = 2.0 * b.damping_ratio * math.sqrt(k_t * j_r * j_cs / (j_r + j_cs))
    ew_f, ew_b = worm_efficiencies(spec.worm)
    eta_b = spec.cvt_efficiency * ew_b if ew_b > 0 else ew_b
    return ReflectedDriveline(
        ratio=ratio, rotor_inertia=j_r, shaft_inertia=j_s, cam_inertia=spec.cam_inertia,
        torsional_stiffness=k_t, torsional_damping=c_t,
        slip_torque=capstan_force_limit(b.pretension, b.friction_coefficient, b.wrap_angle, b.groove_angle) * arm,
        creep_compliance=1.0 / (b.axial_stiffness * arm),
        eta_forward=spec.cvt_efficiency * ew_f, eta_back=eta_b, spec=spec)


def belt_torque(red: ReflectedDriveline, windup, omega_rotor, omega_cam):
    """Belt torque at cam scale and the windup rate, with elastic creep and the gross-slip cap.

    Parameters
    ----------
    red : ReflectedDriveline
        The driveline reflected to the cam (:func:`reflect_to_cam`).
    windup : array_like
        psi, elastic belt windup at cam scale (rad).
    omega_rotor, omega_cam : array_like
        Rotor (cam scale) and cam speeds (rad/s), > 0.

    Returns
    -------
    (torque, windup_rate, creep_rate, slip_rate) : tuple of ndarray
        T_b = k_t psi + c_t psi' (N m); psi' = w_r - w_c - creep - slip (rad/s), with
        creep = w_r C k_t psi (Reynolds' elastic creep: the belt leaves the driver pulley stretched by
        the effective pull and the driven pulley runs slower by (T1 - T2)/EA), and slip = the rest of
        the windup rate while |k_t psi| >= slip torque and growing (gross slip: the stretch stops
        increasing).

    Notes
    -----
    Power balance (exact, used by the energy audit): T_b (w_r - w_c) = d/dt(k_t psi^2 / 2) + c_t psi'^2
    + T_b (creep + slip).  Departure: the damper acts on the elastic stretch rate, so a slipping belt
    transmits exactly the capstan limit.

    References
    ----------
    Creep: O. Reynolds (1874); belt mechanics and Euler-Eytelwein as in Shigley's *Mechanical
    Engineering Design* (belt drives).
    """
    psi = np.asarray(windup, float)
    w_r = np.asarray(omega_rotor, float)
    w_c = np.asarray(omega_cam, float)
    t_el = red.torsional_stiffness * psi
    creep = w_r * red.creep_compliance * t_el
    free = w_r - w_c - creep
    slipping = (np.abs(t_el) >= red.slip_torque) & (free * np.sign(t_el) > 0)
    slip = np.where(slipping, free, 0.0)
    rate = free - slip
    return t_el + red.torsional_damping * rate, rate, creep, slip


def mesh_acceleration(red: ReflectedDriveline, belt_torque_cam, load_torque):
    """Cam acceleration through the CVT + worm with direction-dependent efficiency.

    Parameters
    ----------
    red : ReflectedDriveline
        The driveline reflected to the cam (:func:`reflect_to_cam`).
    belt_torque_cam : array_like
        T_b on the driven shaft at cam scale (N m).
    load_torque : array_like
        T_L resisting the cam (N m).

    Returns
    -------
    (alpha, torque_in, torque_out) : tuple of ndarray
        alpha = (T_b - h T_L)/(J_s + h J_c) with h = 1/eta_f if the mesh drives the cam
        (T_out = J_c alpha + T_L >= 0) else eta_b; T_in = h T_out.  Gear loss power = (T_in - T_out) w_c.

    Notes
    -----
    Friction in the mesh acts against the sliding, whose direction is fixed while the cam turns
    forward; the loaded flank changes with the sign of T_out, hence the two efficiencies (Shigley).
    With eta_b > 0 T_in(T_out) is continuous and increasing, so exactly one case is consistent.  With a
    self-locking worm (eta_b <= 0) T_in > 0 on both branches; we take the forward branch when it is
    consistent, else the back-driven branch, and raise SimulationError if neither is (an indeterminate
    lock).

    References
    ----------
    Worm efficiencies: Shigley's *Mechanical Engineering Design* (worm gearing).
    """
    tb = np.asarray(belt_torque_cam, float)
    tl = np.asarray(load_torque, float)
    js, jc = red.shaft_inertia, red.cam_inertia
    hf, hb = 1.0 / red.eta_forward, red.eta_back
    a_f = (tb - hf * tl) / (js + hf * jc)
    ok_f = jc * a_f + tl >= 0.0
    den_b = js + hb * jc
    if den_b <= 0:
        raise SimulationError("self-locking worm with J_s + eta_b J_c <= 0: back-driven branch ill-posed")
    a_b = (tb - hb * tl) / den_b
    ok_b = jc * a_b + tl < 0.0
    if np.any(~ok_f & ~ok_b):
        raise SimulationError("worm mesh state indeterminate (self-locking lock-up); reduce the overrunning load")
    alpha = np.where(ok_f, a_f, a_b)
    t_out = jc * alpha + tl
    t_in = np.where(ok_f, hf, hb) * t_out
    return alpha, t_in, t_out


# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class SteadyState:
    """Steady operating point under a constant cam load.

    Attributes
    ----------
    cam_speed, motor_speed : float
        rad/s.
    belt_torque : float
        At cam scale (N m).
    creep : float
        Fractional belt speed loss (dimensionless).
    input_power, output_power : float
        Prime-mover power and power delivered to the load (W).
    """

    cam_speed: float
    motor_speed: float
    belt_torque: float
    creep: float
    input_power: float
    output_power: float


def steady_state_speed(spec: DrivelineSpec, load_torque: float) -> SteadyState:
    """Steady cam speed under a constant resisting cam torque.

    Parameters
    ----------
    spec : DrivelineSpec
        The driveline description.
    load_torque : float
        T_L at the cam (N m).

    Returns
    -------
    SteadyState
        Solves T_r(w_r) = T_b with T_b = h(T_L) T_L (the mesh at alpha = 0) on the stable (highest-speed)
        branch of the torque curve, then w_c = w_r (1 - C T_b) (creep).

    Raises
    ------
    SimulationError
        The prime mover cannot deliver the torque (stall) or the belt would slip.
    """
    from scipy.optimize import brentq

    red = reflect_to_cam(spec)
    tb = (load_torque / red.eta_forward) if load_torque >= 0 else red.eta_back * load_torque
    if abs(tb) >= red.slip_torque:
        raise SimulationError(f"belt slips: needs {abs(tb):.3g} N m at the cam scale, capstan limit "
                              f"{red.slip_torque:.3g} N m; raise the pretension or the wrap")
    w_top = _top_speed(spec) / red.ratio
    grid = np.linspace(w_top, 0.0, 4001)
    g = red.rotor_torque(grid) - tb
    idx = np.nonzero(g >= 0)[0]
    if idx.size == 0 or idx[0] == 0:
        raise SimulationError(f"the prime mover cannot deliver {tb:.3g} N m at the cam scale (stall)")
    i = idx[0]
    w_r = brentq(lambda w: float(red.rotor_torque(w)) - tb, grid[i], grid[i - 1], xtol=1e-13, rtol=1e-15)
    creep = red.creep_compliance * tb
    w_c = w_r * (1.0 - creep)
    return SteadyState(cam_speed=w_c, motor_speed=w_r * red.ratio, belt_torque=tb, creep=creep,
                       input_power=float(red.rotor_torque(w_r)) * w_r, output_power=load_torque * w_c)


def _top_speed(spec: DrivelineSpec) -> float:
    m = spec.motor
    if isinstance(m, InductionMotor):
        return m.synchronous_speed * 1.2
    if isinstance(m, EngineCurve):
        return m.governed_speed * (1.0 + m.droop) * 1.001
    return m.speeds[-1]


# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class DrivelineRun:
    """Result of :func:`simulate_two_inertia`.

    Attributes
    ----------
    t, cam_angle, cam_speed, rotor_speed, belt_torque : ndarray
        Samples over the whole run (s, rad, rad/s at cam scale, N m at cam scale).
    speed_min, speed_max, speed_mean, ripple : float
        Cam speed over the last ``revolutions_measured`` revolutions (rad/s); ripple = (max - min)/mean.
    input_power : float
        Mean prime-mover power over the measured revolutions (W).
    energy : dict
        Over the whole run (J): motor_work, kinetic_change, spring_change, belt_dissipation (damping + creep + slip),
        gear_loss, load_work, and ``residual`` = motor_work - all the others, ``relative_residual``.
    """

    t: np.ndarray
    cam_angle: np.ndarray
    cam_speed: np.ndarray
    rotor_speed: np.ndarray
    belt_torque: np.ndarray
    speed_min: float
    speed_max: float
    speed_mean: float
    ripple: float
    input_power: float
    energy: dict


def simulate_two_inertia(spec: DrivelineSpec, load_torque, revolutions: float = 4.0,
                         revolutions_measured: float = 1.0, rtol: float = 1e-10) -> DrivelineRun:
    """Reduced 2-DOF check model: reflected rotor and cam joined by the belt, cam loaded by T_L(phi).

    Parameters
    ----------
    spec : DrivelineSpec
        The driveline description.
    load_torque : callable
        T_L(phi) (N m), vectorised over the cam angle phi (rad); positive resists the motion.
    revolutions : float
        Cam revolutions to simulate (dimensionless), starting from the steady state under the mean load.
    revolutions_measured : float
        Trailing revolutions used for the speed statistics and the mean input power (dimensionless).
    rtol : float
        Relative tolerance of the integrator (DOP853; dimensionless); the energy audit closes to about this
        level.

    Returns
    -------
    DrivelineRun
        Time series, speed statistics, input power and the energy audit (SI).

    Notes
    -----
    States: phi, w_c, w_r, psi and four energy quadratures (motor work, belt dissipation, gear loss,
    load work), integrated with scipy.integrate.solve_ivp (DOP853).  The audit compares the motor work
    with the kinetic + spring energy change and the integrated losses; because the losses are computed
    from separate power expressions, it checks the equations of motion.
    """
    from scipy.integrate import solve_ivp

    red = reflect_to_cam(spec)
    phis = np.linspace(0.0, 2 * math.pi, 721)
    t_mean = float(np.mean(np.asarray(load_torque(phis[:-1]), float)))
    ss = steady_state_speed(spec, t_mean)
    w0 = ss.cam_speed
    psi0 = ss.belt_torque / red.torsional_stiffness
    w_r0 = ss.motor_speed / red.ratio

    def rhs(t, y):
        phi, w_c, w_r, psi = y[:4]
        if w_c <= 0:
            raise SimulationError(f"cam stalled at t = {t:.4g} s")
        tb, rate, creep, slip = belt_torque(red, psi, w_r, w_c)
        tl = float(load_torque(np.array([phi]))[0])
        alpha, t_in, t_out = mesh_acceleration(red, tb, tl)
        tr = float(red.rotor_torque(w_r))
        tb, rate = float(tb), float(rate)
        return [w_c, float(alpha), (tr - tb) / red.rotor_inertia, rate,
                tr * w_r,
                red.torsional_damping * rate * rate + tb * float(creep + slip),
                float(t_in - t_out) * w_c,
                tl * w_c]

    t_end = revolutions * 2 * math.pi / w0
    y0 = [0.0, w0, w_r0, psi0, 0.0, 0.0, 0.0, 0.0]
    sol = solve_ivp(rhs, (0.0, t_end), y0, method="DOP853", rtol=rtol, atol=1e-12 * max(1.0, w0),
                    dense_output=False, max_step=t_end / 2000)
    if not sol.success:
        raise SimulationError(f"driveline integration failed: {sol.message}")
    phi, w_c, w_r, psi, w_m, d_b, g_l, w_l = sol.y
    tb = belt_torque(red, psi, w_r, w_c)[0]
    j_cs = red.shaft_inertia + red.cam_inertia
    ke = 0.5 * red.rotor_inertia * w_r**2 + 0.5 * j_cs * w_c**2
    pe = 0.5 * red.torsional_stiffness * psi**2
    energy = {"motor_work": float(w_m[-1]), "kinetic_change": float(ke[-1] - ke[0]),
              "spring_change": float(pe[-1] - pe[0]), "belt_dissipation": float(d_b[-1]),
              "gear_loss": float(g_l[-1]), "load_work": float(w_l[-1])}
    energy["residual"] = energy["motor_work"] - sum(v for k, v in energy.items() if k != "motor_work")
    energy["relative_residual"] = abs(energy["residual"]) / max(abs(energy["motor_work"]), 1e-300)
    sel = phi >= phi[-1] - revolutions_measured * 2 * math.pi
    if np.count_nonzero(sel) < 10:
        raise SimulationError("too few samples in the measured revolutions; lower max_step")
    ws = w_c[sel]
    # mean speed and power over the window from the integrals (exact), extremes from the samples
    t_sel = sol.t[sel]
    dt = t_sel[-1] - t_sel[0]
    mean = (phi[sel][-1] - phi[sel][0]) / dt
    p_in = (w_m[sel][-1] - w_m[sel][0]) / dt
    return DrivelineRun(t=sol.t, cam_angle=phi, cam_speed=w_c, rotor_speed=w_r, belt_torque=tb,
                        speed_min=float(ws.min()), speed_max=float(ws.max()), speed_mean=float(mean),
                        ripple=float((ws.max() - ws.min()) / mean), input_power=float(p_in), energy=energy)
