"""Reading a filled field sheet back, strictly (issue "never compute on a misread input").

Every cell that is used is parsed and checked, and anything that cannot be read unambiguously stops with a
:class:`ConfigError` naming the row (line of the file, header = line 1), the run and the column, and
saying how to fix it.  Level cells are matched by value or by level number whatever the coding; factor
columns may be the planner's ``<name>_level`` / ``<name>_<unit>`` pair or plain value columns as
statistics packages write them.

long module: every check of a filled sheet (cells, units, levels, replicates, the run plan) is one reader; split,
a check would sit away from the row and column bookkeeping its error messages need.
"""

from __future__ import annotations

import io
import re
from pathlib import Path

import numpy as np
import pandas as pd

from berryshaker.errors import ConfigError
from berryshaker.experiment.designs import is_orthogonal
from berryshaker.experiment.field_columns import (INDEX_COLUMNS, INDEX_NAMES, INDEX_UNITS, MAX_ROWS, META_COLUMNS,
                                                  RAW_COLUMNS,
                                                  Factor, FieldResults, compute_indexes, reserved_columns)
from berryshaker.units import unit_dimension, unit_factor

_MISSING = {"", "na", "n/a", "nan", "none", "-"}
_CELL = re.compile(r"^\s*([-+]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?)\s*([A-Za-z%µμ/^*·0-9_]*)\s*$")


