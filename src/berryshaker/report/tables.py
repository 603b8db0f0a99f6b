"""The one table writer: CSV files (atomic, UTF-8, a header row; cells as :mod:`berryshaker.report.table_files`
writes them) and the same rows as a rich table for the terminal, so every command and the study write tables the
same way."""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Iterable, Sequence

from berryshaker.user_text import visible


def _cell(v) -> object:
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float) and not math.isfinite(v):
        return ""
    return v


def csv_text(header: Sequence[str], rows: Iterable[Sequence], float_format: str | None = None) -> str:
    """CSV text with a header row, as the table files write it (:func:`berryshaker.report.table_files.csv_bytes`):
    booleans as yes/no, non-finite numbers as empty cells, text neutralised against formula injection.

    Parameters
    ----------
    header : sequence of str
        Column headers, written as the first row.
    rows : iterable of sequences
        One sequence of cells per row (:func:`berryshaker.report.table_files.table_cell`).
    float_format : str, optional
        Format of float cells, e.g. ``".9g"`` (default: Python's shortest exact form).

    Returns
    -------
    str
        The CSV text, ``\\n`` line endings, a header row first.
    """
    from berryshaker.report.table_files import csv_bytes

    return csv_bytes(header, rows, float_format).decode("utf-8")


def write_csv(path: str | Path, header: Sequence[str], rows: Iterable[Sequence]) -> None:
    """Write a CSV table atomically (see :func:`csv_text`).

    Parameters
    ----------
    path : str or Path
        File to write (replaced atomically).
    header : sequence of str
        Column headers, written as the first row.
    rows : iterable of sequences
        One sequence of cells per row (see :func:`csv_text`).
    """
    from berryshaker.outputs import write_text_atomic

    write_text_atomic(path, csv_text(header, list(rows)))


_SEGMENT = re.compile(r"[^._/]*[._/]+|[^._/]+")
#: a hyphen between letters ("steel-on-bronze"), or a dot or underscore before a letter
#: ("plant.contact.finger"); never inside a number ("0.25", "-1.5e-05")
_CELL_SEGMENT = re.compile(r".*?(?:[A-Za-z]-|[A-Za-z0-9)\]][._])(?=[A-Za-z])|.+")


#: signs that bind the numbers on either side into one unit: "12.5 ± 1.3" never ends a line at the sign
_BINDING = ("±", "+-")


def _words(line: str) -> list[str]:
    """The words of a line, a "±" (or "+-") joined with its neighbours into one word: "12.5 ± 1.3"."""
    out: list[str] = []
    glue_next = False
    for w in line.split():
        if out and (w in _BINDING or glue_next):
            out[-1] += " " + w
        else:
            out.append(w)
        glue_next = w in _BINDING
    return out


def _header_segments(word: str) -> list[str]:
    """Pieces of one header word that may end a line: after a dot, an underscore or a slash."""
    return _SEGMENT.findall(word) or [word]


def _cell_segments(word: str) -> list[str]:
    """Pieces of one cell word that may end a line: after a hyphen between letters, or a dot or underscore
    before a letter (numbers stay whole; a "mean ± SD" word is never cut)."""
    if " " in word:
        return [word]
    return _CELL_SEGMENT.findall(word) or [word]


def _wrap_header(header: str, width: int, segments=_header_segments) -> str:
    """``header`` on lines of at most ``width`` cells, broken only at spaces and after the pieces of
    ``segments`` (dots, underscores and slashes for a header; explicit newlines kept); a single piece longer than
    ``width`` stays whole on its own line."""
    from rich.cells import cell_len

    out = []
    for line in header.split("\n"):
        cur = ""
        for w, word in enumerate(_words(line)):
            for k, seg in enumerate(segments(word)):
                glue = " " if (k == 0 and w > 0) else ""
                if cur and cell_len(cur + glue + seg) > width:
                    out.append(cur)
                    cur = seg
                else:
                    cur = cur + glue + seg if cur else seg
        out.append(cur)
    return "\n".join(out)


def _min_header(header: str) -> int:
    from rich.cells import cell_len

    return max((cell_len(seg) for word in header.split() for seg in _header_segments(word)), default=0)


def _tokens_width(text: str) -> tuple[int, int]:
    """(longest unbreakable piece, longest line) of a cell, in terminal cells."""
    from rich.cells import cell_len

    lines = text.split("\n")
    return (max((cell_len(p) for ln in lines for t in _words(ln) for p in _cell_segments(t)), default=0),
            max((cell_len(ln) for ln in lines), default=0))


