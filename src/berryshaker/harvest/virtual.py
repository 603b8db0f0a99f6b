"""Virtual harvest: a seeded population of bushes run through the coupled machine-plant simulation.

Chain (docs/harvest.md):

1. For each branch class (the reference branch with its diameters scaled), one coupled drive-past
   simulation (berryshaker.harvest.coupled) gives a table of peak stem loads over position and fruit mass.
2. Bushes carry ``branches_per_bush`` branches of random class; fruit sit uniformly along the fruit zone
   of each branch, with lognormal masses (mean m0, coefficient of variation ``fruit_mass_cv``), ripe or
   unripe (mass fraction ``unripe_fraction``), and a lognormal strength factor (mean 1, CV ``bond_cv`` or
   ``unripe_bond_cv``).
3. Detachment (``bond_model = "pull_shear"``): a fruit comes off when the peak over the drive-past of its
   pull-shear load ratio, sqrt((F_pull/P)^2 + (F_shear/S)^2) with its class's mean pull and shear strengths
   (ripe 0.47 / 0.23 N, Kong et al. 2014 [published]), reaches its strength factor
   (berryshaker.plant.pedicel.peak_stem_loads); the study's eq. 17 bands on the stem-force magnitude
   (ripe 0.26-0.30 N, unripe 1.0-3.6 N) are the labelled alternative ``"study_eq17"``.  No cumulative
   (fatigue) detachment: we know no source for blueberry pedicel fatigue under shaking.
4. Damage (``damage_model = "impact"``): a detached fruit is bruised by its strike (the fingers' peak speed)
   or its fall onto the catching surface, against drop-test bruising thresholds (berryshaker.harvest.bruising,
   Brown et al. 1996); the former Weibull law in the stem force's acceleration is ``"stem_acceleration"``.
   The expected damaged mass is used (no sampling noise in the index).
5. Indexes as the study defines them: efficiency = picked mass per minute (bushes per minute = walking
   speed / plant spacing), unripe rate = unripe picked mass / picked mass, damage rate = damaged mass /
   picked mass.

Nothing is fitted to the study by default: the yield per bush comes from published yields
(docs/harvest.md, "Yield"), so the study's 3.93 kg/min, 3.1 % and 2.8 % are held-out checks
(berryshaker.harvest.calibration.calibration_table, ``berryshaker validate``).  :func:`calibrate_harvest` can
still fit the yield (and, with the Weibull damage, its scale) to a field value, and labels it fitted.

long module: the population, detachment, indexes, replicate statistics and the fit to a field value are one chain
read together (docs/harvest.md); bruising has its own module (berryshaker.harvest.bruising).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import optimize

from berryshaker.config import Machine, machine_from_dict
from berryshaker.harvest.shaking import shaking_amplitude
from berryshaker.harvest.spec import COUPLED_RTOL
from berryshaker.plant.response import RIPE_BOND_N, UNRIPE_BOND_N

STUDY_TARGETS = {"efficiency_kg_min": 3.93, "unripe_rate_pct": 3.1, "damage_rate_pct": 2.8}
Z_GRID = np.linspace(0.0, 1.0, 41)
#: bounds of the fruit sampled per bush: each bush carries its real number of fruit, yield per bush / mean fruit mass
#: (:func:`fruit_per_bush`), so the population's sampling noise is that of a real test run of ``harvest.bushes``
#: bushes; the bounds only keep a description's extreme values tractable
FRUIT_PER_BUSH_BOUNDS = (50, 20000)


def fruit_per_bush(machine: Machine, yield_per_bush: float | None = None) -> int:
    """Fruit on one bush at a harvest pass: yield per bush / mean fruit mass m0 (428 on the reference machine:
    0.77 kg of 1.8 g berries), within :data:`FRUIT_PER_BUSH_BOUNDS`.

    Parameters
    ----------
    machine : Machine
        Machine description with [plant] and [harvest] (fruit mass m0, ``harvest.yield_per_bush``).
    yield_per_bush : float, optional
        Yield per bush (kg), default ``harvest.yield_per_bush``.

    Returns
    -------
    int
        round(yield / m0), clipped to :data:`FRUIT_PER_BUSH_BOUNDS`.
    """
    yb = machine.harvest.yield_per_bush if yield_per_bush is None else yield_per_bush
    return int(np.clip(round(yb / machine.plant.fruit.mass), *FRUIT_PER_BUSH_BOUNDS))


def acceleration_envelope(machine: Machine, clearance: dict[str, float] | None, scale: float) -> np.ndarray:
    """Peak |acceleration| (m/s^2) along the branch (at Z_GRID fractions) for one branch class.

    Parameters
    ----------
    machine : Machine
        Machine description with [plant] and [harvest].
    clearance : dict of str to float or None
        Clearance sizes (m) per pair; None keeps the description's.
    scale : float
        Diameter scale of the branch class (dimensionless).

    Returns
    -------
    numpy.ndarray
        Peak lateral acceleration (m/s^2) over the drive-past at each fraction of :data:`Z_GRID`.
    """
    from berryshaker.harvest.coupled import drive_past

    m = branch_class_machine(machine, scale)
    _, motion = drive_past(m, clearance)
    # fruit forces are m0 * acceleration; recover accelerations on the grid from the modal solution
    acc = motion.lateral(Z_GRID * m.plant.branch.length)[2]  # (nz, n_t)
    return np.max(np.abs(acc), axis=1)


#: fruit-mass factors (of m0) of the stem-force envelope table; fruit in between are interpolated in log mass
MASS_FACTORS = np.exp(np.linspace(math.log(0.4), math.log(2.5), 9))


def stem_force_envelope(machine: Machine, clearance: dict[str, float] | None, scale: float) -> np.ndarray:
    """Peak stem force (N) of fruit on compliant pedicels, table over Z_GRID (rows) x MASS_FACTORS * m0
    (:func:`stem_force_envelope_run` from the centred initial state).

    Parameters
    ----------
    machine : Machine
        Machine description with [plant] and [harvest].
    clearance : dict of str to float or None
        Clearance sizes (m) per pair; None keeps the description's.
    scale : float
        Diameter scale of the branch class (dimensionless).

    Returns
    -------
    numpy.ndarray
        The table of :func:`stem_force_table`: (Z_GRID, MASS_FACTORS, channels), force in N and load ratios
        dimensionless.
    """
    return stem_force_envelope_run(machine, clearance, scale)[0]


#: output step (s) of the coupled drive-past behind a stem-force envelope (and a replicate's drive torque):
#: the integrator's step cap, so at most one written sample per step.  Chosen by
#: tests/harvest/test_virtual_sampling.py: on one trajectory (the engine's steps do not depend on the output grid)
#: the envelope at 1e-4 s is within 1.2e-4 of a 1e-5 s grid (1.2e-4 of 2e-5 s) and the sampled drive-torque peak and RMS within
#: 0.7 %, far inside a replicate's scatter (drive torque peak: SD ~7 %); 5e-4 s misses (torque RMS 3 %).
#: It was 2e-5 s with every 5th sample used: the same envelope, 14 % more CPU per run.
ENVELOPE_OUTPUT_STEP = 1e-4


def stem_force_envelope_run(machine: Machine, clearance: dict[str, float] | None, scale: float,
                            initial_perturbation=None, rtol: float = COUPLED_RTOL):
    """Peak stem-force table of one branch class and the coupled run it came from: ``(table, result)``.

    Table: :func:`stem_force_table` of the branch class ``scale`` (diameters scaled); ``result``: the
    run's :class:`~berryshaker.multibody.engine.MultibodyResult` (collision forces, drive torque).
    ``initial_perturbation`` and ``rtol`` go to the coupled run
    (:func:`berryshaker.harvest.coupled.drive_past`, the run of
    :func:`berryshaker.harvest.coupled.simulate_fruit_force` without its named fruit): a replicate starts the
    machine off centre in its clearances and at another drive phase.

    Parameters
    ----------
    machine : Machine
        Machine description with [plant] and [harvest].
    clearance : dict of str to float or None
        Clearance sizes (m) per pair; None keeps the description's.
    scale : float
        Diameter scale of the branch class (dimensionless).
    initial_perturbation : InitialPerturbation or RandomInitialPerturbation, optional
        Start of a replicate (default the centred start).
    rtol : float
        Relative integrator tolerance (dimensionless).

    Returns
    -------
    table : numpy.ndarray
        :func:`stem_force_table` (N for the force channel, dimensionless load ratios).
    result : MultibodyResult
        The coupled run, written every :data:`ENVELOPE_OUTPUT_STEP`.
    """
    from berryshaker.harvest.coupled import drive_past

    m = branch_class_machine(machine, scale)
    res, motion = drive_past(m, clearance, rtol=rtol, initial_perturbation=initial_perturbation,
                             output_step=ENVELOPE_OUTPUT_STEP)
    return stem_force_table(m, motion), res


def branch_class_machine(machine: Machine, scale: float) -> Machine:
    """The machine with its branch's root and tip diameters scaled by ``scale`` (one branch class).

    Parameters
    ----------
    machine : Machine
        Machine description with a [plant] block.
    scale : float
        Diameter scale (dimensionless).

    Returns
    -------
    Machine
        A validated copy with ``plant.branch.root_diameter`` and ``tip_diameter`` multiplied by ``scale``.
    """
    d = machine.model_dump()
    d["plant"]["branch"]["root_diameter"] *= scale
    d["plant"]["branch"]["tip_diameter"] *= scale
    return machine_from_dict(d)


#: channels of a stem-force table (last axis): the peak stem-force magnitude (N) and the peak pull-shear load ratio
#: of the ripe and of the unripe fruit (dimensionless, berryshaker.plant.pedicel.peak_stem_loads)
CH_FORCE, CH_RIPE, CH_UNRIPE = 0, 1, 2


def bond_strengths(machine: Machine) -> list[tuple[float, float]]:
    """Mean (pull, shear) strengths (N) of the ripe and the unripe fruit (``harvest.ripe_pull`` ... ``unripe_shear``).

    Parameters
    ----------
    machine : Machine
        Machine description with a [harvest] block.

    Returns
    -------
    list of (float, float)
        [(ripe pull, ripe shear), (unripe pull, unripe shear)] (N).
    """
    h = machine.harvest
    return [(h.ripe_pull, h.ripe_shear), (h.unripe_pull, h.unripe_shear)]


def stem_force_table(machine: Machine, motion) -> np.ndarray:
    """Peak stem loads of fruit on compliant pedicels over Z_GRID x MASS_FACTORS * m0 x channels.

    ``motion``: the branch's :class:`~berryshaker.harvest.coupled.BranchMotion` of a drive-past.  The fruit
    is one-way coupled, so every (position, mass) is a post-processing of the same branch motion (computed for the
    whole table at once by berryshaker.plant.pedicel.peak_stem_loads).  Channels (:data:`CH_FORCE` ...):
    max |F| (N, the magnitude of berryshaker.harvest.coupled.stem_forces) and the peak pull-shear load ratio of
    the ripe and of the unripe fruit's mean strengths (:func:`bond_strengths`).  With ``pedicel.rigid`` the force is m x the peak
    branch acceleration (study eq. 16), taken as pure shear (lateral) for the load ratios.

    Parameters
    ----------
    machine : Machine
        Machine description (the branch class's) with [plant] and [harvest].
    motion : BranchMotion
        The branch's modal solution of a drive-past.

    Returns
    -------
    numpy.ndarray
        Shape (len(Z_GRID), len(MASS_FACTORS), 3): channel :data:`CH_FORCE` peak |F| (N), :data:`CH_RIPE` and
        :data:`CH_UNRIPE` peak pull-shear load ratios (dimensionless).
    """
    from berryshaker.plant.pedicel import peak_stem_loads

    pl = machine.plant
    z = Z_GRID * pl.branch.length
    masses = MASS_FACTORS * pl.fruit.mass
    st = bond_strengths(machine)
    if pl.fruit.pedicel.rigid:
        force = np.outer(np.max(np.abs(motion.lateral(z)[2]), axis=1), masses)
        return np.stack([force, force / st[0][1], force / st[1][1]], axis=-1)
    y, v, _ = motion.lateral(z, acceleration=False)
    ped = pl.fruit.pedicel
    return peak_stem_loads(motion.t, (y, v), motion.axial(z), masses, ped.stiffness, ped.damping,
                           ped.include_weight, st)


def _interp_table(table: np.ndarray, z: np.ndarray, mass: np.ndarray, m0: float) -> np.ndarray:
    """A (Z_GRID x MASS_FACTORS) table at fractions z and masses ``mass``: linear in z and in log mass."""
    cols = np.array([np.interp(z, Z_GRID, table[:, j]) for j in range(table.shape[1])])  # (n_mass, n_fruit)
    lm = np.log(np.clip(mass / m0, MASS_FACTORS[0], MASS_FACTORS[-1]))
    lg = np.log(MASS_FACTORS)
    j = np.clip(np.searchsorted(lg, lm) - 1, 0, len(lg) - 2)
    w = (lm - lg[j]) / (lg[j + 1] - lg[j])
    idx = np.arange(len(z))
    return (1 - w) * cols[j, idx] + w * cols[j + 1, idx]


def fruit_peak_force(envelope: np.ndarray, z: np.ndarray, mass: np.ndarray, m0: float) -> np.ndarray:
    """Peak stem force (N) on fruit at fractions z with masses ``mass`` from one branch class's envelope.

    A 1-D envelope is a peak acceleration (m/s^2) on Z_GRID (eq. 16: force = m a); a 2-D envelope a stem-force table
    over Z_GRID x MASS_FACTORS m0, a 3-D one the channels of :func:`stem_force_table` (the force channel is read);
    tables are interpolated linearly in z and in log mass.

    Parameters
    ----------
    envelope : numpy.ndarray
        Acceleration envelope (m/s^2, 1-D), force table (N, 2-D) or :func:`stem_force_table` (3-D).
    z : numpy.ndarray
        Fruit positions, fractions of the branch length (dimensionless).
    mass : numpy.ndarray
        Fruit masses (kg).
    m0 : float
        Mean fruit mass of the table's mass factors (kg).

    Returns
    -------
    numpy.ndarray
        Peak stem force of each fruit (N); masses outside the table's range take its nearest column.
    """
    env = np.asarray(envelope, float)
    if env.ndim == 1:
        return mass * np.interp(z, Z_GRID, env)
    return _interp_table(env[..., CH_FORCE] if env.ndim == 3 else env, z, mass, m0)


def fruit_peak_load(envelope: np.ndarray, z: np.ndarray, mass: np.ndarray, m0: float, ripe: np.ndarray,
                    strengths: list[tuple[float, float]]) -> np.ndarray:
    """Peak pull-shear load ratio (dimensionless) of each fruit against its class's mean strengths.

    From the channels of :func:`stem_force_table` (the ripe or the unripe ratio by ``ripe``).  A table without
    load channels (1-D acceleration envelope or 2-D force table) is read as pure shear: ratio = peak force / mean
    shear strength ``strengths[c][1]`` (c = 0 ripe, 1 unripe).

    Parameters
    ----------
    envelope : numpy.ndarray
        Acceleration envelope (m/s^2, 1-D), force table (N, 2-D) or :func:`stem_force_table` (3-D).
    z : numpy.ndarray
        Fruit positions, fractions of the branch length (dimensionless).
    mass : numpy.ndarray
        Fruit masses (kg).
    m0 : float
        Mean fruit mass of the table's mass factors (kg).
    ripe : numpy.ndarray of bool
        Whether each fruit is ripe.
    strengths : list of (float, float)
        Mean (pull, shear) strengths (N) of the ripe and the unripe fruit (:func:`bond_strengths`).

    Returns
    -------
    numpy.ndarray
        Peak load ratio of each fruit (dimensionless); it comes off when this reaches its strength factor.
    """
    env = np.asarray(envelope, float)
    if env.ndim == 3:
        return np.where(ripe, _interp_table(env[..., CH_RIPE], z, mass, m0),
                        _interp_table(env[..., CH_UNRIPE], z, mass, m0))
    return fruit_peak_force(env, z, mass, m0) / np.where(ripe, strengths[0][1], strengths[1][1])


@dataclass
class Population:
    """Fruit of the sampled bushes (flat arrays).

    Attributes
    ----------
    branch_class : numpy.ndarray of int
        Index into ``harvest.branch_classes`` of each fruit's branch.
    z : numpy.ndarray
        Position along the branch, fraction of its length (dimensionless).
    mass : numpy.ndarray
        Fruit mass (kg).
    ripe : numpy.ndarray of bool
        Whether the fruit is ripe.
    bond : numpy.ndarray
        Bond drawn uniformly in the study's eq. 17 band (N; used with ``bond_model = "study_eq17"``).
    bushes : int
        Bushes sampled.
    weight : float
        Real fruit represented by each sampled fruit (dimensionless): yield per bush x bushes / sampled mass.
    strength : numpy.ndarray or None
        Strength factor s of each fruit (dimensionless): its pull and shear strengths are s P, s S.
    """

    branch_class: np.ndarray  # index into branch_classes
    z: np.ndarray  # fraction of branch length
    mass: np.ndarray  # kg
    ripe: np.ndarray  # bool
    bond: np.ndarray  # N, the study's eq. 17 band draw (bond_model = "study_eq17")
    bushes: int
    weight: float  # real fruit represented by each sampled fruit (yield / (samples x mean mass))
    strength: np.ndarray | None = None  # strength factor s of a fruit: its pull and shear strengths are s P, s S


def sample_population(machine: Machine, seed: int | None = None, unripe_fraction: float | None = None,
                      yield_per_bush: float | None = None) -> Population:
    """Seeded plant population (deterministic for a seed).

    Per fruit: branch class (uniform), position along the branch (uniform over ``harvest.fruit_zone``), mass
    (lognormal, mean m0, CV ``fruit_mass_cv``), ripe or unripe (unripe with probability ``unripe_fraction``), a
    strength factor s (lognormal with mean 1 and CV ``bond_cv``, ripe, or ``unripe_bond_cv``: the fruit's pull and
    shear strengths are s times its class's means, both modes scaled together [assumed]) and an eq. 17 bond
    (uniform in the study's band).

    Parameters
    ----------
    machine : Machine
        Machine description with [plant] and [harvest].
    seed : int, optional
        Seed of the population (default ``harvest.seed``).
    unripe_fraction : float, optional
        Probability that a fruit is unripe (dimensionless; default ``harvest.unripe_fraction``).
    yield_per_bush : float, optional
        Yield per bush (kg) that sets ``weight`` (default ``harvest.yield_per_bush``); the number of fruit
        sampled stays that of the described yield.

    Returns
    -------
    Population
        :func:`fruit_per_bush` x ``harvest.bushes`` fruit.
    """
    h = machine.harvest
    rng = np.random.default_rng(h.seed if seed is None else seed)
    m0 = machine.plant.fruit.mass
    yb = h.yield_per_bush if yield_per_bush is None else yield_per_bush
    uf = h.unripe_fraction if unripe_fraction is None else unripe_fraction
    n = fruit_per_bush(machine) * h.bushes  # the real count at the described yield (a fitted yield keeps the weights)
    sigma = math.sqrt(math.log(1 + h.fruit_mass_cv**2))
    mass = m0 * rng.lognormal(-0.5 * sigma**2, sigma, n)
    ripe = rng.random(n) >= uf
    u_bond = rng.random(n)
    bond = np.where(ripe, RIPE_BOND_N[0] + u_bond * (RIPE_BOND_N[1] - RIPE_BOND_N[0]),
                    UNRIPE_BOND_N[0] + u_bond * (UNRIPE_BOND_N[1] - UNRIPE_BOND_N[0]))
    z = rng.uniform(*h.fruit_zone, n)
    cls = rng.integers(0, len(h.branch_classes), n)
    s_sigma = np.where(ripe, math.sqrt(math.log(1 + h.bond_cv**2)), math.sqrt(math.log(1 + h.unripe_bond_cv**2)))
    strength = np.exp(-0.5 * s_sigma**2 + s_sigma * rng.standard_normal(n))
    weight = yb * h.bushes / float(mass.sum())
    return Population(cls, z, mass, ripe, bond, h.bushes, weight, strength)


def harvest_indexes(machine: Machine, envelopes: list[np.ndarray], pop: Population,
                    damage_acceleration: float | None = None) -> dict:
    """Efficiency (kg/min), unripe rate (%), damage rate (%) and removal fractions of a population under envelopes.

    Detachment (``harvest.bond_model``): "pull_shear" -- a fruit comes off when the peak pull-shear load ratio of
    its class's mean strengths reaches its strength factor (berryshaker.plant.pedicel.peak_stem_loads); "study_eq17"
    -- when the peak stem-force magnitude reaches its eq. 17 bond.  Damage (``harvest.damage_model``): "impact" --
    the probability that a detached fruit is bruised by its impacts (berryshaker.harvest.bruising.impact_damage);
    "stem_acceleration" -- 1 - exp(-(a/a_d)^k) in the acceleration a = peak stem force / mass.  The expected
    damaged mass is used (no sampling noise in the index).

    Parameters
    ----------
    machine : Machine
        Machine description with [plant], [harvest] and [operation] (walking speed, plant spacing).
    envelopes : list of numpy.ndarray
        One envelope per branch class (:func:`stem_force_table`, or the 1-D / 2-D forms of
        :func:`fruit_peak_force`; N, m/s^2 for the 1-D form).
    pop : Population
        The sampled fruit.
    damage_acceleration : float, optional
        Weibull scale a_d (m/s^2) of the "stem_acceleration" damage model (default
        ``harvest.damage_acceleration``).

    Returns
    -------
    dict
        ``efficiency_kg_min`` (kg/min), ``unripe_rate_pct`` and ``damage_rate_pct`` (% of the picked mass; NaN
        when nothing is picked), ``ripe_picked_fraction`` and ``unripe_shed_fraction`` (fractions of the ripe and
        unripe mass), ``fruit_sampled``, ``yield_per_bush_kg`` (kg), ``bushes`` and ``bushes_per_min`` (1/min).
    """
    h = machine.harvest
    m0 = machine.plant.fruit.mass
    strengths = bond_strengths(machine)
    n = len(pop.mass)
    force, load = np.zeros(n), np.zeros(n)
    for c, env in enumerate(envelopes):
        sel = pop.branch_class == c
        force[sel] = fruit_peak_force(env, pop.z[sel], pop.mass[sel], m0)
        load[sel] = fruit_peak_load(env, pop.z[sel], pop.mass[sel], m0, pop.ripe[sel], strengths)
    if h.bond_model == "pull_shear" and pop.strength is not None:
        off = load >= pop.strength
    else:
        off = force >= pop.bond
    picked = pop.weight * float(np.sum(pop.mass[off]))
    unripe = pop.weight * float(np.sum(pop.mass[off & ~pop.ripe]))
    if h.damage_model == "impact":
        from berryshaker.harvest.bruising import impact_damage

        p_damage = impact_damage(machine, pop.z)
    else:
        ad = h.damage_acceleration if damage_acceleration is None else damage_acceleration
        p_damage = 1.0 - np.exp(-((force / pop.mass) / ad) ** h.damage_shape)
    damaged = pop.weight * float(np.sum((pop.mass * p_damage)[off]))
    bushes_per_min = machine.operation.walking_speed / machine.operation.plant_spacing * 60.0
    per_bush = picked / pop.bushes
    ripe_total = float(np.sum(pop.mass[pop.ripe]))
    return {
        "efficiency_kg_min": per_bush * bushes_per_min,
        "unripe_rate_pct": 100.0 * unripe / picked if picked > 0 else float("nan"),
        "damage_rate_pct": 100.0 * damaged / picked if picked > 0 else float("nan"),
        "ripe_picked_fraction": float(np.sum(pop.mass[off & pop.ripe]) / ripe_total) if ripe_total else 0.0,
        "unripe_shed_fraction": (float(np.sum(pop.mass[off & ~pop.ripe]) / np.sum(pop.mass[~pop.ripe]))
                                 if np.any(~pop.ripe) else 0.0),
        "fruit_sampled": int(len(pop.mass)),
        "yield_per_bush_kg": pop.weight * float(np.sum(pop.mass)) / pop.bushes,
        "bushes": pop.bushes,
        "bushes_per_min": bushes_per_min,
    }


def envelopes_for(machine: Machine, clearance: dict[str, float] | None) -> list[np.ndarray]:
    """Stem-force envelopes (:func:`stem_force_envelope`) of every branch class.

    Parameters
    ----------
    machine : Machine
        Machine description with [plant] and [harvest].
    clearance : dict of str to float or None
        Clearance sizes (m) per pair; None keeps the description's.

    Returns
    -------
    list of numpy.ndarray
        One :func:`stem_force_table` per ``harvest.branch_classes`` entry (N, dimensionless load ratios).
    """
    return [stem_force_envelope(machine, clearance, s) for s in machine.harvest.branch_classes]


def virtual_harvest(machine: Machine, clearance: dict[str, float] | None = None, seed: int | None = None,
                    envelopes: list[np.ndarray] | None = None) -> dict:
    """Indexes of one virtual field test run at the given clearances (seeded, deterministic).

    Parameters
    ----------
    machine : Machine
        Machine description with [plant] and [harvest].
    clearance : dict of str to float, optional
        Clearance sizes (m) per pair.
    seed : int, optional
        Population seed (default ``harvest.seed``).
    envelopes : list of numpy.ndarray, optional
        Envelopes already computed at these clearances (N, dimensionless load ratios; default
        :func:`envelopes_for`).

    Returns
    -------
    dict
        :func:`harvest_indexes` with ``clearance_mm`` (mm per pair).
    """
    env = envelopes if envelopes is not None else envelopes_for(machine, clearance)
    pop = sample_population(machine, seed)
    out = harvest_indexes(machine, env, pop)
    out["clearance_mm"] = {k: v * 1e3 for k, v in
                           machine.with_clearances(clearance or {}).clearance_sizes().items()}
    return out


def calibrate_harvest(machine: Machine, targets: dict | None = None, fit: tuple[str, ...] = (),
                      envelopes: list[np.ndarray] | None = None,
                      replicates: list[tuple[list[np.ndarray], int]] | None = None) -> dict:
    """Fit the picking model to some of the study's field values at the machine's (chosen) clearances and hold
    the others out.

    Parameters
    ----------
    machine : Machine
        Machine description at the study's chosen clearances (A1B1C1F3 on the reference machine).
    targets : dict, optional
        The study's values (:data:`STUDY_TARGETS`: 3.93 kg/min, 3.1 % unripe, 2.8 % damage [study]).
    fit : tuple of {"efficiency", "unripe", "damage"}
        What is fitted: "efficiency" -> ``yield_per_bush`` (the efficiency is proportional to it, one step),
        "damage" -> ``damage_acceleration`` (Brent's method), "unripe" -> ``unripe_fraction`` (Brent's
        method, when reachable).  Every value not fitted keeps its description value and its index is
        reported as a held-out prediction.  Default: nothing fitted (the description's values come from published
        data, docs/harvest.md), every index held out.  "damage" needs ``damage_model = "stem_acceleration"`` (the
        impact model has no free scale).
    envelopes : list of ndarray, optional
        Stem-force envelopes (:func:`envelopes_for`; N, dimensionless load ratios) already computed at these
        clearances: one drive-past per
        branch class from the unperturbed start, with the description's population (``harvest.seed``).
    replicates : list of (envelopes, population_seed), optional
        Replicates of the virtual test run at these clearances (the replicated L9's statistic,
        docs/harvest.md "Replicates"): per replicate the stem-force envelopes of its perturbed drive-pasts
        (:func:`berryshaker.study.runs.replicate_run`) and the seed of its population.  Every index is then the
        mean over the replicates, I = (1/R) sum_k I(envelopes_k, population(seed_k)), and the fit is on that
        mean (the efficiency stays proportional to the yield per bush, so its fit is still one step).  Takes
        precedence over ``envelopes``.

    Returns
    -------
    dict
        ``yield_per_bush_kg``, ``unripe_fraction``, ``damage_acceleration_m_s2`` (fitted or as described),
        ``fitted`` (index -> parameter), ``held_out`` (index -> {"model", "study"}), ``check`` (the indexes
        with the returned values; replicate means with ``replicates``), ``reachable``, ``uncertainty`` (standard
        error of every fitted parameter from the replicate noise, :func:`_calibration_uncertainty`; empty for a
        single run), ``replicates`` (number of replicates averaged; 0 for the single unperturbed drive-past).
    """
    from berryshaker.errors import ConfigError

    targets = targets or STUDY_TARGETS
    unknown = set(fit) - {"efficiency", "unripe", "damage"}
    if unknown:
        raise ConfigError(f"calibrate_harvest: unknown index {sorted(unknown)} in fit; choose from efficiency, "
                          "unripe, damage")
    if "damage" in fit and machine.harvest.damage_model != "stem_acceleration":
        raise ConfigError("calibrate_harvest: damage can only be fitted with harvest.damage_model = "
                          "\"stem_acceleration\" (its scale damage_acceleration); the impact model's bruise "
                          "thresholds come from drop tests")
    if replicates is not None:
        if not replicates:
            raise ConfigError("calibrate_harvest: replicates is empty; give at least one (envelopes, seed) pair")
        runs = [([np.asarray(e) for e in env_k], int(seed_k)) for env_k, seed_k in replicates]
    else:
        runs = [(envelopes if envelopes is not None else envelopes_for(machine, None), None)]

    def idx(yb=None, uf=None, ad=None, per_replicate=False):
        """Indexes averaged over the replicates (one run: that run's indexes); with ``per_replicate`` also each
        replicate's."""
        each = [harvest_indexes(machine, env_k, sample_population(machine, seed=seed_k, unripe_fraction=uf,
                                                                  yield_per_bush=yb), ad) for env_k, seed_k in runs]
        mean = {k: float(np.nanmean([e[k] for e in each])) for k in each[0]
                if isinstance(each[0][k], (int, float, np.floating))}
        return (mean, each) if per_replicate else mean

    yb, uf, ad = machine.harvest.yield_per_bush, machine.harvest.unripe_fraction, machine.harvest.damage_acceleration
    if idx(yb=yb, uf=uf)["efficiency_kg_min"] <= 0:
        raise ConfigError("no fruit comes off in the virtual harvest (every peak stem force is below its bond): "
                          "the picking indexes cannot be calibrated")
    reachable = {"unripe_rate_pct": idx(yb=yb, uf=0.95)["unripe_rate_pct"] > targets["unripe_rate_pct"]}
    for _ in range(4):  # the three couple weakly through the sampled population: a few sweeps converge
        if "unripe" in fit and reachable["unripe_rate_pct"]:
            uf = optimize.brentq(lambda u: idx(yb=yb, uf=u)["unripe_rate_pct"] - targets["unripe_rate_pct"],
                                 1e-3, 0.95, xtol=1e-6)
        if "efficiency" in fit:
            yb = yb * targets["efficiency_kg_min"] / idx(yb=yb, uf=uf)["efficiency_kg_min"]
        if "damage" in fit:
            ad = optimize.brentq(lambda a: idx(yb=yb, uf=uf, ad=a)["damage_rate_pct"] - targets["damage_rate_pct"],
                                 1.0, 1e5, xtol=1e-3)
    check, each = idx(yb=yb, uf=uf, ad=ad, per_replicate=True)
    names = {"efficiency": ("efficiency_kg_min", "yield_per_bush"), "unripe": ("unripe_rate_pct", "unripe_fraction"),
             "damage": ("damage_rate_pct", "damage_acceleration")}
    fitted = {names[k][0]: names[k][1] for k in fit if k != "unripe" or reachable["unripe_rate_pct"]}
    held_out = {key: {"model": check[key], "study": targets[key]} for key in targets if key not in fitted}
    unc = _calibration_uncertainty(idx, each, fitted, yb, uf, ad) if len(runs) > 1 else {}
    return {"yield_per_bush_kg": yb, "unripe_fraction": uf, "damage_acceleration_m_s2": ad, "check": check,
            "fitted": fitted, "held_out": held_out, "reachable": reachable, "uncertainty": unc,
            "replicates": len(runs) if replicates is not None else 0}


def _calibration_uncertainty(idx, each: list[dict], fitted: dict, yb: float, uf: float, ad: float) -> dict:
    """Standard error of every fitted parameter from the replicate noise of the mean it was fitted to.

    The fit solves mean_k I_k(theta) = target; the replicate mean has standard error SE(I) = sd_k(I_k) / sqrt(R),
    so, to first order (delta method), SE(theta) = SE(I) / |d mean I / d theta|.  The efficiency is proportional to
    the yield per bush, so SE(yield) / yield = SE(efficiency) / efficiency exactly; the damage rate's slope in the
    Weibull scale and the unripe rate's in the unripe fraction are central differences of +-1 %.
    """
    R = len(each)

    def se(key):
        v = np.array([e[key] for e in each], float)
        v = v[np.isfinite(v)]
        return float(np.std(v, ddof=1) / math.sqrt(v.size)) if v.size > 1 else float("nan")

    out = {}
    if "efficiency_kg_min" in fitted:
        m = float(np.mean([e["efficiency_kg_min"] for e in each]))
        out["yield_per_bush_kg"] = yb * se("efficiency_kg_min") / m if m > 0 else float("nan")
    if "damage_rate_pct" in fitted:
        slope = (idx(yb=yb, uf=uf, ad=ad * 1.01)["damage_rate_pct"] - idx(yb=yb, uf=uf, ad=ad / 1.01)["damage_rate_pct"]
                 ) / (ad * (1.01 - 1 / 1.01))
        out["damage_acceleration_m_s2"] = se("damage_rate_pct") / abs(slope) if slope else float("nan")
    if "unripe_rate_pct" in fitted:
        slope = (idx(yb=yb, uf=uf * 1.01)["unripe_rate_pct"] - idx(yb=yb, uf=uf / 1.01)["unripe_rate_pct"]
                 ) / (uf * (1.01 - 1 / 1.01))
        out["unripe_fraction"] = se("unripe_rate_pct") / abs(slope) if slope else float("nan")
    out["method"] = (f"delta method on the replicate mean of {R} starts: SE(parameter) = SE(fitted index) / |slope of "
                     "the mean index in the parameter|")
    return out


def replicate_seeds(machine: Machine, replicates: int | None = None) -> list[int]:
    """Seeds of the replicates of a virtual test run (docs/harvest.md, "Replicates"): ``harvest.seed + 1000 k``,
    k = 0 .. R - 1, R = ``replicates`` or ``harvest.replicates``; replicate k's drive-past of branch class c
    starts from the perturbation seeded (seed_k, c), its population is seeded seed_k (the calibration's and
    the virtual L9's seeds: berryshaker.study.l9 uses this function).

    Parameters
    ----------
    machine : Machine
        Machine description with a [harvest] block.
    replicates : int, optional
        R (default ``harvest.replicates``).

    Returns
    -------
    list of int
        ``harvest.seed + 1000 k`` for k = 0 .. R - 1.
    """
    h = machine.harvest
    r = int(h.replicates if replicates is None else replicates)
    return [h.seed + 1000 * k for k in range(r)]


def replicate_envelopes_run(machine: Machine, clearance: dict | None = None, replicates: int | None = None
                            ) -> list[tuple[list[np.ndarray], int]]:
    """Stem-force envelopes of every branch class for each replicate, with the replicate's population seed:
    the ``replicates`` of :func:`calibrate_harvest` and :func:`replicate_response`.  Replicate k's run of
    class c starts from :class:`berryshaker.multibody.perturbation.RandomInitialPerturbation` ((seed_k, c),
    ``harvest.initial_eccentricity``, ``harvest.start_phase_spread``), as the calibration's and the L9's
    (berryshaker.study.runs.replicate_run).

    Parameters
    ----------
    machine : Machine
        Machine description with [plant] and [harvest].
    clearance : dict, optional
        Clearance sizes (m) per pair.
    replicates : int, optional
        R (default ``harvest.replicates``).

    Returns
    -------
    list of (list of numpy.ndarray, int)
        Per replicate: one :func:`stem_force_table` per branch class (N, dimensionless load ratios) and the
        population seed.
    """
    from berryshaker.multibody.perturbation import RandomInitialPerturbation

    h = machine.harvest
    out = []
    for sd in replicate_seeds(machine, replicates):
        env = [stem_force_envelope_run(machine, clearance, s, RandomInitialPerturbation(
            (sd, c), h.initial_eccentricity, h.start_phase_spread))[0] for c, s in enumerate(h.branch_classes)]
        out.append((env, sd))
    return out


def replicate_response(machine: Machine, replicates: list[tuple[list[np.ndarray], int]]) -> dict:
    """Replicate mean and standard deviation of every index of :func:`response_indexes` over replicates
    ``(envelopes, population seed)`` (:func:`replicate_envelopes_run`, or berryshaker.study.l9.replicate_envelopes):
    I = (1/R) sum_k I_k with I_k the indexes of envelopes_k on the population seeded seed_k (the statistic the
    calibration fits, :func:`calibrate_harvest`).  Keys: every index (mean), ``<index>_sd`` (sample SD over
    the replicates, ddof 1; 0 for one replicate), ``replicates`` (R), ``shaking_frequency_hz`` and the shaking
    amplitude (:func:`shaking_amplitude`).

    Parameters
    ----------
    machine : Machine
        Machine description with [plant], [harvest] and [operation].
    replicates : list of (list of numpy.ndarray, int)
        Per replicate its envelopes (N, dimensionless load ratios) and population seed.

    Returns
    -------
    dict
        The keys above: index means (%, kg/min), ``<index>_sd`` (same units), ``replicates``,
        ``shaking_frequency_hz`` (Hz), ``comb_swing_deg`` (deg) and ``finger_amplitude_mm`` (mm).

    Raises
    ------
    ConfigError
        No replicate given.
    """
    from berryshaker.errors import ConfigError

    if not replicates:
        raise ConfigError("replicate_response: no replicate (every run failed?)")
    each = [response_indexes(machine, [np.asarray(e) for e in env], seed=sd) for env, sd in replicates]
    out = {}
    for key in HARVEST_INDEXES:
        v = np.array([e[key] for e in each], float)
        v = v[np.isfinite(v)]  # the unripe rate of a replicate that picked nothing is undefined
        out[key] = float(np.mean(v)) if len(v) else float("nan")
        out[f"{key}_sd"] = float(np.std(v, ddof=1)) if len(v) > 1 else 0.0
    out["replicates"] = len(each)
    out["shaking_frequency_hz"] = each[0]["shaking_frequency_hz"]
    for key in ("comb_swing_deg", "finger_amplitude_mm"):
        if key in each[0]:
            out[key] = each[0][key]
    return out


#: the indexes of :func:`harvest_response` (sweep columns and the removal figure), with their units
HARVEST_INDEXES = {"ripe_removal_pct": "%", "unripe_shed_pct": "%", "damage_rate_pct": "%",
                   "unripe_rate_pct": "%", "efficiency_kg_min": "kg/min"}


def harvest_response(machine: Machine, clearance: dict | None = None, replicates: int | None = None) -> dict:
    """Virtual harvest of one machine setting, as the vibratory-harvesting literature plots it.

    Parameters
    ----------
    machine : Machine
        Machine description (any drive with a [plant] and a [harvest] section); every value, the calibrated
        population included, as described.
    clearance : dict, optional
        Clearance sizes (m).
    replicates : int, optional
        Replicates R, default ``harvest.replicates`` (the calibration's count and seeds).

    Returns
    -------
    dict
        Replicate means over R perturbed starts (:func:`replicate_response`, the statistic the calibration
        fits) of ripe_removal_pct (ripe mass detached / ripe mass on the bush), unripe_shed_pct (unripe mass
        detached / unripe mass), damage_rate_pct and unripe_rate_pct (of the picked mass, the study's
        indexes), efficiency_kg_min; each with ``<index>_sd`` (SD over the replicates); ``replicates``;
        shaking_frequency_hz (one comb cycle per drive-shaft revolution: drive speed / 2 pi); the shaking
        amplitude of :func:`shaking_amplitude` (comb_swing_deg, finger_amplitude_mm).  R coupled runs
        per branch class (:func:`replicate_envelopes_run`).
    """
    return replicate_response(machine, replicate_envelopes_run(machine, clearance, replicates))


def response_indexes(machine: Machine, envelopes: list[np.ndarray], seed: int | None = None) -> dict:
    """The indexes of :func:`harvest_response` from stem-force envelopes already computed (one per branch
    class), on the population seeded ``seed`` (default ``harvest.seed``): one replicate.

    Parameters
    ----------
    machine : Machine
        Machine description with [plant], [harvest] and [operation].
    envelopes : list of numpy.ndarray
        One envelope per branch class (N, dimensionless load ratios).
    seed : int, optional
        Population seed (default ``harvest.seed``).

    Returns
    -------
    dict
        ``ripe_removal_pct``, ``unripe_shed_pct``, ``damage_rate_pct``, ``unripe_rate_pct`` (%),
        ``efficiency_kg_min`` (kg/min), ``shaking_frequency_hz`` (Hz) and :func:`shaking_amplitude`'s keys.
    """
    idx = harvest_indexes(machine, envelopes, sample_population(machine, seed))
    return {"ripe_removal_pct": 100.0 * idx["ripe_picked_fraction"],
            "unripe_shed_pct": 100.0 * idx["unripe_shed_fraction"], "damage_rate_pct": idx["damage_rate_pct"],
            "unripe_rate_pct": idx["unripe_rate_pct"], "efficiency_kg_min": idx["efficiency_kg_min"],
            "shaking_frequency_hz": machine.drive_speed / (2 * math.pi), **shaking_amplitude(machine)}


def with_drive_speed(machine_data: dict, speed: float) -> dict:
    """A machine description (dict, SI) with the drive shaft's speed replaced (rad/s), for any drive: the
    section whose ``speed`` is the machine's drive speed (``cam.speed``, ``crank.speed``, ...).

    Parameters
    ----------
    machine_data : dict
        Machine description (SI, ``model_dump(mode="json")``); not modified.
    speed : float
        New drive speed (rad/s), > 0.

    Returns
    -------
    dict
        A shallow copy with the drive section's ``speed`` replaced.

    Raises
    ------
    ConfigError
        ``speed`` is not > 0, or no section's speed is the drive speed.
    """
    from berryshaker.errors import ConfigError

    if not speed > 0:
        raise ConfigError(f"drive speed must be > 0, got {speed} rad/s")
    current = machine_from_dict(machine_data).drive_speed
    d = dict(machine_data)
    for key, sec in machine_data.items():
        if isinstance(sec, dict) and isinstance(sec.get("speed"), (int, float)) and \
                math.isclose(sec["speed"], current, rel_tol=1e-12):
            d[key] = dict(sec, speed=float(speed))
            return d
    raise ConfigError("the machine description has no section whose speed is the drive speed")


def removal_at_speed(machine_data: dict, speed_rpm: float, clearance: dict | None = None) -> dict:
    """Virtual harvest at one drive (cam shaft) speed: a plain function of data for the cached runner.

    Parameters
    ----------
    machine_data : dict
        Machine description as a dict (``Machine.model_dump(mode="json")``).
    speed_rpm : float
        Cam shaft speed (r/min); replaces ``cam.speed``.
    clearance : dict, optional
        Clearance sizes (m).

    Returns
    -------
    dict
        speed_rpm and the indexes of :func:`harvest_response`.
    """
    from berryshaker.errors import ConfigError

    d = dict(machine_data)
    if "cam" not in d:
        raise ConfigError("removal_at_speed varies cam.speed: the machine description has no [cam] section")
    if not speed_rpm > 0:
        raise ConfigError(f"cam speed must be > 0 r/min, got {speed_rpm}")
    d["cam"] = dict(d["cam"], speed=float(speed_rpm) * 2 * math.pi / 60.0)
    return {"speed_rpm": float(speed_rpm), **harvest_response(machine_from_dict(d), clearance)}


def removal_vs_frequency(machine: Machine, speeds_rpm, clearance: dict | None = None) -> list[dict]:
    """Ripe removal, unripe shedding and damage against cam speed (one :func:`removal_at_speed` row each).

    Parameters
    ----------
    machine : Machine
        Machine description with a [cam] section, [plant] and [harvest].
    speeds_rpm : iterable of float
        Cam shaft speeds (rpm).
    clearance : dict, optional
        Clearance sizes (m) per pair.

    Returns
    -------
    list of dict
        One :func:`removal_at_speed` row per speed.
    """
    data = machine.model_dump(mode="json")
    return [removal_at_speed(data, s, clearance) for s in speeds_rpm]