class _Sheet:
    """The raw sheet (all cells as text) with the helpers that read cells and name them in errors."""

    def __init__(self, df: pd.DataFrame, decimal_comma: bool, sep: str):
        self.df = df
        self.decimal_comma = decimal_comma
        self.sep = sep
        self.run_label: list[str | None] = [None] * len(df)
        self.adopted_units: dict[str, str] = {}
        #: units read from the header ("Speed (rpm)", "Speed [r/min]") or a units row, per (bare) column name
        self.header_units: dict[str, str] = {}
        #: the header as written, per (bare) column name
        self.original: dict[str, str] = {c: c for c in df.columns}
        #: line of the file of data row 0 (header = line 1; a units row below it moves the data one line down)
        self.first_line = 2

    def line(self, i: int) -> int:
        """Line of the file of data row ``i`` (header = line 1)."""
        return i + self.first_line

    def row(self, i: int) -> str:
        """"results CSV row N (run R...)" of data row ``i``."""
        label = self.run_label[i] if i < len(self.run_label) else None
        return f"results CSV row {self.line(i)}" + (f" ({label})" if label else "")

    def where(self, i: int, col: str) -> str:
        return f"{self.row(i)}, column {self.original.get(col, col)!r}"

    def text(self, col: str) -> pd.Series:
        return self.df[col]

    def numbers(self, col: str, allow_unit: str | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Floats of a column (NaN where empty) and a mask of empty cells.

        ``allow_unit``: cells may carry a unit ("0.25 mm"), converted to this unit ('?': the first unit
        found in the column, kept in ``adopted_units``; None: no unit allowed).
        """
        s = self.df[col]
        empty = np.array(s.isna(), dtype=bool)
        t = s.fillna("")
        if self.decimal_comma:
            both = t.str.contains(",", regex=False) & t.str.contains(".", regex=False)
            if both.any():
                i = int(np.argmax(both.to_numpy()))
                raise ConfigError(f"{self.where(i, col)}: {s.iloc[i]!r} mixes '.' and ',' (thousands separator?); "
                                  "write the number without a thousands separator")
            t = t.str.replace(",", ".", regex=False)
        vals = np.array(pd.to_numeric(t.where(~empty, "nan"), errors="coerce"), dtype=float)
        bad = np.flatnonzero(np.isnan(vals) & ~empty)
        for i in bad:
            cell = str(s.iloc[i])
            tt = str(t.iloc[i])
            m = _CELL.match(tt)
            if m and m.group(2) and allow_unit is not None:
                if allow_unit == "?":  # unit not known yet: the first unit in the column is the unit
                    allow_unit = self.adopted_units.setdefault(col, m.group(2).strip())
                vals[i] = float(m.group(1)) * _unit_factor(m.group(2), allow_unit, self.where(i, col))
                continue
            if tt.strip().lower() in ("nan",):
                empty[i] = True
                continue
            hint = ""
            if "," in cell and not self.decimal_comma:
                hint = ("; decimal comma? this sheet is comma-separated, so write 3.9, or save it with ';' as the "
                        "separator (then decimal commas are read)")
            elif m and m.group(2):
                hint = "; units are not allowed in this column (its unit is in the header)"
            raise ConfigError(f"{self.where(i, col)}: {cell!r} is not a number{hint}")
        return vals, empty


def _unit_factor(unit: str, target: str, where: str) -> float:
    """Factor converting a value in ``unit`` to ``target`` (1 when they are the same)."""
    unit = unit.strip()
    if unit == target:
        return 1.0
    if not target:
        raise ConfigError(f"{where}: unit {unit!r} given, but the factor has no unit; write the plain number")
    return unit_factor(unit, target, where)


def _load_sheet(path_or_text) -> _Sheet:
    try:
        if isinstance(path_or_text, str) and "\n" in path_or_text:
            text = path_or_text
        else:
            text = Path(path_or_text).read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise ConfigError(f"results file not found: {path_or_text}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"cannot read the results file {path_or_text} ({exc}); save it as UTF-8 CSV") from None
    text = text.lstrip("\ufeff")
    header = next((ln for ln in text.splitlines() if ln.strip()), "")
    if not header:
        raise ConfigError("results CSV is empty; fill in the field sheet from `berryshaker doe plan`")
    counts = {s: header.count(s) for s in (",", ";", "\t")}
    sep = max(counts, key=counts.get)
    try:
        df = pd.read_csv(io.StringIO(text), sep=sep, dtype=str, keep_default_na=False, skipinitialspace=True,
                         skip_blank_lines=True)
    except Exception as exc:  # pandas parser errors
        raise ConfigError(f"cannot read the results CSV ({exc})") from None
    names = [str(h).strip() for h in next(iter(pd.read_csv(io.StringIO(header), sep=sep, header=None, dtype=str,
                                                           keep_default_na=False)
                                                .itertuples(index=False, name=None)))]
    if any(not h for h in names):
        raise ConfigError(f"results CSV: header column {names.index('') + 1} has no name; name every column "
                          "(as written by `berryshaker doe plan`)")
    dup = sorted({h for h in names if names.count(h) > 1})
    if dup:
        raise ConfigError(f"results CSV: column(s) {dup} appear more than once in the header; keep one of each")
    df.columns = [str(c).strip() for c in df.columns]
    if len(df) > MAX_ROWS:
        raise ConfigError(f"results CSV has {len(df)} rows, more than the {MAX_ROWS} a field sheet can have; "
                          "is this the right file?")
    for c in df.columns:
        s = df[c].astype(str).str.strip()
        df[c] = s.where(~s.str.lower().isin(_MISSING), None)
    df = df.dropna(how="all").reset_index(drop=True)
    units_row = _units_row(df)
    if units_row is not None:
        df = df.iloc[1:].reset_index(drop=True)
    bare, header_units, original = [], {}, {}
    for c in df.columns:
        name, unit = _header_unit(c)
        if units_row is not None and units_row.get(c) is not None:
            if unit is not None and _same_unit(unit, units_row[c]) is False:
                raise ConfigError(f"results CSV column {c!r}: the header says {unit!r}, the units row "
                                  f"{units_row[c]!r}; keep one unit")
            unit = units_row[c]
        if name in original:
            raise ConfigError(f"results CSV: columns {original[name]!r} and {c!r} both name {name!r}; keep one")
        original[name] = c
        bare.append(name)
        if unit is not None:
            header_units[name] = unit
    df.columns = bare
    sheet = _Sheet(df, decimal_comma=sep != ",", sep=sep)
    sheet.header_units, sheet.original = header_units, original
    sheet.first_line = 3 if units_row is not None else 2
    return sheet


#: Bookkeeping columns of statistics packages (Minitab: StdOrder, RunOrder, CenterPt, PtType, Blocks; JMP: Pattern;
#: Design-Expert: Std, Space Type): never a factor, never a response; compared without case, spaces or '_'.
BOOKKEEPING_COLUMNS = ("stdorder", "runorder", "centerpt", "pttype", "blocks", "block", "pattern", "std", "spacetype",
                       "standardorder")

_HEADER_UNIT = re.compile(r"^(.*?\S)\s*(?:\(([^()]*)\)|\[([^\[\]]*)\])\s*$")


def _unit_or_none(text: str) -> str | None:
    """The unit a header or units-row cell names ('' for dimensionless: '-', '1'), or None if it names none."""
    u = text.strip()
    if u in ("-", "1", "", "—"):
        return "" if u else None
    if u in ("%", "pct"):
        return "%"
    return u if unit_dimension(u) is not None else None


def _header_unit(col: str) -> tuple[str, str | None]:
    """``"Speed (rpm)"`` / ``"Speed [r/min]"`` -> ("Speed", unit); a header without a unit in brackets: (col, None).
    A bracket that names no unit ("Run (first)") stays part of the name."""
    m = _HEADER_UNIT.match(col)
    if not m:
        return col, None
    unit = _unit_or_none(m.group(2) if m.group(2) is not None else m.group(3))
    return (m.group(1).strip(), unit) if unit is not None else (col, None)


def _same_unit(a: str, b: str) -> bool:
    return a.strip() == b.strip()


def _units_row(df: pd.DataFrame) -> dict[str, str] | None:
    """A units row under the header (every filled cell of the first data row names a unit, at least two are not
    '-', no note column is filled), as column -> unit ('' dimensionless; None where the cell is empty); else None."""
    if len(df) < 2:
        return None
    first = df.iloc[0]
    filled = {c: str(v) for c, v in first.items() if not pd.isna(v) and str(v).strip()}
    if not filled:
        return None
    if any(str(c).lower() in META_COLUMNS for c in filled):  # a note is data, never a unit
        return None
    units = {c: _unit_or_none(v) for c, v in filled.items()}
    if any(u is None for u in units.values()) or sum(1 for u in units.values() if u) < 2:
        return None
    if any(_CELL.match(v) and not _CELL.match(v).group(2) for v in filled.values()):  # a bare number: data
        return None
    return {c: units.get(c) for c in df.columns}


def is_bookkeeping(col: str) -> bool:
    """True for a statistics package's bookkeeping column (:data:`BOOKKEEPING_COLUMNS`), e.g. Minitab's RunOrder.

    Parameters
    ----------
    col : str
        Column name (compared without case, spaces, '_' or '.').

    Returns
    -------
    bool
        Whether the column is bookkeeping (never a factor or a response).
    """
    return re.sub(r"[\s_.]", "", str(col)).lower() in BOOKKEEPING_COLUMNS


def _split_unit(col: str) -> tuple[str, str] | None:
    """``A_mm`` -> ('A', 'mm') if the part after the last '_' is a unit; None otherwise."""
    if "_" not in col:
        return None
    name, unit = col.rsplit("_", 1)
    if not name or not unit:
        return None
    if unit in ("%", "pct"):
        return name, "%"
    return (name, unit) if unit_dimension(unit) is not None else None


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
        raise ConfigError(f"results CSV column {col!r}: its cells read both as {' and as '.join(codings)} of "
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


def _check_orphan_values(cols: list[str], names: set[str], reserved: set[str]) -> None:
    """Refuse a factor's value column (``A_mm``) whose ``A_level`` column is missing while other factors have
    theirs: the factor would otherwise be left out of the analysis without a word."""
    for c in cols:
        su = _split_unit(c) if c not in reserved and not c.endswith("_level") else None
        if su and su[0] not in names:
            raise ConfigError(f"results CSV: column {c!r} holds the values of factor {su[0]!r}, but its "
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
                raise ConfigError(f"results CSV: factor {f.name!r} has neither a {f.name + '_level'!r} nor a "
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
                    raise ConfigError(f"results CSV: factor {name!r} has several value columns {cand}; keep one")
                value = cand[0] if cand else None
                unit = (sheet.header_units.get(value) if value in sheet.header_units else
                        (_split_unit(value) or (name, ""))[1] if value and value != name else "")
                found.append((name, code, value, unit, None))
            _check_orphan_values(cols, {f[0] for f in found}, reserved | meta)
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
                raise ConfigError("results CSV: no factor columns found (<FACTOR>_level columns as written by "
                                  "`berryshaker doe plan`, or plain factor columns such as A, B or 'Speed (rpm)' "
                                  "holding level values)")
    names = [f[0] for f in found]
    if len(set(names)) != len(names):
        raise ConfigError(f"results CSV: factor names {names} are not distinct")
    for name, code, value, unit, _ in found:
        for c in (name, value, code):
            if c is not None and c in reserved:
                raise ConfigError(f"results CSV: factor {name!r} would take the column {c!r}, which is a response, "
                                  "raw-measurement or reserved column; rename the factor (e.g. "
                                  f"{name + '_x'!r}) in the sheet")
    used = {c for f in found for c in f[1:3] if c}
    ignored = [c for c in cols if c not in used and c not in reserved]
    return found, ignored


def block_column(df: pd.DataFrame) -> str | None:
    """The column that numbers a run's repeats: ``block`` (or ``blocks``, any case: a field day, a row of bushes
    shared by every run) if the sheet has one, else ``replicate`` (`doe plan --replicates`), else None.

    Parameters
    ----------
    df : pandas.DataFrame
        The sheet.

    Returns
    -------
    str or None
        The column's name.
    """
    for c in df.columns:
        if str(c).strip().lower() in ("block", "blocks"):
            return c
    return "replicate" if "replicate" in df.columns else None


def _check_runs(sheet: _Sheet) -> tuple[np.ndarray, np.ndarray | None]:
    """Run numbers per row (1..n) and, if the sheet has a ``block`` or ``replicate`` column
    (:func:`block_column`), repeat numbers per row: every run then has the repeats 1..R once each, with the same R
    for every run (complete blocks, balanced)."""
    if "run" not in sheet.df.columns:
        raise ConfigError("results CSV: no 'run' column (the field sheet from `berryshaker doe plan` has one)")
    runs, empty = sheet.numbers("run")
    if empty.any():
        i = int(np.argmax(empty))
        raise ConfigError(f"results CSV row {sheet.line(i)}, column 'run': empty run number; fill it in")
    bad = ~np.isfinite(runs) | (runs != np.round(runs)) | (runs < 1)
    if bad.any():
        i = int(np.argmax(bad))
        raise ConfigError(f"results CSV row {sheet.line(i)}, column 'run': {sheet.df['run'].iloc[i]!r} is not a run "
                          "number (1, 2, 3, ...)")
    runs = runs.astype(np.int64)
    sheet.run_label = [f"run {r}" for r in runs]
    reps = None
    col = block_column(sheet.df)
    what = "block" if col != "replicate" else "replicate"
    if col is not None:
        reps, empty = sheet.numbers(col)
        bad = empty | ~np.isfinite(reps) | (reps != np.round(reps)) | (reps < 1)
        if bad.any():
            i = int(np.argmax(bad))
            raise ConfigError(f"results CSV row {sheet.line(i)} (run {runs[i]}), column {col!r}: "
                              f"{sheet.df[col].iloc[i]!r} is not a {what} number (1, 2, 3, ...); fill it in")
        reps = reps.astype(np.int64)
        if reps.max() > 1:
            sheet.run_label = [f"run {r}, {what} {k}" for r, k in zip(runs, reps)]
    _check_repeats(sheet, runs, reps, what)
    n = int(runs.max())
    present = set(runs.tolist())
    if len(present) != n:
        missing = sorted(set(range(1, n + 1)) - present)[:10]
        raise ConfigError(f"results CSV: runs must be numbered 1..{n} once each"
                          + (f"; missing run(s) {missing}" if missing else ""))
    return runs, reps


def _check_repeats(sheet: _Sheet, runs: np.ndarray, reps: np.ndarray | None, what: str) -> None:
    """Each run once (per repeat), and with repeats every run has the repeats 1..R once each, the same R for all."""
    key = runs if reps is None else runs * (int(reps.max()) + 1) + reps
    _, counts = np.unique(key, return_counts=True)
    if (counts > 1).any():
        dup = int(np.unique(key)[np.argmax(counts > 1)])
        rows = [sheet.line(int(i)) for i in np.flatnonzero(key == dup)]
        if reps is None:
            raise ConfigError(f"results CSV: run {dup} appears {len(rows)} times (rows {', '.join(map(str, rows))}); "
                              "keep one row per run, or number the repeats of a run in a 'replicate' column "
                              "(`doe plan --replicates`)")
        i = int(np.flatnonzero(key == dup)[0])
        raise ConfigError(f"results CSV: run {runs[i]} appears {len(rows)} times (rows {', '.join(map(str, rows))}) "
                          f"as {what} {reps[i]}; keep one row per run and {what}")
    if reps is not None:
        r = int(reps.max())
        for run in sorted(set(runs.tolist())):
            have = sorted(reps[runs == run].tolist())
            if have != list(range(1, r + 1)):
                missing = sorted(set(range(1, r + 1)) - set(have))
                raise ConfigError(f"results CSV: run {run} has {what}(s) {have}, other runs go up to {r}; every "
                                  f"run needs {what}s 1..{r} once each (missing {missing}) - fill in the missing "
                                  f"rows or delete the extra {what}s of the other runs")


def _settings_text(names: list[str], levels_row, level_values: dict, units: dict) -> str:
    """"A = 0.25 mm, B = 2" of one run's settings (level values where known, else level numbers)."""
    out = []
    for name, k in zip(names, levels_row):
        lv = level_values.get(name)
        out.append(f"{name} = {lv[int(k) - 1]:g}{(' ' + units[name]) if units.get(name) else ''}" if lv is not None
                   else f"{name} level {int(k)}")
    return ", ".join(out)


