"""The factors of a filled field sheet (:func:`berryshaker.experiment.field_results.read_results`): their columns
found (the plan's ``<name>_level`` / ``<name>_<unit>`` pair, or plain value columns as statistics packages write
them) and their level cells read as level numbers, by value or by level number whatever the coding, a coding that
reads two ways or a cell that matches no level refused with its row and column.
"""

from __future__ import annotations

import numpy as np

from berryshaker.errors import ConfigError
from berryshaker.experiment.field_cells import _Sheet, _split_unit, block_column, is_bookkeeping
from berryshaker.experiment.field_columns import META_COLUMNS, Factor, reserved_columns


def _balance_problem(sheet: _Sheet, col: str, x: np.ndarray) -> None:
    """In an orthogonal array every level of a column occurs equally often: a value that occurs less than half
    as often as the typical level is a stray (a typo matching no level).  A cell changed to another level
    leaves no stray; the orthogonality check reports it."""
    vals, counts = np.unique(x, return_counts=True)
    if len(vals) < 2:
        return
    typical = float(np.median(counts))
    stray = vals[counts < typical / 2]
    others = vals[counts >= typical / 2]
    if len(stray) == 0 or len(others) < 2:
        return
    i = int(np.flatnonzero(np.isin(x, stray))[0])
    raise ConfigError(f"{sheet.where(i, col)}: {x[i]:g} matches no level ({', '.join(f'{v:g}' for v in others)}) "
                      f"and occurs only {int(counts[vals == x[i]][0])} time(s) where a level occurs about "
                      f"{typical:g} times; correct the cell")


def _codes_for(sheet: _Sheet, col: str, x: np.ndarray, levels: tuple[float, ...], fname: str, unit: str,
               is_code_column: bool) -> np.ndarray:
    """1-based level numbers of column ``col`` whose cells are level codes (1..k or 0..k-1) or level values."""
    k = len(levels)
    lv = np.asarray(levels, float)
    match = np.isclose(x[:, None], lv[None, :], rtol=1e-9, atol=1e-12)
    by_value = match.argmax(axis=1) + 1 if match.any(axis=1).all() else None
    codings = {}
    if by_value is not None:
        codings["level values"] = by_value
    if is_code_column:
        integral = np.all(x == np.round(x))
        if integral and x.min() >= 1 and x.max() <= k:
            codings["level numbers 1..%d" % k] = x.astype(int)
        if integral and x.min() >= 0 and x.max() <= k - 1:
            codings["level numbers 0..%d" % (k - 1)] = x.astype(int) + 1
    distinct = {tuple(v) for v in (np.asarray(c) for c in codings.values())}
    if len(distinct) == 1:
        return next(iter(codings.values()))
    shown = ", ".join(f"{v:g}" for v in levels) + (f" {unit}" if unit else "")
    if len(distinct) > 1:
        raise ConfigError(f"{sheet.label} column {col!r}: its cells read both as {' and as '.join(codings)} of "
                          f"factor {fname!r} (levels {shown}) with different meanings; write the level values with "
                          f"the unit (e.g. '{levels[0]:g} {unit or ''}'.strip()) or fill the value column")
    # nothing fits every cell: name the first cell that matches no level value and no level number
    ok = match.any(axis=1)
    if is_code_column:
        ok |= (x == np.round(x)) & (x >= 0) & (x <= k)
    bad = np.flatnonzero(~ok)
    i = int(bad[0]) if len(bad) else 0
    codes = f"; or level numbers 1..{k}" if is_code_column else ""
    raise ConfigError(f"{sheet.where(i, col)}: {x[i]:g} matches no level of factor {fname!r} (levels {shown}{codes}); "
                      "correct the cell")


