"""Tolerance design: choose an ISO 286 fit for every clearance joint, trading manufacturing cost, collision
force and life (NSGA-II, pymoo).

Each joint picks one fit from a discrete list of running fits (default :data:`CANDIDATE_FITS`) at its nominal
diameter (``[clearance.<pair>] diameter``).  Three objectives, all minimised:

1. **cost** -- a reciprocal-power cost-tolerance model per part, C(T) = a + b / T^k (T the part's IT width,
   um), summed over hole and shaft of every joint, in relative cost units.  This model form is one of the
   cost-tolerance curves compared by Chase, Greenwood, Loosli and Hauglund (1990), "Least cost tolerance
   allocation for mechanical assemblies with automated process selection", Manufacturing Review 3(1).  The
   coefficients (a = 1, b = 20 um, k = 1) are **[assumed]**: fit them to the shop's own cost data.
2. **static-equivalent collision force** (N) -- the largest over the joints, each joint's p95 of its impact peaks at
   its fit's mean clearance (berryshaker.multibody.impacts; a run's single largest force is an extreme, not a load).
3. **-life** (h) -- the machine's maintenance interval: the first joint to grow from its fit's mean clearance
   to its clearance limit, dc/dh = r(c) with r the Archard growth rate (hours = int dc / r(c)).

The dynamics enter through a **surrogate** (:mod:`berryshaker.life.clearance_response`): per joint, its static-equivalent
collision force (the mean over perturbed starts of each run's p95 of its impact peaks) and growth rate against its own clearance from a
one-at-a-time grid of multibody runs; NSGA-II runs on their linear interpolants, and a force that falls with growing
clearance beyond the start-to-start noise is flagged and explained (:func:`force_fall_notes`).  The recommended
design is the compromise point of the Pareto front nearest the ideal point in objectives normalised to [0, 1] over
the front.

NSGA-II: K. Deb, A. Pratap, S. Agarwal and T. Meyarivan, "A fast and elitist multiobjective genetic algorithm:
NSGA-II", IEEE Trans. Evol. Comput. 6 (2002) 182-197; pymoo: J. Blank and K. Deb, IEEE Access 8 (2020).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from berryshaker.errors import ConfigError
from berryshaker.life.clearance_response import (  # noqa: F401  (the surrogate's public names, re-exported)
    GRID_FLOOR,
    LIFE_CAP_H,
    ClearanceResponse,
    clearance_responses,
    default_clearance_limits,
    response_grid,
)
from berryshaker.life.fits import Fit, parse_fit
from berryshaker.life.wear import clearance_size_from_fit

#: Running fits offered to every joint, tightest first (ISO 286 hole-basis clearance fits).
CANDIDATE_FITS: tuple[str, ...] = ("H7/g6", "H7/f7", "H8/f7", "H8/e8", "H9/d9", "H11/c11")
#: Reciprocal-power cost model C(T) = a + b / T^k per part, T in um [assumed coefficients].
COST_MODEL: dict[str, float] = {"a": 1.0, "b": 20.0, "k": 1.0}


def tolerance_cost(tolerance_um, a: float = COST_MODEL["a"], b: float = COST_MODEL["b"],
                   k: float = COST_MODEL["k"]):
    """Relative manufacturing cost of one part with tolerance T (um): C = a + b / T^k.

    Parameters
    ----------
    tolerance_um : float or array_like
        Tolerance width T (um), > 0.
    a, b, k : float
        Fixed cost, precision cost scale (cost units um^k) and exponent [assumed defaults].

    Returns
    -------
    float or numpy.ndarray
        Cost in relative units (1 = the fixed cost of a part).

    Notes
    -----
    Reciprocal-power cost-tolerance model, one of the forms compared by Chase, Greenwood, Loosli and Hauglund
    (1990), Manufacturing Review 3(1).  Coefficients are assumed, not fitted to cost data.
    """
    t = np.asarray(tolerance_um, float)
    if np.any(~(t > 0)):
        raise ConfigError(f"tolerance must be > 0 um, got {tolerance_um!r}")
    out = a + b / t**k
    return float(out) if out.ndim == 0 else out


def fit_cost(fit: Fit) -> float:
    """Cost of a fit: :func:`tolerance_cost` of the hole's plus the shaft's IT width.

    Parameters
    ----------
    fit : Fit
        An ISO fit with hole and shaft classes.

    Returns
    -------
    float
        Cost in relative units (dimensionless; :data:`COST_MODEL`, 2 = the fixed cost of two parts).

    Raises
    ------
    ConfigError
        The fit is an explicit clearance range (no parts).
    """
    if fit.hole is None or fit.shaft is None:
        raise ConfigError(f"fit {fit.designation!r}: a cost needs hole and shaft classes, not a clearance range")
    return tolerance_cost(fit.hole.tolerance_um) + tolerance_cost(fit.shaft.tolerance_um)


def _joint_kind(machine, joint: str) -> str:
    return "revolute" if machine.clearance[joint].kind == "pin-in-bore" else "point-line"


@dataclass
class JointCandidates:
    """The fits one joint may take and what each means for it.

    Attributes
    ----------
    joint : str
        Pair name.
    diameter_mm : float
        Nominal diameter of the fits (mm).
    fits : list of Fit
        Candidate fits.
    size : numpy.ndarray
        Mean clearance of each fit in the machine's convention (m): radial for pins, diametral (free travel)
        for rollers.
    cost : numpy.ndarray
        :func:`fit_cost` of each (relative cost units, dimensionless).
    """

    joint: str
    diameter_mm: float
    fits: list[Fit]
    size: np.ndarray
    cost: np.ndarray


def joint_candidates(machine, joints, fits=CANDIDATE_FITS) -> dict[str, JointCandidates]:
    """Candidate fits per joint at its diameter (``[clearance.<pair>] diameter``, else the [assumed] default).

    Parameters
    ----------
    machine : MachineBase
        The machine description.
    joints : iterable of str
        Clearance pairs.
    fits : sequence of str
        Fit designations (at least one), each a clearance fit at every joint's diameter.

    Returns
    -------
    dict of str to JointCandidates
        Per joint: the fits, their mean clearance size (m, machine convention) and cost.

    Raises
    ------
    ConfigError
        No fit given, or a fit that is not a clearance fit at a joint's diameter.
    """
    from berryshaker.life.joint_loads import joint_geometry

    if not fits:
        raise ConfigError("tolerance: give at least one candidate fit, e.g. H7/f7")
    out = {}
    for j in joints:
        geo = joint_geometry(machine, j)
        d_mm = geo.diameter * 1e3
        fl = [parse_fit(f, d_mm) for f in fits]
        bad = [f.designation for f in fl if f.kind != "clearance"]
        if bad:
            raise ConfigError(f"tolerance: {', '.join(bad)} are not clearance fits at {d_mm:g} mm; a running "
                              "joint needs a clearance fit (e.g. H7/f7)")
        kind = _joint_kind(machine, j)
        out[j] = JointCandidates(j, d_mm, fl, np.array([clearance_size_from_fit(f, kind, "mean") for f in fl]),
                                 np.array([fit_cost(f) for f in fl]))
    return out


def evaluate_designs(choice: np.ndarray, joints, candidates: dict[str, JointCandidates],
                     responses: dict[str, ClearanceResponse], limits: dict[str, float]) -> np.ndarray:
    """Objectives [cost, static-equivalent force (N), -life (h)] of designs (rows of fit indices, one column per joint).

    Parameters
    ----------
    choice : array_like of int
        Designs: one row per design, one fit index per joint (a single row may be 1-D).
    joints : sequence of str
        Joints in the columns' order.
    candidates : dict of str to JointCandidates
        The fits each joint may take.
    responses : dict of str to ClearanceResponse
        The surrogate per joint.
    limits : dict of str to float
        Clearance limit per joint (m).

    Returns
    -------
    numpy.ndarray
        Shape (designs, 3): summed cost (relative units), largest static-equivalent force over the joints (N) at the fits'
        mean clearances, minus the shortest hours to a joint's limit (h).
    """
    choice = np.atleast_2d(np.asarray(choice, int))
    out = np.zeros((choice.shape[0], 3))
    for r, row in enumerate(choice):
        cost, force, life = 0.0, 0.0, math.inf
        for k, j in enumerate(joints):
            cand = candidates[j]
            c0 = float(cand.size[row[k]])
            cost += float(cand.cost[row[k]])
            force = max(force, float(responses[j].force(c0)))
            life = min(life, responses[j].service_hours(c0, limits[j]))
        out[r] = (cost, force, -life)
    return out


def non_dominated(f: np.ndarray) -> np.ndarray:
    """Boolean mask of the rows of f (minimised objectives) that no other row dominates.

    Parameters
    ----------
    f : array_like
        Objectives, one row per point (any units, all minimised).

    Returns
    -------
    numpy.ndarray of bool
        True for the non-dominated rows.
    """
    f = np.asarray(f, float)
    keep = np.ones(len(f), bool)
    for i in range(len(f)):
        dominated = np.all(f <= f[i], axis=1) & np.any(f < f[i], axis=1)
        keep[i] = not dominated.any()
    return keep


def compromise_index(f: np.ndarray) -> int:
    """Index of the point nearest the ideal point, objectives normalised to [0, 1] over the given set.

    Parameters
    ----------
    f : array_like
        Objectives, one row per point (any units, all minimised).

    Returns
    -------
    int
        Row nearest (Euclidean, normalised) to the per-objective minima.
    """
    f = np.asarray(f, float)
    lo, hi = f.min(axis=0), f.max(axis=0)
    span = np.where(hi > lo, hi - lo, 1.0)
    d = np.linalg.norm((f - lo) / span, axis=1)
    return int(np.argmin(d))


@dataclass
class ToleranceDesign:
    """Pareto front of fit choices and the recommended one.

    Attributes
    ----------
    joints : list of str
        Joints designed.
    front : list of dict
        Non-dominated designs: ``fits`` (joint -> fit), ``cost``, ``design_force_N``, ``life_h``.
    recommended : dict
        The compromise design with, per joint, the fit, its clearance range and mean (mm), the predicted static-equivalent
        force and the hours to the joint's limit (``maintenance_interval_h``).
    responses : dict
        The surrogate per joint.
    limits_m : dict
        Clearance limit per joint (m).
    runs : int
        Multibody runs of the grid.
    seed : int
        NSGA-II seed.
    notes : list of str
        Assumptions of this design.
    """

    joints: list[str]
    front: list[dict]
    recommended: dict
    responses: dict[str, ClearanceResponse]
    limits_m: dict[str, float]
    runs: int
    seed: int
    notes: list[str] = field(default_factory=list)

    def to_dict(self) -> dict:
        """JSON-able result.

        Returns
        -------
        dict
            ``joints``, ``front``, ``recommended``, ``surrogate`` (per joint, :meth:`ClearanceResponse.to_dict`),
            ``clearance_limit_mm`` (mm), ``simulations``, ``seed``, ``cost_model`` and ``notes``.
        """
        return {"joints": self.joints, "front": self.front, "recommended": self.recommended,
                "surrogate": {j: r.to_dict() for j, r in self.responses.items()},
                "clearance_limit_mm": {j: v * 1e3 for j, v in self.limits_m.items()},
                "simulations": self.runs, "seed": self.seed, "cost_model": dict(COST_MODEL), "notes": self.notes}


def nsga2_front(joints, candidates, responses, limits, pop_size: int = 60, generations: int = 80,
                seed: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """NSGA-II (pymoo) over integer fit indices; returns (designs, objectives) of the final non-dominated set.

    Integer coding: one variable per joint in 0..len(fits)-1, integer random sampling, SBX crossover and
    polynomial mutation with rounding repair (pymoo's recipe for discrete variables).  Duplicate offspring are
    allowed (the design space is small, and eliminating them makes pymoo's mating loop retry for long); the
    returned set is de-duplicated and filtered to the non-dominated designs.

    Parameters
    ----------
    joints : sequence of str
        Joints designed.
    candidates : dict of str to JointCandidates
        The fits each joint may take.
    responses : dict of str to ClearanceResponse
        The surrogate per joint.
    limits : dict of str to float
        Clearance limit per joint (m).
    pop_size : int
        NSGA-II population size.
    generations : int
        NSGA-II generations.
    seed : int
        Seed of pymoo's random sampling and operators.

    Returns
    -------
    designs : numpy.ndarray of int
        Non-dominated designs (fit index per joint), sorted by cost, then static-equivalent force.
    objectives : numpy.ndarray
        Their objectives (:func:`evaluate_designs`: cost, N, -h).
    """
    from pymoo.algorithms.moo.nsga2 import NSGA2
    from pymoo.core.problem import Problem
    from pymoo.operators.crossover.sbx import SBX
    from pymoo.operators.mutation.pm import PM
    from pymoo.operators.repair.rounding import RoundingRepair
    from pymoo.operators.sampling.rnd import IntegerRandomSampling
    from pymoo.optimize import minimize

    ub = np.array([len(candidates[j].fits) - 1 for j in joints])

    class FitChoice(Problem):
        def __init__(self):
            super().__init__(n_var=len(joints), n_obj=3, xl=np.zeros(len(joints)), xu=ub, vtype=int)

        def _evaluate(self, x, out, *args, **kwargs):
            out["F"] = evaluate_designs(np.rint(x).astype(int), joints, candidates, responses, limits)

    algo = NSGA2(pop_size=pop_size, sampling=IntegerRandomSampling(),
                 crossover=SBX(prob=0.9, eta=3.0, vtype=float, repair=RoundingRepair()),
                 mutation=PM(eta=3.0, vtype=float, repair=RoundingRepair()), eliminate_duplicates=False)
    res = minimize(FitChoice(), algo, ("n_gen", int(generations)), seed=int(seed), verbose=False)
    x = np.atleast_2d(np.rint(res.X).astype(int))
    f = evaluate_designs(x, joints, candidates, responses, limits)
    keep = non_dominated(f)
    x, f = x[keep], f[keep]
    order = np.lexsort((f[:, 1], f[:, 0]))
    x, f = x[order], f[order]
    uniq = np.unique(x, axis=0, return_index=True)[1]
    uniq.sort()
    return x[uniq], f[uniq]


def tolerance_design(machine, runner, joints=None, fits=CANDIDATE_FITS, limits: dict[str, float] | None = None,
                     n_points: int = 4, revolutions: int = 2, pop_size: int = 60, generations: int = 80,
                     seed: int = 1, starts: int | None = None) -> ToleranceDesign:
    """Choose a fit per joint: surrogate grid through the runner, NSGA-II on it, compromise design.

    Parameters
    ----------
    machine : MachineBase
        The machine description (geometry, material and diameter of each pair).
    runner : SweepRunner
        Cached runner for the grid's multibody runs.
    joints : list of str, optional
        Joints to design (default every pair).
    fits : sequence of str
        Candidate fits (default :data:`CANDIDATE_FITS`).
    limits : dict, optional
        Clearance limit per joint (m) for the life objective (default the service limit,
        :func:`berryshaker.life.service.service_limits`).
    n_points : int
        Grid clearances per joint (runs = joints x n_points).
    revolutions : int
        Drive revolutions per run (>= 2).
    pop_size, generations, seed : int
        NSGA-II settings (same seed, same front).
    starts : int, optional
        Perturbed starts per grid point (runs = joints x n_points x starts; default ``harvest.replicates``); the
        force objective is the mean of the per-start static-equivalent loads.

    Returns
    -------
    ToleranceDesign
        The Pareto front, the recommended (compromise) design per joint, the surrogate and the notes.

    Raises
    ------
    ConfigError
        An unknown joint, or invalid fits, grid or starts.
    """
    joints = list(joints) if joints else list(machine.pair_names)
    unknown = [j for j in joints if j not in machine.pair_names]
    if unknown:
        raise ConfigError(f"unknown joint(s) {', '.join(unknown)}; pairs: {', '.join(machine.pair_names)}")
    from berryshaker.life.service import service_limits

    lim = service_limits(machine, joints)
    lim.update({k: float(v) for k, v in (limits or {}).items() if k in joints})
    cands = joint_candidates(machine, joints, fits)
    grid = response_grid(machine, joints, lim, {j: float(cands[j].size.min()) for j in joints}, n_points)
    starts = int(machine.harvest.replicates if starts is None else starts)
    responses = clearance_responses(machine, joints, grid, runner, revolutions, starts=starts)
    x, f = nsga2_front(joints, cands, responses, lim, pop_size, generations, seed)
    front = [{"fits": {j: cands[j].fits[row[k]].designation for k, j in enumerate(joints)},
              "cost": float(fr[0]), "design_force_N": float(fr[1]), "life_h": float(-fr[2])}
             for row, fr in zip(x, f)]
    best = compromise_index(f)
    row = x[best]
    per_joint = {}
    for k, j in enumerate(joints):
        fit = cands[j].fits[row[k]]
        c0 = float(cands[j].size[row[k]])
        per_joint[j] = {"fit": fit.designation, "diameter_mm": cands[j].diameter_mm,
                        "clearance_min_mm": fit.clearance_min * 1e3, "clearance_max_mm": fit.clearance_max * 1e3,
                        "size_mm": c0 * 1e3,
                        "size_convention": "radial" if _joint_kind(machine, j) == "revolute" else "free travel",
                        "cost": float(cands[j].cost[row[k]]),
                        "design_force_N": float(responses[j].force(c0)),
                        "design_force_se_N": (float(np.interp(c0, responses[j].clearance, responses[j].design_force_se))
                                            if responses[j].design_force_se is not None else None),
                        "clearance_limit_mm": lim[j] * 1e3,
                        "maintenance_interval_h": responses[j].service_hours(c0, lim[j])}
    recommended = {**front[best], "index": best, "joints": per_joint,
                   "maintenance_interval_h": float(-f[best, 2])}
    notes = [f"surrogate: {n_points} clearances per joint, one joint at a time (others at the description's "
             f"sizes), each the mean over {starts} perturbed start(s) of the run's static-equivalent collision force "
             "(the p95 of its impact peaks; the same starts at "
             "every point), linear interpolation; interactions between joints are ignored",
             f"force and growth rate held constant below {GRID_FLOOR * 1e3:g} mm and beyond the grid",
             "cost: reciprocal-power model a + b/T^k per part (Chase et al. 1990 compare this form); "
             "coefficients [assumed]",
             "life: Archard growth from the fit's mean clearance to the limit under the faster wear mode "
             "(abrasive field wear where it is faster than the pair's lubricated wear, docs/life.md); its k "
             "dominates the uncertainty",
             "recommended: Pareto point nearest the ideal point, objectives normalised over the front"]
    notes += force_fall_notes(responses, machine)
    return ToleranceDesign(joints, front, recommended, responses, lim, len(joints) * n_points * int(starts), int(seed),
                           notes)


def force_fall_notes(responses: dict[str, ClearanceResponse], machine=None) -> list[str]:
    """A note for every joint whose mean static-equivalent force falls as its clearance grows beyond the noise
    (:meth:`ClearanceResponse.force_falls`), so that a tighter fit with a higher force is explained, not hidden.

    Why it is physics, not noise: the pin-in-bore contact law depends on the radii only through the radial clearance
    c (Johnson's internal line contact, :func:`berryshaker.contact.pin_in_bore.pin_in_bore_law`): the smaller c, the
    more conformal and the stiffer the contact, so an impact at a given approach speed peaks higher.  On the
    reference machine C and F fall from 0.025 to 0.083 mm by 5 and 4 standard errors of the difference over 8
    starts.

    Parameters
    ----------
    responses : dict of str to ClearanceResponse
        The surrogate per joint.
    machine : MachineBase, optional
        Tells pins from rollers (without it every joint is explained as a pin).

    Returns
    -------
    list of str
        One note per falling grid step, with the fall, its standard error, p and why.
    """
    out = []
    for j, r in responses.items():
        pin = machine is None or _joint_kind(machine, j) == "revolute"
        why = ("the pin-in-bore contact stiffens as the radial clearance shrinks (Johnson's internal line contact "
               "depends on the radii through the clearance, docs/contact.md), so a tighter fit hits harder at the "
               "same approach speed") if pin else "a property of this joint's dynamics that the runs measure"
        for f in r.force_falls():
            out.append(f"{j}: the mean static-equivalent force falls by {-f['change_N']:.0f} +- {f['se_N']:.0f} N (SE, paired over "
                       f"{r.starts} starts, p = {f['p']:.2g}) from {f['from_mm']:.3g} to {f['to_mm']:.3g} mm, beyond "
                       f"the start-to-start noise: {why}")
    return out
