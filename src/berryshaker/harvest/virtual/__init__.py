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
(berryshaker.harvest.calibration.calibration_table, ``berryshaker validate``).
:func:`~berryshaker.harvest.virtual.field_fit.calibrate_harvest` can still fit the yield (and, with the Weibull
damage, its scale) to a field value, and labels it fitted.

This package re-exports the chain's public names; each step has its module, importing only the ones below it:

* :mod:`~berryshaker.harvest.virtual.stem_force_tables`: the stem-force tables of the branch classes (step 1) and
  their reading at each fruit;
* :mod:`~berryshaker.harvest.virtual.population`: the fruit population (step 2);
* :mod:`~berryshaker.harvest.virtual.indexes`: detachment, damage and the indexes (steps 3-5), one virtual test run;
* :mod:`~berryshaker.harvest.virtual.replicates`: replicate seeds, tables and responses (the harvest response);
* :mod:`~berryshaker.harvest.virtual.field_fit`: the fit to field values (``calibrate_harvest``);
* :mod:`~berryshaker.harvest.virtual.drive_speed`: the harvest against drive speed.

The combs' shaking amplitude a response reports is berryshaker.harvest.shaking's (re-exported here).
"""

from berryshaker.harvest.shaking import shaking_amplitude
from berryshaker.harvest.virtual.drive_speed import removal_at_speed, removal_vs_frequency, with_drive_speed
from berryshaker.harvest.virtual.field_fit import STUDY_TARGETS, calibrate_harvest
from berryshaker.harvest.virtual.indexes import harvest_indexes, virtual_harvest
from berryshaker.harvest.virtual.population import FRUIT_PER_BUSH_BOUNDS, Population, fruit_per_bush, sample_population
from berryshaker.harvest.virtual.replicates import (HARVEST_INDEXES, harvest_response, replicate_envelopes_run,
                                                    replicate_response, replicate_seeds, response_indexes)
from berryshaker.harvest.virtual.stem_force_tables import (CH_FORCE, CH_RIPE, CH_UNRIPE, ENVELOPE_OUTPUT_STEP,
                                                           MASS_FACTORS, Z_GRID, acceleration_envelope,
                                                           bond_strengths, branch_class_machine, envelopes_for,
                                                           fruit_peak_force, fruit_peak_load, stem_force_envelope,
                                                           stem_force_envelope_run, stem_force_table)

__all__ = [
    "CH_FORCE", "CH_RIPE", "CH_UNRIPE", "ENVELOPE_OUTPUT_STEP", "FRUIT_PER_BUSH_BOUNDS", "HARVEST_INDEXES",
    "MASS_FACTORS", "STUDY_TARGETS", "Z_GRID", "Population", "acceleration_envelope", "bond_strengths",
    "branch_class_machine", "calibrate_harvest", "envelopes_for", "fruit_peak_force", "fruit_peak_load",
    "fruit_per_bush", "harvest_indexes", "harvest_response", "removal_at_speed", "removal_vs_frequency",
    "replicate_envelopes_run", "replicate_response", "replicate_seeds", "response_indexes", "sample_population",
    "shaking_amplitude", "stem_force_envelope", "stem_force_envelope_run", "stem_force_table", "virtual_harvest",
    "with_drive_speed",
]
