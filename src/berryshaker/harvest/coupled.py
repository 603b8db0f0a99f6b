"""Rigid-flexible coupling: the multibody harvester drives past a branch whose modal coordinates are part
of the same integrated state; the combs strike it through the IMPACT law and it pushes back (study
sec. 2.5, Figs. 24-26).  Output: fruit harvesting force at the root, middle and end of the branch against
the machine-to-plant distance, and the eq. 17 verdict per position.

This module builds the coupled machine-plant mechanism (:func:`coupled_mechanism`), reads the bush's load moment on
the combs from a run (:func:`comb_load_moment`) and runs the drive-past (:func:`simulate_fruit_force`,
:func:`drive_past`).  The modal bodies and the branch motion read from a run are berryshaker.harvest.coupled_branch's,
the fruit-force result berryshaker.harvest.fruit_force's; their public names are exported here too.
"""

from __future__ import annotations

import math

import numpy as np

from berryshaker.config import Machine
from berryshaker.drives import drive_of
from berryshaker.errors import ConfigError
from berryshaker.harvest.coupled_branch import BranchMotion, branch_motion, bush_members, plant_modes, stem_forces
from berryshaker.harvest.fruit_force import STUDY_FRUIT_FORCE_N, FruitForceResult
from berryshaker.harvest.spec import COUPLED_RTOL, COUPLED_VELOCITY_SCALE
from berryshaker.multibody import layout as mb
from berryshaker.multibody.engine import MultibodyResult, simulate_mechanism
from berryshaker.multibody.spec import mechanism_from_dict
from berryshaker.plant.bush import member_weight

__all__ = ["AGGREGATE_LOAD_FORCES", "STUDY_FRUIT_FORCE_N", "BranchMotion", "FruitForceResult", "branch_motion",
           "bush_members", "comb_load_moment", "coupled_mechanism", "drive_past", "plant_modes",
           "simulate_fruit_force", "stem_forces"]


#: names of the aggregate bush spring-dampers every drive's mechanism carries (``drives/*/mechanism.py``)
AGGREGATE_LOAD_FORCES = ("bush_left", "bush_right")


def _finger_points(machine, drive, ct):
    """Finger sections (body point, mid-stroke global position, shaft position, push side) of both combs."""
    lc = machine.combs.length
    rf = ct.finger_radius
    td0, te0 = drive.mid_stroke_angles(machine)
    xd, yd = machine.shaft_D
    xe, ye = machine.shaft_E
    # left comb: the finger section rf from D along the comb (the body's +x axis); pushes +x
    # right comb: the fingers point away from arm E->F (upwards); pushes -x
    return {"left": dict(body="left_comb", point=[-lc / 2 + rf, 0.0], side=1, shaft=(xd, yd),
                         mid=(xd + rf * math.cos(td0), yd + rf * math.sin(td0))),
            "right": dict(body="right_comb", point=[-lc / 2 - rf, 0.0], side=-1, shaft=(xe, ye),
                          mid=(xe - rf * math.cos(te0), ye - rf * math.sin(te0)))}


