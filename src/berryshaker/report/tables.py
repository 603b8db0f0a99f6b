"""The one table writer: CSV files (atomic, UTF-8, a header row) and the same rows as a rich table for the
terminal, so every command and the study write tables the same way."""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path
from typing import Iterable, Sequence


def _cell(v) -> object:
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float) and not math.isfinite(v):
        return ""
    return v


def csv_text(header: Sequence[str], rows: Iterable[Sequence]) -> str:
    """CSV text with a header row; booleans as yes/no, non-finite numbers as empty cells."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(header)
    for r in rows:
        w.writerow([_cell(v) for v in r])
    return buf.getvalue()


def write_csv(path: str | Path, header: Sequence[str], rows: Iterable[Sequence]) -> None:
    """Write a CSV table atomically (see :func:`csv_text`)."""
    from berryshaker.outputs import write_text_atomic

    write_text_atomic(path, csv_text(header, list(rows)))


def rich_table(header: Sequence[str], rows: Iterable[Sequence], title: str | None = None, digits: int = 4):
    """The same rows as a :class:`rich.table.Table` for the terminal (numbers to ``digits`` significant
    digits, columns never truncated: long headers wrap)."""
    from rich.markup import escape
    from rich.table import Table

    # cells and headers are data, not markup: "[study]" or "[0.1, 0.2]" must print as written
    tb = Table(title=escape(title) if title else None, header_style="bold")
    for i, h in enumerate(header):
        tb.add_column(escape(str(h)), justify="left" if i == 0 else "right", overflow="fold")
    for r in rows:
        cells = []
        for v in r:
            v = _cell(v)
            cells.append(f"{v:.{digits}g}" if isinstance(v, float) else escape(str(v)))
        tb.add_row(*cells)
    return tb
