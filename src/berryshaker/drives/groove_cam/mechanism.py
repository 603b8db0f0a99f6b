"""The harvester drive as a planar multibody mechanism (the study's ADAMS model, built from a Machine).

Bodies: cam (driven clockwise at the cam speed), push rod (prismatic guide with friction), left comb
(pivot D, slot for roller B), connecting rod CF, right comb (pivot E).  A pair with a clearance > 0
becomes a clearance joint with a contact law; a pair with zero clearance is the ideal joint
(cam_roller, point_on_line, revolute).  The bush acts on each comb as the same viscoelastic moment as
in the MLSD model.  Contact law: the pair's resolved law (:meth:`MachineBase.pair_contact`): by default the
steel line-contact power law from its geometry with Lankarani-Nikravesh hysteresis damping; a pair that gives
its linear stiffness K_i keeps the ADAMS IMPACT function (cmax = C_i, full damping at 0.01 mm) of 0.1.0.
"""

from __future__ import annotations

import math

from berryshaker.drives.base import HARVESTER_RTOL, HARVESTER_VELOCITY_SCALE
from berryshaker.drives.groove_cam.kinematics import geometry_vector, ideal_state, mid_stroke_angles, require_buildable
from berryshaker.drives.groove_cam.machine import GrooveCamMachine as Machine
from berryshaker.drives.powered import is_powered, powered_mechanism
from berryshaker.multibody.spec import MechanismSpec, mechanism_from_dict

CAM_MASS = 8.0  # kg [assumed]; the cam is driven at constant speed, so its mass only loads its bearing


