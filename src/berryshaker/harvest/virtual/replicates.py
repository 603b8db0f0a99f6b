"""Replicates of a virtual test run and the harvest response (docs/harvest.md, "Replicates"): the starts of a run, each
start's stem-load tables from perturbed drive-pasts, and every response's mean and spreads over the starts.  Part of
the virtual harvest (berryshaker.harvest.virtual).

Over R starts a response has two spreads: the **model's** (start to start: the SD of the expectation, from the
machine's initial state and the drive phase at which the comb meets the bush) and the **field's** (test to test:
the SD of the counted field results, the model's spread plus the counting noise of a field test's few bushes and
fruit).  The mean is the mean of the expectation.
"""

from __future__ import annotations

import math

import numpy as np

from berryshaker.config import Machine
from berryshaker.harvest.shaking import shaking_amplitude
from berryshaker.harvest.virtual.indexes import start_responses
from berryshaker.harvest.virtual.responses import RESPONSES
from berryshaker.harvest.virtual.seeds import MACHINE, seed_sequence, start_numbers
from berryshaker.harvest.virtual.stem_force_tables import class_tables_run


def replicate_starts(machine: Machine, replicates: int | None = None) -> list[int]:
    """The start numbers of a virtual test run's replicates: 0 .. R - 1 of the description's seed family
    (berryshaker.harvest.virtual.seeds), R = ``replicates`` or ``harvest.replicates``.

    Parameters
    ----------
    machine : Machine
        Machine description with a [harvest] block.
    replicates : int, optional
        R (default ``harvest.replicates``).

    Returns
    -------
    list of int
        0 .. R - 1.
    """
    return start_numbers(machine.harvest.replicates if replicates is None else replicates)


def machine_start(machine: Machine, key):
    """The seeded initial perturbation of a machine start: spawn key ``key`` (``(k, MACHINE, class)``, ...) of the
    description's seed family, with ``harvest.initial_eccentricity`` and ``harvest.start_phase_spread``
    (:class:`berryshaker.multibody.perturbation.RandomInitialPerturbation`).

    Parameters
    ----------
    machine : Machine
        Machine description with a [harvest] block.
    key : sequence of int
        Spawn key (berryshaker.harvest.virtual.seeds).

    Returns
    -------
    RandomInitialPerturbation
        Eccentricities uniform over the disc of ``initial_eccentricity`` x each free radius, drive phase uniform in
        +-``start_phase_spread``.
    """
    from berryshaker.multibody.perturbation import RandomInitialPerturbation

    h = machine.harvest
    return RandomInitialPerturbation(seed_sequence(h.seed, key), h.initial_eccentricity, h.start_phase_spread)


def class_starts(machine: Machine, key) -> list:
    """The machine starts of every branch class of one replicate start: :func:`machine_start` of ``(*key, c)`` for
    each class c (``key`` = ``(k, MACHINE)`` for start k).

    Parameters
    ----------
    machine : Machine
        Machine description with a [harvest] block.
    key : sequence of int
        Spawn key of the start (berryshaker.harvest.virtual.seeds).

    Returns
    -------
    list of RandomInitialPerturbation
        One per ``harvest.branch_classes`` entry, in its order.
    """
    return [machine_start(machine, (*key, c)) for c in range(len(machine.harvest.branch_classes))]


def replicate_envelopes_run(machine: Machine, clearance: dict | None = None, replicates: int | None = None
                            ) -> list[tuple[list[np.ndarray], int]]:
    """Stem-force tables of every branch class for each start, with the start number (in this process; the study
    runs the same drive-pasts through its cached runner, berryshaker.study.runs.replicate_run).  Start k is one
    coupled drive-past carrying every class as a probe at its own drive phase
    (:func:`~berryshaker.harvest.virtual.stem_force_tables.class_tables_run` of :func:`class_starts`
    ``(k, MACHINE)``).

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
        Per start: one :func:`~berryshaker.harvest.virtual.stem_force_tables.stem_force_table` per branch class
        (N, dimensionless load ratios) and the start number.
    """
    return [(class_tables_run(machine, clearance, class_starts(machine, (k, MACHINE)))[0], k)
            for k in replicate_starts(machine, replicates)]


