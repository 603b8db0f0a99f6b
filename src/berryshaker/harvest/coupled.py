"""Rigid-flexible coupling: the multibody harvester drives past a branch whose modal coordinates are part
of the same integrated state; the combs strike it through the IMPACT law and it pushes back (study
sec. 2.5, Figs. 24-26).  Output: fruit harvesting force at the root, middle and end of the branch against
the machine-to-plant distance, and the eq. 17 verdict per position.

long module: the coupled machine-plant mechanism, its drive-past run, the branch motion and the fruit forces
read from it are one model; split, each part would import the others' layouts.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np

from berryshaker.config import Machine
from berryshaker.multibody import layout as mb
from berryshaker.multibody.engine import MultibodyResult, simulate_mechanism
from berryshaker.multibody.spec import mechanism_from_dict
from berryshaker.errors import ConfigError
from berryshaker.drives import drive_of
from berryshaker.harvest.spec import COUPLED_RTOL, COUPLED_VELOCITY_SCALE
from berryshaker.plant.bush import member_weight
from berryshaker.plant.modes import branch_modes
from berryshaker.plant.response import harvest_verdict

#: the study's fruit-force ranges (N) at the root, middle and end of the branch [study, claim 5]
STUDY_FRUIT_FORCE_N = {"root": (0.25, 0.4), "middle": (0.65, 0.9), "end": (0.8, 1.2)}


@functools.lru_cache(maxsize=32)
def _fruit_branch(branch_key: tuple, n_modes: int, z: tuple, mass: float, stiffness: float, damping: float):
    from berryshaker.plant.modes import cached_analytic_modes
    from berryshaker.plant.pedicel import fruit_branch_modes

    return fruit_branch_modes(cached_analytic_modes(branch_key, n_modes), np.array(z), mass, stiffness, damping)


def plant_modes(machine: Machine):
    """Modes the coupled run integrates: ``(modes, fruit_branch)``.

    With the pedicel model and ``pedicel.coupling = "two_way"`` (default) the named fruit sit on their
    stems inside the modal model (berryshaker.plant.pedicel.fruit_branch_modes: n_modes branch modes
    + one mode per fruit); ``fruit_branch`` then gives the fruit displacements.  Otherwise the branch's
    own modes (study eq. 15) and ``None``.

    Parameters
    ----------
    machine : Machine
        Machine description with a [plant] block.

    Returns
    -------
    modes : Modes
        The modes integrated: the branch's ``plant.contact.n_modes`` modes, or the combined branch-and-fruit
        modes (branch part, mass-normalised).
    fruit_branch : FruitBranchModes or None
        The combined modes with their fruit part (two-way pedicel), else None.
    """
    pl = machine.plant
    modes = branch_modes(pl.branch, pl.contact.n_modes)
    ped = pl.fruit.pedicel
    if ped.rigid or ped.coupling == "one_way":
        return modes, None
    b = pl.branch
    key = (b.root_diameter, b.tip_diameter, b.length, b.elastic_modulus, b.density, b.damping_ratio)
    z = tuple(float(f * b.length) for f in pl.fruit.positions)
    fb = _fruit_branch(key, pl.contact.n_modes, z, pl.fruit.mass, ped.stiffness, ped.damping)
    return fb.modes, fb


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


def bush_members(machine: Machine):
    """The reached members of the machine's bush population (berryshaker.plant.bush), with their modes.

    Parameters
    ----------
    machine : Machine
        Machine description with a [plant] block.

    Returns
    -------
    list of (BushBranch, Modes)
        The members the fingers reach (a station on the branch), in drawing order, each with its
        ``plant.bush.n_modes`` modes; empty when ``combs.load_model = "aggregate"`` or
        ``plant.bush.members = 0``.
    """
    from berryshaker.plant.bush import member_modes, sample_bush

    if machine.combs.load_model != "branches":
        return []
    return [(mb_, member_modes(mb_, machine.plant.bush.n_modes)) for mb_ in sample_bush(machine.plant)
            if mb_.station is not None]


def coupled_mechanism(machine: Machine, clearance: dict[str, float] | None = None, margin: float = 0.15,
                      probes: tuple = ()):
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
    clearance chain's sensitivity to the step sequence (docs/plant.md, "Convergence with modes").

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

    Returns
    -------
    spec : MechanismSpec
        The validated mechanism description with its modal plant body and comb-branch contacts.
    machine : Machine
        ``machine`` with the clearances applied.

    Raises
    ------
    ConfigError
        The description has no [plant] block.
    """
    if machine.plant is None:
        raise ConfigError("the machine description has no [plant] block (see `berryshaker config init`)")
    machine = machine.with_clearances(clearance)
    drive = drive_of(machine)
    pl = machine.plant
    ct = pl.contact
    branches = machine.combs.load_model == "branches"
    members = bush_members(machine)
    half = ct.span / 2
    v = machine.operation.walking_speed
    duration = (2 * (half + margin)) / v
    period = 2 * math.pi / machine.drive_speed
    revolutions = max(2, int(math.ceil(duration / period)))
    spec = drive.mechanism(machine, revolutions=revolutions).model_dump()
    if branches:
        spec["forces"] = [f for f in spec["forces"] if f["name"] not in AGGREGATE_LOAD_FORCES]
    fingers = _finger_points(machine, drive, ct)
    station = 0.5 * (ct.station_left + ct.station_right) * pl.branch.length
    k_contact, n_contact = ct.impact_stiffness(
        pl.branch.root_diameter * (1 - (1 - pl.branch.tip_diameter / pl.branch.root_diameter) * station
                                   / pl.branch.length))
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
            axis=list(n), row_offset=member.row_offset, contact=dict(law, stiffness=k_m, exponent=n_m),
            reaction_weight=weight))
    for i, (pm, pfb) in enumerate(probe_modes):
        for c in contacts[:2]:  # the instrumented branch's two contacts, repeated on the probe's own block
            row = [0.0] * n_total
            row[col:col + len(pm.omega)] = np.atleast_1d(pm.shape_at(c["station"] * pl.branch.length)).tolist()
            shapes.append(row)
            contacts.append(dict(c, name=f"{c['name']}_probe{i + 1}"))
        col += len(pm.omega)
        omega += pm.omega.tolist()
        zeta += (pfb.damping_ratios.tolist() if pfb is not None else [pl.branch.damping_ratio] * len(pm.omega))
    spec["plant"] = dict(
        omega=omega, damping_ratio=zeta if (fb is not None or members or probes) else pl.branch.damping_ratio,
        shapes=shapes, lateral_axis=[1.0, 0.0], walking_speed=v,
        start_distance=-(half + margin), half_span=half, ramp=min(0.1, half / 2), ramp_depth=0.2,
        contact=law, contacts=contacts)
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


