"""A mechanism description compiled into the arrays of the compiled core (:mod:`berryshaker.multibody.kernel`): one
record per constraint block and per force element (:mod:`berryshaker.multibody.layout`), the bodies' masses, the
cams, the modal body, the contact laws and the solve plan, and the state and work arrays of a run.

The coordinates are the bodies' (x, y, phi), then the modal coordinates, then the auxiliary ones: one windup state
per geared spring-damper, then, with the energy audit, one energy accumulator per force element plus two
(:func:`berryshaker.multibody.force_elements.accumulator_start`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from berryshaker.contact.laws import get_law, law_table, slot_c
from berryshaker.contact.pin_in_bore import pin_in_bore_stiffness
from berryshaker.errors import ConfigError
from berryshaker.kinematics.cam import FOLLOWER_LAWS
from berryshaker.multibody import layout as L
from berryshaker.multibody.cam_pitch import FOOT_MEMORY
from berryshaker.multibody.model import MechanismModel
from berryshaker.multibody.sparsity import solve_plan
from berryshaker.multibody.spec import MechanismSpec


@dataclass
class CompiledMechanism:
    """A description (``spec``) compiled for the core: ``model`` is the record of arrays every compiled function
    takes (:class:`~berryshaker.multibody.model.MechanismModel`), the names, kinds and rows say which block or
    element is which, ``m`` and ``n`` count the constraint rows and coordinates, ``q0`` holds the bodies' positions
    of the description and ``period`` the first driver's revolution (statistics skip it; None without a turning
    driver).

    Attributes
    ----------
    spec : MechanismSpec
        The description.
    body_index : dict of str to int
        Each body's index.
    model : MechanismModel
        The arrays every compiled function takes, by name (:mod:`berryshaker.multibody.model`; SI).
    con_names, frc_names : list of str
        Names of the constraint blocks and of the force elements.
    con_rows : list of tuple of int
        First row and number of rows of each block.
    frc_kinds : list of str
        Kind of each force element.
    m, n : int
        Constraint rows and coordinates.
    q0 : numpy.ndarray
        The bodies' positions of the description (m, rad).
    period : float or None
        The first driver's revolution (s); None without a turning driver.
    n_base : int
        Coordinates of the bodies and modes (where the auxiliary coordinates begin).
    state_windup0 : list of float
        Initial windup of each geared element (rad).
    acc_start : int
        First energy accumulator (-1: no energy audit).
    """

    spec: MechanismSpec
    body_index: dict[str, int]
    model: MechanismModel
    con_names: list[str]  # one per constraint block
    con_rows: list[tuple[int, int]]  # (first row, number of rows)
    frc_names: list[str]
    frc_kinds: list[str]
    m: int
    n: int
    q0: np.ndarray
    period: float | None
    # powered drives: auxiliary coordinates after the bodies and modes (force_elements.accumulator_start)
    n_base: int = 0  # 3 x bodies + modes: where the auxiliary coordinates begin
    state_windup0: list[float] = field(default_factory=list)  # initial windup of each geared element, in order
    acc_start: int = -1  # first energy accumulator (-1: no energy audit)


def _cam_array(spec: MechanismSpec) -> tuple[np.ndarray, dict[str, int]]:
    cams = np.zeros((max(1, len(spec.cams)), L.N_CAM))
    idx = {}
    for i, c in enumerate(spec.cams):
        idx[c.name] = i
        cams[i, L.CAM_LAW] = FOLLOWER_LAWS[c.law]
        cams[i, L.CAM_STROKE] = c.stroke
        cams[i, L.CAM_RISE] = c.rise_angle
        cams[i, L.CAM_FAR] = c.far_dwell_angle
        cams[i, L.CAM_RETURN] = c.return_angle
        cams[i, L.CAM_S0] = math.sqrt(c.base_radius**2 - c.offset**2)
        cams[i, L.CAM_OFFSET] = c.offset
    return cams, idx


def _contact_law(c, stiffness) -> dict:
    """The contact-law slots of a contact element with contact description ``c`` (a ``ContactSpec``)."""
    law = get_law(c.law)
    return dict(law=law.code, monotone=float(law.monotone), k=stiffness, n=c.exponent, e=c.restitution,
                c=slot_c(c.law, c.damping, c.restitution_velocity), d=c.damping_depth)


def compile_mechanism(spec: MechanismSpec, ideal_clearances: bool = False) -> CompiledMechanism:
    """Turn a description into the arrays of the compiled core.

    With ``ideal_clearances`` every clearance joint becomes its ideal counterpart (used to assemble the
    initial configuration with the joints centred and to compute consistent initial velocities).

    Parameters
    ----------
    spec : MechanismSpec
        The mechanism description.
    ideal_clearances : bool
        Close every clearance joint to its ideal counterpart.

    Returns
    -------
    CompiledMechanism
        The core's arrays and the names of the blocks and elements.
    """
    bidx = {b.name: i for i, b in enumerate(spec.bodies)}
    bidx_g = dict(bidx, ground=-1)
    nb = len(spec.bodies)
    mass = np.array([b.mass for b in spec.bodies])
    inertia = np.array([b.inertia for b in spec.bodies])
    cams, cidx = _cam_array(spec)
    ctype, cint, cflt, crow, con_names, con_rows = [], [], [], [], [], []
    ftype, fint, fflt, frc_names, frc_kinds = [], [], [], [], []
    row = 0
    n_modes = len(spec.plant.omega) if spec.plant is not None else 0
    windup0 = []  # geared spring-dampers: their windup states follow the bodies and modes

    def add_con(name, typ, **slots):
        nonlocal row
        ints, flts = L.constraint_record(typ, **slots)
        ctype.append(typ)
        cint.append(ints)
        cflt.append(flts)
        crow.append(row)
        con_names.append(name)
        con_rows.append((row, L.CON_ROWS[typ]))
        row += L.CON_ROWS[typ]

    def add_frc(name, kind, typ, **slots):
        ints, flts = L.force_record(typ, **slots)
        ftype.append(typ)
        fint.append(ints)
        fflt.append(flts)
        frc_names.append(name)
        frc_kinds.append(kind)

    for j in spec.joints:
        bi, bj = bidx_g[j.body_i], bidx_g[j.body_j]
        u = np.array(j.axis, float) / math.hypot(*j.axis)
        points = dict(six=j.point_i[0], siy=j.point_i[1], sjx=j.point_j[0], sjy=j.point_j[1])
        typ = j.type
        if ideal_clearances:
            typ = {"revolute_clearance": "revolute", "slot_clearance": "point_on_line",
                   "groove_clearance": "cam_roller"}.get(typ, typ)
        if typ == "revolute":
            add_con(j.name, L.CON_REVOLUTE, body_i=bi, body_j=bj, **points)
        elif typ == "prismatic":
            ang_i = spec.bodies[bi].angle if bi >= 0 else 0.0
            ang_j = spec.bodies[bj].angle if bj >= 0 else 0.0
            sup = j.supports or (0.0, 1.0)
            add_con(j.name, L.CON_PRISMATIC, body_i=bi, body_j=bj, rel_angle=ang_j - ang_i,
                    mu=j.friction_coefficient, xig=sup[0], xih=sup[1], ux=u[0], uy=u[1], **points)
        elif typ == "point_on_line":
            add_con(j.name, L.CON_POINT_LINE, body_i=bi, body_j=bj, ux=u[0], uy=u[1], **points)
        elif typ == "cam_roller":
            add_con(j.name, L.CON_CAM_ROLLER, body_i=bi, body_j=bj, cam=cidx[j.cam], six=j.point_i[0],
                    siy=j.point_i[1])
        else:
            if typ == "revolute_clearance" and j.pin_radius > 0 and j.clearance >= j.pin_radius:
                raise ConfigError(f"joint {j.name!r}: clearance {j.clearance * 1e3:g} mm does not fit a pin of "
                                  f"radius {j.pin_radius * 1e3:g} mm (the bore would be over twice the pin)")
            c = j.contact
            k = c.stiffness
            if k == "hertz":
                if typ != "revolute_clearance":
                    raise ConfigError(f"joint {j.name!r}: give contact.stiffness (N/m^n); 'hertz' is "
                                      "computed only for pins in bores")
                if j.pin_radius <= 0:
                    raise ConfigError(f"joint {j.name!r}: contact.stiffness = 'hertz' needs pin_radius")
                k = pin_in_bore_stiffness(c.elastic_modulus, c.poisson_ratio, c.elastic_modulus,
                                          c.poisson_ratio, j.pin_radius, j.pin_radius + j.clearance)
            clearance = dict(body_i=bi, body_j=bj, pin_x=j.point_i[0], pin_y=j.point_i[1], clearance=j.clearance,
                             mu=j.friction_coefficient, **_contact_law(c, k))
            if typ == "revolute_clearance":
                add_frc(j.name, typ, L.FRC_REV_CL, bore_x=j.point_j[0], bore_y=j.point_j[1],
                        pin_radius=j.pin_radius, **clearance)
            elif typ == "slot_clearance":
                add_frc(j.name, typ, L.FRC_SLOT_CL, slot_x=j.point_j[0], slot_y=j.point_j[1], slot_ux=u[0],
                        slot_uy=u[1], **clearance)
            else:
                add_frc(j.name, typ, L.FRC_GROOVE_CL, cam=cidx.get(j.cam, 0) if j.cam else 0, **clearance)
    period = None
    for d in spec.drivers:
        b = bidx[d.body]
        phi0 = spec.bodies[b].angle if d.angle0 is None else d.angle0
        if d.type == "angle":
            add_con(d.name, L.CON_DRIVER, body_i=b, body_j=-1, angle0=phi0, speed=d.speed)
            if period is None and d.speed != 0:
                period = 2 * math.pi / abs(d.speed)
        elif d.type == "torque_speed":
            add_frc(d.name, "torque_speed", L.FRC_TORQUE_SPEED, body_i=b, body_j=-1, table_n=len(d.speeds),
                    table_speeds=d.speeds, table_torques=d.torques)
            if period is None and d.speed != 0:
                period = 2 * math.pi / abs(d.speed)  # statistics skip the first revolution of the source
        else:
            add_frc(d.name, "torque", L.FRC_TORQUE, body_i=b, torque=d.torque)
    for f in spec.forces:
        if f.type == "force":
            if bidx_g[f.body_i] < 0:
                raise ConfigError(f"force {f.name!r}: an applied force needs a moving body, not ground")
            add_frc(f.name, "force", L.FRC_FORCE, body_i=bidx_g[f.body_i], point_x=f.point[0], point_y=f.point[1],
                    force_x=f.force[0], force_y=f.force[1])
        elif f.type == "geared_spring_damper":
            add_frc(f.name, f.type, L.FRC_GEAR_SD, body_i=bidx_g[f.body_i], body_j=bidx_g[f.body_j],
                    windup=3 * nb + n_modes + len(windup0), gear_k=f.stiffness, gear_c=f.damping, ratio=f.ratio,
                    eta_f=f.efficiency_forward, eta_b=f.efficiency_back, creep=f.creep_compliance,
                    slip=f.slip_torque)
            windup0.append(f.windup0)
        else:
            add_frc(f.name, f.type, L.FRC_ROT_SD, body_i=bidx_g[f.body_i], body_j=bidx_g[f.body_j],
                    rsd_k=f.stiffness, rsd_c=f.damping, rsd_angle0=f.angle0)

    modal_w = np.zeros(0)
    modal_z = np.zeros(0)
    phi_tab = np.zeros((1, 1))
    plant_p = np.zeros(L.N_PLANT)
    if spec.plant is not None:
        pl = spec.plant
        modal_w = np.array(pl.omega, float)
        modal_z = (np.array(pl.damping_ratio, float) if isinstance(pl.damping_ratio, list)
                   else np.full(len(modal_w), pl.damping_ratio))
        phi_tab = np.array(pl.shapes, float)
        plant_p[L.PLANT_SPEED] = pl.walking_speed
        plant_p[L.PLANT_START] = pl.start_distance
        plant_p[L.PLANT_HALF_SPAN] = pl.half_span
        plant_p[L.PLANT_RAMP] = pl.ramp
        plant_p[L.PLANT_RAMP_DEPTH] = pl.ramp_depth
        ax, ay = np.array(pl.lateral_axis, float) / math.hypot(*pl.lateral_axis)
        for station_row, c in enumerate(pl.contacts):
            cc = pl.contact if c.contact is None else c.contact
            cx, cy = (ax, ay) if c.axis is None else np.array(c.axis, float) / math.hypot(*c.axis)
            # the modal columns its shape row touches (a bush member's own block): the kernel's sums skip the zeros
            nz = np.flatnonzero(phi_tab[station_row])
            first, end = (int(nz[0]), int(nz[-1]) + 1) if nz.size else (0, 0)
            add_frc(c.name, "branch_contact", L.FRC_BRANCH, body_i=bidx[c.body], branch_row=station_row,
                    branch_mode0=first, branch_mode_end=end, finger_x=c.finger_point[0], finger_y=c.finger_point[1],
                    branch_ux=cx, branch_uy=cy, engagement=c.engagement, side=float(c.side),
                    mid_lateral=c.mid_lateral, row_offset=c.row_offset, reaction=c.reaction_weight,
                    **_contact_law(cc, float(cc.stiffness)))

    def arr(x, shape, dtype):
        return np.array(x, dtype=dtype).reshape(shape) if len(x) else np.zeros(shape, dtype)

    con = dict(ctype=arr(ctype, (len(ctype),), np.int64), cint=arr(cint, (len(cint), L.N_CI), np.int64),
               cflt=arr(cflt, (len(cflt), L.N_CF), float), crow=arr(crow, (len(crow),), np.int64))
    model = MechanismModel(mass=mass, inertia=inertia, gravity=np.array(spec.mechanism.gravity, float), **con,
                           ftype=arr(ftype, (len(ftype),), np.int64), fint=arr(fint, (len(fint), L.N_FI), np.int64),
                           fflt=arr(fflt, (len(fflt), L.N_FF), float), cams=cams, modal_w=modal_w, modal_z=modal_z,
                           phi_tab=phi_tab, plant_p=plant_p, laws=law_table(),
                           plan=solve_plan(*con.values(), row, 3 * nb + len(modal_w)))
    audit = spec.simulation.energy_audit
    if audit is None:
        audit = any(d.type == "torque_speed" for d in spec.drivers)
    n_base = 3 * nb + len(modal_w)
    n_aux = len(windup0) + (len(ftype) + 2 if audit else 0)
    q0 = np.zeros(n_base + n_aux)
    for i, b in enumerate(spec.bodies):
        q0[3 * i:3 * i + 3] = [b.position[0], b.position[1], b.angle]
    return CompiledMechanism(spec, bidx, model, con_names, con_rows, frc_names, frc_kinds, row,
                             n_base + n_aux, q0, period, n_base, windup0,
                             n_base + len(windup0) if audit else -1)


def _state_and_work(cm: CompiledMechanism):
    nf = len(cm.frc_names)
    nc = len(cm.con_names)
    state = (np.zeros(max(nf, 1), np.bool_)[:nf], np.zeros(nf), np.full(nc, np.nan),
             np.concatenate([np.full(nf, np.nan), np.zeros((FOOT_MEMORY - 1) * nf)]),
             np.zeros(cm.m))
    mass, inertia = cm.model.mass, cm.model.inertia
    minv = np.ones(cm.n)  # modal coordinates are mass-normalised
    nb3 = 3 * len(mass)
    minv[0:nb3:3] = 1.0 / mass
    minv[1:nb3:3] = 1.0 / mass
    minv[2:nb3:3] = 1.0 / inertia
    work = (np.zeros(cm.m), np.zeros((cm.m, cm.n)), np.zeros(cm.m), np.zeros(cm.m), np.zeros(cm.n),
            np.zeros((nf, L.N_EO)), np.zeros(cm.m), minv, np.zeros((cm.m, cm.m)), np.zeros(cm.m))
    return state, work
