"""The crank-rocker drive as a planar multibody mechanism for the generic engine.

Bodies: crank (driven clockwise at the drive speed), connecting rod, left comb (pivot D; rocker pin R on it),
coupler CF, right comb (pivot E).  A pair with clearance > 0 becomes a pin-in-bore clearance joint with the
pair's contact law; zero clearance is the ideal revolute.  The bush acts on each comb as the aggregate
viscoelastic moment of ``[combs]`` (as for the groove-cam drive).
"""

from __future__ import annotations

import math

from berryshaker.drives.base import HARVESTER_RTOL, HARVESTER_VELOCITY_SCALE
from berryshaker.drives.crank_rocker.kinematics import check_machine, mid_stroke_angles, rocker_position
from berryshaker.drives.powered import is_powered, powered_mechanism
from berryshaker.kinematics.linkage import four_bar_position
from berryshaker.multibody.spec import MechanismSpec, mechanism_from_dict


def crank_rocker_mechanism(machine, revolutions: int = 2) -> MechanismSpec:
    """Mechanism description of the crank-rocker drive with its clearances (SI numbers).

    Bodies crank, rod, left comb, coupler and right comb in their positions at crank angle 0; the crank and
    rocker pins and the four-bar pins C and F are clearance joints where the machine gives them a clearance;
    the comb loads are rotational spring-dampers about the mid-stroke angles; the crank is driven at its speed
    (clockwise), or by the driveline when the machine is powered.

    Parameters
    ----------
    machine : CrankRockerMachine
        The machine description (checked with :func:`~berryshaker.drives.crank_rocker.kinematics.check_machine`).
    revolutions : int
        Crank revolutions to simulate (sets the simulation duration).

    Returns
    -------
    MechanismSpec
        The validated mechanism description.
    """
    check_machine(machine)
    cr, rod, ro = machine.crank, machine.rod, machine.rocker
    phi0 = 0.0
    rx, ry, px, py, thd = (float(v[0]) for v in rocker_position(phi0, machine))
    xd, yd = machine.shaft_D
    xe, ye = machine.shaft_E
    lc = machine.combs.length
    lcd, gam = ro.arm_CD, ro.arm_angle
    lcf, lfe = machine.four_bar.coupler_CF, machine.four_bar.arm_FE
    th4, the = (float(v[0]) for v in four_bar_position(thd + gam, machine.shaft_D, machine.shaft_E, lcd, lcf, lfe,
                                                        machine.four_bar.branch))
    cx, cy = xd + lcd * math.cos(thd + gam), yd + lcd * math.sin(thd + gam)
    th_rod = math.atan2(ry - py, rx - px)
    lr = rod.length
    bodies = [
        dict(name="crank", mass=cr.mass, inertia=cr.inertia, position=[0.0, 0.0], angle=phi0),
        dict(name="rod", mass=rod.mass, inertia=rod.mass * lr**2 / 12,
             position=[px + lr / 2 * math.cos(th_rod), py + lr / 2 * math.sin(th_rod)], angle=th_rod),
        dict(name="left_comb", mass=machine.combs.left_mass, inertia=machine.combs.left_mass * lc**2 / 12,
             position=[xd + lc / 2 * math.cos(thd), yd + lc / 2 * math.sin(thd)], angle=thd),
        dict(name="coupler", mass=machine.four_bar.coupler_mass, inertia=machine.four_bar.coupler_mass * lcf**2 / 12,
             position=[cx + lcf / 2 * math.cos(th4), cy + lcf / 2 * math.sin(th4)], angle=th4),
        dict(name="right_comb", mass=machine.combs.right_mass, inertia=machine.combs.right_mass * lc**2 / 12,
             position=[xe + lc / 2 * math.cos(the), ye + lc / 2 * math.sin(the)], angle=the),
    ]
    sizes = machine.clearance_sizes()

    def pin(name, body_i, body_j, point_i, point_j):
        return dict(name=name, type="revolute_clearance" if sizes[name] > 0 else "revolute", body_i=body_i,
                    body_j=body_j, point_i=point_i, point_j=point_j, clearance=sizes[name],
                    contact=machine.pair_contact(name).engine_contact() if sizes[name] > 0 else {})

    b = ro.arm_R
    joints = [
        dict(name="crank_bearing", type="revolute", body_i="ground", body_j="crank"),
        dict(name="shaft_D", type="revolute", body_i="ground", body_j="left_comb", point_i=[xd, yd],
             point_j=[-lc / 2, 0.0]),
        dict(name="shaft_E", type="revolute", body_i="ground", body_j="right_comb", point_i=[xe, ye],
             point_j=[-lc / 2, 0.0]),
        pin("crank_pin", "crank", "rod", [cr.radius, 0.0], [-lr / 2, 0.0]),
        pin("rocker_pin", "left_comb", "rod", [-lc / 2 + b * math.cos(ro.arm_R_angle), b * math.sin(ro.arm_R_angle)],
            [lr / 2, 0.0]),
        pin("C", "left_comb", "coupler", [-lc / 2 + lcd * math.cos(gam), lcd * math.sin(gam)], [-lcf / 2, 0.0]),
        pin("F", "right_comb", "coupler", [-lc / 2 + lfe, 0.0], [lcf / 2, 0.0]),
    ]
    td0, te0 = mid_stroke_angles(machine)
    forces = [
        dict(name="bush_left", body_i="left_comb", stiffness=machine.combs.load_stiffness,
             damping=machine.combs.load_damping, angle0=td0),
        dict(name="bush_right", body_i="right_comb", stiffness=machine.combs.load_stiffness,
             damping=machine.combs.load_damping, angle0=te0),
    ]
    period = 2 * math.pi / cr.speed
    spec = dict(
        mechanism=dict(name=f"{machine.machine.name} (multibody)", gravity=[0.0, 0.0]),
        bodies=bodies, joints=joints, forces=forces,
        drivers=[dict(name="drive", type="angle", body="crank", speed=-cr.speed, angle0=phi0)],
        simulation=dict(duration=revolutions * period, rtol=HARVESTER_RTOL, output_step=1e-4, max_step=2e-4,
                        velocity_scale=HARVESTER_VELOCITY_SCALE),
    )
    if is_powered(machine):  # the driveline turns the crank instead of the imposed speed (drives/powered.py)
        spec = powered_mechanism(spec, machine, "crank")
    return mechanism_from_dict(spec, "(crank-rocker harvester built from the machine)")