@dataclass
class FruitForceResult:
    """Drive-past run: fruit forces per fruit position against time and machine-to-plant distance.

    ``fruit_force`` is the force the model compares with the bond (eq. 17): with the pedicel model
    (default) the magnitude of the in-plane stem force (lateral and axial, the fruit's weight included
    when ``plant.fruit.pedicel.include_weight``), with ``pedicel.rigid = true`` the study's eq. 16,
    m0 x branch acceleration (signed).  ``rigid_force`` is always eq. 16.

    Attributes
    ----------
    distance : numpy.ndarray
        Machine-to-plant distance along the row at each output time (m), negative before the comb centre.
    t : numpy.ndarray
        Output times (s).
    fruit_force : dict of str to numpy.ndarray
        Per fruit name: the force compared with the bond (N; stem force magnitude, or eq. 16 when rigid).
    z : dict of str to float
        Fruit positions (m from the root).
    contact_force : dict of str to numpy.ndarray
        Comb-branch normal contact forces on this branch (N), per contact.
    deflection : dict of str to numpy.ndarray
        Lateral branch deflection at each fruit (m).
    result : MultibodyResult
        The multibody run.
    machine : Machine
        The machine description (clearances applied).
    rigid_force : dict of str to numpy.ndarray
        Eq. 16, m0 x lateral branch acceleration at each fruit (N).
    stem_lateral : dict of str to numpy.ndarray
        Lateral stem force on each fruit (N); empty when rigid.
    stem_axial : dict of str to numpy.ndarray
        Axial stem force on each fruit, weight included when configured (N); empty when rigid.
    motion : BranchMotion or None
        The branch's modal solution, for post-processing.
    load_moment : dict of str to numpy.ndarray
        Moment of the bush on each comb about its shaft (N m; :func:`comb_load_moment`).
    probes : list of FruitForceResult
        The result of each probe carried in the same run.
    """

    distance: np.ndarray  # machine-to-plant distance along the row (m), negative before the comb centre
    t: np.ndarray
    fruit_force: dict[str, np.ndarray]  # N, per fruit name (stem force magnitude, or eq. 16 when rigid)
    z: dict[str, float]  # fruit positions (m)
    contact_force: dict[str, np.ndarray]  # comb-branch normal forces (N)
    deflection: dict[str, np.ndarray]  # branch deflection at each fruit (m)
    result: MultibodyResult = field(repr=False)
    machine: Machine = field(repr=False)
    rigid_force: dict[str, np.ndarray] = field(default_factory=dict)  # eq. 16, m0 x branch acceleration (N)
    stem_lateral: dict[str, np.ndarray] = field(default_factory=dict)  # lateral stem force on the fruit (N)
    stem_axial: dict[str, np.ndarray] = field(default_factory=dict)  # axial stem force incl. weight (N)
    motion: "BranchMotion | None" = field(default=None, repr=False)  # modal solution, for post-processing
    load_moment: dict[str, np.ndarray] = field(default_factory=dict)  # bush on each comb about its shaft (N m)
    probes: list = field(default_factory=list, repr=False)  # FruitForceResult of each probe of the same run

    def summary(self) -> dict:
        """Peaks per fruit position with the eq. 17 verdict and the study's ranges, contact statistics.

        Returns
        -------
        dict
            ``positions`` (per fruit: ``z_m``, ``peak_force_N``, ``rms_force_N``, ``peak_at_distance_m``,
            ``eq17`` verdict, ``rigid_peak_force_N`` and, where the study gives one, ``study_range_N`` and
            ``within_study_range``), ``study_ranges_N``, ``fruit_model``, ``pedicel`` (stiffness N/m, damping
            N s/m, natural frequency Hz, damping ratio...; not when rigid), ``contact`` (per contact ``peak_N`` and
            ``impacts``), ``rises_root_to_end``, ``load_model``, ``load_moment_Nm`` (per comb peak, rms and mean
            |M| while the bush is inside the comb, N m), ``bush`` (branches load model), ``steps``,
            ``wall_time_s`` (s) and ``clearance_mm`` (mm).
        """
        out = {"positions": {}, "study_ranges_N": STUDY_FRUIT_FORCE_N, "contact": {}}
        ped = self.machine.plant.fruit.pedicel
        out["fruit_model"] = "rigid (eq. 16)" if ped.rigid else "pedicel"
        if not ped.rigid:
            from berryshaker.plant.pedicel import damping_ratio, natural_frequency

            m0 = self.machine.plant.fruit.mass
            out["pedicel"] = {"stiffness_N_m": ped.stiffness, "damping_N_s_m": ped.damping,
                              "natural_frequency_hz": float(natural_frequency(m0, ped.stiffness)),
                              "damping_ratio": float(damping_ratio(m0, ped.stiffness, ped.damping)),
                              "include_weight": ped.include_weight, "coupling": ped.coupling}
            if ped.coupling == "two_way":
                per_mode = isinstance(self.result.compiled.spec.plant.damping_ratio, list)
                out["pedicel"]["mode_damping"] = ("per mode" if per_mode else
                                                  "one ratio for all modes (engine limitation; docs/plant.md)")
        for name, f in self.fruit_force.items():
            peak = float(np.max(np.abs(f)))
            entry = {"z_m": self.z[name], "peak_force_N": peak,
                     "rms_force_N": float(np.sqrt(np.mean(f**2))),
                     "peak_at_distance_m": float(self.distance[int(np.argmax(np.abs(f)))]),
                     "eq17": harvest_verdict(peak).as_dict()}
            if name in self.rigid_force:
                entry["rigid_peak_force_N"] = float(np.max(np.abs(self.rigid_force[name])))
            if name in STUDY_FRUIT_FORCE_N:
                lo, hi = STUDY_FRUIT_FORCE_N[name]
                entry["study_range_N"] = [lo, hi]
                entry["within_study_range"] = bool(lo <= peak <= hi)
            out["positions"][name] = entry
        for name, f in self.contact_force.items():
            out["contact"][name] = {"peak_N": float(np.max(f)), "impacts": int(np.sum(np.diff((f > 0).astype(int)) == 1))}
        names = list(self.fruit_force)
        peaks = [out["positions"][n]["peak_force_N"] for n in names]
        out["rises_root_to_end"] = bool(all(a < b for a, b in zip(peaks[:-1], peaks[1:])))
        out["load_model"] = self.machine.combs.load_model
        # statistics while the bush centre is inside the comb's length (both load models alike)
        sel = np.abs(self.distance) <= self.result.compiled.spec.plant.half_span
        # mean |M| (the moment's time average: what the impacts deliver per unit time) converges with the bush's
        # sample and modes; rms and peak are set by the impact peaks, which depend on the modes kept (docs/plant.md)
        out["load_moment_Nm"] = {side: {"peak": float(np.max(np.abs(m[sel]))),
                                        "rms": float(np.sqrt(np.mean(m[sel] ** 2))),
                                        "mean": float(np.mean(np.abs(m[sel])))}
                                 for side, m in self.load_moment.items()}
        if self.machine.combs.load_model == "branches":
            pop = self.machine.plant.bush
            out["bush"] = {"branches": pop.branches, "members": pop.members,
                           "reached": len(bush_members(self.machine)), "modes_per_member": pop.n_modes,
                           "seed": pop.seed}
        out["steps"] = int(self.result.info[0])
        out["wall_time_s"] = self.result.wall_time_s
        out["clearance_mm"] = {k: v * 1e3 for k, v in self.machine.clearance_sizes().items()}
        return out


