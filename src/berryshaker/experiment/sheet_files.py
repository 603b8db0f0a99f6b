"""A field sheet's file as :func:`berryshaker.experiment.field_cells.sheet_table` reads it: the one check of the file
(a regular file of bounded size, opened without blocking, so a FIFO or a device is refused instead of hanging or
filling the memory) and an Excel workbook's cells as text (.xlsx through openpyxl, formulas never evaluated).

A workbook's cells are written as the text a CSV would hold, so one strict parser reads both
(:class:`berryshaker.experiment.field_cells._Sheet`): numbers in their shortest exact form (``repr``), text as
typed.  What a CSV cannot hold is refused or marked: a formula (``=B2/60``) or an error value (``#DIV/0!``) is an
error naming the cell, since berryshaker evaluates no formula and a cached result may be stale; a date, a time
or a boolean is kept as text and marked, so that a column where a number belongs refuses it naming the cell
(Excel turns "3.5" into 3 May in some locales).  Legacy .xls workbooks are refused with the fix (their reader,
xlrd, gives formulas' cached values, which could not be told from typed numbers).
"""

from __future__ import annotations

import datetime as _dt
import io
import zipfile
from dataclasses import dataclass, field

from berryshaker.errors import ConfigError
from berryshaker.input_files import read_input_file

#: largest sheet file read (bytes): a field sheet of MAX_ROWS rows fits; the limit guards against a wrong file
MAX_SHEET_BYTES = 100 * 2**20
#: largest uncompressed content of a workbook (bytes): a zip bomb is refused before openpyxl unpacks it
MAX_WORKBOOK_BYTES = 400 * 2**20
#: widest sheet read (columns; Excel's own limit)
MAX_COLUMNS = 16384

_ZIP = b"PK\x03\x04"
_OLE2 = b"\xd0\xcf\x11\xe0\xa1\xb1\x1a\xe1"  # the compound file of a legacy .xls workbook


def read_sheet_bytes(path, what: str = "results file", limit: int = MAX_SHEET_BYTES) -> bytes:
    """The bytes of a sheet file, read only if it is a regular file of at most ``limit`` bytes, through the one
    reader of the user's files (:func:`berryshaker.input_files.read_input_file`: opened without blocking and checked
    on the open descriptor, so a FIFO, a device such as ``/dev/zero`` or a folder is refused at once, and a file that
    grows while it is read is refused too).

    Parameters
    ----------
    path : str or Path
        The file.
    what : str
        What the file is, for the messages ("results file").
    limit : int
        Largest size accepted (bytes).

    Returns
    -------
    bytes
        The file's content.

    Raises
    ------
    ConfigError
        The file is missing, unreadable, not a regular file or larger than ``limit``.
    """
    return read_input_file(path, what, limit, fix="give the sheet's file (.csv or .xlsx)")


def sheet_kind(data: bytes) -> str:
    """What a sheet file holds, by its first bytes: ``"xlsx"`` (a zip: an Office Open XML workbook), ``"xls"`` (a
    legacy compound file) or ``"text"`` (a CSV).

    Parameters
    ----------
    data : bytes
        The file's content.

    Returns
    -------
    str
        The kind.
    """
    if data.startswith(_ZIP):
        return "xlsx"
    if data.startswith(_OLE2):
        return "xls"
    return "text"


@dataclass
class WorkbookSheet:
    """One worksheet's cells as text, as a CSV would hold them.

    Attributes
    ----------
    name : str
        The worksheet's name.
    header : list of str
        The first non-empty row (the column names).
    rows : list of list of str or None
        The rows below it (None: an empty cell), as wide as the header.
    lines : list of int
        The worksheet row number of each of ``rows`` (1-based, as Excel numbers them).
    header_line : int
        The worksheet row of the header.
    marked : dict of (int, int) to str
        (index in ``rows``, column index) -> "date", "time" or "boolean": cells that are text here but were not
        typed as text or numbers (refused where a number belongs).
    """

    name: str
    header: list[str]
    rows: list[list[str | None]]
    lines: list[int]
    header_line: int
    marked: dict = field(default_factory=dict)


def _column_letter(j: int) -> str:
    from openpyxl.utils import get_column_letter

    return get_column_letter(j + 1)


def cell_name(sheet: str, line: int, j: int) -> str:
    """``'Sheet1'!C5``: a worksheet cell as a spreadsheet names it.

    Parameters
    ----------
    sheet : str
        Worksheet name.
    line : int
        Row number (1-based).
    j : int
        Column index (0-based).

    Returns
    -------
    str
        The cell's name.
    """
    return f"{sheet!r}!{_column_letter(j)}{line}"


def _text_of(value) -> tuple[str | None, str | None]:
    """A cell value as CSV text and its mark (None, or "date" / "time" / "boolean")."""
    if value is None:
        return None, None
    if isinstance(value, bool):
        return ("TRUE" if value else "FALSE"), "boolean"
    if isinstance(value, int):
        return str(value), None
    if isinstance(value, float):
        return repr(value), None
    if isinstance(value, (_dt.datetime, _dt.date)):
        return value.isoformat(), "date"
    if isinstance(value, (_dt.time, _dt.timedelta)):
        return str(value), "time"
    return str(value), None