def _bookkeeping_column(sheet: _Sheet, *keys: str) -> str | None:
    """The first column whose normalised name is one of ``keys`` (e.g. "stdorder", "runorder")."""
    for key in keys:
        for c in sheet.df.columns:
            if re.sub(r"[\s_.]", "", str(c)).lower() == key:
                return c
    return None


def _runs_from_settings(sheet: _Sheet, levels: np.ndarray, names: list[str], level_values: dict,
                        units: dict) -> tuple[np.ndarray, np.ndarray | None, str]:
    """Run and repeat numbers per row of a sheet without a ``run`` column (Minitab's worksheet, a statistics
    package's export): a run is a distinct combination of factor levels, and rows with the same settings are its
    replicates.

    Runs are numbered in the design's standard order: by the smallest StdOrder (Minitab's standard order) of their
    rows where the sheet has that column, else by their levels (an orthogonal array's standard order).  Repeats
    are numbered by the block column where it holds more than one block (Minitab's Blocks: each run once per block),
    else in standard order (StdOrder), else in test order (RunOrder), else in the order of the rows; every run needs
    the same number of them.
    """
    keys = [tuple(int(v) for v in row) for row in levels]
    std = _bookkeeping_column(sheet, "stdorder", "standardorder", "std")
    test = _bookkeeping_column(sheet, "runorder")
    order_of = {}
    for name, col in (("std", std), ("test", test)):
        if col is None:
            continue
        v, empty = sheet.numbers(col)
        bad = empty | ~np.isfinite(v)
        if bad.any():
            i = int(np.argmax(bad))
            raise ConfigError(f"{sheet.where(i, col)}: empty or not a number; fill in the order (1, 2, 3, ...) or "
                              "delete the column")
        order_of[name] = v
    settings = sorted(set(keys))
    if "std" in order_of:
        first = {k: min(order_of["std"][i] for i, kk in enumerate(keys) if kk == k) for k in settings}
        settings.sort(key=lambda k: (first[k], k))
    run_of = {k: i + 1 for i, k in enumerate(settings)}
    runs = np.array([run_of[k] for k in keys], dtype=np.int64)
    sheet.run_label = [f"run {r}" for r in runs]
    counts = np.bincount(runs)[1:]
    blk = block_column(sheet.df)
    blocks = None
    if blk is not None:
        b, empty = sheet.numbers(blk)
        bad = empty | ~np.isfinite(b) | (b != np.round(b)) | (b < 1)
        if bad.any():
            i = int(np.argmax(bad))
            raise ConfigError(f"{sheet.where(i, blk)}: {sheet.df[blk].iloc[i]!r} is not a block number (1, 2, 3, "
                              "...); fill it in")
        if len(np.unique(b)) > 1:
            blocks = b.astype(np.int64)
    if blocks is not None:
        reps, how = blocks, f"factor settings; repeats numbered by the blocks in {sheet.original.get(blk, blk)!r}"
        what = "block"
    else:
        by = order_of.get("std", order_of.get("test"))
        col = std if "std" in order_of else test
        rank = np.arange(len(keys), dtype=float) if by is None else by
        reps = np.zeros(len(keys), dtype=np.int64)
        for run in range(1, len(settings) + 1):
            rows = np.flatnonzero(runs == run)
            reps[rows[np.argsort(rank[rows], kind="stable")]] = np.arange(1, len(rows) + 1)
        how = ("factor settings; repeats numbered in " + (f"the order of {sheet.original.get(col, col)!r}"
                                                          if col else "the order of the rows"))
        what = "replicate"
        if counts.max() != counts.min():
            few = int(np.argmin(counts)) + 1
            many = int(np.argmax(counts)) + 1
            i = int(np.flatnonzero(runs == few)[0])
            j = int(np.flatnonzero(runs == many)[0])
            raise ConfigError(
                f"results CSV: the settings {_settings_text(names, levels[i], level_values, units)} occur in "
                f"{counts[few - 1]} row(s), the settings {_settings_text(names, levels[j], level_values, units)} in "
                f"{counts[many - 1]}; rows with the same factor settings are replicates of one run, and every run "
                "needs the same number of them - add the missing replicates or delete the extra rows (a typo in a "
                "factor cell also makes a new setting)")
    if counts.max() == 1 and blocks is None:
        return runs, None, "factor settings (one row per run)"
    sheet.run_label = [f"run {r}, {what} {k}" for r, k in zip(runs, reps)]
    _check_repeats(sheet, runs, reps, what)
    return runs, reps, how


