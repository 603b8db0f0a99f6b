"""Fruit on compliant stems: the fruit as a mass m0 on a compliant pedicel, base-excited by the branch at z_m
(docs/plant.md).  The study's eq. 16 (fruit force = m0 x branch acceleration) is the rigid-stem limit.

This package re-exports the public names of its modules:

* :mod:`~berryshaker.plant.pedicel.oscillator`: the fruit-stem oscillator, its parameters, closed forms
  (natural frequency, damping ratio, force transmissibility) and its response to a branch motion
  (``stem_response``);
* :mod:`~berryshaker.plant.pedicel.peaks`: the compiled pass giving the peak stem force, the peak and the
  Miner-Basquin equivalent pull-shear load ratios of a table of positions x fruit masses over a branch motion
  (``peak_stem_loads``);
* :mod:`~berryshaker.plant.pedicel.miner`: detachment that accumulates over load cycles, the Miner-Basquin
  equivalent load ratio of a load-ratio series and its reading at any exponent (``miner_equivalent``,
  ``miner_load``);
* :mod:`~berryshaker.plant.pedicel.two_way`: the fruit's reaction on the branch, its checks (modal mass ratio,
  one-way against two-way frequency response) and the two-way model (``fruit_branch_modes``).
"""

from berryshaker.plant.pedicel.miner import MINER_EXPONENTS, REVERSAL_GATE, miner_equivalent, miner_load
from berryshaker.plant.pedicel.oscillator import (
    GRAVITY,
    damping_ratio,
    discretise_foh,
    force_transmissibility,
    natural_frequency,
    stem_response,
)
from berryshaker.plant.pedicel.peaks import compile_peak_stem_force, peak_stem_force, peak_stem_loads
from berryshaker.plant.pedicel.two_way import (
    FruitBranchModes,
    fruit_branch_modes,
    fruit_loaded_modes,
    modal_mass_ratio,
    two_way_stem_force_frf,
)

__all__ = ["GRAVITY", "MINER_EXPONENTS", "REVERSAL_GATE", "FruitBranchModes", "compile_peak_stem_force",
           "damping_ratio", "discretise_foh", "force_transmissibility", "fruit_branch_modes", "fruit_loaded_modes",
           "miner_equivalent", "miner_load", "modal_mass_ratio", "natural_frequency", "peak_stem_force", "peak_stem_loads", "stem_response", "two_way_stem_force_frf"]