def _fit_widths(minw: list[int], targets: list[list[int]], available: int) -> list[int]:
    """Column widths from their minimum up to each target in turn (the cells' natural width first, then the
    header's) within ``available`` cells, the columns that need the fewest extra cells first (so as many cells
    as possible stay on one line; a header wraps before a value does)."""
    widths = list(minw)
    extra = available - sum(widths)
    for target in targets:
        for i in sorted(range(len(widths)), key=lambda i: target[i] - widths[i]):
            d = max(0, min(target[i] - widths[i], extra))
            widths[i] += d
            extra -= d
    return widths


def rich_table(header: Sequence[str], rows: Iterable[Sequence], title: str | None = None, digits: int = 4,
               justify: Sequence[str] | None = None, width: int | None = None):
    """The same rows as a :class:`rich.table.Table` for the terminal: the one terminal table writer.

    Cells, headers and the title are data, never markup ("[study]" or "[0.1, 0.2]" print as written), their
    control characters made visible (:func:`berryshaker.user_text.visible`: an ESC in a sheet header prints as
    ``\\x1b``); a cell may also be a :class:`rich.text.Text` (styled).  Numbers are written to ``digits`` significant digits.  At ``width``
    terminal cells (default the terminal's) no number or word is ever split: headers wrap at spaces, dots,
    underscores and slashes, cells wrap at spaces; when even the narrowest such layout is wider than the
    terminal, each row is stacked as "column | value" lines instead.

    Parameters
    ----------
    header : sequence of str
        Column headers (an explicit newline is a line break).
    rows : iterable of sequences
        Cells: str, :class:`rich.text.Text`, numbers (floats formatted), booleans (yes/no), non-finite (empty).
    title : str, optional
        Table title (plain text).
    digits : int
        Significant digits of float cells.
    justify : sequence of {"left", "right", "center"}, optional
        Per column (default the first column left, the others right).
    width : int, optional
        Terminal width in cells (default :class:`rich.console.Console`'s, from ``COLUMNS`` or the terminal).

    Returns
    -------
    rich.table.Table
        One column per header when the columns fit ``width``, otherwise two columns ("column | value") with one
        section per row.
    """
    from rich.console import Console
    from rich.table import Table
    from rich.text import Text

    header = [visible(str(h), keep_lines=True) for h in header]
    n = len(header)
    just = list(justify) if justify else ["left"] + ["right"] * (n - 1)
    body = []
    for r in rows:
        cells = []
        for v in r:
            if isinstance(v, Text):
                cells.append(v)
                continue
            v = _cell(v)
            cells.append(Text(f"{v:.{digits}g}" if isinstance(v, float) else visible(str(v), keep_lines=True)))
        body.append(cells + [Text("")] * (n - len(cells)))
    width = int(width or Console().width)
    minw, natural, cell_natural = [], [], []
    for i, h in enumerate(header):
        tok = [_tokens_width(c[i].plain) for c in body]
        minw.append(max([_min_header(h)] + [t for t, _ in tok] + [1]))
        cell_natural.append(max([minw[-1]] + [ln for _, ln in tok]))
        natural.append(max([_tokens_width(h)[1], cell_natural[-1]]))
    overhead = 3 * n + 1  # borders and one space of padding each side
    title_text = Text(visible(title)) if title else None
    if sum(natural) + overhead <= width or sum(minw) + overhead <= width:
        widths = natural if sum(natural) + overhead <= width else _fit_widths(minw, [cell_natural, natural], width - overhead)
        tb = Table(title=title_text, header_style="bold")
        for h, w, j in zip(header, widths, just):
            tb.add_column(Text(_wrap_header(h, w)), justify=j, width=w, overflow="fold")
        for cells in body:
            tb.add_row(*[Text(_wrap_header(c.plain, w, _cell_segments)) if not c.spans and not c.style else c
                         for c, w in zip(cells, widths)])
        return tb
    # too many columns for the terminal even at their narrowest: one block of "column | value" lines per row
    tb = Table(title=title_text, header_style="bold", show_header=False)
    tb.add_column(justify="left", overflow="fold", max_width=max(12, width // 3))
    tb.add_column(justify="left", overflow="fold")
    for cells in body:
        for k, (h, c) in enumerate(zip(header, cells)):
            tb.add_row(Text(h.replace("\n", " "), style="bold"), c, end_section=k == n - 1)
    return tb
