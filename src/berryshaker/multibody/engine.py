"""Running a mechanism description through the compiled multibody core (berryshaker.multibody.kernel).

long module: compiling a description into the kernel's arrays, assembling its initial state, the result object
and the run set-up all depend on one array layout (coordinates, constraint rows, force elements, auxiliary
states); perturbed starts live in berryshaker.multibody.perturbation.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from berryshaker.compiled_cache import kernel_choice
from berryshaker.contact.laws import LawEntryPoint, get_law, law_table, slot_c
from berryshaker.contact.stiffness import pin_in_bore_stiffness
from berryshaker.errors import ConfigError, GeometryError, SimulationError
from berryshaker.kinematics.cam import FOLLOWER_LAWS
from berryshaker.multibody import kernel as mb
from berryshaker.multibody.sparsity import solve_plan
from berryshaker.multibody.spec import MechanismSpec

if TYPE_CHECKING:
    from berryshaker.multibody.perturbation import InitialPerturbation, RandomInitialPerturbation


@dataclass
class CompiledMechanism:
    spec: MechanismSpec
    body_index: dict[str, int]
    model: tuple
    con_names: list[str]  # one per constraint block
    con_rows: list[tuple[int, int]]  # (first row, number of rows)
    frc_names: list[str]
    frc_kinds: list[str]
    m: int
    n: int
    q0: np.ndarray
    period: float | None
    # powered drives: auxiliary coordinates after the bodies and modes (kernel.accumulator_start)
    n_base: int = 0  # 3 x bodies + modes: where the auxiliary coordinates begin
    state_windup0: list[float] = field(default_factory=list)  # initial windup of each geared element, in order
    acc_start: int = -1  # first energy accumulator (-1: no energy audit)


def _cam_array(spec: MechanismSpec) -> tuple[np.ndarray, dict[str, int]]:
    cams = np.zeros((max(1, len(spec.cams)), 7))
    idx = {}
    for i, c in enumerate(spec.cams):
        idx[c.name] = i
        cams[i] = [FOLLOWER_LAWS[c.law], c.stroke, c.rise_angle, c.far_dwell_angle, c.return_angle,
                   math.sqrt(c.base_radius**2 - c.offset**2), c.offset]
    return cams, idx


def compile_mechanism(spec: MechanismSpec, ideal_clearances: bool = False) -> CompiledMechanism:
    """Turn a description into the arrays of the compiled core.

    With ``ideal_clearances`` every clearance joint becomes its ideal counterpart (used to assemble the
    initial configuration with the joints centred and to compute consistent initial velocities).
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

    def add_con(name, typ, bi, bj, cam=0, **vals):
        nonlocal row
        f = np.zeros(mb.N_CF)
        for key, v in vals.items():
            f[getattr(mb, "CF_" + key.upper())] = v
        ctype.append(typ)
        cint.append([bi, bj, cam])
        cflt.append(f)
        crow.append(row)
        con_names.append(name)
        con_rows.append((row, mb.CON_ROWS[typ]))
        row += mb.CON_ROWS[typ]

    def add_frc(name, kind, typ, bi, bj, cam=0, law=0, end=0, **vals):
        f = np.zeros(mb.N_FF)
        for key, v in vals.items():
            f[getattr(mb, "FF_" + key.upper())] = v
        ftype.append(typ)
        fint.append([bi, bj, cam, law, end])
        fflt.append(f)
        frc_names.append(name)
        frc_kinds.append(kind)

    for j in spec.joints:
        bi, bj = bidx_g[j.body_i], bidx_g[j.body_j]
        u = np.array(j.axis, float) / math.hypot(*j.axis)
        common = dict(six=j.point_i[0], siy=j.point_i[1], sjx=j.point_j[0], sjy=j.point_j[1], ux=u[0], uy=u[1])
        typ = j.type
        if ideal_clearances:
            typ = {"revolute_clearance": "revolute", "slot_clearance": "point_on_line",
                   "groove_clearance": "cam_roller"}.get(typ, typ)
        if typ == "revolute":
            add_con(j.name, mb.CON_REVOLUTE, bi, bj, **common)
        elif typ == "prismatic":
            ang_i = spec.bodies[bi].angle if bi >= 0 else 0.0
            ang_j = spec.bodies[bj].angle if bj >= 0 else 0.0
            sup = j.supports or (0.0, 1.0)
            add_con(j.name, mb.CON_PRISMATIC, bi, bj, phi0=ang_j - ang_i, mu=j.friction_coefficient,
                    xig=sup[0], xih=sup[1], **common)
        elif typ == "point_on_line":
            add_con(j.name, mb.CON_POINT_LINE, bi, bj, **common)
        elif typ == "cam_roller":
            add_con(j.name, mb.CON_CAM_ROLLER, bi, bj, cam=cidx[j.cam], **common)
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
            code = {"revolute_clearance": mb.FRC_REV_CL, "slot_clearance": mb.FRC_SLOT_CL,
                    "groove_clearance": mb.FRC_GROOVE_CL}[typ]
            add_frc(j.name, typ, code, bi, bj, cam=cidx.get(j.cam, 0) if j.cam else 0,
                    law=get_law(c.law).code, monotone=float(get_law(c.law).monotone), gap=j.clearance, k=k,
                    n=c.exponent, e=c.restitution,
                    c=slot_c(c.law, c.damping, c.restitution_velocity), d=c.damping_depth,
                    mu=j.friction_coefficient, rpin=j.pin_radius, **common)
    period = None
    for d in spec.drivers:
        b = bidx[d.body]
        phi0 = spec.bodies[b].angle if d.angle0 is None else d.angle0
        if d.type == "angle":
            add_con(d.name, mb.CON_DRIVER, b, -1, phi0=phi0, speed=d.speed)
            if period is None and d.speed != 0:
                period = 2 * math.pi / abs(d.speed)
        elif d.type == "torque_speed":
            add_frc(d.name, "torque_speed", mb.FRC_TORQUE_SPEED, b, -1, ntab=len(d.speeds))
            fflt[-1][mb.FF_TAB:mb.FF_TAB + len(d.speeds)] = d.speeds
            fflt[-1][mb.FF_TAB + mb.MAX_TABLE:mb.FF_TAB + mb.MAX_TABLE + len(d.torques)] = d.torques
            if period is None and d.speed != 0:
                period = 2 * math.pi / abs(d.speed)  # statistics skip the first revolution of the source
        else:
            add_frc(d.name, "torque", mb.FRC_TORQUE, b, -1, torque=d.torque)
    for f in spec.forces:
        if f.type == "force":
            if bidx_g[f.body_i] < 0:
                raise ConfigError(f"force {f.name!r}: an applied force needs a moving body, not ground")
            add_frc(f.name, "force", mb.FRC_FORCE, bidx_g[f.body_i], -1, six=f.point[0], siy=f.point[1],
                    ux=f.force[0], uy=f.force[1])
        elif f.type == "geared_spring_damper":
            add_frc(f.name, f.type, mb.FRC_GEAR_SD, bidx_g[f.body_i], bidx_g[f.body_j],
                    cam=3 * nb + n_modes + len(windup0), k=f.stiffness, c=f.damping, ratio=f.ratio,
                    eta_f=f.efficiency_forward, eta_b=f.efficiency_back, creep=f.creep_compliance,
                    slip=f.slip_torque)  # fint[., 2] holds the coordinate of its windup state
            windup0.append(f.windup0)
        else:
            add_frc(f.name, f.type, mb.FRC_ROT_SD, bidx_g[f.body_i], bidx_g[f.body_j], k=f.stiffness, c=f.damping,
                    phi0=f.angle0)

    modal_w = np.zeros(0)
    modal_z = np.zeros(0)
    phi_tab = np.zeros((1, 1))
    plant_p = np.zeros(5)
    if spec.plant is not None:
        pl = spec.plant
        modal_w = np.array(pl.omega, float)
        modal_z = (np.array(pl.damping_ratio, float) if isinstance(pl.damping_ratio, list)
                   else np.full(len(modal_w), pl.damping_ratio))
        phi_tab = np.array(pl.shapes, float)
        plant_p = np.array([pl.walking_speed, pl.start_distance, pl.half_span, pl.ramp, pl.ramp_depth])
        ax, ay = np.array(pl.lateral_axis, float) / math.hypot(*pl.lateral_axis)
        for station_row, c in enumerate(pl.contacts):
            cc = pl.contact if c.contact is None else c.contact
            cx, cy = (ax, ay) if c.axis is None else np.array(c.axis, float) / math.hypot(*c.axis)
            # the modal columns its shape row touches (a bush member's own block): the kernel's sums skip the zeros
            nz = np.flatnonzero(phi_tab[station_row])
            first, end = (int(nz[0]), int(nz[-1]) + 1) if nz.size else (0, 0)
            add_frc(c.name, "branch_contact", mb.FRC_BRANCH, bidx[c.body], station_row, cam=first, end=end,
                    law=get_law(cc.law).code, monotone=float(get_law(cc.law).monotone),
                    six=c.finger_point[0], siy=c.finger_point[1], ux=cx, uy=cy, gap=c.engagement,
                    k=float(cc.stiffness), n=cc.exponent, e=cc.restitution,
                    c=slot_c(cc.law, cc.damping, cc.restitution_velocity), d=cc.damping_depth,
                    rpin=float(c.side), phi0=c.mid_lateral, row=c.row_offset, react=c.reaction_weight)
            # fint[., 1] holds the phi_tab row of a branch contact, fint[., 2:5:2] its nonzero columns

    def arr(x, shape, dtype):
        return np.array(x, dtype=dtype).reshape(shape) if len(x) else np.zeros(shape, dtype)

    con = (arr(ctype, (len(ctype),), np.int64), arr(cint, (len(cint), 3), np.int64),
           arr(cflt, (len(cflt), mb.N_CF), float), arr(crow, (len(crow),), np.int64))
    model = (mass, inertia, np.array(spec.mechanism.gravity, float), *con,
             arr(ftype, (len(ftype),), np.int64), arr(fint, (len(fint), 5), np.int64),
             arr(fflt, (len(fflt), mb.N_FF), float), cams, modal_w, modal_z, phi_tab, plant_p, law_table(),
             solve_plan(*con, row, 3 * nb + len(modal_w)))
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
             np.concatenate([np.full(nf, np.nan), np.zeros((mb.FOOT_MEMORY - 1) * nf)]),
             np.zeros(cm.m))
    mass, inertia = cm.model[0], cm.model[1]
    minv = np.ones(cm.n)  # modal coordinates are mass-normalised
    nb3 = 3 * len(mass)
    minv[0:nb3:3] = 1.0 / mass
    minv[1:nb3:3] = 1.0 / mass
    minv[2:nb3:3] = 1.0 / inertia
    work = (np.zeros(cm.m), np.zeros((cm.m, cm.n)), np.zeros(cm.m), np.zeros(cm.m), np.zeros(cm.n),
            np.zeros((nf, mb.N_EO)), np.zeros(cm.m), minv, np.zeros((cm.m, cm.m)), np.zeros(cm.m))
    return state, work