#: samples per block of :meth:`BranchMotion.axial` (a few MB of pair products; 3000-8000 all measured alike)
AXIAL_BLOCK = 4096


@dataclass(frozen=True)
class BranchMotion:
    """Modal solution of a coupled run, ready for evaluation anywhere on the branch.

    Frozen: :attr:`_rows` keeps per-mode copies of the series, so the series must not change after construction
    (``eta`` and ``etad`` are views of the run's state array: do not write into ``res.y`` either).

    Attributes
    ----------
    t : numpy.ndarray
        Output times (s), uniform.
    modes : Modes
        The branch's mass-normalised modes (shapes 1/sqrt(kg)).
    eta : numpy.ndarray
        Modal displacements, (n_t, n_modes) (sqrt(kg) m).
    etad : numpy.ndarray
        Modal velocities (sqrt(kg) m/s).
    etadd : numpy.ndarray
        Modal accelerations from the branch's stiffness, damping and the comb contacts (sqrt(kg) m/s^2).
    contact_force : dict of str to numpy.ndarray
        Normal force of each comb contact that loads this branch (N).
    """

    t: np.ndarray
    modes: object  # berryshaker.plant.modes.Modes
    eta: np.ndarray  # (n_t, n_modes) modal displacements
    etad: np.ndarray  # modal velocities
    etadd: np.ndarray  # modal accelerations (branch stiffness, damping and the comb contacts)
    contact_force: dict[str, np.ndarray]

    def every(self, n: int) -> "BranchMotion":
        """Every n-th sample (for post-processing on a coarser, still uniform, time grid).

        Parameters
        ----------
        n : int
            Keep samples 0, n, 2n, ...

        Returns
        -------
        BranchMotion
            The same motion on the coarser grid.
        """
        return BranchMotion(self.t[::n], self.modes, self.eta[::n], self.etad[::n], self.etadd[::n],
                            {k: v[::n] for k, v in self.contact_force.items()})

    @functools.cached_property
    def _rows(self) -> tuple[np.ndarray, np.ndarray]:
        """eta and eta' as contiguous rows per mode, (n_modes, n_t) each (the series are strided columns of the
        run's state array; per-mode rows make the products below contiguous).  Copied row-block first, then
        transposed in cache (a direct transposed copy of the strided columns misses the cache at every sample)."""
        return tuple(np.ascontiguousarray(x).T.copy() for x in (self.eta, self.etad))

    @functools.cached_property
    def _acceleration_rows(self) -> np.ndarray:
        """eta'' as contiguous rows per mode, (n_modes, n_t)."""
        return np.ascontiguousarray(self.etadd.T)

    def lateral(self, z, acceleration: bool = True):
        """Lateral displacement (m), velocity (m/s), acceleration (m/s^2) at positions z, each (n_z, n_t).

        ``acceleration=False``: the third is None (not computed: the stem forces need only the first two).

        Parameters
        ----------
        z : float or array_like
            Positions along the branch (m from the root).
        acceleration : bool
            Also compute the acceleration.

        Returns
        -------
        displacement : numpy.ndarray
            (n_z, n_t) lateral displacement (m).
        velocity : numpy.ndarray
            (n_z, n_t) lateral velocity (m/s).
        acceleration : numpy.ndarray or None
            (n_z, n_t) lateral acceleration (m/s^2), or None.
        """
        phi_t = self.modes.shape_at(np.atleast_1d(z)).T  # (n_z, n_modes)
        e, ed = self._rows
        return phi_t @ e, phi_t @ ed, (phi_t @ self._acceleration_rows if acceleration else None)

    def axial(self, z):
        """Axial (along-branch) displacement and velocity at z from the bending's foreshortening (m, m/s).

        u(z, t) = -1/2 int_0^z (dw/ds)^2 ds = -1/2 eta^T G(z) eta,  G_ij(z) = int_0^z phi_i' phi_j' ds
        (second order in the deflection; the Euler-Bernoulli branch has no first-order axial motion).

        Parameters
        ----------
        z : float or array_like
            Positions along the branch (m from the root).

        Returns
        -------
        displacement : numpy.ndarray
            (n_z, n_t) axial displacement u (m), <= 0 (towards the root).
        velocity : numpy.ndarray
            (n_z, n_t) axial velocity (m/s).
        """
        zs = np.atleast_1d(np.asarray(z, float))
        m = self.modes
        cum = m.slope_product_integral  # (n_modes, n_modes, n_s), cached with the modes
        j = np.clip(np.searchsorted(m.z, zs) - 1, 0, len(m.z) - 2)
        wgt = (zs - m.z[j]) / (m.z[j + 1] - m.z[j])
        g = (1 - wgt) * cum[:, :, j] + wgt * cum[:, :, j + 1]  # (n_modes, n_modes, n_z), symmetric in the modes
        # eta^T G eta and eta^T G eta' for every time and position: two matrix products over the mode pairs i <= j
        # (G is symmetric: the products slope_i slope_j and their running integral are the same numbers for (j, i)),
        # eta^T G eta = sum_{i<=j} (2 - delta_ij) G_ij eta_i eta_j,
        # eta^T G eta' = sum_{i<=j} G_ij (eta_i eta'_j + eta_j eta'_i) (1 - delta_ij / 2)
        # (the modal series as contiguous rows per mode; the pair products row block by row block, i fixed and
        # j = i ... n - 1, in the order of numpy.triu_indices: no gathered copies)
        nm = g.shape[0]
        iu, ju = np.triu_indices(nm)
        diag = iu == ju
        gp = g[iu, ju, :].T  # (n_z, pairs)
        wu = -0.5 * (gp * np.where(diag, 1.0, 2.0))  # (the factors -1/2 and -1 are exact: as if applied after)
        wv = -(gp * np.where(diag, 0.5, 1.0))
        e, ed = self._rows
        nt = e.shape[1]
        u = np.empty((len(zs), nt))
        v = np.empty((len(zs), nt))
        # in blocks of AXIAL_BLOCK samples: the pair products (66 rows for 11 modes) stay in cache and their
        # buffers are reused (one pass over the whole series wrote ~23 MB of fresh memory per call; the matrix
        # products give each column the same sums either way)
        ee = np.empty((len(iu), min(AXIAL_BLOCK + 1, nt)))
        eed = np.empty_like(ee)
        s0 = 0
        while s0 < nt:
            s1 = min(s0 + AXIAL_BLOCK, nt)
            if nt - s1 == 1:
                s1 = nt  # no one-sample block: numpy would hand it to a matrix-vector product, summing in another order
            w = s1 - s0
            k = 0
            for i in range(nm):
                rows = slice(k, k + nm - i)
                np.multiply(e[i, s0:s1], e[i:, s0:s1], out=ee[rows, :w])
                np.multiply(e[i, s0:s1], ed[i:, s0:s1], out=eed[rows, :w])
                eed[rows, :w] += e[i:, s0:s1] * ed[i, s0:s1]
                k += nm - i
            np.matmul(wu, ee[:, :w], out=u[:, s0:s1])
            np.matmul(wv, eed[:, :w], out=v[:, s0:s1])
            s0 = s1
        return u, v


