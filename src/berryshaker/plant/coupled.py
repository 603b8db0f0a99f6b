"""Rigid-flexible coupling: the multibody harvester drives past a branch whose modal coordinates are part
of the same integrated state; the combs strike it through the IMPACT law and it pushes back (study
sec. 2.5, Figs. 24-26).  Output: fruit harvesting force at the root, middle and end of the branch against
the machine-to-plant distance, and the eq. 17 verdict per position."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from berryshaker.config import Machine
from berryshaker.multibody import kernel as mb
from berryshaker.multibody.engine import MultibodyResult, simulate_mechanism
from berryshaker.drives.groove_cam.mechanism import harvester_mechanism
from berryshaker.multibody.spec import mechanism_from_dict
from berryshaker.errors import ConfigError
from berryshaker.drives.groove_cam.kinematics import mid_stroke_angles
from berryshaker.plant.response import harvest_verdict

#: the study's fruit-force ranges (N) at the root, middle and end of the branch [study, claim 5]
STUDY_FRUIT_FORCE_N = {"root": (0.25, 0.4), "middle": (0.65, 0.9), "end": (0.8, 1.2)}


def coupled_mechanism(machine: Machine, clearance: dict[str, float] | None = None, margin: float = 0.15):
    """Harvester mechanism description with the machine's branch coupled to both combs."""
    if machine.plant is None:
        raise ConfigError("the machine description has no [plant] block (see `berryshaker config init`)")
    if clearance:
        from berryshaker.drives.groove_cam.mlsd import validate_clearances

        machine = machine.with_clearances(validate_clearances(machine, clearance))
    pl = machine.plant
    ct = pl.contact
    half = ct.span / 2
    v = machine.operation.walking_speed
    duration = (2 * (half + margin)) / v
    period = 2 * math.pi / machine.cam.speed
    revolutions = max(2, int(math.ceil(duration / period)))
    spec = harvester_mechanism(machine, revolutions=revolutions).model_dump()
    lc = machine.combs.length
    rf = ct.finger_radius
    td0, te0 = mid_stroke_angles(machine)
    xd, _ = machine.shaft_D
    xe, _ = machine.shaft_E
    spec["plant"] = dict(
        branch=pl.branch.model_dump(), n_modes=ct.n_modes, lateral_axis=[1.0, 0.0], walking_speed=v,
        start_distance=-(half + margin), half_span=half, ramp=min(0.1, half / 2), ramp_depth=0.2,
        contact=dict(law="impact", stiffness=ct.stiffness, exponent=ct.exponent, damping=ct.damping,
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
    out = mechanism_from_dict(spec, "(harvester + branch)")
    return out, machine


@dataclass
class FruitForceResult:
    distance: np.ndarray  # machine-to-plant distance along the row (m), negative before the comb centre
    t: np.ndarray
    fruit_force: dict[str, np.ndarray]  # N, per fruit name
    z: dict[str, float]  # fruit positions (m)
    contact_force: dict[str, np.ndarray]  # comb-branch normal forces (N)
    deflection: dict[str, np.ndarray]  # branch deflection at each fruit (m)
    result: MultibodyResult = field(repr=False)
    machine: Machine = field(repr=False)

    def summary(self) -> dict:
        out = {"positions": {}, "study_ranges_N": STUDY_FRUIT_FORCE_N, "contact": {}}
        for name, f in self.fruit_force.items():
            peak = float(np.max(np.abs(f)))
            entry = {"z_m": self.z[name], "peak_force_N": peak,
                     "rms_force_N": float(np.sqrt(np.mean(f**2))),
                     "peak_at_distance_m": float(self.distance[int(np.argmax(np.abs(f)))]),
                     "eq17": harvest_verdict(peak).as_dict()}
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
        out["clearance_mm"] = {k: v * 1e3 for k, v in self.machine.clearance.sizes().items()}
        return out


def simulate_fruit_force(machine: Machine, clearance: dict[str, float] | None = None, rtol: float = 1e-6,
                         output_step: float = 2e-5) -> FruitForceResult:
    """Drive the harvester past one branch and record the fruit harvesting force (eq. 16)."""
    spec, machine = coupled_mechanism(machine, clearance)
    res = simulate_mechanism(spec, rtol=rtol, output_step=output_step)
    cm = res.compiled
    modes = cm.modes
    nb3 = 3 * len(spec.bodies)
    nm = len(modes.omega)
    n = cm.n
    eta = res.y[:, nb3:nb3 + nm]
    etad = res.y[:, n + nb3:n + nb3 + nm]
    w = modes.omega
    zeta = spec.plant.branch.damping_ratio
    etadd = -(w**2) * eta - 2 * zeta * w * etad
    phi_tab = cm.model[13]
    contact_force = {}
    for row, c in enumerate(spec.plant.contacts):
        k = cm.frc_names.index(c.name)
        f = res.elements[:, k, mb.EO_FN]
        contact_force[c.name] = f
        etadd += np.outer(c.side * f, phi_tab[row])
    pl = machine.plant
    fruit, zs, defl = {}, {}, {}
    for name, frac in zip(pl.fruit.names, pl.fruit.positions):
        z = frac * pl.branch.length
        phi = modes.shape_at(z)
        fruit[name] = pl.fruit.mass * (etadd @ phi)
        defl[name] = eta @ phi
        zs[name] = z
    distance = spec.plant.start_distance + spec.plant.walking_speed * res.t
    return FruitForceResult(distance, res.t, fruit, zs, contact_force, defl, res, machine)
