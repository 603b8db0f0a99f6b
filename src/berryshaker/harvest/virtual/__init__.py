"""Virtual harvest: the coupled machine-plant drive-past run through the fruit of a field test.

Chain (docs/harvest.md):

1. For each branch class (the reference branch with its diameters scaled), a coupled drive-past
   (berryshaker.harvest.coupled) gives a table of peak stem loads over position and fruit mass
   (:mod:`~berryshaker.harvest.virtual.stem_force_tables`); a replicate start's classes are one-way probes of
   one run.
2. A start (one drive-past carrying every class's branch as a probe at its own seeded drive phase,
   :mod:`~berryshaker.harvest.virtual.seeds`) is
   one field test (:mod:`~berryshaker.harvest.virtual.field_test`): the model's expectation by quadrature over the
   fruit a test meets, and one field result counted fruit by fruit over the bushes ``operation.test_duration``
   passes, with its counting noise.
3. Detachment (``bond_model = "pull_shear"``): a fruit comes off when the peak over the drive-past of its
   pull-shear load ratio, sqrt((F_pull/P)^2 + (F_shear/S)^2) with its class's mean pull and shear strengths
   (ripe 0.47 / 0.23 N, Kong et al. 2014 [published]), reaches its lognormal strength factor (mean 1, CV
   ``bond_cv`` or its stage's); unripe fruit are green, pink or red (berryshaker.harvest.ripeness: green's bond
   from the study's eq. 17, pink and red interpolated), all counted as unripe; the study's eq. 17 bands on the stem-force magnitude are the labelled
   alternative ``"study_eq17"``.
4. Damage (``damage_model = "impact"``): a detached fruit is bruised by its impacts added up as a cumulative drop
   height (a finger's strike on a share of the fruit, the fall onto the catching surface), against drop-test
   bruising thresholds (berryshaker.harvest.bruising, Brown et al. 1996: the cushioned safe height a low fractile);
   the former Weibull law in the stem force's acceleration is ``"stem_acceleration"``.
5. The responses of one table (:mod:`~berryshaker.harvest.virtual.responses`): efficiency, ripe removal, unripe
   rate, unripe shed, damage rate, each a function of the test's tally.

Nothing is fitted to the study by default: the yield per bush comes from published yields
(docs/harvest.md, "Yield"), so the study's 3.93 kg/min, 3.1 % and 2.8 % are held-out checks (``berryshaker
validate``).  :func:`~berryshaker.harvest.virtual.field_fit.calibrate_harvest` can still fit the yield (and, with the
Weibull damage, its scale) to a field value, and labels it fitted.

This package re-exports the chain's public names; each step has its module, importing only the ones below it:
:mod:`~berryshaker.harvest.virtual.replicates` (the starts of a run and their mean and spreads),
:mod:`~berryshaker.harvest.virtual.indexes` (one start's responses), :mod:`~berryshaker.harvest.virtual.field_fit`
(the fit to field values), :mod:`~berryshaker.harvest.virtual.drive_speed` (the harvest against drive speed).
"""

from berryshaker.harvest.shaking import shaking_amplitude
from berryshaker.harvest.virtual.drive_speed import removal_at_speed, removal_vs_frequency, with_drive_speed
from berryshaker.harvest.virtual.field_fit import STUDY_TARGETS, calibrate_harvest
from berryshaker.harvest.virtual.field_test import (
    HarvestParameters,
    LoadGrid,
    bushes_per_test,
    expectation,
    expected_tally,
    field_tally,
    load_grid,
    stiffness_scale,
)
from berryshaker.harvest.virtual.indexes import start_responses, virtual_harvest
from berryshaker.harvest.virtual.replicates import (
    class_starts,
    harvest_columns,
    harvest_response,
    machine_start,
    replicate_envelopes_run,
    replicate_response,
    replicate_starts,
)
from berryshaker.harvest.virtual.responses import RESPONSES, HarvestResponse, Tally, register_response, response_values
from berryshaker.harvest.virtual.seeds import FIELD, FRESH_STARTS, MACHINE, MODEL_CHECK, start_numbers
from berryshaker.harvest.virtual.stem_force_tables import (
    CH_FORCE,
    CH_RIPE,
    CH_UNRIPE,
    ENVELOPE_OUTPUT_STEP,
    MASS_FACTORS,
    STIFFNESS_RANGE,
    TABLE_STEP,
    Z_GRID,
    acceleration_envelope,
    bond_strengths,
    branch_class_machine,
    class_phase_offsets,
    class_tables_run,
    envelopes_for,
    fruit_load_channels,
    fruit_peak_force,
    fruit_peak_load,
    miner_channels,
    stem_force_envelope,
    stem_force_envelope_run,
    stem_force_table,
)

__all__ = [
    "CH_FORCE", "CH_RIPE", "CH_UNRIPE", "ENVELOPE_OUTPUT_STEP", "TABLE_STEP", "FIELD", "FRESH_STARTS",
    "HarvestParameters", "HarvestResponse", "LoadGrid", "MACHINE", "MASS_FACTORS", "MODEL_CHECK", "RESPONSES",
    "STIFFNESS_RANGE", "STUDY_TARGETS", "Tally", "Z_GRID", "acceleration_envelope", "bond_strengths", "branch_class_machine",
    "bushes_per_test", "class_phase_offsets", "class_starts", "class_tables_run", "calibrate_harvest",
    "envelopes_for", "expectation", "expected_tally", "field_tally",
    "fruit_load_channels", "fruit_peak_force", "fruit_peak_load", "harvest_columns", "harvest_response", "load_grid",
    "machine_start", "miner_channels",
    "register_response", "removal_at_speed", "removal_vs_frequency", "replicate_envelopes_run",
    "replicate_response", "replicate_starts", "response_values", "shaking_amplitude", "start_numbers",
    "start_responses", "stiffness_scale", "stem_force_envelope", "stem_force_envelope_run", "stem_force_table", "virtual_harvest",
    "with_drive_speed",
]