def harvester_mechanism(machine: Machine, revolutions: int = 2) -> MechanismSpec:
    """Mechanism description of the groove-cam drive with its clearances (SI numbers).

    Each clearance pair's contact law and parameters are resolved from the machine description
    (``[clearance.<pair>]``; :meth:`~berryshaker.drives.base.MachineBase.pair_contact`).

    Parameters
    ----------
    machine : GrooveCamMachine
        The machine description (SI inside).
    revolutions : int
        Cam revolutions to simulate (>= 1): the mechanism's duration is ``revolutions`` cam periods.

    Returns
    -------
    MechanismSpec
        Bodies, joints (the clearance pairs with their contact laws), drivers and forces, in SI units.
    """
    require_buildable(machine)
    g = geometry_vector(machine)
    c = machine.cam
    ok, s, v, a, thd, wd, ad, th4, w4, a4, the, we, ae = ideal_state(0.0, g)
    xd, yd = machine.shaft_D
    xe, ye = machine.shaft_E
    lab = machine.push_rod.length
    lc = machine.combs.length
    lcd, gam = machine.rocker.arm_CD, machine.rocker.arm_angle
    lcf, lfe = machine.four_bar.coupler_CF, machine.four_bar.arm_FE
    cx, cy = xd + lcd * math.cos(thd + gam), yd + lcd * math.sin(thd + gam)
    td0, te0 = mid_stroke_angles(machine)
    bodies = [
        dict(name="cam", mass=CAM_MASS, inertia=c.inertia, position=[0.0, 0.0], angle=0.0),
        dict(name="push_rod", mass=machine.push_rod.mass, inertia=machine.push_rod.mass * lab**2 / 12,
             position=[c.s0 + s + lab / 2, c.offset], angle=0.0),
        dict(name="left_comb", mass=machine.combs.left_mass, inertia=machine.combs.left_mass * lc**2 / 12,
             position=[xd + lc / 2 * math.cos(thd), yd + lc / 2 * math.sin(thd)], angle=thd),
        dict(name="coupler", mass=machine.four_bar.coupler_mass,
             inertia=machine.four_bar.coupler_mass * lcf**2 / 12,
             position=[cx + lcf / 2 * math.cos(th4), cy + lcf / 2 * math.sin(th4)], angle=th4),
        dict(name="right_comb", mass=machine.combs.right_mass, inertia=machine.combs.right_mass * lc**2 / 12,
             position=[xe + lc / 2 * math.cos(the), ye + lc / 2 * math.sin(the)], angle=the),
    ]
    xg, xh = machine.push_rod.bearing_G_x, machine.push_rod.bearing_H_x
    joints = [
        dict(name="cam_bearing", type="revolute", body_i="ground", body_j="cam"),
        dict(name="guide", type="prismatic", body_i="ground", body_j="push_rod", point_i=[0.0, c.offset],
             axis=[1.0, 0.0], friction_coefficient=machine.push_rod.friction_coefficient, supports=[xg, xh]),
        dict(name="shaft_D", type="revolute", body_i="ground", body_j="left_comb", point_i=[xd, yd],
             point_j=[-lc / 2, 0.0]),
        dict(name="shaft_E", type="revolute", body_i="ground", body_j="right_comb", point_i=[xe, ye],
             point_j=[-lc / 2, 0.0]),
    ]

    def contact(pair):
        if machine.clearance[pair].size <= 0:  # an ideal joint: no contact law
            return {}
        return machine.pair_contact(pair).engine_contact()

    sizes = machine.clearance_sizes()
    pin_a = [-lab / 2, 0.0]
    joints.append(dict(name="A", type="groove_clearance" if sizes["A"] > 0 else "cam_roller", body_i="push_rod",
                       body_j="cam", point_i=pin_a, cam="groove", clearance=sizes["A"], contact=contact("A")))
    joints.append(dict(name="B", type="slot_clearance" if sizes["B"] > 0 else "point_on_line", body_i="push_rod",
                       body_j="left_comb", point_i=[lab / 2, 0.0], point_j=[-lc / 2, 0.0], axis=[1.0, 0.0],
                       clearance=sizes["B"], contact=contact("B")))
    joints.append(dict(name="C", type="revolute_clearance" if sizes["C"] > 0 else "revolute", body_i="left_comb",
                       body_j="coupler", point_i=[-lc / 2 + lcd * math.cos(gam), lcd * math.sin(gam)],
                       point_j=[-lcf / 2, 0.0], clearance=sizes["C"], contact=contact("C")))
    joints.append(dict(name="F", type="revolute_clearance" if sizes["F"] > 0 else "revolute", body_i="right_comb",
                       body_j="coupler", point_i=[-lc / 2 + lfe, 0.0], point_j=[lcf / 2, 0.0],
                       clearance=sizes["F"], contact=contact("F")))
    forces = [
        dict(name="bush_left", body_i="left_comb", stiffness=machine.combs.load_stiffness,
             damping=machine.combs.load_damping, angle0=td0),
        dict(name="bush_right", body_i="right_comb", stiffness=machine.combs.load_stiffness,
             damping=machine.combs.load_damping, angle0=te0),
    ]
    period = 2 * math.pi / c.speed
    spec = dict(
        mechanism=dict(name=f"{machine.machine.name} (multibody)", gravity=[0.0, 0.0]),
        bodies=bodies, joints=joints, forces=forces,
        drivers=[dict(name="drive", type="angle", body="cam", speed=-c.speed, angle0=0.0)],
        cams=[dict(name="groove", law=c.law, base_radius=c.base_radius, offset=c.offset, stroke=c.stroke,
                   rise_angle=c.rise_angle, far_dwell_angle=c.far_dwell_angle, return_angle=c.return_angle)],
        simulation=dict(duration=revolutions * period, rtol=HARVESTER_RTOL, output_step=1e-4, max_step=2e-4,
                        velocity_scale=HARVESTER_VELOCITY_SCALE),
    )
    if is_powered(machine):  # the driveline turns the cam instead of the imposed speed (drives/powered.py)
        spec = powered_mechanism(spec, machine, "cam")
    return mechanism_from_dict(spec, "(harvester built from the machine)")