def coupled_mechanism(machine: Machine, clearance: dict[str, float] | None = None, margin: float = 0.15,
                      probes: tuple = (), probe_offsets: tuple = (), probes_in_error_norm: bool = True):
    """Harvester mechanism description with the machine's branch coupled to both combs.

    The run covers the instrumented branch's passage through the comb (its span plus ``margin`` either
    side); members standing elsewhere along the row enter or leave the comb during it, as the neighbours
    of a branch do.  The comb's load (``combs.load_model``): with ``"branches"`` (default) the bush population of
    ``plant.bush`` (berryshaker.plant.bush) joins the instrumented fruit branch in one block-diagonal
    modal body (each member's few modes, its own station, contact direction, contact stiffness and
    place along the row), each member acts back on its comb with weight branches / members (it stands for
    that many branches of the bush), and the drive's aggregate spring-dampers (``bush_left``,
    ``bush_right``) are removed, so the comb's load moment is the sum of the branch reactions (never both).
    With ``"aggregate"`` the spring-dampers stay.  In both the instrumented fruit branch is a probe: driven
    by the combs without acting back (in the bush it is one of the branches the sample represents), so the
    combs' motion does not depend on its modal model and its fruit forces converge with its modes.

    ``probes``: further machine descriptions whose instrumented fruit branch (``plant.contact.n_modes``,
    ``plant.fruit``) is carried in the same run as one more probe each -- its own modal block after the
    bush members, struck by both combs at the same stations, acting back on nothing.  Since no probe acts
    back, the combs' motion is the same for all of them, so the probes differ only by their own modal
    model: a comparison of modal models (convergence in modes, two-way against one-way fruit) free of the
    clearance chain's sensitivity to the step sequence (docs/plant.md, "Convergence with modes").  With
    ``probes_in_error_norm=False`` the probes' modes are left out of the integrator's step-size control
    (``plant.probe_modes``): the error norm is that of the machine, the bush and the instrumented branch, as in a
    run without probes (the branch classes of a replicate start, whose 22 more of 60 coordinates otherwise dilute
    the norm and loosen the machine's effective tolerance); a comparison of modal models keeps them in it, so that
    each probe's own integration error is controlled.  A probe is
    struck through the contact law of its own branch's diameter at the stations, so a probe may also be another
    branch class (berryshaker.harvest.virtual.stem_force_tables.class_tables_run).

    ``probe_offsets``: each probe's place along the row relative to the instrumented branch (m; default 0 each).  A
    probe at d passes the comb d / walking speed later than a probe at 0; the run then covers every branch's
    passage (from margin before the first to margin after the last), and the bush members stand centred on the
    branches (their row offsets moved by the middle of the smallest and the largest offset, 0 included).

    Parameters
    ----------
    machine : Machine
        Machine description with a [plant] block.
    clearance : dict of str to float, optional
        Clearance sizes (m) per pair; missing pairs keep the description's.
    margin : float
        Distance before and after the instrumented branch's span covered by the run (m).
    probes : tuple of Machine
        Further descriptions whose instrumented branch is carried as a probe (see above).
    probe_offsets : tuple of float
        Row offset of each probe relative to the instrumented branch (m); empty: all 0.
    probes_in_error_norm : bool
        Keep the probes' modes in the integrator's step-size control (see above).

    Returns
    -------
    spec : MechanismSpec
        The validated mechanism description with its modal plant body and comb-branch contacts.
    machine : Machine
        ``machine`` with the clearances applied.

    Raises
    ------
    ConfigError
        The description has no [plant] block, or ``probe_offsets`` is not one offset per probe.
    """
    if machine.plant is None:
        raise ConfigError("the machine description has no [plant] block (see `berryshaker config init`)")
    offsets = tuple(float(d) for d in probe_offsets) if probe_offsets else (0.0,) * len(probes)
    if len(offsets) != len(probes):
        raise ConfigError(f"coupled_mechanism: {len(offsets)} probe offsets for {len(probes)} probes")
    lo, hi = min((0.0, *offsets)), max((0.0, *offsets))
    machine = machine.with_clearances(clearance)
    drive = drive_of(machine)
    pl = machine.plant
    ct = pl.contact
    branches = machine.combs.load_model == "branches"
    members = bush_members(machine)
    half = ct.span / 2
    v = machine.operation.walking_speed
    duration = (2 * (half + margin) + hi - lo) / v
    period = 2 * math.pi / machine.drive_speed
    revolutions = max(2, int(math.ceil(duration / period)))
    spec = drive.mechanism(machine, revolutions=revolutions).model_dump()
    if branches:
        spec["forces"] = [f for f in spec["forces"] if f["name"] not in AGGREGATE_LOAD_FORCES]
    fingers = _finger_points(machine, drive, ct)
    k_contact, n_contact = _station_stiffness(machine)
    modes, fb = plant_modes(machine)
    nm = len(modes.omega)
    probe_modes = [plant_modes(p) for p in probes]
    n_total = nm + sum(len(mm.omega) for _, mm in members) + sum(len(pm.omega) for pm, _ in probe_modes)
    pad = [0.0] * (n_total - nm)
    contacts = [
        dict(name="comb_left", body="left_comb", finger_point=fingers["left"]["point"], station=ct.station_left,
             side=1, mid_lateral=fingers["left"]["mid"][0], engagement=ct.engagement, reaction_weight=0.0),
        dict(name="comb_right", body="right_comb", finger_point=fingers["right"]["point"],
             station=ct.station_right, side=-1, mid_lateral=fingers["right"]["mid"][0], engagement=ct.engagement,
             reaction_weight=0.0),
    ]
    shapes = [np.atleast_1d(modes.shape_at(st * pl.branch.length)).tolist() + pad
              for st in (ct.station_left, ct.station_right)]
    law = dict(law="impact", stiffness=k_contact, exponent=n_contact, damping=ct.damping,
               damping_depth=ct.penetration_depth)
    omega = modes.omega.tolist()
    zeta = (fb.damping_ratios.tolist() if fb is not None else [pl.branch.damping_ratio] * nm)
    col = nm
    weight = member_weight(pl.bush)  # each simulated member stands for this many branches of the bush
    for member, mm in members:
        f = fingers[member.comb]
        n = member.normal
        zc = member.station * member.branch.length
        k_m, n_m = ct.impact_stiffness(float(member.branch.diameter(zc)))
        row = [0.0] * n_total
        row[col:col + len(mm.omega)] = np.atleast_1d(mm.shape_at(zc)).tolist()
        col += len(mm.omega)
        shapes.append(row)
        omega += mm.omega.tolist()
        zeta += [member.branch.damping_ratio] * len(mm.omega)
        contacts.append(dict(
            name=member.name, body=f["body"], finger_point=f["point"], station=member.station, side=f["side"],
            # pen = side (n.p - n.p_mid) + lateral_offset: the offset folded into mid_lateral
            mid_lateral=n[0] * f["mid"][0] + n[1] * f["mid"][1] - f["side"] * member.lateral_offset,
            axis=list(n), row_offset=member.row_offset + (lo + hi) / 2,
            contact=dict(law, stiffness=k_m, exponent=n_m),
            reaction_weight=weight))
    for i, (pm, pfb) in enumerate(probe_modes):
        k_p, n_p = _station_stiffness(probes[i])
        for c in contacts[:2]:  # the instrumented branch's two contacts, repeated on the probe's own block
            row = [0.0] * n_total
            z = c["station"] * probes[i].plant.branch.length
            row[col:col + len(pm.omega)] = np.atleast_1d(pm.shape_at(z)).tolist()
            shapes.append(row)
            contacts.append(dict(c, name=f"{c['name']}_probe{i + 1}", row_offset=offsets[i],
                                 contact=dict(law, stiffness=k_p, exponent=n_p)))
        col += len(pm.omega)
        omega += pm.omega.tolist()
        zeta += (pfb.damping_ratios.tolist() if pfb is not None
                 else [probes[i].plant.branch.damping_ratio] * len(pm.omega))
    spec["plant"] = dict(
        omega=omega, damping_ratio=zeta if (fb is not None or members or probes) else pl.branch.damping_ratio,
        shapes=shapes, lateral_axis=[1.0, 0.0], walking_speed=v,
        start_distance=lo - (half + margin), half_span=half, ramp=min(0.1, half / 2), ramp_depth=0.2,
        contact=law, contacts=contacts,
        probe_modes=0 if probes_in_error_norm else sum(len(pm.omega) for pm, _ in probe_modes))
    spec["simulation"]["duration"] = duration
    # the coupled runs' velocity scale is their own, studied with their tolerance (COUPLED_VELOCITY_SCALE)
    spec["simulation"]["velocity_scale"] = COUPLED_VELOCITY_SCALE
    spec["mechanism"]["name"] = f"{machine.machine.name} + branch (rigid-flexible coupling)"
    if fb is not None and not members and not probes:
        try:
            out = mechanism_from_dict(spec, "(harvester + branch)")
        except ConfigError as err:
            if "damping_ratio" not in str(err):
                raise
            # an engine taking one ratio only gets the branch's
            spec["plant"]["damping_ratio"] = pl.branch.damping_ratio
            out = mechanism_from_dict(spec, "(harvester + branch)")
        return out, machine
    out = mechanism_from_dict(spec, "(harvester + branch)")
    return out, machine