def initial_state(spec: MechanismSpec, q_start: np.ndarray | None = None) -> np.ndarray:
    """Assembled positions and consistent velocities with every clearance joint centred (ideal).

    Torque-driven bodies start at their driver's ``speed``.  Powered drives: a ``torque_speed`` driver's body
    starts at its ``speed``, and a body driven through a geared spring-damper at the speed that keeps the windup
    constant, omega_j = omega_i (1 - creep k psi0) / ratio (propagated along the chain of gears); every windup
    starts at its ``windup0`` and every energy accumulator at zero.
    ``q_start``: positions the Newton assembly starts from (default: the bodies' positions and angles in
    ``spec``; the body coordinates only).
    """
    ideal = compile_mechanism(spec, ideal_clearances=True)
    target = compile_mechanism(spec) if ideal.n > ideal.n_base else ideal  # layout of the auxiliary coordinates
    # temporary speed constraints for torque-driven bodies, so that the velocity projection is determined
    data = _speed_driver_spec(spec)
    if data is not None:
        from berryshaker.multibody.spec import mechanism_from_dict

        ideal = compile_mechanism(mechanism_from_dict(data), ideal_clearances=True)
    state, work = _state_and_work(ideal)
    y = np.concatenate([ideal.q0 if q_start is None else np.array(q_start, float), np.zeros(ideal.n)])
    res = 0.0
    if ideal.m:
        res = call_compiled(mb.project, 0.0, y, ideal.model, state, work, 60)
        if not (res < 1e-9):
            mb.constraints(0.0, y[:ideal.n], y[ideal.n:], *ideal.model[3:7], ideal.model[10], state[2],
                           work[0], work[1], work[2], work[3])
            worst = int(np.argmax(np.abs(work[0])))
            name = next(n for n, (r0, nr) in zip(ideal.con_names, ideal.con_rows) if r0 <= worst < r0 + nr)
            raise GeometryError(f"the mechanism cannot assemble: joint {name!r} stays {abs(work[0][worst]):.3g} "
                                "(m or rad) from closing; check its points and the bodies' initial positions")
    if ideal.n != target.n or target.state_windup0:
        # the temporary mechanism has no energy accumulators (they come last): pad, then set the windups
        n_t, n = ideal.n, target.n
        full = np.zeros(2 * n)
        full[:n_t] = y[:n_t]
        full[n:n + n_t] = y[n_t:]
        for i, psi0 in enumerate(target.state_windup0):
            full[n + target.n_base + i] = psi0
        y = full
    return y