def _finite(values) -> np.ndarray:
    v = np.asarray(values, float)
    return v[np.isfinite(v)]  # a rate of a start that picked nothing is undefined


def replicate_response(machine: Machine, replicates: list[tuple[list[np.ndarray], int]],
                       known: list[dict | None] | None = None) -> dict:
    """Every response's mean and spreads over starts ``(envelopes, start number)`` (module docstring).

    Keys per response, by its column name (``efficiency_kg_min`` ...): the mean of the model's expectation;
    ``<column>_sd`` the model's start-to-start SD (ddof 1; 0 for one start); ``<column>_field_sd`` the field's
    test-to-test SD (of the counted field results); ``<column>_count_sd`` the counting noise of one field test (RMS
    over the starts).  Then ``replicates`` (R), ``shaking_frequency_hz`` and the shaking amplitude
    (:func:`~berryshaker.harvest.shaking.shaking_amplitude`).

    Parameters
    ----------
    machine : Machine
        Machine description with [plant], [harvest] and [operation].
    replicates : list of (list of numpy.ndarray, int)
        Per start its envelopes (N, dimensionless load ratios) and start number.
    known : list of (dict or None), optional
        Per start (in ``replicates``' order) its :func:`~berryshaker.harvest.virtual.start_responses` when the
        caller has them (a run that kept them), None where they are to be computed from the envelopes.

    Returns
    -------
    dict
        The keys above (the responses' units: kg/min, %), ``shaking_frequency_hz`` (Hz), ``comb_swing_deg`` (deg)
        and ``finger_amplitude_mm`` (mm).

    Raises
    ------
    ConfigError
        No start given.
    """
    from berryshaker.errors import ConfigError

    if not replicates:
        raise ConfigError("replicate_response: no start (every run failed?)")
    known = known or [None] * len(replicates)
    each = [s if s is not None else start_responses(machine, env, k) for (env, k), s in zip(replicates, known)]
    out: dict = {}
    for n, r in RESPONSES.items():
        e = _finite([s["expected"][n] for s in each])
        f = _finite([s["field"][n] for s in each])
        c = _finite([s["count_sd"][n] for s in each])
        out[r.column] = float(np.mean(e)) if e.size else float("nan")
        out[f"{r.column}_sd"] = float(np.std(e, ddof=1)) if e.size > 1 else 0.0
        out[f"{r.column}_field_sd"] = float(np.std(f, ddof=1)) if f.size > 1 else 0.0
        out[f"{r.column}_count_sd"] = float(np.sqrt(np.mean(c**2))) if c.size else float("nan")
    out["replicates"] = len(each)
    out["shaking_frequency_hz"] = machine.drive_speed / (2 * math.pi)
    out.update(shaking_amplitude(machine))
    return out


def harvest_columns() -> dict[str, str]:
    """The columns of :func:`replicate_response` for the responses, with their units.

    Returns
    -------
    dict of str to str
        Column -> unit, for every response's mean and its three spreads.
    """
    out = {}
    for r in RESPONSES.values():
        for suffix in ("", "_sd", "_field_sd", "_count_sd"):
            out[r.column + suffix] = r.unit
    return out


def harvest_response(machine: Machine, clearance: dict | None = None, replicates: int | None = None) -> dict:
    """Virtual harvest of one machine setting over ``harvest.replicates`` perturbed starts: :func:`replicate_response`
    of :func:`replicate_envelopes_run`.

    Parameters
    ----------
    machine : Machine
        Machine description (any drive with a [plant] and a [harvest] section).
    clearance : dict, optional
        Clearance sizes (m).
    replicates : int, optional
        Starts R, default ``harvest.replicates``.

    Returns
    -------
    dict
        :func:`replicate_response`: every response's mean over the starts with its model, field and counting
        spreads, ``replicates``, the shaking frequency (one comb cycle per drive-shaft revolution: drive speed /
        2 pi) and amplitude.
    """
    return replicate_response(machine, replicate_envelopes_run(machine, clearance, replicates))