def _station_stiffness(machine: Machine) -> tuple[float, float]:
    """Contact stiffness (N/m^n) and exponent of the comb on the machine's branch at the middle of its two stations
    (``plant.contact.impact_stiffness`` at the branch's diameter there)."""
    pl = machine.plant
    ct = pl.contact
    station = 0.5 * (ct.station_left + ct.station_right) * pl.branch.length
    return ct.impact_stiffness(pl.branch.root_diameter * (1 - (1 - pl.branch.tip_diameter / pl.branch.root_diameter)
                                                          * station / pl.branch.length))


def comb_load_moment(res: MultibodyResult, machine: Machine) -> dict[str, np.ndarray]:
    """Moment of the bush on each comb about its shaft (N m, counter-clockwise positive), per output time.

    ``"branches"``: the sum over the comb's branch contacts of (finger point - shaft) x (force on the comb),
    the force on the comb being -side F_n n (F_n the contact's normal force, n its direction), times the
    contact's reaction weight (branches / members for a sampled member, 0 for the instrumented fruit
    branch, which is driven without acting back).  ``"aggregate"``: the spring-damper's moment
    (``bush_left``, ``bush_right``).

    Parameters
    ----------
    res : MultibodyResult
        A coupled run (:func:`coupled_mechanism`).
    machine : Machine
        Its machine description (load model and shaft positions).

    Returns
    -------
    dict of str to numpy.ndarray
        ``left`` and ``right`` -> moment on the comb (N m) at each output time (a side without contacts or
        spring-damper is absent).
    """
    cm = res.compiled
    spec = cm.spec
    out = {}
    if machine.combs.load_model == "aggregate":
        for side, name in (("left", "bush_left"), ("right", "bush_right")):
            if name in cm.frc_names:
                out[side] = res.elements[:, cm.frc_names.index(name), mb.EO_FN].copy()
        return out
    bidx = {b.name: i for i, b in enumerate(spec.bodies)}
    shafts = {"left_comb": machine.shaft_D, "right_comb": machine.shaft_E}
    axis0 = np.array(spec.plant.lateral_axis, float) / math.hypot(*spec.plant.lateral_axis)
    for c in spec.plant.contacts:
        if c.reaction_weight == 0:
            continue
        b = bidx[c.body]
        x, y, phi = res.y[:, 3 * b], res.y[:, 3 * b + 1], res.y[:, 3 * b + 2]
        px = x + np.cos(phi) * c.finger_point[0] - np.sin(phi) * c.finger_point[1]
        py = y + np.sin(phi) * c.finger_point[0] + np.cos(phi) * c.finger_point[1]
        n = axis0 if c.axis is None else np.array(c.axis, float) / math.hypot(*c.axis)
        fn = res.elements[:, cm.frc_names.index(c.name), mb.EO_FN]
        fx, fy = -c.reaction_weight * c.side * fn * n[0], -c.reaction_weight * c.side * fn * n[1]
        sx, sy = shafts[c.body]
        side = "left" if c.body == "left_comb" else "right"
        out[side] = out.get(side, 0.0) + (px - sx) * fy - (py - sy) * fx
    return out


