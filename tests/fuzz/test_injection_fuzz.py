"""Fuzzing (hypothesis) of user text on its way to every edge (issue 59), so that a regression fails the build:

* HTML: any text in a page berryshaker writes (the one helper, a field sheet's page, a field-test analysis whose
  headers are the text) makes no element, no attribute and no entity of its own;
* CSV and xlsx: any cell or header is written as text that no spreadsheet reads as a formula, and never an
  openpyxl error;
* the terminal: any text printed (a table, an error, a path) reaches it without a control character and without
  being read as rich markup, never a MarkupError;
* long text: names and cells up to 200k characters are refused or written in linear time.

Fixed, derandomised examples in CI (about 10-20 s in all); ``BERRYSHAKER_FUZZ_EXAMPLES=5000`` explores further."""

from __future__ import annotations

import csv
import io
import re
import time
from html.parser import HTMLParser

import pandas as pd
from fuzzing import fuzz, work_dir
from hypothesis import HealthCheck, given
from hypothesis import strategies as st
from rich.console import Console

from berryshaker.errors import ConfigError
from berryshaker.experiment.field_sheet import plan_html
from berryshaker.report.table_files import csv_bytes, xlsx_bytes
from berryshaker.report.tables import rich_table
from berryshaker.user_text import FORMULA_STARTS, cell_text, check_user_text, html_text, markup_text, visible

WORK = work_dir("injection")
#: the pieces an attacker (or an accident) puts in a name: markup, formula starts, terminal controls, bidi
PIECES = ["<script>", "</script>", "<img src=x onerror=alert(1)>", "&amp;", "&#x3c;", '"', "'", "=", "+", "-",
          "@", "\t", "\r", "\n", "\x1b[31m", "\x1b]0;title\x07", "\x9b2J", "\x9d8;;http://x\x9c", "\u202e", "[red]",
          "[/]", "[bold", "\\", "\\[x]", "$", "$^$", "$\\frac{", "%", "=HYPERLINK(\"http://x\",\"y\")", "@SUM(A1:A9)", "\x00", "\x7f", "µ", "🍓"]
hostile = st.lists(st.one_of(st.sampled_from(PIECES), st.text(max_size=4)), max_size=8).map("".join)
#: what a terminal acts on
CONTROL = re.compile("[\x00-\x08\x0b-\x1f\x7f-\x9f\u202a-\u202e\u2066-\u2069]")


def _markup(text: str) -> tuple[list, list, list]:
    """The elements, attributes and entity/char references an HTML parser finds in ``text``."""
    tags, attrs, refs = [], [], []

    class P(HTMLParser):
        def handle_starttag(self, tag, a):
            tags.append(tag)
            attrs.extend(k for k, _ in a)

        def handle_startendtag(self, tag, a):
            self.handle_starttag(tag, a)

        def handle_endtag(self, tag):
            tags.append("/" + tag)

        def handle_entityref(self, name):
            refs.append(name)

        def handle_charref(self, name):
            refs.append(name)

    P(convert_charrefs=False).feed(text)
    return tags, attrs, refs


@fuzz(100)
@given(text=hostile)
def test_html_text_makes_no_markup(text):
    out = html_text(text)
    tags, attrs, refs = _markup(f"<p>{out}</p><a title=\"{out}\">x</a>")
    assert tags == ["p", "/p", "a", "/a"] and attrs == ["title"], (text, out)
    assert set(refs) <= {"amp", "lt", "gt", "quot", "x27"}, refs
    assert not CONTROL.search(out)


PAGE_TAGS = {"html", "head", "meta", "title", "style", "body", "h2", "div", "b", "span", "p", "table", "colgroup",
             "col", "thead", "tr", "th", "tbody", "td", "br"}


@fuzz(30)
@given(name=hostile, cell=hostile)
def test_a_field_sheet_page_makes_no_markup_of_its_text(name, cell):
    df = pd.DataFrame({"run": [1, 2], "order": [2, 1], f"{name}_mm": [0.1, cell], "duration_s": [None, None]})
    tags, attrs, _ = _markup(plan_html(df, f"field sheet of {name}"))
    assert {t.lstrip("/") for t in tags} <= PAGE_TAGS
    assert not [a for a in attrs if a.startswith("on")]


