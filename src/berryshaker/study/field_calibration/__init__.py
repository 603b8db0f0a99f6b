"""Calibrate the harvest model to a user's own field sheet and predict the settings it did not test
(``berryshaker calibrate``, docs/calibration.md).

The method is one chain, each part's inputs the previous part's outputs; each part is a module of this package:

1. **Parameters and priors** (:mod:`~berryshaker.study.field_calibration.priors`, :data:`PARAMETERS`): the eight
   harvest parameters that act only in the post-processing of the coupled runs' stem-load tables, each with a
   prior from the cited ranges, and the prior's unit cube the emulator and the sampler work on.
2. **The field sheet** (:mod:`~berryshaker.study.field_calibration.sheet`, :func:`read_sheet`): its factors
   mapped to the machine (:func:`factor_target`), its settings and replicate results.
3. **Simulator** (:mod:`~berryshaker.study.field_calibration.simulator`, :class:`Simulator`): every setting of the
   sheet run from R perturbed starts through the cached runner, then the model's expectation and the counting
   noise at (setting, start, theta) are the virtual harvest's own quadrature of the runs' stem-load tables.
4. **Emulator** (:mod:`~berryshaker.study.field_calibration.emulator`, :class:`Emulator`): scikit-learn Gaussian
   processes of log(mean + c), log(model SD) and log(counting SD), per simulated setting and joint over (coded
   setting, theta).
5. **Likelihood and sampler** (:mod:`~berryshaker.study.field_calibration.posterior`, :func:`log_likelihood`,
   :func:`sample_posterior`): a Student-t likelihood of each run's replicates, sampled with ``emcee`` in the
   prior's standard-normal coordinates.
6. **Identifiability, checks, predictions** (:mod:`~berryshaker.study.field_calibration.workflow`,
   :func:`calibrate`): prior against posterior 90 % intervals, posterior predictive checks per run, a held-out run,
   what the sheet shows that the model does not produce, predictions of every level set of the sheet's factors (and
   named settings) with 90 % intervals of a future field result, and a recommendation made on them
   (:data:`RECOMMENDATION_RULE`); :func:`predict_saved` predicts again from a saved calibration
   (:mod:`~berryshaker.study.field_calibration.saved`).
7. **The result** (:mod:`~berryshaker.study.field_calibration.result`, :class:`CalibrationResult`): typed records,
   written as the command's JSON by :meth:`CalibrationResult.to_json` and read back by
   :meth:`CalibrationResult.from_json`.

:mod:`~berryshaker.study.field_calibration.synthetic_sheets` fills a field sheet with counted field tests at known
parameters (the docs' example, the test and the coverage study).  Every name callers use is importable from here
(``from berryshaker.study import field_calibration as fc``).
"""

from __future__ import annotations

from berryshaker.study.field_calibration.emulator import GP_FIT_ITERATIONS, Emulator, FittedGP
from berryshaker.study.field_calibration.posterior import (
    DISCREPANCY_SCALE,
    FIELD_NOISE_SCALE,
    SheetStatistics,
    log_likelihood,
    predictive,
    sample_posterior,
)
from berryshaker.study.field_calibration.priors import (
    HARD_BRUISE,
    PARAMETER_NAMES,
    PARAMETERS,
    RESPONSE_PARAMETERS,
    Z90,
    Parameter,
    calibrated_responses,
    described_values,
    latin_hypercube,
    parameters_for,
    prior_rows,
    theta_of,
    unit_of,
)
from berryshaker.study.field_calibration.result import (
    CalibrationRecommendation,
    CalibrationResult,
    Checks,
    CheckSummary,
    Confounding,
    EmulatorCheck,
    EmulatorSummary,
    FactorSummary,
    HeldOutRun,
    HyperSummary,
    ModelDiscrepancy,
    ParameterSummary,
    Prediction,
    PriorSummary,
    ResidualEffect,
    ResponsePrediction,
    RunCheck,
    SamplerSummary,
    SettingValue,
    SheetSummary,
    SimulatorSummary,
    Timings,
)
from berryshaker.study.field_calibration.saved import STATE_FILE, load_state, save_state
from berryshaker.study.field_calibration.sheet import (
    DRIVE_SPEED_NAMES,
    FactorTarget,
    Sheet,
    factor_target,
    level_sets,
    parse_setting,
    read_sheet,
    setting_data,
)
from berryshaker.study.field_calibration.simulator import Simulator, fresh_starts, start_statistics, training_starts
from berryshaker.study.field_calibration.synthetic_sheets import synthetic_sheet
from berryshaker.study.field_calibration.workflow import (
    CONFOUNDED_RULE,
    IDENTIFIED_RULE,
    LIMITS,
    RECOMMENDATION_RULE,
    RESIDUAL_RULE,
    CalibrationSettings,
    calibrate,
    predict_saved,
)

# the emulator's training data and held-out check, which the test calls directly
from berryshaker.study.field_calibration.workflow import _emulator_check as _emulator_check
from berryshaker.study.field_calibration.workflow import _train as _train

__all__ = ["CONFOUNDED_RULE", "DISCREPANCY_SCALE", "DRIVE_SPEED_NAMES", "FIELD_NOISE_SCALE", "GP_FIT_ITERATIONS",
           "HARD_BRUISE", "IDENTIFIED_RULE", "LIMITS", "PARAMETERS", "PARAMETER_NAMES", "RECOMMENDATION_RULE",
           "RESIDUAL_RULE", "RESPONSE_PARAMETERS", "STATE_FILE", "Z90", "CalibrationRecommendation",
           "CalibrationResult", "CalibrationSettings", "CheckSummary", "Checks", "Confounding", "Emulator",
           "EmulatorCheck", "EmulatorSummary", "FactorSummary", "FactorTarget", "FittedGP", "HeldOutRun",
           "HyperSummary", "ModelDiscrepancy", "Parameter", "ParameterSummary", "Prediction", "PriorSummary",
           "ResidualEffect", "ResponsePrediction", "RunCheck", "SamplerSummary", "SettingValue", "Sheet",
           "SheetStatistics", "SheetSummary", "Simulator", "SimulatorSummary", "Timings", "calibrate",
           "calibrated_responses", "described_values", "factor_target", "fresh_starts", "latin_hypercube",
           "level_sets", "load_state", "log_likelihood", "parameters_for", "parse_setting", "predict_saved",
           "predictive", "prior_rows", "read_sheet", "sample_posterior", "save_state", "setting_data",
           "start_statistics", "synthetic_sheet", "theta_of", "training_starts", "unit_of"]