def _speed_driver_spec(spec: MechanismSpec) -> dict | None:
    """The description as a dict with temporary ``angle`` drivers that fix the initial speeds (see
    :func:`initial_state`), energy audit off; None when no driver needs it.

    Speeds come from the ``angle`` and ``torque_speed`` drivers first, spread along the geared spring-dampers,
    then from ``torque`` drivers on bodies still without a speed (a torque driver on a body that already has one
    is a load and is left out of the temporary description)."""
    if not any(d.type in ("torque", "torque_speed") for d in spec.drivers):
        return None
    data = spec.model_dump()
    data["simulation"]["energy_audit"] = False
    speeds: dict[str, float] = {}
    drivers = []
    geared = [f for f in spec.forces if f.type == "geared_spring_damper"]

    def spread():
        changed = True
        while changed:
            changed = False
            for f in geared:
                drift = 1.0 - f.creep_compliance * f.stiffness * f.windup0
                if f.body_i in speeds and f.body_j not in speeds and f.body_j != "ground":
                    new, speeds[f.body_j] = f.body_j, speeds[f.body_i] * drift / f.ratio
                elif f.body_j in speeds and f.body_i not in speeds and f.body_i != "ground":
                    new, speeds[f.body_i] = f.body_i, speeds[f.body_j] * f.ratio / drift
                else:
                    continue
                drivers.append(dict(name=f"initial speed of {new}", type="angle", body=new, speed=speeds[new]))
                changed = True

    for d in data["drivers"]:
        if d["type"] in ("angle", "torque_speed") and d["body"] not in speeds:
            speeds[d["body"]] = d["speed"]
            drivers.append(dict(d, type="angle", speeds=[], torques=[]))
    spread()
    for d in data["drivers"]:
        if d["type"] == "torque" and d["body"] not in speeds:
            speeds[d["body"]] = d["speed"]
            drivers.append(dict(d, type="angle"))
            spread()
    data["drivers"] = drivers
    return data


