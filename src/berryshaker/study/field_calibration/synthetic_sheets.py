"""Synthetic field sheets: a filled ``doe plan`` sheet of field results counted by the virtual harvest at known
parameters from starts the calibration never trains on (:func:`synthetic_sheet`), optionally with a further field
noise the likelihood does not assume in that form; the docs' example, the test and the coverage study calibrate such
sheets."""

from __future__ import annotations

import numpy as np

from berryshaker.config import Machine
from berryshaker.study.field_calibration.priors import calibrated_responses, described_values
from berryshaker.study.field_calibration.sheet import factor_target
from berryshaker.study.field_calibration.simulator import Simulator, fresh_starts


def synthetic_sheet(machine: Machine, runner, factors, theta: dict[str, float] | None = None, array: str = "L9",
                    replicates: int = 3, seed_offset: int = 0, responses=None, field_noise: float = 0.0,
                    noise_seed: int = 0):
    """A filled field sheet (``doe plan`` layout) from the virtual harvest at known parameters: the plan of
    :func:`berryshaker.experiment.field_sheet.plan_table` with its index columns filled by one counted field test
    per row (:func:`~berryshaker.harvest.virtual.field_test.field_tally`) at ``theta``, each row from its own fresh
    start (:func:`~berryshaker.study.field_calibration.simulator.fresh_starts`: its own machine start, bushes and
    fruit, as in a field), so it carries a field test's noise.

    Parameters
    ----------
    machine : Machine
        The machine description.
    runner : SweepRunner
        Cached runner of the coupled starts.
    factors : list of Factor
        The plan's factors (berryshaker.experiment.field_sheet.parse_factor), named as :func:`factor_target` reads
        them.
    theta : dict of str to float, optional
        Parameter values (SI) by name; missing ones take the description's (:func:`described_values`).
    array : str
        Orthogonal array of the plan.
    replicates : int
        Replicates per run.
    seed_offset : int
        First fresh start (row i: start ``fresh_starts(.., seed_offset)[i]``), so sheets with offsets apart by the row
        count share none.
    responses : sequence of str, optional
        Responses filled in (default the calibrated ones; the others are left empty).
    field_noise : float
        CV of a further multiplicative field noise on every result (lognormal, mean 1; 0: none): scatter between
        rows and days that the virtual harvest does not model.
    noise_seed : int
        Seed of that noise.

    Returns
    -------
    pandas.DataFrame
        The filled sheet (write it with ``to_csv(path, index=False)``).
    """
    from berryshaker.experiment.field_sheet import plan_table

    rows = calibrated_responses()
    names = list(rows) if responses is None else [r for r in rows if r in responses]
    plan = plan_table(array, list(factors), replicates=replicates)
    targets = [factor_target(machine, f.name, f.unit, f.levels) for f in factors]
    sim = Simulator(machine, targets)
    idx = [sim.setting_index([row[f.column] * t.to_si for f, t in zip(factors, targets)]) for _, row in plan.iterrows()]
    starts = fresh_starts(len(plan), seed_offset)  # every row its own start and bushes, as in a field
    sim.run_starts(runner, list(zip(idx, starts)), "synthetic sheet: fresh starts")
    vals = {**described_values(machine), **(theta or {})}
    res = np.array([sim.field_results(s, [k], vals, names)[0] for s, k in zip(idx, starts)])
    if field_noise > 0:
        sig = np.sqrt(np.log1p(field_noise**2))
        res = res * np.exp(-0.5 * sig**2 + sig * np.random.default_rng(noise_seed).standard_normal(res.shape))
    res = np.nan_to_num(res, nan=0.0)
    for j, r in enumerate(names):
        plan[rows[r].column] = res[:, j]
    return plan
