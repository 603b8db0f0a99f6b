"""Rigid-flexible coupling: the multibody harvester drives past a branch whose modal coordinates are part
of the same integrated state; the combs strike it through the IMPACT law and it pushes back (study
sec. 2.5, Figs. 24-26).  Output: fruit harvesting force at the root, middle and end of the branch against
the machine-to-plant distance, and the eq. 17 verdict per position."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np

from berryshaker.config import Machine
from berryshaker.multibody import kernel as mb
from berryshaker.multibody.engine import MultibodyResult, simulate_mechanism
from berryshaker.multibody.spec import mechanism_from_dict
from berryshaker.errors import ConfigError
from berryshaker.drives import drive_of
from berryshaker.plant.modes import branch_modes
from berryshaker.plant.response import harvest_verdict

#: the study's fruit-force ranges (N) at the root, middle and end of the branch [study, claim 5]
STUDY_FRUIT_FORCE_N = {"root": (0.25, 0.4), "middle": (0.65, 0.9), "end": (0.8, 1.2)}


@functools.lru_cache(maxsize=32)
def _fruit_branch(branch_key: tuple, n_modes: int, z: tuple, mass: float, stiffness: float, damping: float):
    from berryshaker.plant.branch import Branch
    from berryshaker.plant.modes import analytic_modes
    from berryshaker.plant.pedicel import fruit_branch_modes

    return fruit_branch_modes(analytic_modes(Branch(*branch_key), n_modes), np.array(z), mass, stiffness, damping)


def plant_modes(machine: Machine):
    """Modes the coupled run integrates: ``(modes, fruit_branch)``.

    With the pedicel model and ``pedicel.coupling = "two_way"`` (default) the named fruit sit on their
    stems inside the modal model (berryshaker.plant.pedicel.fruit_branch_modes: n_modes branch modes
    + one mode per fruit); ``fruit_branch`` then gives the fruit displacements.  Otherwise the branch's
    own modes (study eq. 15) and ``None``.
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


def coupled_mechanism(machine: Machine, clearance: dict[str, float] | None = None, margin: float = 0.15):
    """Harvester mechanism description with the machine's branch coupled to both combs."""
    if machine.plant is None:
        raise ConfigError("the machine description has no [plant] block (see `berryshaker config init`)")
    machine = machine.with_clearances(clearance)
    drive = drive_of(machine)
    pl = machine.plant
    ct = pl.contact
    half = ct.span / 2
    v = machine.operation.walking_speed
    duration = (2 * (half + margin)) / v
    period = 2 * math.pi / machine.drive_speed
    revolutions = max(2, int(math.ceil(duration / period)))
    spec = drive.mechanism(machine, revolutions=revolutions).model_dump()
    lc = machine.combs.length
    rf = ct.finger_radius
    td0, te0 = drive.mid_stroke_angles(machine)
    xd, _ = machine.shaft_D
    xe, _ = machine.shaft_E
    station = 0.5 * (ct.station_left + ct.station_right) * pl.branch.length
    k_contact, n_contact = ct.impact_stiffness(
        pl.branch.root_diameter * (1 - (1 - pl.branch.tip_diameter / pl.branch.root_diameter) * station
                                   / pl.branch.length))
    modes, fb = plant_modes(machine)
    spec["plant"] = dict(
        omega=modes.omega.tolist(), damping_ratio=pl.branch.damping_ratio,
        shapes=[np.atleast_1d(modes.shape_at(st * pl.branch.length)).tolist()
                for st in (ct.station_left, ct.station_right)],
        lateral_axis=[1.0, 0.0], walking_speed=v,
        start_distance=-(half + margin), half_span=half, ramp=min(0.1, half / 2), ramp_depth=0.2,
        contact=dict(law="impact", stiffness=k_contact, exponent=n_contact, damping=ct.damping,
                     damping_depth=ct.penetration_depth),
        contacts=[
            # left comb: the finger section rf from D along the comb (the body's +x axis); pushes +x
            dict(name="comb_left", body="left_comb", finger_point=[-lc / 2 + rf, 0.0],
                 station=ct.station_left, side=1, mid_lateral=xd + rf * math.cos(td0), engagement=ct.engagement),
            # right comb: the fingers point away from arm E->F (upwards); pushes -x
            dict(name="comb_right", body="right_comb", finger_point=[-lc / 2 - rf, 0.0],
                 station=ct.station_right, side=-1, mid_lateral=xe - rf * math.cos(te0),
                 engagement=ct.engagement),
        ],
    )
    spec["simulation"]["duration"] = duration
    spec["mechanism"]["name"] = f"{machine.machine.name} + branch (rigid-flexible coupling)"
    if fb is not None:
        # per-mode damping of the fruit-branch modes; an engine taking one ratio only gets the branch's
        spec["plant"]["damping_ratio"] = fb.damping_ratios.tolist()
        try:
            out = mechanism_from_dict(spec, "(harvester + branch)")
        except ConfigError as err:
            if "damping_ratio" not in str(err):
                raise
            spec["plant"]["damping_ratio"] = pl.branch.damping_ratio
            out = mechanism_from_dict(spec, "(harvester + branch)")
        return out, machine
    out = mechanism_from_dict(spec, "(harvester + branch)")
    return out, machine