@dataclass
class MultibodyResult:
    t: np.ndarray
    y: np.ndarray  # (n_out, 2n)
    elements: np.ndarray  # (n_out, nf, 4): normal force, penetration, its rate, tangential force
    multipliers: np.ndarray  # (n_out, m)
    peaks: np.ndarray
    first: np.ndarray
    info: np.ndarray
    wall_time_s: float
    stats_from: float
    compiled: CompiledMechanism = field(repr=False)

    def element_force(self, name: str) -> np.ndarray:
        return self.elements[:, self.compiled.frc_names.index(name), mb.EO_FN]

    def reaction(self, name: str) -> np.ndarray:
        """Magnitude of the reaction force of an ideal joint (from its Lagrange multipliers), N."""
        k = self.compiled.con_names.index(name)
        r0, nr = self.compiled.con_rows[k]
        typ = self.compiled.model[3][k]
        lam = self.multipliers[:, r0:r0 + nr]
        if typ == mb.CON_PRISMATIC:
            return np.abs(lam[:, 1])
        if typ == mb.CON_DRIVER:
            return -lam[:, 0]  # torque applied by the driver on its body (N m)
        return np.sqrt(np.sum(lam**2, axis=1))

    def contact_onsets(self, names=None) -> dict[str, int]:
        """Impacts per clearance element over the statistics window: the integrator's located contact onsets
        (separated -> in contact on an accepted step) whose approach speed is at least
        :data:`berryshaker.multibody.kernel.IMPACT_COUNT_SPEED` (1 mm/s).

        Counted by the integrator on every step, so the count does not depend on the output grid (the written
        series at 0.1 ms missed ~11 % of the onsets of the reference harvester).  Closings slower than 1 mm/s (a
        pin settling into its bore) are not impacts: their number moves with the tolerance (docs/multibody.md,
        "Impacts").  Not the count of steps cut back to an onset (``info[2]``, ``event_cuts`` in
        :meth:`summary`), which counts every refinement.  ``names``: the elements to count (default every
        clearance element); a name that is no clearance element (e.g. a pair closed to an ideal joint) has none.
        """
        cm = self.compiled
        if names is None:
            names = [n for n, kind in zip(cm.frc_names, cm.frc_kinds) if kind.endswith("_clearance")]
        out = {}
        for name in names:
            if name not in cm.frc_names or not cm.frc_kinds[cm.frc_names.index(name)].endswith("_clearance"):
                out[name] = 0
                continue
            out[name] = int(self.first[cm.frc_names.index(name), 4])
        return out

    def summary(self) -> dict:
        """The JSON of ``simulate --mechanism``: per joint force statistics (clearance joints: contact
        fraction, first impact, ``contact_onsets``), driver torques, integrator statistics.

        The onset keys mean what they mean in the harvester summaries (``drives.simulation``):
        ``contact_onsets`` impacts per clearance joint (:meth:`contact_onsets`: located onsets closing at
        >= 1 mm/s over the statistics window), ``contact_onsets_located`` their total, ``event_cuts`` the integrator steps cut
        back to an onset over the whole run (every refinement counts).
        """
        cm = self.compiled
        onsets = self.contact_onsets()
        sel = self.t >= self.stats_from - 1e-12
        out = {"model": "multibody", "mechanism": cm.spec.mechanism.name, "joints": {}, "drivers": {},
               "duration_s": float(self.t[-1]),
               "statistics_over": (f"t >= {self.stats_from:.6g} s (whole driver revolutions after the first)"
                                   if self.stats_from > 0 else "the whole run"),
               "steps": int(self.info[0]), "rejected_steps": int(self.info[1]),
               "contact_onsets": onsets, "contact_onsets_located": int(sum(onsets.values())),
               "event_cuts": int(self.info[2]),
               "max_constraint_residual": float(self.info[5]), "wall_time_s": self.wall_time_s}
        for k, (name, kind) in enumerate(zip(cm.frc_names, cm.frc_kinds)):
            if not kind.endswith("_clearance"):
                continue
            f = np.abs(self.elements[sel, k, mb.EO_FN])
            pen = self.elements[:, k, mb.EO_PEN]
            entry = {"type": kind, "force_N": _stats(f, self.peaks[k]),
                     "contact_fraction": float(np.mean(pen[sel] > 0)), "contact_onsets": onsets[name]}
            if self.first[k, 3] > 0:
                entry["first_impact"] = {"time_s": float(self.first[k, 0]),
                                         "impact_velocity_m_s": float(self.first[k, 1]),
                                         "peak_force_N": float(self.first[k, 2])}
            out["joints"][name] = entry
        if cm.acc_start >= 0:
            from berryshaker.multibody.energy import energy_audit

            out["energy"] = energy_audit(self)
        for k, name in enumerate(cm.con_names):
            typ = cm.model[3][k]
            if typ == mb.CON_DRIVER:
                tq = self.reaction(name)[sel]
                out["drivers"][name] = {"torque_Nm": {"peak": float(np.max(np.abs(tq))), "mean": float(np.mean(tq)),
                                                      "rms": float(np.sqrt(np.mean(tq**2)))}}
            else:
                f = self.reaction(name)[sel]
                out["joints"][name] = {"type": _CON_KIND[typ], "force_N": _stats(f, 0.0)}
        return out


_CON_KIND = {mb.CON_REVOLUTE: "revolute", mb.CON_PRISMATIC: "prismatic", mb.CON_POINT_LINE: "point_on_line",
             mb.CON_CAM_ROLLER: "cam_roller"}


def _stats(f: np.ndarray, peak: float) -> dict:
    if f.size == 0:
        return {"peak": float(peak), "mean": 0.0, "rms": 0.0, "p50": 0.0, "p95": 0.0, "p99": 0.0}
    p50, p95, p99 = np.percentile(f, (50, 95, 99))  # one partition for the three (the same order statistics)
    return {"peak": float(max(peak, f.max())), "mean": float(f.mean()), "rms": float(np.sqrt(np.mean(f**2))),
            "p50": float(p50), "p95": float(p95), "p99": float(p99)}


#: what the written series of a run may cover (:func:`simulate_mechanism`'s ``series``)
SERIES = {"whole": "every output sample of the run",
          "statistics": "the initial state and the samples of the statistics window (driver revolutions 2..N) "
                        "with the one before it"}

#: length (m) below which a position's error is held absolutely: atol = rtol x POSITION_SCALE for the
#: positions (the velocities' scale is the spec's ``simulation.velocity_scale``)
POSITION_SCALE = 1e-3
#: most output samples one run may write (the series are held in memory: about 0.7 kB per sample for the
#: harvester drives, so 1.4 GB at the cap); a longer run must use a coarser ``output_step`` or be shorter
MAX_OUTPUT_SAMPLES = 2_000_000
#: default step budget: one integrator step (accepted or rejected) per STEP_BUDGET_DT of simulated time.  The
#: harvester drives take about one step per 50 us (27 000 steps for 3 revolutions at 120 rpm), so the budget
#: is some 50 times what a sound run needs; a run that needs more is stiffer than any description here
#: should be (a contact stiffness or damping off by orders of magnitude) and would run for many minutes.
STEP_BUDGET_DT = 1e-6
#: the budget is never below this many steps (short runs with many contact onsets)
MIN_STEP_BUDGET = 200_000
#: integrator steps per compiled call of a run (:func:`integrate_in_chunks`): between two chunks the run is back
#: in Python, where Ctrl-C is seen; ~0.15 s of a harvester run's steps (7-8 us each), so a 2-revolution run is
#: one chunk.  The results do not depend on it: a chunk resumes the step sequence exactly (bitwise)
CHUNK_STEPS = 20_000


