"""The fruit population of a virtual harvest: bushes carrying ``branches_per_bush`` branches of random class, fruit
uniformly along the fruit zone with lognormal masses, ripe or unripe, each with a lognormal strength factor and an
eq. 17 bond (docs/harvest.md); seeded, deterministic.  Part of the virtual harvest (berryshaker.harvest.virtual).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from berryshaker.config import Machine
from berryshaker.plant.response import RIPE_BOND_N, UNRIPE_BOND_N


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