def simulate_fruit_force(machine: Machine, clearance: dict[str, float] | None = None, rtol: float = COUPLED_RTOL,
                         output_step: float = 2e-5, initial_perturbation=None, probes: tuple = ()) -> FruitForceResult:
    """Drive the harvester past one branch and record the fruit harvesting force.

    With the pedicel model (default) the force is the stem force of a fruit on a compliant stem
    (berryshaker.plant.pedicel; lateral: two-way coupled inside the modal model, or one-way by
    post-processing with ``pedicel.coupling = "one_way"``; axial: one-way, from the branch's
    foreshortening); with ``plant.fruit.pedicel.rigid`` it is the study's
    eq. 16, m0 x branch acceleration at the fruit.  Both are returned (``rigid_force`` is always eq. 16).
    ``initial_perturbation`` (berryshaker.multibody.perturbation.InitialPerturbation or RandomInitialPerturbation):
    start the machine off centre in its clearances and at another drive phase (replicate runs).
    ``probes``: machine descriptions differing from ``machine`` only in the instrumented branch's modal model
    (``plant.contact.n_modes``) or its fruit (``plant.fruit``), carried in the same run as further probes
    (:func:`coupled_mechanism`); their results, in order, are in the returned result's ``probes``.

    Parameters
    ----------
    machine : Machine
        Machine description with a [plant] block.
    clearance : dict of str to float, optional
        Clearance sizes (m) per pair; missing pairs keep the description's.
    rtol : float
        Relative integrator tolerance (dimensionless).
    output_step : float
        Output sampling step (s).
    initial_perturbation : InitialPerturbation or RandomInitialPerturbation, optional
        Start off centre and at another drive phase (default the centred start).
    probes : tuple of Machine
        Descriptions carried as probes (see above).

    Returns
    -------
    FruitForceResult
        Fruit forces, contact forces, deflections and comb load moments of the run, with the probes' results.

    Raises
    ------
    ConfigError
        A probe differs from ``machine`` elsewhere than ``plant.contact.n_modes`` and ``plant.fruit``.
    """
    for i, p in enumerate(probes):
        same = p.model_dump()
        ref = machine.model_dump()
        same["plant"]["contact"]["n_modes"] = ref["plant"]["contact"]["n_modes"]
        same["plant"]["fruit"] = ref["plant"]["fruit"]
        if same != ref:
            raise ConfigError(f"probe {i + 1}: a probe may differ from the machine only in plant.contact.n_modes and "
                              "plant.fruit (the combs, the branch and its contact are shared)")
    spec, machine = coupled_mechanism(machine, clearance, probes=tuple(probes))
    res = simulate_mechanism(spec, rtol=rtol, output_step=output_step, initial_perturbation=initial_perturbation)
    out = _fruit_result(res, spec, machine, 0)
    out.load_moment = comb_load_moment(res, machine)
    offset = len(out.motion.modes.omega) + sum(len(mm.omega) for _, mm in bush_members(machine))
    for p in probes:
        p = p.with_clearances(clearance)
        pr = _fruit_result(res, spec, p, offset)
        offset += len(pr.motion.modes.omega)
        out.probes.append(pr)
    return out


