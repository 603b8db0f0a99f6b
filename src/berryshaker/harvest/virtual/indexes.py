"""The harvest indexes of a fruit population under the stem-force tables of its branch classes: detachment (pull-shear
or eq. 17 bond), damage (impact bruising or the Weibull law in the stem force's acceleration), efficiency, unripe
and damage rates, removal fractions; and one virtual field test run.  Part of the virtual harvest
(berryshaker.harvest.virtual).
"""

from __future__ import annotations

import numpy as np

from berryshaker.config import Machine
from berryshaker.harvest.virtual.population import Population, sample_population
from berryshaker.harvest.virtual.stem_force_tables import (bond_strengths, envelopes_for, fruit_peak_force,
                                                           fruit_peak_load)


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
        One envelope per branch class (:func:`~berryshaker.harvest.virtual.stem_force_tables.stem_force_table`,
        or the 1-D / 2-D forms of :func:`~berryshaker.harvest.virtual.stem_force_tables.fruit_peak_force`; N,
        m/s^2 for the 1-D form).
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
        :func:`~berryshaker.harvest.virtual.stem_force_tables.envelopes_for`).

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