def check_output_samples(duration: float, output_step: float,
                         fix: str = "simulate a shorter time or write a coarser output_step") -> int:
    """Number of output samples of a run, refused above :data:`MAX_OUTPUT_SAMPLES` before anything is allocated.

    Parameters
    ----------
    duration, output_step : float
        Simulated time and spacing of the written series (s).
    fix : str
        What the user should change, quoted in the message (e.g. "use fewer --revolutions").

    Raises
    ------
    ConfigError
        Non-finite or non-positive times, or too many samples (the message gives the longest allowed time).
    """
    for name, v in (("duration", duration), ("output_step", output_step)):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or not v > 0:
            raise ConfigError(f"{name} must be a finite time > 0 s, got {v!r}")
    n_samples = duration / output_step + 1
    if n_samples > MAX_OUTPUT_SAMPLES:
        raise ConfigError(f"a run of {duration:.6g} s written every {output_step:.3g} s needs {n_samples:.3g} output "
                          f"samples, more than the {MAX_OUTPUT_SAMPLES:,} one run may hold in memory (at most "
                          f"{(MAX_OUTPUT_SAMPLES - 1) * output_step:.4g} s of simulated time); {fix}")
    return max(2, int(round(duration / output_step)) + 1)


def _auxiliary_tolerances(cm: CompiledMechanism, rtol: float, atol: np.ndarray) -> tuple[float, np.ndarray]:
    """Error weights with auxiliary coordinates: a windup state (velocity slot) is weighted like a position,
    the integral slots and the energy accumulators are left out of the step-size control (atol 1e300), and
    rtol and atol are scaled by sqrt(n_controlled / 2n) so that the integrator's RMS error norm, which divides
    by all 2n components, asks the same accuracy of the physical state as a run without them."""
    n, n0 = cm.n, cm.n_base
    atol = atol.copy()
    atol[n0:n] = 1e300
    n_states = len(cm.state_windup0)
    atol[n + n0:n + n0 + n_states] = atol[0]
    atol[n + n0 + n_states:] = 1e300
    f = math.sqrt(np.count_nonzero(atol < 1e299) / (2 * n))
    return rtol * f, atol * f


def default_step_budget(duration: float) -> int:
    """The step budget of a run of ``duration`` seconds: ``max(MIN_STEP_BUDGET, duration / STEP_BUDGET_DT)``."""
    return int(max(MIN_STEP_BUDGET, math.ceil(duration / STEP_BUDGET_DT)))


#: the argument types (:func:`_argument_types`) the compiled integrator has been called with in this process
_WARM: set = set()


def _type_key(x):
    """What numba's ``typeof`` makes of ``x``, as a hashable key, or None where this function does not know.

    Exact types only (a subclass, a named tuple or an enum member gets None): a plain ``ndarray`` by its dtype
    (fields and units included), dimensions, layout (C, F or any, numba's ``map_layout``), read-only and aligned
    flags; a plain tuple by its elements' keys; a Python or numpy scalar by its type and numba's own type of it
    (cheap for a scalar; ints by value range, datetimes by unit); a contact law's entry point by its class (typed
    by the one law signature, :class:`~berryshaker.contact.laws.LawEntryPoint`).  Equal keys give equal numba
    types (tests/test_engine_dispatch.py), which is what makes :func:`call_compiled`'s direct call safe.
    """
    t = type(x)
    if t is np.ndarray:
        f = x.flags
        layout = "C" if f.c_contiguous else "F" if f.f_contiguous else "A"
        return ("array", x.dtype, x.ndim, layout, f.writeable, f.aligned)
    if t is tuple:
        keys = tuple(_type_key(e) for e in x)
        return None if any(k is None for k in keys) else ("tuple", keys)
    if t in (bool, int, float) or isinstance(x, np.generic):
        from numba import typeof

        try:
            return ("scalar", t, typeof(x))
        except (TypeError, ValueError):  # numba cannot type it: leave it to the dispatcher's error
            return None
    if t is LawEntryPoint:
        return t
    return None


def _argument_types(run: "PreparedRun") -> tuple:
    """What decides which compiled specialisation of ``kernel.integrate`` a run calls (:func:`_type_key` of its
    arguments).  A run whose key is in :data:`_WARM` needs no warm-up call to keep compilation out of its
    ``wall_time_s``."""
    return _type_key((run.y, run.cm.model, run.state, run.work, run.atol, run.out_y, run.out_e, run.out_lam,
                      run.peaks, run.first, run.info))


#: compiled entry points of kernel functions by (function, :func:`_type_key` of the arguments), see
#: :func:`call_compiled`
_ENTRY_POINTS: dict = {}


def call_compiled(fn, *args):
    """``fn(*args)`` for a numba-compiled kernel function, without numba's typing of the arguments after the
    first call with the same argument types in this process.

    numba's dispatcher types every argument at every call, in Python for tuples: the kernel's model, state and
    work tuples (~30 arrays) cost ~0.2 ms per call, against ~15 us for the call itself (benchmarks/HISTORY.md
    sec. 23); a harvester run made two such calls, a perturbed start one per continuation step.  The first call
    goes through the dispatcher (which compiles or loads the specialisation); the specialisation it used is then
    called directly for arguments of the same :func:`_type_key`, which follows numba's own typing rules, so the
    same compiled code runs on the same arguments.  Arguments whose types the key does not cover always go
    through the dispatcher, and so does everything when ``fn`` is not a dispatcher (``NUMBA_DISABLE_JIT``).
    A function recompiled after its first call (``fn.recompile()``, nothing in berryshaker does) keeps its old
    entry point here.
    """
    key = _type_key(args)
    entry = _ENTRY_POINTS.get((fn, key)) if key is not None else None
    if entry is not None:
        return entry(*args)
    out = fn(*args)
    overloads = getattr(fn, "overloads", None)  # None: not a dispatcher (NUMBA_DISABLE_JIT, a wrapper)
    if key is not None and overloads is not None:
        from numba import typeof

        compiled = overloads.get(tuple(typeof(a) for a in args))
        entry = getattr(compiled, "entry_point", None)  # (numba internals: without them, the dispatcher every time)
        if entry is not None:  # an exact match (a call converted to another signature is not remembered)
            _ENTRY_POINTS[(fn, key)] = entry
    return out