@dataclass
class FruitForceResult:
    """Drive-past run: fruit forces per fruit position against time and machine-to-plant distance.

    ``fruit_force`` is the force the model compares with the bond (eq. 17): with the pedicel model
    (default) the magnitude of the in-plane stem force (lateral and axial, the fruit's weight included
    when ``plant.fruit.pedicel.include_weight``), with ``pedicel.rigid = true`` the study's eq. 16,
    m0 x branch acceleration (signed).  ``rigid_force`` is always eq. 16.
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

    def summary(self) -> dict:
        """Peaks per fruit position with the eq. 17 verdict and the study's ranges, contact statistics."""
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
        out["steps"] = int(self.result.info[0])
        out["wall_time_s"] = self.result.wall_time_s
        out["clearance_mm"] = {k: v * 1e3 for k, v in self.machine.clearance_sizes().items()}
        return out


@dataclass
class BranchMotion:
    """Modal solution of a coupled run, ready for evaluation anywhere on the branch."""

    t: np.ndarray
    modes: object  # berryshaker.plant.modes.Modes
    eta: np.ndarray  # (n_t, n_modes) modal displacements
    etad: np.ndarray  # modal velocities
    etadd: np.ndarray  # modal accelerations (branch stiffness, damping and the comb contacts)
    contact_force: dict[str, np.ndarray]

    def every(self, n: int) -> "BranchMotion":
        """Every n-th sample (for post-processing on a coarser, still uniform, time grid)."""
        return BranchMotion(self.t[::n], self.modes, self.eta[::n], self.etad[::n], self.etadd[::n],
                            {k: v[::n] for k, v in self.contact_force.items()})

    def lateral(self, z):
        """Lateral displacement (m), velocity (m/s), acceleration (m/s^2) at positions z, each (n_z, n_t)."""
        phi = self.modes.shape_at(np.atleast_1d(z))  # (n_modes, n_z)
        return (self.eta @ phi).T, (self.etad @ phi).T, (self.etadd @ phi).T

    def axial(self, z):
        """Axial (along-branch) displacement and velocity at z from the bending's foreshortening (m, m/s).

        u(z, t) = -1/2 int_0^z (dw/ds)^2 ds = -1/2 eta^T G(z) eta,  G_ij(z) = int_0^z phi_i' phi_j' ds
        (second order in the deflection; the Euler-Bernoulli branch has no first-order axial motion).
        """
        zs = np.atleast_1d(np.asarray(z, float))
        m = self.modes
        slope = np.array([np.gradient(s, m.z) for s in m.shapes])  # (n_modes, n_s)
        prod = slope[:, None, :] * slope[None, :, :]
        from scipy import integrate as _int

        cum = _int.cumulative_trapezoid(prod, m.z, axis=-1, initial=0.0)
        j = np.clip(np.searchsorted(m.z, zs) - 1, 0, len(m.z) - 2)
        wgt = (zs - m.z[j]) / (m.z[j + 1] - m.z[j])
        u, v = np.zeros((len(zs), len(self.t))), np.zeros((len(zs), len(self.t)))
        for i in range(len(zs)):
            g = (1 - wgt[i]) * cum[:, :, j[i]] + wgt[i] * cum[:, :, j[i] + 1]
            eg = self.eta @ g
            u[i] = -0.5 * np.sum(eg * self.eta, axis=1)
            v[i] = -np.sum(eg * self.etad, axis=1)
        return u, v


