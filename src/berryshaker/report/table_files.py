"""Table files: one writer puts a table on disk as CSV and, beside it, as an Excel workbook (.xlsx, openpyxl), so the
study's tables and those of ``doe analyze`` open in a spreadsheet with numbers as numbers.

Cells: booleans as yes/no, non-finite numbers as empty cells, numpy scalars as Python numbers, text (headers too)
neutralised against formula injection and with its control characters visible
(:func:`berryshaker.user_text.cell_text`: ``=HYPERLINK(...)`` from a sheet header is text, never a live formula);
the header row is bold and frozen in the workbook, every text cell stored as text.  The two files are written
together or not at all (:func:`berryshaker.outputs.write_files_atomic`).
"""

from __future__ import annotations

import csv
import io
import math
import re
from pathlib import Path
from typing import Iterable, Sequence

import numpy as np

from berryshaker.outputs import write_files_atomic
from berryshaker.user_text import cell_text, file_part


def table_cell(v) -> object:
    """A cell as written to both files: yes/no for booleans, None (empty) for NaN/inf, Python numbers for numpy's,
    text neutralised (:func:`berryshaker.user_text.cell_text`).

    Parameters
    ----------
    v : object
        A cell value (a number keeps its unit, the column's).

    Returns
    -------
    object
        The cell as written.
    """
    if isinstance(v, (bool, np.bool_)):
        return "yes" if v else "no"
    if isinstance(v, np.integer):
        return int(v)
    if isinstance(v, (float, np.floating)):
        v = float(v)
        return v if math.isfinite(v) else None
    if v is None or isinstance(v, int):
        return v
    return cell_text(str(v))


def csv_bytes(header: Sequence[str], rows: Iterable[Sequence], float_format: str | None = None) -> bytes:
    """The table as UTF-8 CSV with a header row (empty cell for None).

    Parameters
    ----------
    header : sequence of str
        Column names.
    rows : iterable of sequences
        One sequence per row (cells: :func:`table_cell`).
    float_format : str, optional
        Format of float cells, e.g. ``".9g"`` for a time series (default: Python's shortest exact form).

    Returns
    -------
    bytes
        The UTF-8 CSV.
    """
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow([cell_text(str(h)) for h in header])
    for r in rows:
        cells = (table_cell(v) for v in r)
        w.writerow(["" if c is None else format(c, float_format) if float_format and isinstance(c, float) else c
                    for c in cells])
    return buf.getvalue().encode("utf-8")


def xlsx_bytes(header: Sequence[str], rows: Iterable[Sequence], sheet: str = "table") -> bytes:
    """The table as an .xlsx workbook of one sheet (bold, frozen header; columns sized to their text).

    Parameters
    ----------
    header : sequence of str
        Column names.
    rows : iterable of sequences
        One sequence per row (cells: :func:`table_cell`).
    sheet : str
        Worksheet name (at most 31 characters are kept).

    Returns
    -------
    bytes
        The workbook.
    """
    from openpyxl import Workbook
    from openpyxl.styles import Font

    wb = Workbook()
    ws = wb.active
    ws.title = re.sub(r"[\\/?*\[\]:']", "_", sheet or "table")[:31] or "table"  # the characters Excel refuses
    ws.append([cell_text(str(h)) for h in header])
    for c in ws[1]:
        c.font = Font(bold=True)
        c.data_type = "s"  # text, never a formula
    widths = [len(str(h)) for h in header]
    for r in rows:
        cells = [table_cell(v) for v in r]
        ws.append(cells)
        for c in ws[ws.max_row]:
            if isinstance(c.value, str):
                c.data_type = "s"  # openpyxl would store a string starting with "=" as a formula
        for j, c in enumerate(cells[:len(widths)]):
            widths[j] = max(widths[j], len(f"{c:.6g}" if isinstance(c, float) else str(c if c is not None else "")))
    ws.freeze_panes = "A2"
    from openpyxl.utils import get_column_letter

    for j, w in enumerate(widths):
        ws.column_dimensions[get_column_letter(j + 1)].width = min(60, w + 2)
    buf = io.BytesIO()
    wb.save(buf)
    return buf.getvalue()


