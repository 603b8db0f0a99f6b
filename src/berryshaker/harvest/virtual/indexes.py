"""The harvest responses of one start: the model's expectation, one counted field test and that test's counting
noise, every response of the table (:data:`~berryshaker.harvest.virtual.responses.RESPONSES`); and the virtual
harvest of the centred start at given clearances.  Part of the virtual harvest (berryshaker.harvest.virtual).
"""

from __future__ import annotations

import math

import numpy as np

from berryshaker.config import Machine
from berryshaker.harvest.virtual.field_test import (
    HarvestParameters,
    expectation,
    field_tally,
    load_grid,
)
from berryshaker.harvest.virtual.responses import response_values
from berryshaker.harvest.virtual.stem_force_tables import envelopes_for


def start_responses(machine: Machine, envelopes: list, start: int, params: HarvestParameters | None = None) -> dict:
    """Every harvest response of one start (its stem-load tables): the model's expectation, one field test counted
    fruit by fruit, and the field test's counting SD about the expectation
    (berryshaker.harvest.virtual.field_test).

    Parameters
    ----------
    machine : Machine
        Machine description with [plant], [harvest] and [operation].
    envelopes : list of numpy.ndarray
        One stem-load table per branch class (N, dimensionless load ratios).
    start : int
        Start number (its field test's stream).
    params : HarvestParameters, optional
        Parameter values (scalars; default the description's).

    Returns
    -------
    dict
        ``expected``, ``field`` and ``count_sd``: response name -> value (its unit; NaN where undefined, e.g. a rate
        when nothing is picked).
    """
    envelopes = [np.asarray(e, float) for e in envelopes]
    grid = load_grid(machine, envelopes)
    tally, var = expectation(machine, grid, params)
    return {"expected": response_values(tally),
            "field": response_values(field_tally(machine, envelopes, start, params)),
            "count_sd": {n: math.sqrt(v) if np.isfinite(v) and v >= 0 else float("nan") for n, v in var.items()}}


def virtual_harvest(machine: Machine, clearance: dict[str, float] | None = None, start: int = 0,
                    envelopes: list[np.ndarray] | None = None) -> dict:
    """Harvest responses of the centred start at the given clearances (seeded, deterministic).

    Parameters
    ----------
    machine : Machine
        Machine description with [plant] and [harvest].
    clearance : dict of str to float, optional
        Clearance sizes (m) per pair.
    start : int
        Start number of the field test.
    envelopes : list of numpy.ndarray, optional
        Envelopes already computed at these clearances (N, dimensionless load ratios; default
        :func:`~berryshaker.harvest.virtual.stem_force_tables.envelopes_for`).

    Returns
    -------
    dict
        :func:`start_responses` with ``clearance_mm`` (mm per pair).
    """
    env = envelopes if envelopes is not None else envelopes_for(machine, clearance)
    out = start_responses(machine, env, start)
    out["clearance_mm"] = {k: v * 1e3 for k, v in
                           machine.with_clearances(clearance or {}).clearance_sizes().items()}
    return out