def branch_motion(res: MultibodyResult, modes) -> BranchMotion:
    """Modal displacements, velocities and accelerations of the branch from a coupled multibody result
    (``modes``: the :class:`~berryshaker.plant.modes.Modes` the run was built with)."""
    cm = res.compiled
    spec = cm.spec
    nb3 = 3 * len(spec.bodies)
    nm = len(modes.omega)
    n = cm.n
    eta = res.y[:, nb3:nb3 + nm]
    etad = res.y[:, n + nb3:n + nb3 + nm]
    w = modes.omega
    zeta = np.asarray(spec.plant.damping_ratio, float)  # one ratio, or one per mode
    etadd = -(w**2) * eta - 2 * zeta * w * etad
    phi_tab = cm.model[13]
    contact_force = {}
    for row, c in enumerate(spec.plant.contacts):
        k = cm.frc_names.index(c.name)
        f = res.elements[:, k, mb.EO_FN]
        contact_force[c.name] = f
        etadd = etadd + np.outer(c.side * f, phi_tab[row])
    return BranchMotion(res.t, modes, eta, etad, etadd, contact_force)


def stem_forces(motion: BranchMotion, z, mass, pedicel) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Stem force on fruit of mass ``mass`` at positions z (berryshaker.plant.pedicel).

    ``z``: positions (m), or a tuple (y, v, y_axial, v_axial) of branch motions already evaluated there
    (BranchMotion.lateral / axial), to reuse them for several masses.
    Returns (lateral, axial, magnitude), each (n_z, n_t), N.  The axial force includes the weight m0 g
    when ``pedicel.include_weight`` (upright branch: its axis is vertical).  Lateral: driven by the
    branch's lateral displacement and velocity (absolute-coordinate form, smooth inputs); axial: by the
    foreshortening displacement and velocity (BranchMotion.axial).
    """
    from berryshaker.plant.pedicel import GRAVITY, stem_response

    if isinstance(z, tuple) and len(z) == 4:  # precomputed (y, v, y_axial, v_axial): many masses, one motion
        y, v, ya, va = z
    else:
        y, v, _ = motion.lateral(z)
        ya, va = motion.axial(z)
    _, f_lat = stem_response(motion.t, y, v, mass=mass, stiffness=pedicel.stiffness, damping=pedicel.damping)
    _, f_ax = stem_response(motion.t, ya, va, mass=mass, stiffness=pedicel.stiffness, damping=pedicel.damping)
    if pedicel.include_weight:
        f_ax = f_ax + mass * GRAVITY
    return f_lat, f_ax, np.hypot(f_lat, f_ax)


def simulate_fruit_force(machine: Machine, clearance: dict[str, float] | None = None, rtol: float = 1e-6,
                         output_step: float = 2e-5, initial_perturbation=None) -> FruitForceResult:
    """Drive the harvester past one branch and record the fruit harvesting force.

    With the pedicel model (default) the force is the stem force of a fruit on a compliant stem
    (berryshaker.plant.pedicel; lateral: two-way coupled inside the modal model, or one-way by
    post-processing with ``pedicel.coupling = "one_way"``; axial: one-way, from the branch's
    foreshortening); with ``plant.fruit.pedicel.rigid`` it is the study's
    eq. 16, m0 x branch acceleration at the fruit.  Both are returned (``rigid_force`` is always eq. 16).
    ``initial_perturbation`` (berryshaker.multibody.perturbation.InitialPerturbation or RandomInitialPerturbation):
    start the machine off centre in its clearances and at another drive phase (replicate runs).
    """
    spec, machine = coupled_mechanism(machine, clearance)
    res = simulate_mechanism(spec, rtol=rtol, output_step=output_step, initial_perturbation=initial_perturbation)
    pl = machine.plant
    modes, fb = plant_modes(machine)
    motion = branch_motion(res, modes)
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