def branch_motion(res: MultibodyResult, modes, offset: int = 0) -> BranchMotion:
    """Modal displacements, velocities and accelerations of the branch from a coupled multibody result
    (``modes``: the :class:`~berryshaker.plant.modes.Modes` the run was built with; ``offset``: index of its
    first modal coordinate in the plant's block-diagonal modal body, 0 for the instrumented branch, another for
    a probe of :func:`coupled_mechanism`).

    Parameters
    ----------
    res : MultibodyResult
        A coupled run.
    modes : Modes
        The modes the branch was built with.
    offset : int
        Index of the branch's first modal coordinate in the plant's modal body.

    Returns
    -------
    BranchMotion
        Modal displacements and velocities from the run's state, accelerations from the modal equations
        (stiffness, damping and the contacts that load this branch), and those contacts' normal forces.
    """
    cm = res.compiled
    spec = cm.spec
    nb3 = 3 * len(spec.bodies)
    nm = len(modes.omega)
    n = cm.n
    cols = slice(offset, offset + nm)
    eta = res.y[:, nb3 + offset:nb3 + offset + nm]
    etad = res.y[:, n + nb3 + offset:n + nb3 + offset + nm]
    w = modes.omega
    zeta = np.asarray(spec.plant.damping_ratio, float)  # one ratio, or one per mode
    zeta = zeta[cols] if zeta.ndim else zeta  # the other blocks' modes follow (block-diagonal)
    etadd = -(w**2) * eta - 2 * zeta * w * etad
    phi_tab = cm.model[13]
    contact_force = {}
    for row, c in enumerate(spec.plant.contacts):
        if not np.any(phi_tab[row, cols]):
            continue  # another branch's contact (a bush member, a probe): it does not load this branch
        k = cm.frc_names.index(c.name)
        f = res.elements[:, k, mb.EO_FN]
        contact_force[c.name] = f
        etadd = etadd + np.outer(c.side * f, phi_tab[row, cols])
    return BranchMotion(res.t, modes, eta, etad, etadd, contact_force)