def _check_zip(data: bytes, source: str) -> None:
    try:
        with zipfile.ZipFile(io.BytesIO(data)) as z:
            total = sum(i.file_size for i in z.infolist())
    except zipfile.BadZipFile:
        raise ConfigError(f"{source} starts like a workbook (.xlsx) but is not a readable one; save it again as "
                          ".xlsx or as CSV") from None
    if total > MAX_WORKBOOK_BYTES:
        raise ConfigError(f"{source}: the workbook unpacks to {total:,} bytes, more than the {MAX_WORKBOOK_BYTES:,} "
                          "a field sheet can have; save the sheet alone (or as CSV)")


def read_workbook(data: bytes, sheet: str | None, source: str, max_rows: int) -> WorkbookSheet:
    """A worksheet of an .xlsx workbook as text cells (openpyxl, read-only, formulas kept as written).

    Parameters
    ----------
    data : bytes
        The workbook file's content.
    sheet : str or None
        The worksheet's name (None: the first).
    source : str
        The file's name, for messages.
    max_rows : int
        Most data rows read (more is an error).

    Returns
    -------
    WorkbookSheet
        The header, rows and marked cells.

    Raises
    ------
    ConfigError
        Not a workbook, no such worksheet (the names are listed), an empty worksheet, a formula or an error value
        in a cell (named), too many rows or columns.
    """
    import warnings

    from openpyxl import load_workbook

    _check_zip(data, source)
    try:
        with warnings.catch_warnings():  # openpyxl warns about unsupported extensions (data validation, styles)
            warnings.simplefilter("ignore")
            wb = load_workbook(io.BytesIO(data), read_only=True, data_only=False)
    except Exception as exc:  # openpyxl raises many types for a damaged or foreign zip (KeyError, InvalidFile...)
        raise ConfigError(f"{source} is not a readable .xlsx workbook ({type(exc).__name__}); save it again as "
                          ".xlsx or as CSV") from None
    try:
        names = list(wb.sheetnames)
        if sheet is None:
            if not names:
                raise ConfigError(f"{source}: the workbook has no worksheet")
            name = names[0]
        elif sheet not in names:
            raise ConfigError(f"{source}: no worksheet {sheet!r}; the workbook has {', '.join(map(repr, names))} "
                              "(--sheet NAME, as spelled on the tab)")
        else:
            name = sheet
        ws = wb[name]
        if not hasattr(ws, "iter_rows") or ws.__class__.__name__ == "ReadOnlyChartsheet":
            raise ConfigError(f"{source}: {name!r} is a chart sheet, not a worksheet; give the sheet with the table")
        if hasattr(ws, "reset_dimensions"):
            ws.reset_dimensions()  # the stored dimension may be wrong: read every row there is
        return _worksheet_cells(ws, name, source, max_rows)
    finally:
        wb.close()


def _worksheet_cells(ws, name: str, source: str, max_rows: int) -> WorkbookSheet:
    header: list | None = None
    header_line = 0
    rows: list[list] = []
    lines: list[int] = []
    marked: dict = {}
    for line, cells in enumerate(ws.iter_rows(), start=1):
        if len(cells) > MAX_COLUMNS:
            raise ConfigError(f"{source}: worksheet {name!r} row {line} has {len(cells):,} columns, more than "
                              f"{MAX_COLUMNS:,}")
        texts, marks = [], {}
        for j, c in enumerate(cells):
            kind = getattr(c, "data_type", None)
            value = getattr(c, "value", None)
            if kind == "f" or (isinstance(value, str) and kind != "s" and value.startswith("=")) \
                    or type(value).__name__ in ("ArrayFormula", "DataTableFormula"):
                shown = value if isinstance(value, str) else getattr(value, "text", "a formula")
                raise ConfigError(f"{source}: cell {cell_name(name, line, j)} holds a formula ({str(shown)[:60]!r}); "
                                  "berryshaker evaluates no formula: paste the values instead (Paste Special > "
                                  "Values) or save the sheet as CSV")
            if kind == "e":
                raise ConfigError(f"{source}: cell {cell_name(name, line, j)} holds the spreadsheet error "
                                  f"{str(value)!r}; fill in the value or leave the cell empty")
            text, mark = _text_of(value)
            if isinstance(text, str) and not text.strip():
                text = None
            texts.append(text)
            if mark and text is not None:
                marks[j] = mark
        if header is None:
            if any(t is not None for t in texts):
                header, header_line = texts, line
            continue
        if not any(t is not None for t in texts):
            continue  # an empty row (a CSV's blank line)
        if len(rows) >= max_rows:
            raise ConfigError(f"{source}: worksheet {name!r} has more than {max_rows:,} rows, more than a field sheet "
                              "can have; is this the right sheet?")
        for j, mark in marks.items():
            marked[(len(rows), j)] = mark
        rows.append(texts)
        lines.append(line)
    if header is None:
        raise ConfigError(f"{source}: worksheet {name!r} is empty; fill in the field sheet from `berryshaker doe plan`")
    width = max([len(header)] + [len(r) for r in rows])
    # columns without a header and without a cell (formatting beyond the table) are not part of it
    used = [j for j in range(width) if (j < len(header) and header[j] is not None)
            or any(j < len(r) and r[j] is not None for r in rows)]
    last = max(used) + 1 if used else 0
    header = [("" if h is None else h) for h in (header + [None] * width)[:last]]
    rows = [(r + [None] * width)[:last] for r in rows]
    return WorkbookSheet(name, header, rows, lines, header_line, marked)


__all__ = ["MAX_COLUMNS", "MAX_SHEET_BYTES", "MAX_WORKBOOK_BYTES", "WorkbookSheet", "cell_name", "read_sheet_bytes",
           "read_workbook", "sheet_kind"]