def write_table(path: str | Path, header: Sequence[str], rows: Iterable[Sequence], *,
                sheet: str | None = None) -> tuple[Path, Path]:
    """Write a table as ``<stem>.csv`` and ``<stem>.xlsx`` (same rows, same header), both or neither.

    Parameters
    ----------
    path : path
        The CSV file (``.csv``) or the stem; the workbook goes beside it with the suffix ``.xlsx``.
    header : sequence of str
        Column names (with units, e.g. ``"peak_N"`` or ``"efficiency (kg/min)"``).
    rows : iterable of sequences
        One sequence per row; see :func:`table_cell` for how cells are written.
    sheet : str, optional
        Worksheet name (default: the file stem, at most 31 characters).

    Returns
    -------
    (Path, Path)
        The CSV and the workbook written.
    """
    path = Path(path)
    csv_path = path if path.suffix.lower() == ".csv" else path.with_name(path.name + ".csv")
    xlsx_path = csv_path.with_suffix(".xlsx")
    rows = [list(r) for r in rows]
    write_files_atomic({csv_path: csv_bytes(header, rows), xlsx_path: xlsx_bytes(header, rows, sheet or csv_path.stem)})
    return csv_path, xlsx_path


def read_xlsx(path: str | Path) -> tuple[list[str], list[list]]:
    """Header and rows of the first sheet of a workbook written by :func:`write_table` (for checks and tests).

    Parameters
    ----------
    path : path
        The workbook.

    Returns
    -------
    (list of str, list of lists)
        Header and rows of its first sheet.
    """
    from openpyxl import load_workbook

    ws = load_workbook(path, read_only=True, data_only=True).active
    values = [list(r) for r in ws.iter_rows(values_only=True)]
    return [str(h) for h in values[0]], values[1:]


def doe_tables(res) -> dict[str, tuple[list[str], list[list]]]:
    """The tables of a ``doe analyze`` analysis (:func:`berryshaker.experiment.field_results.analyze_sheet`), as
    file stem -> (header, rows): per response its range analysis (``range_<response>``: level means k1..kn, range R,
    best level, ANOVA F and p, or "pooled"), and the weighted optimum (``optimum``: level per factor and the
    predicted responses with their units).

    Parameters
    ----------
    res : DoeAnalysis or SheetReplicatedAnalysis
        The analysis (:mod:`berryshaker.experiment.analysis_records`,
        :mod:`~berryshaker.experiment.replicated_records`).

    Returns
    -------
    dict
        File stem -> (header, rows).
    """
    out = {}
    units = res.response_units or {}
    for name, ra in res.responses.items():
        an = ra.anova.factors
        nlev = len(next(iter(ra.factors.values())).level_means)
        header = ["factor", *[f"k{j + 1}" + (f" ({units[name]})" if units.get(name) else "") for j in range(nlev)],
                  "R", "best level", "ANOVA F", "p"]
        rows = [[f, *d.level_means, d.range, d.best_level, an[f].f if f in an else "pooled",
                 an[f].p if f in an else None] for f, d in ra.factors.items()]
        out[f"range_{name}"] = (header, rows)
    o = res.optimum
    rows = [["level", f, n if n is not None else "no meaningful difference", o.settings.get(f)]
            for f, n in o.levels.items()]
    rows += [["predicted", r, v, units.get(r, "")] for r, v in o.values.items()]
    out["optimum"] = (["what", "factor or response", "level or value", "setting or unit"], rows)
    return out


def write_doe_tables(res, folder: str | Path) -> list[Path]:
    """Write :func:`doe_tables` into ``folder``, each as CSV and .xlsx (:func:`write_table`; a stem that is not a
    plain file name made one by :func:`berryshaker.user_text.file_part`); returns the files.

    Parameters
    ----------
    res : DoeAnalysis or SheetReplicatedAnalysis
        The analysis (:func:`doe_tables`).
    folder : path
        Where the files go.

    Returns
    -------
    list of Path
        The CSV and .xlsx files written.
    """
    files = []
    for stem, (header, rows) in doe_tables(res).items():  # a response's name is never a path (user_text.file_part)
        files += list(write_table(Path(folder) / f"{file_part(stem)}.csv", header, rows))
    return files


__all__ = ["csv_bytes", "doe_tables", "read_xlsx", "table_cell", "write_doe_tables", "write_table", "xlsx_bytes"]