def stem_forces(motion: BranchMotion, z, mass, pedicel) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Stem force on fruit of mass ``mass`` at positions z (berryshaker.plant.pedicel).

    ``z``: positions (m), or a tuple (y, v, y_axial, v_axial) of branch motions already evaluated there
    (BranchMotion.lateral / axial), to reuse them for several masses.
    The axial force includes the weight m0 g when ``pedicel.include_weight`` (upright branch: its axis is
    vertical).  Lateral: driven by the branch's lateral displacement and velocity (absolute-coordinate form,
    smooth inputs); axial: by the foreshortening displacement and velocity (BranchMotion.axial).

    Parameters
    ----------
    motion : BranchMotion
        The branch's modal solution (its time grid, and the motion when ``z`` is positions).
    z : array_like or tuple
        Fruit positions (m from the root), or (y, v, y_axial, v_axial) already evaluated there (m, m/s).
    mass : float
        Fruit mass m0 (kg).
    pedicel : PedicelSpec
        The pedicel description (``stiffness`` N/m, ``damping`` N s/m, ``include_weight``).

    Returns
    -------
    lateral, axial, magnitude : numpy.ndarray
        Stem force on the fruit, each (n_z, n_t) (N): lateral, axial and the in-plane magnitude.
    """
    from berryshaker.plant.pedicel import GRAVITY, stem_response

    if isinstance(z, tuple) and len(z) == 4:  # precomputed (y, v, y_axial, v_axial): many masses, one motion
        y, v, ya, va = z
    else:
        y, v, _ = motion.lateral(z, acceleration=False)
        ya, va = motion.axial(z)
    _, f_lat = stem_response(motion.t, y, v, mass=mass, stiffness=pedicel.stiffness, damping=pedicel.damping,
                             displacement=False)
    _, f_ax = stem_response(motion.t, ya, va, mass=mass, stiffness=pedicel.stiffness, damping=pedicel.damping,
                            displacement=False)
    if pedicel.include_weight:
        f_ax = f_ax + mass * GRAVITY
    return f_lat, f_ax, np.hypot(f_lat, f_ax)


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
    (:class:`BranchMotion`), for callers that evaluate the branch elsewhere (the stem-force envelopes over
    the whole fruit zone, berryshaker.harvest.virtual.stem_force_envelope_run).  The same run, step for
    step, as :func:`simulate_fruit_force` with the same arguments (no probes): the fruit forces, the comb load
    moments and their summary are left out (~40 ms of a replicate's ~0.5 s, benchmarks/HISTORY.md sec. 22).

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
