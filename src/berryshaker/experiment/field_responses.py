"""The responses of a filled field sheet (:func:`berryshaker.experiment.field_results.read_results`): each
response's column and unit, its cells checked against the physical ranges, and the indexes computed from the raw
masses where their cells are empty.
"""

from __future__ import annotations

import numpy as np

from berryshaker.errors import ConfigError
from berryshaker.experiment.field_cells import _Sheet, _split_unit, block_column, is_bookkeeping
from berryshaker.experiment.field_columns import (
    META_COLUMNS,
    RAW_COLUMNS,
    compute_indexes,
    index_columns,
    index_names,
    index_units,
)


def _response_column(sheet: _Sheet, r: str) -> str:
    """The column of response ``r``: the index column of an index name (``efficiency`` -> efficiency_kg_min), the
    column of that name, else the one column named so without regard to case ("Efficiency (kg/min)" for
    ``efficiency``); the index column name when none is there (the index is then computed from raw masses)."""
    cols = list(sheet.df.columns)
    names = index_names()
    if r in names and names[r] in cols:
        return names[r]
    if r in cols:
        return r
    same = [c for c in cols if c.lower() == r.lower()]
    if len(same) == 1:
        return same[0]
    return names.get(r, r)


def _response_unit(sheet: _Sheet, col: str) -> str:
    """Unit of a response column: from the header or the units row, else the index column's, else a ``_unit``
    suffix; '' when none is given."""
    if col in sheet.header_units:
        return sheet.header_units[col]
    units = index_units()
    if col in units:
        return units[col]
    su = _split_unit(col) if col in sheet.df.columns else None
    return su[1] if su else ""


def _response(sheet: _Sheet, r: str, factor_cols: set[str] | frozenset[str] = frozenset(), col: str | None = None,
              lost: bool = False) -> np.ndarray:
    """Values of one response per row (file order), checked; indexes computed from raw masses where empty.

    ``lost``: a row whose response is empty (an index: and every raw mass of it too) is a lost plot, NaN (a
    replicated sheet); otherwise an empty response is an error."""
    df = sheet.df
    blk = block_column(df)
    numeric_cols = [c for c in df.columns if c not in ("run", "replicate", "order", blk) and c.lower() not in META_COLUMNS
                    and c not in factor_cols and c not in RAW_COLUMNS and not is_bookkeeping(c)]
    col = col or _response_column(sheet, r)
    if r not in index_names() and col not in df.columns:
        raise ConfigError(f"unknown response {r!r}; valid: {', '.join(index_names())} (indexes or raw masses) or a "
                          f"column of the sheet ({', '.join(c for c in numeric_cols if not c.endswith('_level'))})")
    n = len(df)
    if col in df.columns:
        vals, empty = sheet.numbers(col)
    else:
        vals, empty = np.full(n, np.nan), np.ones(n, bool)
    _check_range(sheet, col, vals, ~empty)
    if empty.any() and col in index_columns():
        need = np.flatnonzero(empty)
        if lost:  # rows with no raw mass either are lost plots; the others are computed (or refused) below
            present = [c for c in RAW_COLUMNS if c in df.columns]
            blank = np.ones(n, bool)
            for c in present:
                blank &= np.asarray(df[c].isna(), bool)
            need = need[~blank[need]]
            if not len(need):
                return vals
        raw = {}
        for c in RAW_COLUMNS:
            if c not in df.columns:
                i = int(need[0])
                raise ConfigError(f"{sheet.where(i, col)}: response {r!r} is empty and cannot be computed from "
                                  f"{', '.join(RAW_COLUMNS)} (no {c!r} column); fill in {col!r}")
            v, e = sheet.numbers(c)
            _check_range(sheet, c, v, ~e)
            miss = need[e[need]]
            if len(miss):
                i = int(miss[0])
                raise ConfigError(f"{sheet.row(i)}: response {r!r} is empty and "
                                  f"cannot be computed from {', '.join(RAW_COLUMNS)}: {c!r} is empty; fill in "
                                  f"{col!r} or the raw measurements")
            raw[c] = v
        d, p, u, dm = (raw[c] for c in RAW_COLUMNS)
        for c, x in (("unripe_mass_kg", u), ("damaged_mass_kg", dm)):
            over = np.flatnonzero(x[need] > p[need])
            if len(over):
                i = int(need[over[0]])
                raise ConfigError(f"{sheet.where(i, c)}: {x[i]:g} kg is more than the picked mass {p[i]:g} kg "
                                  "(rates would exceed 100 %); the picked mass is everything picked, including "
                                  "unripe and damaged fruit")
        if col != "efficiency_kg_min":
            zero = np.flatnonzero(p[need] <= 0)
            if len(zero):
                i = int(need[zero[0]])
                raise ConfigError(f"{sheet.where(i, 'picked_mass_kg')}: picked mass is 0, so the rate {col!r} is "
                                  "undefined; fill in the rate or check the mass")
        computed = compute_indexes(d, p, u, dm)[col]
        vals[need] = computed[need]
    elif empty.any() and not lost:
        i = int(np.argmax(empty))
        raise ConfigError(f"{sheet.row(i)}: response {r!r} is empty; fill in "
                          f"{col!r}")
    return vals


def _check_range(sheet: _Sheet, col: str, vals: np.ndarray, filled: np.ndarray) -> None:
    """Physical ranges of the measured quantities (only filled cells are checked)."""
    v = np.where(filled, vals, 0.0)
    checks = [(~np.isfinite(v), "must be a finite number")]
    if col == "duration_s":
        checks.append(((v <= 0) & filled, "duration must be > 0 s"))
    elif col in RAW_COLUMNS:
        checks.append((v < 0, "mass must be >= 0 kg"))
    elif col in ("unripe_rate_pct", "damage_rate_pct"):
        checks.append(((v < 0) | (v > 100), "rate must be within 0-100 % (a fraction 0.03 is 3 %)"))
    elif col == "efficiency_kg_min":
        checks.append((v < 0, "efficiency must be >= 0 kg/min"))
    for bad, msg in checks:
        if bad.any():
            i = int(np.argmax(bad))
            raise ConfigError(f"{sheet.where(i, col)}: {sheet.df[col].iloc[i]!r}: {msg}")