def drive_past(machine: Machine, clearance: dict[str, float] | None = None, rtol: float = COUPLED_RTOL,
               output_step: float = 2e-5, initial_perturbation=None) -> tuple[MultibodyResult, BranchMotion]:
    """The coupled drive-past of :func:`simulate_fruit_force` without its post-processing at the named fruit
    positions: ``(result, motion)``, the multibody result and the instrumented branch's modal solution
    (:class:`~berryshaker.harvest.coupled_branch.BranchMotion`), for callers that evaluate the branch elsewhere
    (the stem-force envelopes over the whole fruit zone,
    berryshaker.harvest.virtual.stem_force_tables.stem_force_envelope_run).  The same run, step for step, as :func:`simulate_fruit_force` with the same arguments (no probes): the fruit forces, the comb load
    moments and their summary are left out (~40 ms of a replicate's ~0.5 s).

    Parameters
    ----------
    machine : Machine
        Machine description with a [plant] block.
    clearance : dict of str to float, optional
        Clearance sizes (m) per pair; missing pairs keep the description's.
    rtol : float
        Relative integrator tolerance (dimensionless).
    output_step : float
        Output sampling step (s).
    initial_perturbation : InitialPerturbation or RandomInitialPerturbation, optional
        Start off centre and at another drive phase (default the centred start).

    Returns
    -------
    result : MultibodyResult
        The multibody run.
    motion : BranchMotion
        The instrumented branch's modal solution.
    """
    spec, machine = coupled_mechanism(machine, clearance)
    res = simulate_mechanism(spec, rtol=rtol, output_step=output_step, initial_perturbation=initial_perturbation)
    modes, _ = plant_modes(machine)
    return res, branch_motion(res, modes, 0)


def _fruit_result(res: MultibodyResult, spec, machine: Machine, offset: int) -> FruitForceResult:
    """Fruit forces of the branch whose modal block starts at ``offset`` (the instrumented branch: 0, a probe:
    after the bush members) in a coupled run (:func:`simulate_fruit_force`)."""
    pl = machine.plant
    modes, fb = plant_modes(machine)
    motion = branch_motion(res, modes, offset)
    ped = pl.fruit.pedicel
    m0 = pl.fruit.mass
    fruit, rigid, zs, defl, lat, ax = {}, {}, {}, {}, {}, {}
    names = list(pl.fruit.names)
    zarr = np.array([frac * pl.branch.length for frac in pl.fruit.positions])
    y, _, a = motion.lateral(zarr)
    if not ped.rigid:
        f_lat, f_ax, f_mag = stem_forces(motion, zarr, m0, ped)
        if fb is not None:  # two-way: the fruit are in the modal model, their stem force is exact
            f_lat = fb.stem_force(motion.eta, motion.etad)
            f_mag = np.hypot(f_lat, f_ax)
    for i, name in enumerate(names):
        zs[name] = float(zarr[i])
        defl[name] = y[i]
        rigid[name] = m0 * a[i]
        if ped.rigid:
            fruit[name] = rigid[name]
        else:
            fruit[name], lat[name], ax[name] = f_mag[i], f_lat[i], f_ax[i]
    distance = spec.plant.start_distance + spec.plant.walking_speed * res.t
    out = FruitForceResult(distance, res.t, fruit, zs, motion.contact_force, defl, res, machine, rigid, lat, ax)
    out.motion = motion
    return out