#: the parts of the compiled core :func:`compile_engine` compiles (in the order kernel.integrate needs them)
ENGINE_PARTS = ("projection", "forces", "right_hand_side", "step_events", "step_forces")


def compile_engine(spec: MechanismSpec, parts: tuple[str, ...] = ENGINE_PARTS) -> dict[str, float]:
    """Compile (or load from numba's on-disk cache) parts of the compiled core for the argument types of
    ``spec``'s runs, without running anything.

    The integrator (``kernel.integrate``) calls a chain of ~30 compiled functions, compiled one after the other
    on first use: about 16 s of one core on a fresh install (benchmarks/HISTORY.md sec. 19-20).  Compiling a part
    compiles the callees it needs that are not compiled yet and writes everything to the cache, so two processes
    can share the work: one compiles ``"forces"`` and ``"step_forces"`` (which share the contact laws' calls and
    only small geometry helpers with the rest) while the other compiles ``"projection"`` and ``"step_events"``,
    then ``"right_hand_side"`` once the first is done; a run then compiles only the integrator itself and loads
    the rest.  (About 3.5 + 0.7 s against 2.8 + 0.9 s of one core; with ``"step"`` whole on the projection's side
    the forces' process idled ~3 s, benchmarks/HISTORY.md sec. 22.)

    Parameters
    ----------
    spec : MechanismSpec
        Any mechanism: the argument types (not the values) decide what is compiled, and every mechanism the
        engine builds (the groove-cam and crank-rocker drives, with a modal plant, with the powered driveline;
        the slider-crank of the validation cases) has the same ones.
    parts : tuple of str
        Any of :data:`ENGINE_PARTS`: ``"projection"`` (``kernel.project``: the constraint equations, their
        Jacobian and the multiplier solve), ``"forces"`` (``kernel.forces``: every force element and contact
        law), ``"right_hand_side"`` (``kernel.accelerations``: the forces, the constraints and the multiplier
        solve of one right-hand side; compiles the other two first if they are not), ``"step_events"`` (the
        integrator's helpers for contact onsets, dense output and output samples), ``"step_forces"`` (its
        helpers that evaluate the contact laws inside a step: the force bound and the interior force peak).

    Returns
    -------
    dict
        CPU seconds per part (about 0.01 s when it was in the cache).

    Raises
    ------
    ConfigError
        An unknown part.
    """
    from numba import typeof

    bad = [p for p in parts if p not in ENGINE_PARTS]
    if bad:
        raise ConfigError(f"compile_engine: unknown part(s) {', '.join(map(repr, bad))}; the parts are "
                          f"{', '.join(map(repr, ENGINE_PARTS))}")
    cm = compile_mechanism(spec)
    state, work = _state_and_work(cm)
    y = np.zeros(2 * cm.n)
    (mass, inertia, gravity, ctype, cint, cflt, crow, ftype, fint, fflt, cams, modal_w, modal_z, phi_tab,
     plant_p, laws, plan) = cm.model
    (in_contact, v_imp, psi_c, psi_f, lam_prev) = state
    q_arg = y[:cm.n]  # kernel.accelerations passes views of y: C-contiguous 1-D arrays, as these
    calls = {"projection": [(mb.project, (0.0, y, cm.model, state, work, np.int64(3)))],
             "forces": [(mb.forces, (0.0, q_arg, y[cm.n:], mass, gravity, ftype, fint, fflt, cams, in_contact,
                                     v_imp, psi_f, ctype, cint, cflt, crow, lam_prev, modal_w, modal_z, phi_tab,
                                     plant_p, work[4], work[5], laws))],
             "right_hand_side": [(mb.accelerations, (0.0, y, cm.model, state, work, np.zeros_like(y)))],
             # the types kernel.integrate passes: a contact index from range() (int64), floats, C arrays
             "step_events": [(mb.fint_is_contact, (cm.model, np.int64(0))),
                             (mb._onset_fraction, (0.0,) * 5), (mb._crossing_rate, (0.0,) * 5),
                             (mb._dense_state, (0.0, 0.0, np.zeros((7, y.shape[0])), y, y, y, y, y)),
                             (mb._write_sample, (np.int64(0), y, work[5], work[6], np.zeros((2, y.shape[0])),
                                                 np.zeros((2,) + work[5].shape), np.zeros((2, cm.m))))],
             "step_forces": [(mb._step_force_bound, (cm.model, np.int64(0)) + (0.0,) * 6),
                             (mb._interior_peak, (cm.model, np.int64(0)) + (0.0,) * 6)]}
    out = {}
    for part in parts:
        c0 = time.process_time()
        for fn, args in calls[part]:
            fn.compile(tuple(typeof(a) for a in args))
        out[part] = time.process_time() - c0
    return out