def _orthogonality_problem(levels: np.ndarray, names: list[str]) -> str:
    import itertools

    n = len(levels)
    for i, j in itertools.combinations(range(levels.shape[1]), 2):
        li, lj = np.unique(levels[:, i]), np.unique(levels[:, j])
        expected = n / (len(li) * len(lj))
        for x in li:
            for y in lj:
                c = int(np.sum((levels[:, i] == x) & (levels[:, j] == y)))
                if c != expected:
                    return (f"levels {names[i]}{x} with {names[j]}{y} occur {c} time(s), expected {expected:g}")
    return ""


def read_results(path_or_text, responses: list[str], factors: list[Factor] | None = None) -> FieldResults:
    """Read a filled field sheet; compute indexes from raw masses where the index cells are empty.

    Parameters
    ----------
    path_or_text : path or str
        CSV file (or its text).  Comma-, semicolon- or tab-separated; in semicolon- and tab-separated
        sheets a decimal comma is read as a decimal point (it cannot be a separator there); in
        comma-separated sheets a cell such as "3,9" is refused with a hint.
    responses : list of str
        ``efficiency``, ``unripe``, ``damage`` (from the index columns, or computed from the raw masses
        where those are empty) or the name of any other numeric column.
    factors : list of Factor, optional
        The plan's factors.  Without them the factors are found in the sheet: ``<name>_level`` columns
        (with an optional ``<name>_<unit>`` or ``<name>`` value column), or else every column that is not
        run, order, a response, a raw measurement, a note (``date``, ``operator``, ``weather``,
        ``notes``, ...) or a statistics package's bookkeeping (:data:`BOOKKEEPING_COLUMNS`) is a factor holding level
        values, as statistics packages write them; a column whose values differ in more than half the rows is a
        measurement (a response not analysed), not a factor.  Without a ``run`` column the runs are told apart by
        their factor settings (rows with the same settings are replicates).  Units come from the header
        ("Speed (rpm)", "Speed [r/min]", ``A_mm``) or a units row under it.

    Notes
    -----
    Level cells are matched by value or by level number, whatever the coding: 1/2/3, 0/1/2 or the level
    values themselves ("0.25" or "0.25 mm"); a coding that reads two ways is refused.  A value that
    matches no level is an error naming the row and column.  Checked as well: run numbers 1..n once
    each, levels forming an orthogonal (balanced) design, finite non-negative masses, duration > 0,
    unripe and damaged mass not above the picked mass, rates within 0-100 %, efficiency >= 0, a factor
    that would take a response column, an unknown response name, a header-only sheet.  Every error is a
    :class:`ConfigError` naming the row (line of the file; header = line 1), run and column.

    Returns
    -------
    FieldResults
        The sheet as read and checked.
    """
    sheet = _load_sheet(path_or_text)
    df = sheet.df
    if len(df) == 0:
        raise ConfigError("results CSV has a header but no rows; fill in the field sheet (one row per run)")
    has_run = "run" in df.columns
    runs = reps = None
    if has_run:
        runs, reps = _check_runs(sheet)
    resp_col = {r: _response_column(sheet, r) for r in responses}
    response_cols = set(resp_col.values()) | set(responses)
    found, ignored = _find_factors(sheet, factors, response_cols)
    # responses named like a factor column
    factor_cols = {c for f in found for c in (f[0], f[1], f[2]) if c}
    for r in responses:
        if r in factor_cols or resp_col[r] in factor_cols:
            raise ConfigError(f"response {r!r} is also a factor column of the sheet; analyse another column or "
                              "rename the factor")
    names, codes, level_values, units, values = [], [], {}, {}, []
    for name, code_col, value_col, unit, given in found:
        c, lv, v, unit = _resolve_factor(sheet, name, code_col, value_col, unit, given)
        names.append(name)
        codes.append(c)
        level_values[name] = lv
        units[name] = unit
        values.append(v if v is not None else c.astype(float))
    levels = np.column_stack(codes).astype(int)
    valuearr = np.column_stack(values).astype(float)
    how = "run column"
    if not has_run:
        runs, reps, how = _runs_from_settings(sheet, levels, names, level_values, units)
    r = 1 if reps is None else int(reps.max())
    order = np.lexsort((np.ones_like(runs) if reps is None else reps, runs))  # by run, then replicate
    levels, valuearr = levels[order], valuearr[order]
    if r > 1:  # the replicates of a run are the same design point
        lv3 = levels.reshape(-1, r, levels.shape[1])
        off = np.argwhere((lv3 != lv3[:, :1, :]).any(axis=2))
        if len(off):
            run_i, k = (int(v) for v in off[0])
            i = int(order[run_i * r + k])
            name = names[int(np.argmax(lv3[run_i, k] != lv3[run_i, 0]))]
            col = next(c for f in found if f[0] == name for c in (f[1], f[2]) if c)
            raise ConfigError(f"{sheet.where(i, col)}: the levels differ from replicate 1 of run {run_i + 1}; the "
                              "replicates of a run repeat the same settings - correct the level or the run number")
    if levels.shape[1] > 1 and not is_orthogonal(levels):
        raise ConfigError("results CSV: the factor level columns do not form an orthogonal (balanced) design ("
                          + _orthogonality_problem(levels, names) + "); was a row edited or a run duplicated?")
    out = {resp: _response(sheet, resp, factor_cols, resp_col[resp])[order] for resp in responses}
    # the table: sorted by run (and replicate), numbers where the sheet's cells are numbers, level numbers
    # normalised
    table = df.iloc[order].reset_index(drop=True).copy()
    for c in table.columns:
        if c.lower() in META_COLUMNS:
            continue
        conv = pd.to_numeric(table[c].str.replace(",", ".", regex=False) if sheet.decimal_comma else table[c],
                             errors="coerce")
        if (conv.notna() | table[c].isna()).all():
            table[c] = conv.astype(float)
    table["run"] = runs[order]
    level_cols = []
    for j, name in enumerate(names):
        col = f"{name}_level"
        table[col] = levels[:, j]
        level_cols.append(col)
        vcol = next((f[2] for f in found if f[0] == name), None)
        if level_values[name] is not None:
            if vcol is None or vcol == name:  # give the values a column ``<name>_<unit>`` / ``<name>_value``
                table[f"{name}_{units[name] or 'value'}"] = valuearr[:, j]
            else:
                table[vcol] = valuearr[:, j]
    if reps is not None:
        table["replicate"] = reps[order]
    per_run = slice(None, None, r)
    replicated = {k: v.reshape(-1, r) for k, v in out.items()} if reps is not None else None
    means = {k: v.mean(axis=1) for k, v in replicated.items()} if replicated is not None else out
    blk = block_column(df) if reps is not None else None
    if not has_run and reps is not None and not how.startswith("factor settings; repeats numbered by the blocks"):
        blk = None  # a constant Blocks column (Minitab's 1 everywhere) numbers no blocks
    return FieldResults(table, level_cols, names, means, levels[per_run], valuearr[per_run], level_values, units,
                        ignored, replicates=r, responses_replicated=replicated, block_column=blk,
                        response_units={resp: _response_unit(sheet, resp_col[resp]) for resp in responses},
                        runs_identified_by=how)