def _resolve_factor(sheet: _Sheet, name: str, code_col: str | None, value_col: str | None, unit: str,
                    given: Factor | None) -> tuple[np.ndarray, tuple[float, ...] | None, np.ndarray | None, str]:
    """Level numbers (1-based), level values (or None), the value per run and the unit of one factor."""
    xc = xv = None
    if code_col is not None:
        xc, empty = sheet.numbers(code_col, allow_unit=unit if (unit or given is not None) else "?")
        unit = unit or sheet.adopted_units.get(code_col, "")
        if empty.any():
            i = int(np.argmax(empty))
            raise ConfigError(f"{sheet.where(i, code_col)}: empty level; fill in the level of {name!r}")
        if not np.isfinite(xc).all():
            i = int(np.argmax(~np.isfinite(xc)))
            raise ConfigError(f"{sheet.where(i, code_col)}: level must be a finite number")
    if value_col is not None:
        xv, empty = sheet.numbers(value_col, allow_unit=unit if (unit or given is not None) else "?")
        unit = unit or sheet.adopted_units.get(value_col, "")
        if empty.any():
            if xc is None:
                i = int(np.argmax(empty))
                raise ConfigError(f"{sheet.where(i, value_col)}: empty level value; fill in the value of {name!r}")
            xv = None if empty.all() else xv
            if xv is not None:
                i = int(np.argmax(empty))
                raise ConfigError(f"{sheet.where(i, value_col)}: empty level value (other rows have one); fill it in")
        if xv is not None and not np.isfinite(xv).all():
            i = int(np.argmax(~np.isfinite(xv)))
            raise ConfigError(f"{sheet.where(i, value_col)}: level value must be a finite number")
    if given is not None:
        levels = given.levels
        codes_v = _codes_for(sheet, value_col, xv, levels, name, unit, False) if xv is not None else None
        codes_c = _codes_for(sheet, code_col, xc, levels, name, unit, True) if xc is not None else None
    else:
        codes_c = codes_v = None
        levels = None
        if xc is not None:  # a typo in the level column; a value column is checked against it below
            _balance_problem(sheet, code_col, xc)
        elif xv is not None:
            _balance_problem(sheet, value_col, xv)
        if xc is not None and xv is not None:
            integral = np.all(xc == np.round(xc))
            k = len(np.unique(xv))
            if integral and xc.min() >= 0 and xc.max() <= k and len(np.unique(xc)) == k:
                codes_c = xc.astype(int) + (1 if xc.min() == 0 else 0)
                levels = [None] * k
                for c in range(1, k + 1):  # level value = the value most rows with this level number have
                    rows = np.flatnonzero(codes_c == c)
                    if len(rows) == 0:
                        continue
                    u, cnt = np.unique(xv[rows], return_counts=True)
                    levels[c - 1] = float(u[np.argmax(cnt)])
                    off = rows[~np.isclose(xv[rows], levels[c - 1], rtol=1e-9, atol=1e-12)]
                    if len(off):
                        i = int(off[0])
                        raise ConfigError(f"{sheet.where(i, value_col)}: {xv[i]:g} disagrees with level {c} in "
                                          f"{code_col!r}, which is {levels[c - 1]:g} in the other rows; correct "
                                          "the level or the value")
                if any(lv is None for lv in levels):
                    levels = None
                    codes_c = None
                else:
                    levels = tuple(levels)
            if levels is None:  # the code column holds values: they must equal the value column
                diff = ~np.isclose(xc, xv, rtol=1e-9, atol=1e-12)
                if diff.any():
                    i = int(np.argmax(diff))
                    raise ConfigError(f"{sheet.where(i, code_col)}: {xc[i]:g} is neither a level number nor the value "
                                      f"{xv[i]:g} in {value_col!r}; correct one of them")
                levels = tuple(float(v) for v in np.unique(xv))
                codes_v = _codes_for(sheet, value_col, xv, levels, name, unit, False)
        elif xv is not None:
            levels = tuple(float(v) for v in np.unique(xv))
            codes_v = _codes_for(sheet, value_col, xv, levels, name, unit, False)
        else:
            integral = np.all(xc == np.round(xc))
            u = np.unique(xc)
            if integral and (u.min() in (0, 1)) and u.max() - u.min() == len(u) - 1 and not unit:
                codes_c = xc.astype(int) + (1 if u.min() == 0 else 0)  # level numbers; values not in the sheet
            else:
                levels = tuple(float(v) for v in u)
                codes_c = _codes_for(sheet, code_col, xc, levels, name, unit, False)
    if codes_c is not None and codes_v is not None and not np.array_equal(codes_c, codes_v):
        i = int(np.argmax(codes_c != codes_v))
        raise ConfigError(f"{sheet.where(i, code_col)}: level {codes_c[i]} disagrees with the value {xv[i]:g} in "
                          f"{value_col!r} (level {codes_v[i]}); correct one of them")
    codes = codes_c if codes_c is not None else codes_v
    values = None if levels is None else np.asarray(levels, float)[codes - 1]
    return codes, levels, values, unit