def simulate_mechanism(spec: MechanismSpec, duration: float | None = None, rtol: float | None = None,
                       output_step: float | None = None, max_step: float | None = None,
                       y0: np.ndarray | None = None, max_steps: int | None = None,
                       initial_perturbation: "InitialPerturbation | RandomInitialPerturbation | None" = None,
                       series: str = "whole", specialised: bool | None = None) -> MultibodyResult:
    """Simulate a mechanism description; statistics over whole driver revolutions after the first.

    Parameters
    ----------
    spec : MechanismSpec
        The mechanism; ``spec.simulation`` gives the defaults of the arguments below.
    duration, rtol, output_step, max_step : float, optional
        Simulated time (s), relative tolerance, spacing of the written series (s), largest step (s).
    y0 : ndarray, optional
        Initial state (positions then velocities); default: assembled with the clearance joints centred.
    max_steps : int, optional
        Step budget of the run (accepted + rejected integrator steps); default
        :func:`default_step_budget` (``duration / 1e-6 s``, at least 200 000).  The run stops with a
        :class:`~berryshaker.errors.SimulationError` when it is spent (checked by the compiled integrator at
        every step).
    initial_perturbation : InitialPerturbation or RandomInitialPerturbation, optional
        Start from a perturbed state: clearance joints off centre, drivers turned (with ``y0`` only the
        driver turn applies).  A random one is drawn for ``spec`` from its seed.
    series : {"whole", "statistics"}
        What the written series cover (:data:`SERIES`): the whole run, or only the statistics window (the
        initial state, then the samples of the whole grid from ``stats_from`` on; the first revolution's
        start-up is not written).  The trajectory, peaks, impact counts and every sample in the window are
        bitwise those of a "whole" run (the steps do not depend on the output grid), so the statistics are too;
        a sweep that keeps only the summary saves the start-up's samples (about 4 % of a harvester run).
    specialised : bool, optional
        Integrate with the kernel specialised to this mechanism's structure
        (:func:`berryshaker.multibody.specialised.specialised_integrator`): bitwise the same results, about a
        third less time per step (a quarter per harvester run), and 10-20 s of compilation the first time a
        structure is run on a machine (cached on disk after that); False: the generic kernel.  Default:
        ``spec.simulation.specialised``, whose default (None) takes the specialised kernel when this machine has
        compiled it for the structure already (:func:`integrator`).

    Raises
    ------
    ConfigError
        Non-positive duration or output step, more than :data:`MAX_OUTPUT_SAMPLES` output samples, or an
        unknown ``series``.
    SimulationError
        The integrator gave up, or the step budget was spent.
    """
    run = prepare_run(spec, duration, rtol, output_step, max_step, y0, max_steps, initial_perturbation, series)
    cm, nf = run.cm, len(run.cm.frc_names)
    integrate = resumable(integrator(cm, run.specialised if specialised is None else specialised))
    key = _argument_types(run)
    if key is not None:
        key = (integrate, key)
    if key is None or key not in _WARM:  # None: types this process cannot key; warm up every time
        # compile (or load from the numba cache) outside the timed region: once per process and argument types
        s2, w2 = _state_and_work(cm)
        call_compiled(integrate, run.y.copy(), run.t_out[:2] * 1e-9, cm.model, s2, w2, run.rtol, run.atol,
                      run.max_step, 0.0, np.zeros((2, 2 * cm.n)), np.zeros((2, nf, mb.N_EO)), np.zeros((2, cm.m)),
                      np.zeros(nf), np.zeros((nf, mb.N_FIRST)), np.zeros(6), np.zeros(mb.resume_size(2 * cm.n, nf)))
        if key is not None:
            _WARM.add(key)
    t0 = time.perf_counter()
    integrate_in_chunks(integrate, run)
    wall = time.perf_counter() - t0
    if integrate is not mb.integrate_resumable:
        from berryshaker.multibody.specialised import mark_compiled

        mark_compiled(cm.model, cm.n, integrate)  # compiled and cached: later runs of the structure take it
    return finish_run(run, wall)


def resumable(integrate):
    """The resumable form of a compiled integrator (``kernel.integrate`` or a specialised module's): the
    ``integrate_resumable`` beside it, which :func:`integrate_in_chunks` calls."""
    return getattr(integrate, "py_func", integrate).__globals__["integrate_resumable"]


def integrate_in_chunks(integrate, run: "PreparedRun", chunk_steps: int | None = None) -> None:
    """Run the compiled integrator ``integrate`` (``kernel.integrate_resumable`` or a specialised module's,
    :func:`resumable`) on ``run``'s arrays in chunks of ``chunk_steps`` steps (its ``resume`` argument), back in Python between them, so that Ctrl-C
    (KeyboardInterrupt) stops a long run within a chunk's time instead of after the whole run (numba's compiled
    code does not see signals).  The step sequence, and so every result, is bitwise that of one call; the step
    budget (``run.budget``, status 4) counts over the whole run.  Leaves the final status in ``run.info``.
    ``chunk_steps``: default :data:`CHUNK_STEPS`."""
    cm = run.cm
    chunk_steps = CHUNK_STEPS if chunk_steps is None else int(chunk_steps)
    resume = np.zeros(mb.resume_size(run.y.shape[0], len(cm.frc_names)))
    while True:
        run.info[0] = run.budget  # the kernel stops with status 4 when accepted + rejected steps reach it
        run.info[3] = 0.0  # t_fail: written by a failure (and by a pause, which is none)
        resume[mb.RS_LIMIT] = resume[mb.RS_ACC] + resume[mb.RS_REJ] + chunk_steps
        call_compiled(integrate, run.y, run.t_out, cm.model, run.state, run.work, run.rtol, run.atol, run.max_step,
                      run.stats_from, run.out_y, run.out_e, run.out_lam, run.peaks, run.first, run.info, resume)
        if int(run.info[4]) != 5:  # 5: a chunk's end, resumable
            return