def _response_column(sheet: _Sheet, r: str) -> str:
    """The column of response ``r``: the index column of an index name (``efficiency`` -> efficiency_kg_min), the
    column of that name, else the one column named so without regard to case ("Efficiency (kg/min)" for
    ``efficiency``); the index column name when none is there (the index is then computed from raw masses)."""
    cols = list(sheet.df.columns)
    if r in INDEX_NAMES and INDEX_NAMES[r] in cols:
        return INDEX_NAMES[r]
    if r in cols:
        return r
    same = [c for c in cols if c.lower() == r.lower()]
    if len(same) == 1:
        return same[0]
    return INDEX_NAMES.get(r, r)


def _response_unit(sheet: _Sheet, col: str) -> str:
    """Unit of a response column: from the header or the units row, else the index column's, else a ``_unit``
    suffix; '' when none is given."""
    if col in sheet.header_units:
        return sheet.header_units[col]
    if col in INDEX_UNITS:
        return INDEX_UNITS[col]
    su = _split_unit(col) if col in sheet.df.columns else None
    return su[1] if su else ""


def _response(sheet: _Sheet, r: str, factor_cols: set[str] = frozenset(), col: str | None = None) -> np.ndarray:
    """Values of one response per row (file order), checked; indexes computed from raw masses where empty."""
    df = sheet.df
    blk = block_column(df)
    numeric_cols = [c for c in df.columns if c not in ("run", "replicate", "order", blk) and c.lower() not in META_COLUMNS
                    and c not in factor_cols and c not in RAW_COLUMNS and not is_bookkeeping(c)]
    col = col or _response_column(sheet, r)
    if r not in INDEX_NAMES and col not in df.columns:
        raise ConfigError(f"unknown response {r!r}; valid: {', '.join(INDEX_NAMES)} (indexes or raw masses) or a "
                          f"column of the sheet ({', '.join(c for c in numeric_cols if not c.endswith('_level'))})")
    n = len(df)
    if col in df.columns:
        vals, empty = sheet.numbers(col)
    else:
        vals, empty = np.full(n, np.nan), np.ones(n, bool)
    _check_range(sheet, col, vals, ~empty)
    if empty.any() and col in INDEX_COLUMNS:
        need = np.flatnonzero(empty)
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
        vals = np.where(empty, computed, vals)
    elif empty.any():
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




