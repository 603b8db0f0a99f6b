"""The fruit-force result of a coupled drive-past (berryshaker.harvest.coupled.simulate_fruit_force): fruit forces per
fruit position against time and machine-to-plant distance, with its summary (peaks, the eq. 17 verdict, the study's
ranges, contact statistics, comb load moments).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from berryshaker.config import Machine
from berryshaker.harvest.coupled_branch import BranchMotion, bush_members
from berryshaker.multibody.engine import MultibodyResult
from berryshaker.plant.response import harvest_verdict

#: the study's fruit-force ranges (N) at the root, middle and end of the branch [study, claim 5]
STUDY_FRUIT_FORCE_N = {"root": (0.25, 0.4), "middle": (0.65, 0.9), "end": (0.8, 1.2)}


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
        Moment of the bush on each comb about its shaft (N m; :func:`~berryshaker.harvest.coupled.comb_load_moment`).
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