@fuzz(25, HealthCheck.function_scoped_fixture)
@given(factor=hostile, response=hostile)
def test_a_field_test_page_makes_no_markup_of_its_headers(factor, response):
    """``doe analyze --out``'s page of a sheet whose factor and response headers are any text."""
    from berryshaker.experiment.field_results import analyze_sheet
    from berryshaker.report.doe_page import doe_report

    factor, response = factor.strip() or "f", response.strip() or "r"
    if factor == response or CONTROL.search(factor + response) or "," in factor + response \
            or '"' in factor + response or "\n" in factor + response:
        return  # a header a CSV cannot hold plainly, or one the reader refuses (tests/test_injection.py)
    rows = [f"{a},{b},{2 + 0.3 * a + 0.1 * b + 0.01 * (a * b % 3)}" for a in (1, 2, 3) for b in (1, 2, 3)]
    sheet = f"{factor},B,{response}\n" + "\n".join(rows) + "\n"
    try:
        _, res = analyze_sheet(sheet, {response: True})
    except ConfigError:
        return  # e.g. a header the sheet reads as a bookkeeping or unit column
    tags, attrs, _ = _markup(doe_report(res, f"Field test analysis: {factor}", results_file=response, version="t"))
    assert "script" not in tags and "img" not in tags and not [a for a in attrs if a.startswith("on")]


@fuzz(60)
@given(header=st.lists(hostile, min_size=1, max_size=4), cells=st.lists(st.one_of(hostile, st.floats(), st.integers(),
                                                                                  st.booleans(), st.none()),
                                                                        max_size=6))
def test_table_files_hold_no_formula(header, cells):
    from openpyxl import load_workbook

    rows = [cells, list(reversed(cells))]
    text = csv_bytes(header, rows).decode("utf-8")
    for row in csv.reader(io.StringIO(text)):
        for cell in row:
            assert not cell.startswith(("=", "+", "@", "\t", "\r")), cell
            assert not cell.startswith("-") or _number(cell), cell
            assert not CONTROL.search(cell.replace("\r", "")), cell
    ws = load_workbook(io.BytesIO(xlsx_bytes(header, rows))).active  # never openpyxl's IllegalCharacterError
    for row in ws.iter_rows():
        for c in row:
            assert c.data_type != "f", c.value
            assert not (isinstance(c.value, str) and c.value.startswith(("=", "+", "-", "@", "\t"))), c.value


def _number(text: str) -> bool:
    try:
        float(text)
        return True
    except ValueError:
        return False


@fuzz(100)
@given(text=hostile)
def test_cells_keep_what_they_say(text):
    """Neutralised, a cell still says what the user wrote (a leading ' added, controls shown as escapes)."""
    assert cell_text(text) == ("'" if text.startswith(FORMULA_STARTS) else "") + visible(text, keep_lines=True)


@fuzz(30)
@given(header=hostile, cell=hostile, title=hostile, message=hostile)
def test_the_terminal_gets_no_control_character_and_no_markup(header, cell, title, message):
    """A table, a markup line with user text in it and a plain line: no control character reaches the terminal,
    and the markup line shows the text exactly as plain text would (no markup read, never a MarkupError)."""
    from rich.text import Text

    from berryshaker.cli.app import SafeConsole

    def printed(*items, **kw) -> str:
        buf = io.StringIO()
        console = SafeConsole(file=buf, width=100, force_terminal=False, color_system=None)
        for item in items:
            console.print(item, **kw)
        return buf.getvalue()

    shown = printed(rich_table([header or "h", "n"], [[cell, 1.5]], title=title or None, width=100)) + printed(
        f"wrote {message}", markup=False) + printed(f"[yellow]warning:[/] {markup_text(message)} (more)")
    assert not CONTROL.search(shown.replace("\n", "")), shown
    assert printed(f"[yellow]warning:[/] {markup_text(message)} (more)") == printed(
        Text(f"warning: {visible(message, keep_lines=True)} (more)"))


@fuzz(40)
@given(n=st.integers(0, 200_000), piece=st.sampled_from(["a", "a1 ", "[b]", "<i>", "=", "\x1b", "é", "a.b_c"]))
def test_long_text_is_linear(n, piece):
    """Up to 200k characters through every helper and the table writer: refused past the bound (with the
    field named) or written, within a second of CPU (rich's highlighter took 60 CPU-s on 100k)."""
    text = (piece * (n // len(piece) + 1))[:n]
    t0 = time.process_time()
    for f in (visible, html_text, cell_text, markup_text):
        f(text)
    try:
        check_user_text(text, "machine.name")
    except ConfigError as exc:
        assert str(exc).startswith("machine.name: ") and len(str(exc)) < 400
    Console(file=io.StringIO(), width=120).print(rich_table(["name", "n"], [[text[:5000], 1]], width=120))
    assert time.process_time() - t0 < 2.0, (n, piece)


@fuzz(5)
@given(label=hostile, title=hostile)
def test_figures_draw_any_text(label, title):
    """A name from a sheet in an axis label, a title and a legend: drawn as text (mathtext is off), never a
    matplotlib parse error."""
    from berryshaker.report.style import finish, label_axes, new_figure

    fig, ax = new_figure()
    ax.plot([0, 1], [0, 1], label=label or "x")
    ax.set_title(title)
    label_axes(ax, f"{label} [mm]", f"{title} [-]")
    ax.legend()
    finish(fig, WORK / "figure.png", dpi=20, svg=False)