def analyze_sheet(path_or_text, senses: dict[str, bool], weights: dict[str, float] | None = None,
                  factors: list[Factor] | None = None) -> tuple[FieldResults, dict]:
    """Read a filled sheet (:func:`read_results`) and analyse it as ``doe analyze`` does.

    A sheet with repeats (a ``replicate`` or ``block`` column, or repeated factor settings) is analysed as
    randomised complete blocks (:func:`berryshaker.experiment.replicates.analyze_replicated`), one without by range
    analysis with the weakest factor pooled (:func:`berryshaker.experiment.analysis.analyze`).  The plan's format
    and a statistics package's worksheet of the same data give the same analysis.

    Parameters
    ----------
    path_or_text : path or str
        The sheet (CSV) or its text.
    senses : dict response -> bool
        True where larger is better; the keys are the responses analysed.
    weights : dict response -> float, optional
        Weights of the composite score (1; default equal).
    factors : list of Factor, optional
        The plan's factors (default: found in the sheet).

    Returns
    -------
    (FieldResults, dict)
        The sheet as read, and the analysis with ``replicates``, ``weights_given``, ``response_units`` (unit per
        response, '' where the sheet gives none), ``block_column`` (replicated) and ``runs_identified_by``.
    """
    from berryshaker.experiment.analysis import analyze
    from berryshaker.experiment.replicates import analyze_replicated, describe_replicated

    fr = read_results(path_or_text, list(senses), factors)
    if fr.replicates >= 2:
        res = analyze_replicated(fr.levels, fr.values, fr.factor_names, fr.responses_replicated, senses, weights,
                                 level_values=fr.level_values, units=fr.units, blocks=True)
        res["block_column"] = fr.block_column
        res["text"] = describe_replicated(res)
    else:
        res = analyze(fr.levels, fr.values, fr.factor_names, fr.responses, senses, weights,
                      level_values=fr.level_values, units=fr.units)
    res["replicates"] = fr.replicates
    res["weights_given"] = weights is not None
    res["response_units"] = dict(fr.response_units)
    res["runs_identified_by"] = fr.runs_identified_by
    return fr, res


__all__ = ["BOOKKEEPING_COLUMNS", "analyze_sheet", "is_bookkeeping", "read_results"]