def integrator(cm: CompiledMechanism, specialised: bool | None = None):
    """The compiled integrator of ``cm``'s runs: the generic ``kernel.integrate``, or with ``specialised`` the one
    written for its structure (:mod:`berryshaker.multibody.specialised`; same signature, bitwise the same
    results).  ``specialised=None`` (a run left to choose): as the environment variable ``BERRYSHAKER_KERNEL`` says
    (:func:`berryshaker.compiled_cache.kernel_choice`),
    by default ("auto") the structure's own when this machine has compiled it already
    (:func:`berryshaker.multibody.specialised.is_compiled`; a load, not a compilation), else the generic one."""
    from berryshaker.multibody.specialised import is_compiled, specialised_integrator

    if specialised is None:
        choice = kernel_choice()
        specialised = is_compiled(cm.model, cm.n) if choice == "auto" else choice == "specialised"
    if not specialised:
        return mb.integrate

    try:
        return specialised_integrator(cm.model, cm.n, cm.m)
    except OSError as exc:  # no writable folder for the generated source: the generic kernel, same results
        import warnings

        warnings.warn(f"berryshaker: the specialised kernel could not be written ({exc}); running the generic one "
                      "(the same results, slower)", RuntimeWarning, stacklevel=2)
        return mb.integrate


@dataclass
class PreparedRun:
    """Everything one compiled integration needs (:func:`prepare_run`) and fills (outputs, peaks, info)."""

    cm: CompiledMechanism
    state: tuple
    work: tuple
    y: np.ndarray
    t_out: np.ndarray
    rtol: float
    atol: np.ndarray
    max_step: float
    stats_from: float
    budget: int
    duration: float
    out_y: np.ndarray
    out_e: np.ndarray
    out_lam: np.ndarray
    peaks: np.ndarray
    first: np.ndarray
    info: np.ndarray
    specialised: bool | None = None  # spec.simulation.specialised: the structure's own kernel (None: if compiled)


def prepare_run(spec: MechanismSpec, duration: float | None = None, rtol: float | None = None,
                output_step: float | None = None, max_step: float | None = None, y0: np.ndarray | None = None,
                max_steps: int | None = None,
                initial_perturbation: "InitialPerturbation | RandomInitialPerturbation | None" = None,
                series: str = "whole") -> PreparedRun:
    """Check the arguments of :func:`simulate_mechanism` (same meaning and defaults), compile the description,
    assemble the initial state and allocate the arrays of one integration."""
    if series not in SERIES:
        raise ConfigError(f"series must be one of {', '.join(repr(k) for k in SERIES)} (what the written series "
                          f"cover), got {series!r}")
    sim = spec.simulation
    duration = sim.duration if duration is None else duration
    rtol = sim.rtol if rtol is None else rtol
    output_step = sim.output_step if output_step is None else output_step
    max_step = sim.max_step if max_step is None else max_step
    n_out = check_output_samples(duration, output_step,
                                 "simulate a shorter time (fewer revolutions) or write a coarser output_step")
    budget = default_step_budget(duration) if max_steps is None else int(max_steps)
    if budget < 1:
        raise ConfigError(f"max_steps must be >= 1, got {max_steps}")
    pert = None if initial_perturbation is None else initial_perturbation.for_spec(spec)
    if pert is not None:
        spec = pert.shifted_drivers(spec)
    cm = compile_mechanism(spec)
    state, work = _state_and_work(cm)
    if y0 is not None:
        y = np.array(y0, float)
    else:
        y = initial_state(spec) if pert is None else pert.assemble(spec)
    t_out = np.linspace(0.0, duration, n_out)
    nf = len(cm.frc_names)
    # absolute tolerances: positions rtol x 1 mm, velocities rtol x the spec's velocity scale (SimulationSpec)
    atol = np.concatenate([np.full(cm.n, POSITION_SCALE * rtol), np.full(cm.n, sim.velocity_scale * rtol)])
    if cm.n > cm.n_base:
        rtol, atol = _auxiliary_tolerances(cm, rtol, atol)
    stats_from = 0.0
    if cm.period is not None and duration >= 2 * cm.period:
        stats_from = cm.period
    if series == "statistics" and stats_from > 0.0:
        # the start state (the kernel writes sample 0 before the first step), then the whole run's grid from the
        # sample before the first one the statistics select (the same points, so the same samples; the one before
        # keeps a window snapped to the nearest sample, as the energy audit's, where a whole run has it)
        i0 = max(1, int(np.searchsorted(t_out, stats_from - 1e-12)) - 1)
        t_out = np.concatenate([t_out[:1], t_out[i0:]])
        n_out = t_out.shape[0]
    return PreparedRun(cm, state, work, y, t_out, float(rtol), atol, float(max_step), stats_from, budget,
                       float(duration), np.zeros((n_out, 2 * cm.n)), np.zeros((n_out, nf, mb.N_EO)),
                       np.zeros((n_out, cm.m)), np.zeros(nf), np.zeros((nf, mb.N_FIRST)), np.zeros(6),
                       sim.specialised)


def finish_run(run: PreparedRun, wall: float) -> MultibodyResult:
    """The result of an integration of :func:`prepare_run`'s arrays, or the SimulationError its status means."""
    info, duration, budget = run.info, run.duration, run.budget
    if int(info[4]) == 4:
        raise SimulationError(
            f"multibody simulation stopped at t = {info[3]:.6g} s of {duration:.6g} s: it used "
            f"{int(info[0] + info[1]):,} integrator steps, over its budget of {budget:,} (mean step "
            f"{info[3] / max(info[0], 1):.3g} s). The mechanism jams (a guide whose friction self-locks, a joint driven "
            "into a toggle) or the model is far stiffer than intended: check friction coefficients, contact stiffness "
            "and damping (and their units), or simulate fewer revolutions; to allow a longer run pass max_steps")
    status = int(info[4])
    if status != 0:
        why = {1: "the step size fell below 1e-14 s (contact too stiff for the tolerance, or a "
                  "singular configuration)",
               2: "the state became non-finite (the constraint matrix is singular: a redundant or "
                  "locked joint?)",
               3: f"the constraints could not be satisfied after the step (residual {info[5]:.3g})"}[status]
        raise SimulationError(f"multibody simulation gave up at t = {info[3]:.6g} s: {why}")
    return MultibodyResult(run.t_out, run.out_y, run.out_e, run.out_lam, run.peaks, run.first, info, wall,
                           run.stats_from, run.cm)