def _check_orphan_values(sheet: _Sheet, cols: list[str], names: set[str], reserved: set[str]) -> None:
    """Refuse a factor's value column (``A_mm``) whose ``A_level`` column is missing while other factors have
    theirs: the factor would otherwise be left out of the analysis without a word."""
    for c in cols:
        su = _split_unit(c) if c not in reserved and not c.endswith("_level") else None
        if su and su[0] not in names:
            raise ConfigError(f"{sheet.label}: column {c!r} holds the values of factor {su[0]!r}, but its "
                              f"{su[0] + '_level'!r} column is missing (the other factors have theirs); restore "
                              f"{su[0] + '_level'!r} from the plan, or rename {c!r} if it is not a factor")


def _find_factors(sheet: _Sheet, factors: list[Factor] | None, response_cols: set[str]):
    """(name, code column, value column, unit, given Factor) per factor, and the columns ignored."""
    cols = list(sheet.df.columns)
    reserved = (reserved_columns() | response_cols | ({block_column(sheet.df)} - {None})
                | {c for c in cols if is_bookkeeping(c)})
    meta = {c for c in cols if c.lower() in META_COLUMNS}
    found = []
    if factors is not None:
        for f in factors:
            code = f"{f.name}_level" if f"{f.name}_level" in cols else None
            value = f.column if f.column in cols else (f.name if f.name in cols else None)
            if code is None and value is None:
                raise ConfigError(f"{sheet.label}: factor {f.name!r} has neither a {f.name + '_level'!r} nor a "
                                  f"{f.column!r} column")
            found.append((f.name, code, value, f.unit, f))
    else:
        level_cols = [c for c in cols if c.endswith("_level") and len(c) > 6]
        if level_cols:
            for code in level_cols:
                name = code[:-6]
                cand = [c for c in cols if c != code and c not in meta and not c.endswith("_level")
                        and (c == name or (c.startswith(name + "_") and (_split_unit(c) or ("", ""))[0] == name))]
                if len(cand) > 1:
                    raise ConfigError(f"{sheet.label}: factor {name!r} has several value columns {cand}; keep one")
                value = cand[0] if cand else None
                unit = (sheet.header_units.get(value) if value in sheet.header_units else
                        (_split_unit(value) or (name, ""))[1] if value and value != name else "")
                found.append((name, code, value, unit, None))
            _check_orphan_values(sheet, cols, {f[0] for f in found}, reserved | meta)
        else:
            for c in cols:
                if c in reserved or c in meta:
                    continue
                cells = sheet.df[c].dropna()
                if len(sheet.df) >= 4 and cells.nunique() > len(sheet.df) / 2:
                    continue  # nearly every row differs: a measurement (a response not analysed), not a factor
                su = (c, sheet.header_units[c]) if c in sheet.header_units else _split_unit(c)
                name, unit = su if su else (c, "")
                found.append((name, None, c, unit, None))
            if not found:
                raise ConfigError(f"{sheet.label}: no factor columns found (<FACTOR>_level columns as written by "
                                  "`berryshaker doe plan`, or plain factor columns such as A, B or 'Speed (rpm)' "
                                  "holding level values)")
    names = [f[0] for f in found]
    if len(set(names)) != len(names):
        raise ConfigError(f"{sheet.label}: factor names {names} are not distinct")
    for name, code, value, unit, _ in found:
        for c in (name, value, code):
            if c is not None and c in reserved:
                raise ConfigError(f"{sheet.label}: factor {name!r} would take the column {c!r}, which is a response, "
                                  "raw-measurement or reserved column; rename the factor (e.g. "
                                  f"{name + '_x'!r}) in the sheet")
    used = {c for f in found for c in f[1:3] if c}
    ignored = [c for c in cols if c not in used and c not in reserved]
    return found, ignored
