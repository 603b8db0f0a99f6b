"""Replicates of a virtual test run and the harvest response (docs/harvest.md, "Replicates"): the replicate seeds,
each replicate's stem-force tables from perturbed drive-pasts, the indexes of one replicate and their mean and
standard deviation over the replicates.  Part of the virtual harvest (berryshaker.harvest.virtual).
"""

from __future__ import annotations

import math

import numpy as np

from berryshaker.config import Machine
from berryshaker.harvest.shaking import shaking_amplitude
from berryshaker.harvest.virtual.indexes import harvest_indexes
from berryshaker.harvest.virtual.population import sample_population
from berryshaker.harvest.virtual.stem_force_tables import stem_force_envelope_run


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
    the ``replicates`` of :func:`~berryshaker.harvest.virtual.field_fit.calibrate_harvest` and
    :func:`replicate_response`.  Replicate k's run of class c starts from
    :class:`berryshaker.multibody.perturbation.RandomInitialPerturbation` ((seed_k, c),
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
        Per replicate: one :func:`~berryshaker.harvest.virtual.stem_force_tables.stem_force_table` per branch
        class (N, dimensionless load ratios) and the population seed.
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
    calibration fits, :func:`~berryshaker.harvest.virtual.field_fit.calibrate_harvest`).  Keys: every index
    (mean), ``<index>_sd`` (sample SD over the replicates, ddof 1; 0 for one replicate), ``replicates`` (R),
    ``shaking_frequency_hz`` and the shaking amplitude (:func:`~berryshaker.harvest.shaking.shaking_amplitude`).

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
        amplitude of :func:`~berryshaker.harvest.shaking.shaking_amplitude` (comb_swing_deg,
        finger_amplitude_mm).  R coupled runs per branch class (:func:`replicate_envelopes_run`).
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
        ``efficiency_kg_min`` (kg/min), ``shaking_frequency_hz`` (Hz) and the keys of
        :func:`~berryshaker.harvest.shaking.shaking_amplitude`.
    """
    idx = harvest_indexes(machine, envelopes, sample_population(machine, seed))
    return {"ripe_removal_pct": 100.0 * idx["ripe_picked_fraction"],
            "unripe_shed_pct": 100.0 * idx["unripe_shed_fraction"], "damage_rate_pct": idx["damage_rate_pct"],
            "unripe_rate_pct": idx["unripe_rate_pct"], "efficiency_kg_min": idx["efficiency_kg_min"],
            "shaking_frequency_hz": machine.drive_speed / (2 * math.pi), **shaking_amplitude(machine)}
