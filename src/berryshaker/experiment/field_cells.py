"""A filled field sheet as text (:func:`berryshaker.experiment.field_results.read_results`): the CSV loaded
(separator, decimal comma, empty cells, a header unit "Speed (rpm)" / "Speed [r/min]" or a units row under the
header) and its cells read strictly as numbers, each error naming the row (line of the file, header = line 1), the
run and the column; what a column's name says (a statistics package's bookkeeping, a ``<name>_<unit>`` value
column, the block column).
"""

from __future__ import annotations

import io
import re

import numpy as np
import pandas as pd

from berryshaker.errors import ConfigError
from berryshaker.experiment.field_columns import MAX_ROWS, META_COLUMNS
from berryshaker.units import unit_dimension, unit_factor
from berryshaker.user_text import check_user_text

_MISSING = {"", "na", "n/a", "nan", "none", "-"}
_CELL = re.compile(r"^\s*([-+]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?)\s*([A-Za-z%µμ/^*·0-9_]*)\s*$")


class _Sheet:
    """The raw sheet (all cells as text) with the helpers that read cells and name them in errors."""

    def __init__(self, df: pd.DataFrame, decimal_comma: bool, sep: str, label: str = "results CSV"):
        self.df = df
        self.decimal_comma = decimal_comma
        self.sep = sep
        #: how messages name the sheet: "results CSV", or "results sheet 'Plots'" of a workbook
        self.label = label
        self.run_label: list[str | None] = [None] * len(df)
        self.adopted_units: dict[str, str] = {}
        #: units read from the header ("Speed (rpm)", "Speed [r/min]") or a units row, per (bare) column name
        self.header_units: dict[str, str] = {}
        #: the header as written, per (bare) column name
        self.original: dict[str, str] = {c: c for c in df.columns}
        #: line of the file of data row 0 (header = line 1; a units row below it moves the data one line down)
        self.first_line = 2
        #: a workbook's row number of each data row (None for a CSV: ``first_line`` + row)
        self.lines: list[int] | None = None
        #: a workbook's worksheet name and column index per (bare) column name, for cell names ('Plots'!C5)
        self.worksheet: str | None = None
        self.column_index: dict[str, int] = {}
        #: a workbook's cells that were dates, times or booleans there ("date", ...; None elsewhere), like ``df``
        self.marks: pd.DataFrame | None = None

    def line(self, i: int) -> int:
        """Line of the file (a workbook's row number) of data row ``i`` (header = line 1 in a CSV)."""
        if self.lines is not None and 0 <= i < len(self.lines):
            return self.lines[i]
        return i + self.first_line

    def row(self, i: int) -> str:
        """"results CSV row N (run R...)" of data row ``i``."""
        label = self.run_label[i] if i < len(self.run_label) else None
        return f"{self.label} row {self.line(i)}" + (f" ({label})" if label else "")

    def where(self, i: int, col: str) -> str:
        """"results CSV row N (run R), column 'X'" (a workbook's cell name after it) of data row ``i``."""
        text = f"{self.row(i)}, column {self.original.get(col, col)!r}"
        if self.worksheet is not None and col in self.column_index:
            from berryshaker.experiment.sheet_files import cell_name

            text += f" (cell {cell_name(self.worksheet, self.line(i), self.column_index[col])})"
        return text

    def text(self, col: str) -> pd.Series:
        return self.df[col]

    def numbers(self, col: str, allow_unit: str | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Floats of a column (NaN where empty) and a mask of empty cells.

        ``allow_unit``: cells may carry a unit ("0.25 mm"), converted to this unit ('?': the first unit
        found in the column, kept in ``adopted_units``; None: no unit allowed).
        """
        s = self.df[col]
        empty = np.array(s.isna(), dtype=bool)
        if self.marks is not None and col in self.marks.columns:
            marked = np.flatnonzero(self.marks[col].notna().to_numpy() & ~empty)
            if len(marked):
                i = int(marked[0])
                kind = self.marks[col].iloc[i]
                raise ConfigError(f"{self.where(i, col)}: {s.iloc[i]!r} is a {kind} in the workbook where a number "
                                  "belongs (a spreadsheet can turn '3.5' into a date); format the column as a number "
                                  "and type the value again")
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
            if "," in cell and self.worksheet is not None:
                hint = "; decimal comma? type the number as a number in the workbook (3.9)"
            elif "," in cell and not self.decimal_comma:
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


def sheet_table(path_or_text, sheet: str | None = None) -> pd.DataFrame:
    """A results sheet's cells as text, read as ``doe analyze`` reads it: a CSV (UTF-8 with or without a byte-order
    mark, the separator of its header: comma, semicolon or tab; empty lines skipped) or a worksheet of an .xlsx
    workbook (:mod:`berryshaker.experiment.sheet_files`: formulas refused, never evaluated).

    Parameters
    ----------
    path_or_text : str or Path
        The CSV or .xlsx file, or a CSV's text (a string with a line break).
    sheet : str, optional
        The worksheet of a workbook (default its first); refused for a CSV.

    Returns
    -------
    pandas.DataFrame
        Every cell as a string, columns as in the header.

    Raises
    ------
    ConfigError
        The file is missing, unreadable, not a regular file, too large, empty or not a table.
    """
    return _load_sheet(path_or_text, sheet).df


def _load_sheet(path_or_text, sheet: str | None = None) -> _Sheet:
    from berryshaker.experiment.sheet_files import read_sheet_bytes, read_workbook, sheet_kind

    if isinstance(path_or_text, str) and "\n" in path_or_text:
        if sheet is not None:
            raise ConfigError(f"--sheet {sheet!r} names a worksheet of a workbook; the results are CSV text")
        return _csv_sheet(path_or_text)
    data = read_sheet_bytes(path_or_text)  # the one check of the file: regular, bounded, opened without blocking
    kind = sheet_kind(data)
    if kind == "xls":
        raise ConfigError(f"{path_or_text} is a legacy Excel workbook (.xls); save it as .xlsx (Excel Workbook) or as "
                          "CSV UTF-8 and analyse that")
    if kind == "xlsx":
        wb = read_workbook(data, sheet, str(path_or_text), MAX_ROWS)
        return _workbook_sheet(wb)
    if sheet is not None:
        raise ConfigError(f"--sheet {sheet!r} names a worksheet of a workbook; {path_or_text} is a CSV (leave --sheet "
                          "out)")
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise ConfigError(f"cannot read the results file {path_or_text} ({exc}); save it as UTF-8 CSV or as .xlsx") \
            from None
    return _csv_sheet(text)


def _csv_sheet(text: str) -> _Sheet:
    text = text.lstrip("\ufeff")
    header = next((ln for ln in text.splitlines() if ln.strip()), "")
    if not header:
        raise ConfigError("results CSV is empty; fill in the field sheet from `berryshaker doe plan`")
    counts = {s: header.count(s) for s in (",", ";", "\t")}
    sep = max(counts, key=lambda s: counts[s])
    try:
        df = pd.read_csv(io.StringIO(text), sep=sep, dtype=str, keep_default_na=False, skipinitialspace=True,
                         skip_blank_lines=True)
    except Exception as exc:  # pandas parser errors
        raise ConfigError(f"cannot read the results CSV ({exc})") from None
    names = [str(h).strip() for h in next(iter(pd.read_csv(io.StringIO(header), sep=sep, header=None, dtype=str,
                                                           keep_default_na=False)
                                                .itertuples(index=False, name=None)))]
    return _table_sheet(df, names, "results CSV", sep)


def _workbook_sheet(wb) -> _Sheet:
    """The :class:`_Sheet` of a worksheet read by :func:`berryshaker.experiment.sheet_files.read_workbook`."""
    names = [str(h).strip() for h in wb.header]
    df = pd.DataFrame(wb.rows, columns=[f"#{j}" for j in range(len(names))], dtype=object) if wb.rows else \
        pd.DataFrame({f"#{j}": pd.Series([], dtype=object) for j in range(len(names))})
    marks = pd.DataFrame(None, index=df.index, columns=df.columns, dtype=object)
    for (i, j), kind in wb.marked.items():
        marks.iat[i, j] = kind
    df.columns = names
    marks.columns = names
    return _table_sheet(df, names, f"results sheet {wb.name!r}", ",", lines=list(wb.lines), marks=marks,
                        worksheet=wb.name)


def _table_sheet(df: pd.DataFrame, names: list[str], label: str, sep: str, *, lines: list[int] | None = None,
                 marks: pd.DataFrame | None = None, worksheet: str | None = None) -> _Sheet:
    """The cells of a CSV or a worksheet (text, header ``names``) checked and normalised into a :class:`_Sheet`:
    every column named once, empty cells None, empty rows dropped, a units row and header units read."""
    for i, h in enumerate(names, 1):  # a header is a name: bounded, no control characters (they reach terminals)
        check_user_text(h, f"{label} header, column {i}")
    if any(not h for h in names):
        raise ConfigError(f"{label}: header column {names.index('') + 1} has no name; name every column "
                          "(as written by `berryshaker doe plan`)")
    dup = sorted({h for h in names if names.count(h) > 1})
    if dup:
        raise ConfigError(f"{label}: column(s) {dup} appear more than once in the header; keep one of each")
    df.columns = [str(c).strip() for c in df.columns]
    if len(df) > MAX_ROWS:
        raise ConfigError(f"{label} has {len(df)} rows, more than the {MAX_ROWS} a field sheet can have; "
                          "is this the right file?")
    for c in df.columns:
        s = df[c].astype(str).str.strip()
        df[c] = s.where(~s.str.lower().isin(_MISSING) & df[c].notna(), None)
    keep = df.notna().any(axis=1).to_numpy()
    df = df[keep].reset_index(drop=True)
    if lines is not None:
        lines = [ln for ln, k in zip(lines, keep) if k]
    if marks is not None:
        marks = marks[keep].reset_index(drop=True)
    units_row = _units_row(df)
    if units_row is not None:
        df = df.iloc[1:].reset_index(drop=True)
        if lines is not None:
            lines = lines[1:]
        if marks is not None:
            marks = marks.iloc[1:].reset_index(drop=True)
    bare: list[str] = []
    header_units: dict = {}
    original: dict = {}
    for c in df.columns:
        name, unit = _header_unit(c)
        if units_row is not None and units_row.get(c) is not None:
            if unit is not None and _same_unit(unit, units_row[c]) is False:
                raise ConfigError(f"{label} column {c!r}: the header says {unit!r}, the units row "
                                  f"{units_row[c]!r}; keep one unit")
            unit = units_row[c]
        if name in original:
            raise ConfigError(f"{label}: columns {original[name]!r} and {c!r} both name {name!r}; keep one")
        original[name] = c
        bare.append(name)
        if unit is not None:
            header_units[name] = unit
    df.columns = bare
    sheet = _Sheet(df, decimal_comma=sep != ",", sep=sep, label=label)
    sheet.header_units, sheet.original = header_units, original
    sheet.first_line = 3 if units_row is not None else 2
    sheet.lines = lines
    if marks is not None:
        marks.columns = bare
        sheet.marks = marks
    if worksheet is not None:
        sheet.worksheet = worksheet
        sheet.column_index = {name: j for j, name in enumerate(bare)}
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
    if any((m := _CELL.match(v)) and not m.group(2) for v in filled.values()):  # a bare number: data
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
