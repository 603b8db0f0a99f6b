"""Synthetic field sheets: field results of the simulator at known parameters (:func:`synthetic_results`) and a
filled ``doe plan`` sheet made of them from starts the calibration never trains on (:func:`synthetic_sheet`); the
docs' example and the test calibrate such sheets."""

from __future__ import annotations

import numpy as np

from berryshaker.config import Machine
from berryshaker.study.field_calibration.priors import PARAMETER_NAMES, RESPONSES, described_values
from berryshaker.study.field_calibration.sheet import factor_target
from berryshaker.study.field_calibration.simulator import Simulator, fresh_seeds


def synthetic_results(sim: Simulator, settings: list[int], theta: dict[str, float], seeds: list[int],
                      pop_seeds: list[int] | None = None) -> np.ndarray:
    """Field results of the simulator at ``theta`` from starts ``seeds`` (run before with :meth:`Simulator.run`, with
    the same ``pop_seeds``): one result per setting and start, with the replicate noise of the coupled runs and the
    populations.

    Parameters
    ----------
    sim : Simulator
        The simulator.
    settings : list of int
        Setting indexes.
    theta : dict of str to float
        Parameter values (SI) by name.
    seeds : list of int
        Start seeds.
    pop_seeds : list of int, optional
        Population seeds (as given to :meth:`Simulator.run`).

    Returns
    -------
    numpy.ndarray
        (settings, starts, 3) efficiency (kg/min), unripe rate (%), damage rate (%); a rate that is undefined
        (nothing picked) is 0.
    """
    th = np.array([[theta[n] for n in PARAMETER_NAMES]], float)
    return np.nan_to_num(np.stack([sim.responses(s, seeds, th, pop_seeds)[0] for s in settings]), nan=0.0)


def synthetic_sheet(machine: Machine, runner, factors, theta: dict[str, float] | None = None, array: str = "L9",
                    replicates: int = 3, seed_offset: int = 0, responses=tuple(RESPONSES)):
    """A filled field sheet (``doe plan`` layout) from the simulator at known parameters: the plan of
    :func:`berryshaker.experiment.field_sheet.plan_table` with its index columns filled by the virtual harvest at
    ``theta`` from starts the calibration never trains on (:func:`fresh_seeds`), so it carries the real replicate
    noise.  The docs' example and the test calibrate such sheets.

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
        First fresh start (k of :func:`fresh_seeds`); every row has its own start and population (row i: k =
        seed_offset + i), so sheets with offsets apart by the row count share none.
    responses : sequence of str
        Responses filled in (the others are left empty).

    Returns
    -------
    pandas.DataFrame
        The filled sheet (write it with ``to_csv(path, index=False)``).
    """
    from berryshaker.experiment.field_sheet import plan_table

    plan = plan_table(array, list(factors), replicates=replicates)
    targets = [factor_target(machine, f.name, f.unit, f.levels) for f in factors]
    sim = Simulator(machine, targets)
    idx = [sim.setting_index([row[f.column] * t.to_si for f, t in zip(factors, targets)]) for _, row in plan.iterrows()]
    seeds = fresh_seeds(machine, len(plan), seed_offset)  # every row its own start and bushes, as in a field
    sim.run_starts(runner, [(s, sd, sd) for s, sd in zip(idx, seeds)], "synthetic sheet: fresh starts")
    vals = {**described_values(machine), **(theta or {})}
    th = np.array([[vals[n] for n in PARAMETER_NAMES]], float)
    res = np.nan_to_num(np.array([sim.responses(s, [sd], th)[0, 0] for s, sd in zip(idx, seeds)]), nan=0.0)
    cols = {"efficiency": "efficiency_kg_min", "unripe": "unripe_rate_pct", "damage": "damage_rate_pct"}
    for j, r in enumerate(RESPONSES):
        if r in responses:
            plan[cols[r]] = res[:, j]
    return plan
