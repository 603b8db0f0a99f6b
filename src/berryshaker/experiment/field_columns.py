"""The field sheet's columns and the two records read from or written to it: a test factor (:class:`Factor`) and a
filled sheet, read and checked (:class:`FieldResults`), and the study's test indexes from raw masses.

Shared by the writer of a plan (:mod:`berryshaker.experiment.field_sheet`) and the reader of a filled sheet
(:mod:`berryshaker.experiment.field_results`), so neither imports the other's internals.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

RAW_COLUMNS = ["duration_s", "picked_mass_kg", "unripe_mass_kg", "damaged_mass_kg"]
INDEX_COLUMNS = ["efficiency_kg_min", "unripe_rate_pct", "damage_rate_pct"]
INDEX_NAMES = {"efficiency": "efficiency_kg_min", "unripe": "unripe_rate_pct", "damage": "damage_rate_pct"}
#: unit of each index column (the column names carry them: picked mass per minute, mass percentages)
INDEX_UNITS = {"efficiency_kg_min": "kg/min", "unripe_rate_pct": "%", "damage_rate_pct": "%"}
#: free-text columns a crew may add (never read as numbers, never taken as factors)
META_COLUMNS = ("date", "time", "operator", "weather", "notes", "note", "comment", "comments", "remarks", "crew",
                "observer", "site")
#: largest sheet read; the analysis is linear in the rows, the limit only guards against a wrong file
MAX_ROWS = 1_000_000


@dataclass(frozen=True)
class Factor:
    """A test factor: name, level values (in ``unit``, in the order level 1, 2, ...) and unit ('' if none).

    Attributes
    ----------
    name : str
        Factor name (a word: letters, digits, _).
    levels : tuple of float
        Level values, level 1 first (in ``unit``: its units).
    unit : str
        Unit of the levels ('' for none).
    """

    name: str
    levels: tuple[float, ...]  # in ``unit``
    unit: str

    @property
    def column(self) -> str:
        """Column of the level values in the field sheet: ``<name>_<unit>`` or ``<name>`` without a unit."""
        return f"{self.name}_{self.unit}" if self.unit else self.name


def reserved_columns() -> set[str]:
    """Columns of a field sheet that are never a factor: run, replicate, order, raw masses, indexes, notes.

    Returns
    -------
    set of str
        The column names.
    """
    return {"run", "replicate", "order", *RAW_COLUMNS, *INDEX_COLUMNS, *INDEX_NAMES, *META_COLUMNS}


@dataclass
class FieldResults:
    """A filled field sheet, read and checked.

    ``table`` is the sheet sorted by run (and replicate), with ``<factor>_level`` columns holding the 1-based
    level numbers whatever coding the sheet used (added when the sheet had only value columns).  ``levels``
    (runs x factors, int, one row per run) is the design as an array; ``values`` holds the level values (in
    ``units``) where the sheet or the given factors state them and the level number otherwise;
    ``level_values[name]`` is the tuple of level values (level 1, 2, ...) or None when the sheet gives only
    level numbers.  A sheet with a ``replicate`` column: ``replicates`` (R, the same for every run),
    ``responses_replicated`` (name -> runs x R) and ``responses`` the replicate means per run; without it R = 1
    and ``responses_replicated`` is None.  A replicated sheet may have lost plots (a blank response, a deleted row):
    NaN in ``responses_replicated``, listed in ``lost``.  A ``block`` (or ``blocks``) column takes the replicate column's role and
    names the blocks of the analysis (``block_column``: each run once per block).  A sheet without a ``run`` column
    (Minitab's worksheet, a statistics package's export) has its runs told apart by their factor settings: rows with
    the same settings are replicates of one run (``runs_identified_by`` says how they were numbered).

    Attributes
    ----------
    table : pandas.DataFrame
        The sheet, sorted by run and replicate, with normalised level columns.
    factors : list of str
        The ``<factor>_level`` columns of ``table``.
    factor_names : list of str
        The factors.
    responses : dict name -> ndarray (runs,)
        Response per run (replicate means), in its sheet's units (``response_units``).
    levels : ndarray (runs, factors)
        1-based level numbers (1).
    values : ndarray (runs, factors)
        Level values in ``units`` (its units), or the level number where no value is known.
    level_values : dict name -> tuple of float or None
        Values of each level (the factor's units).
    units : dict name -> str
        Unit per factor.
    ignored_columns : list of str
        Columns read as neither factor nor response.
    replicates : int
        Replicates per run (1 without).
    responses_replicated : dict name -> ndarray (runs, replicates) or None
        Every observation (same units as ``responses``).
    block_column : str or None
        The column numbering the blocks.
    response_units : dict name -> str
        Unit per response.
    runs_identified_by : str
        How the runs were told apart.
    lost : dict name -> list of [run, replicate]
        Per response the lost plots (a blank response cell or a deleted row of a replicated sheet): NaN in
        ``responses_replicated``, left out of ``responses`` (the means of the replicates present); empty when the
        sheet is complete.
    """

    table: pd.DataFrame
    factors: list[str]  # level-number columns of ``table``
    factor_names: list[str]
    responses: dict[str, np.ndarray]  # response name -> values per run (in run order)
    levels: np.ndarray | None = None
    values: np.ndarray | None = None
    level_values: dict[str, tuple[float, ...] | None] = field(default_factory=dict)
    units: dict[str, str] = field(default_factory=dict)
    ignored_columns: list[str] = field(default_factory=list)
    replicates: int = 1
    responses_replicated: dict[str, np.ndarray] | None = None
    #: the column whose numbers are the blocks of the replicated analysis (``block``/``blocks``, else ``replicate``)
    block_column: str | None = None
    #: unit per response (from the header, "Efficiency (kg/min)", a units row, or the index column's name)
    response_units: dict[str, str] = field(default_factory=dict)
    #: how the runs were told apart: "run column", or "factor settings" with how the repeats were numbered
    runs_identified_by: str = "run column"
    #: per response the (run, replicate) cells lost (NaN in ``responses_replicated``)
    lost: dict[str, list[list[int]]] = field(default_factory=dict)


def compute_indexes(duration_s, picked_kg, unripe_kg, damaged_kg) -> dict[str, np.ndarray]:
    """Study's test indexes: picked mass per minute, unripe and damaged mass as % of the picked mass.

    Parameters
    ----------
    duration_s : array_like
        Test duration [s].
    picked_kg, unripe_kg, damaged_kg : array_like
        Picked mass (all fruit picked), its unripe and its damaged part [kg].

    Returns
    -------
    dict
        ``efficiency_kg_min`` [kg/min], ``unripe_rate_pct`` and ``damage_rate_pct`` [%].
    """
    duration_s = np.asarray(duration_s, float)
    picked = np.asarray(picked_kg, float)
    with np.errstate(invalid="ignore", divide="ignore"):
        return {
            "efficiency_kg_min": picked / (duration_s / 60.0),
            "unripe_rate_pct": 100.0 * np.asarray(unripe_kg, float) / picked,
            "damage_rate_pct": 100.0 * np.asarray(damaged_kg, float) / picked,
        }


__all__ = ["Factor", "FieldResults", "INDEX_COLUMNS", "INDEX_NAMES", "INDEX_UNITS", "MAX_ROWS", "META_COLUMNS", "RAW_COLUMNS",
           "compute_indexes", "reserved_columns"]
