"""Nothing injected (issue 59): user text -- a machine name, a sheet's headers and cells, a file name, an output
path -- reaches every page, table and terminal line as text.

* HTML: ``doe analyze --out`` (headers, the sheet's file name), ``doe plan``'s printable sheet, the calibration
  page; no script element, no event handler, no image but the embedded figures (the study report:
  tests/report/test_html.py).
* figures (``doe analyze --plot``): a ``$`` in a header is text, not TeX (it was a traceback).
* CSV and xlsx (``doe analyze --plot``): no formula, no cell starting with ``=``, ``+``, ``-``, ``@`` unless
  prefixed by ``'`` (the OWASP rule), every file inside its folder (a header ``../x`` is a name, not a path); a
  control character in a header is one message naming the column, not openpyxl's IllegalCharacterError.
* The terminal: ESC/OSC/BEL from a path or a header never reach it raw; a path with ``[/]`` is no MarkupError
  (it was, after the files were written) and ``[red]plots`` prints as written.
* Long text: a 100k-character machine name is one message in a second, not a minute of rich's highlighter.
"""

from __future__ import annotations

import csv
import html
import time
import tomllib
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from berryshaker.cli import app
from berryshaker.config import reference_toml_text
from berryshaker.experiment.designs import orthogonal_array

runner = CliRunner()
SCRIPT = '<script>alert("x")</script>'
IMG = "<img src=x onerror=alert(1)>"
#: what a terminal would act on: ESC, BEL, the 8-bit CSI and OSC
RAW_CONTROLS = ("\x1b", "\x07", "\x9b", "\x9d")


def _tags(text: str) -> list[tuple[str, dict]]:
    seen = []

    class Tags(HTMLParser):
        def handle_starttag(self, tag, attrs):
            seen.append((tag, dict(attrs)))

    Tags().feed(text)
    return seen


def assert_no_injected_markup(text: str) -> None:
    """No script element, no event-handler attribute, no image that is not an embedded figure."""
    tags = _tags(text)
    assert "script" not in {t for t, _ in tags}
    assert not [(t, a) for t, attrs in tags for a in attrs if a.lower().startswith("on")]
    assert all((a.get("src") or "").startswith("data:image/") for t, a in tags if t == "img")


def _hostile_sheet(folder: Path, headers: list[str], name: str = "sheet.csv") -> Path:
    """An L9 sheet, two blocks, with the given headers: 3 factors, 2 responses, a block column."""
    a = orthogonal_array("L9")
    rng = np.random.default_rng(1)
    rows = []
    for b in (1, 2):
        for i in range(9):
            rows.append([str(a[i, j] + 1) for j in range(3)]
                        + [f"{1 + 0.2 * a[i, 0] + 0.1 * a[i, 1] + rng.normal(0, 0.05):.3f}",
                           f"{3 + 0.5 * a[i, 2] + rng.normal(0, 0.1):.3f}", str(b)])
    p = folder / name
    with open(p, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(headers)
        w.writerows(rows)
    return p


HEADERS = [f"F{SCRIPT}", '=HYPERLINK("http://evil","click")', f"C{IMG}$\\frac{{", f"eff{SCRIPT} (kg/min)",
           "@dmg$^$", "block"]  # "$": matplotlib parsed it as TeX (a ParseSyntaxException traceback)


@pytest.fixture(scope="module")
def analysed(tmp_path_factory):
    """``doe analyze`` of a sheet whose file name and headers are hostile, with --out page and --plot tables."""
    base = tmp_path_factory.mktemp("hostile")
    sheet = _hostile_sheet(base, HEADERS, name=f"{IMG}.csv")
    page, plots = base / f"{IMG}.html", base / "plots"
    r = runner.invoke(app, ["doe", "analyze", str(sheet), "--maximize", f"eff{SCRIPT}", "--minimize", "@dmg$^$",
                            "--out", str(page), "--plot", str(plots)])
    assert r.exit_code == 0, r.output
    return base, page, plots, r.output


def test_doe_analyze_page_shows_hostile_headers_and_file_names_as_text(analysed):
    _, page, _, _ = analysed
    text = page.read_text(encoding="utf-8")
    assert_no_injected_markup(text)
    assert html.escape(SCRIPT) in text and html.escape(IMG) in text


def test_doe_analyze_tables_hold_no_formula(analysed):
    from openpyxl import load_workbook

    base, _, plots, _ = analysed
    assert {p.parent for p in base.rglob("*") if p.is_file()} <= {base, plots}  # nothing written outside
    csvs, books = sorted(plots.glob("*.csv")), sorted(plots.glob("*.xlsx"))
    assert len(csvs) == len(books) >= 3
    for f in csvs:
        with open(f, newline="", encoding="utf-8") as fh:
            for row in csv.reader(fh):
                for cell in row:
                    assert not cell.startswith(("=", "+", "@", "\t", "\r")), (f.name, cell)
                    assert not (cell.startswith("-") and not _number(cell)), (f.name, cell)
    for f in books:
        for ws in load_workbook(f).worksheets:  # formulas are kept as formulas when data_only is off
            for row in ws.iter_rows():
                for c in row:
                    assert c.data_type != "f", (f.name, c.coordinate, c.value)
                    assert not (isinstance(c.value, str) and c.value.startswith(("=", "+", "-", "@"))), c.value


def _number(text: str) -> bool:
    try:
        float(text)
        return True
    except ValueError:
        return False


def test_doe_analyze_terminal_output_is_plain_text(analysed):
    *_, output = analysed
    assert not any(c in output for c in RAW_CONTROLS)
    assert SCRIPT in output  # printed as written, not eaten as markup


def test_a_control_character_in_a_header_is_one_message_naming_the_column(tmp_path):
    """Issue 59: an openpyxl IllegalCharacterError traceback, and nothing written; now refused where the sheet is
    read (ESC/OSC in a header would also reach the terminal)."""
    sheet = _hostile_sheet(tmp_path, ["A", "B", "C", "eff\x1b]0;pwned\x07", "dmg", "block"])
    r = runner.invoke(app, ["doe", "analyze", str(sheet), "--maximize", "dmg", "--plot", str(tmp_path / "plots")])
    assert r.exit_code == 2, r.output
    assert "column 4" in r.output and "U+001B (ESC)" in r.output and "Traceback" not in r.output
    assert not any(c in r.output for c in RAW_CONTROLS)
    assert not (tmp_path / "plots").exists()


def test_doe_plan_page_and_sheet(tmp_path):
    out = tmp_path / f"{IMG}.csv"
    r = runner.invoke(app, ["doe", "plan", "--array", "L4", "--factor", "A=1,2mm", "--factor", "B=1,2mm", "--out",
                            str(out), "--replicates", "1"])
    assert r.exit_code == 0, r.output
    assert_no_injected_markup(out.with_suffix(".html").read_text(encoding="utf-8"))
    r = runner.invoke(app, ["doe", "plan", "--array", "L4", "--factor", f"{SCRIPT}=1,2mm", "--factor", "B=1,2mm",
                            "--out", str(tmp_path / "x.csv")])
    assert r.exit_code == 2 and "factor name must be a word" in r.output  # names are words: no markup, no formula


def test_calibration_page_shows_hostile_text_as_text(tmp_path):
    """The page of `calibrate --out`: the sheet's file name (its title), the level sets' and the factors' names."""
    import dataclasses

    from study.test_field_calibration import _small_result

    from berryshaker.report.calibration import write_calibration_outputs

    res = _small_result()
    preds = [dataclasses.replace(p, level_set=f"{p.level_set}{SCRIPT}") for p in res.predictions]
    res = dataclasses.replace(res, predictions=preds, recommendation=dataclasses.replace(
        res.recommendation, level_set=f"C{IMG}", no_difference=[SCRIPT]))
    write_calibration_outputs(res, tmp_path, f"Calibration to {IMG}.csv")
    text = (tmp_path / "report.html").read_text(encoding="utf-8")
    assert_no_injected_markup(text)
    assert html.escape(IMG) in text and html.escape(SCRIPT) in text


# ---- the terminal -------------------------------------------------------------------------------------------
def _shown(text: str) -> str:
    return text.replace("\x1b", "\\x1b").replace("\x07", "\\x07").replace("\x9b", "\\x9b")


def test_paths_print_as_written(tmp_path):
    """Issue 59: `--plot 'a[/]b'` was a rich MarkupError traceback after the files were written, `[red]plots`
    printed "wrote plots/svaj.png"; ESC/OSC in a path reached the terminal raw."""
    dest = tmp_path / "[red]plots" / "a[/]b\x1b]0;pwned\x07"
    r = runner.invoke(app, ["kinematics", "--plot", str(dest)])
    assert r.exit_code == 0, r.output
    assert "Traceback" not in r.output and not any(c in r.output for c in RAW_CONTROLS)
    assert f"wrote {_shown(str(dest))}/svaj.png" in r.output, r.output
    for folder in ("[/]plots", "[bold]x", "c\x1b[2Jd", "e\x9b2Jf"):
        r = runner.invoke(app, ["config", "init", str(tmp_path / folder / "m.toml")])
        assert r.exit_code == 0 and f"wrote {_shown(str(tmp_path / folder))}/m.toml" in r.output, r.output
        assert not any(c in r.output for c in RAW_CONTROLS)


@pytest.mark.parametrize("name", ["evil\x1b]0;pwned\x07", "red\x1b[31m", "clear\x1b[2J", "csi\x9b2J", "rtl\u202eexe"])
def test_control_characters_in_a_machine_name_are_refused_naming_the_field(tmp_path, name):
    """Issue 59: ESC/OSC from [machine] name reached the terminal raw in `config validate` and `kinematics`."""
    toml_name = "".join(c if c.isascii() and c.isprintable() else f"\\u{ord(c):04x}" for c in name)
    text = reference_toml_text().replace('name = "berryshaker reference harvester"', f'name = "{toml_name}"')
    assert tomllib.loads(text)["machine"]["name"] == name
    p = tmp_path / "m.toml"
    p.write_text(text, encoding="utf-8")
    for args in (["config", "validate", str(p)], ["kinematics", "--config", str(p)]):
        r = runner.invoke(app, args)
        assert r.exit_code == 2 and "machine.name" in r.output and "control character" in r.output, r.output
        assert not any(c in r.output for c in RAW_CONTROLS) and "\u202e" not in r.output


def test_markup_in_a_machine_name_prints_as_written(tmp_path):
    text = reference_toml_text().replace('name = "berryshaker reference harvester"', 'name = "[red]x[/] [/] [bold"')
    p = tmp_path / "m.toml"
    p.write_text(text, encoding="utf-8")
    for args in (["config", "validate", str(p)], ["kinematics", "--config", str(p)]):
        r = runner.invoke(app, args)
        assert r.exit_code == 0 and "[red]x[/] [/] [bold" in r.output, r.output


def test_an_error_quoting_user_text_shows_its_control_characters(tmp_path):
    r = runner.invoke(app, ["doe", "plan", "--factor", "\x1b]0;pwned\x07=1,2mm", "--out", str(tmp_path / "p.csv")])
    assert r.exit_code == 2 and "\\x1b]0;pwned\\x07" in r.output and not any(c in r.output for c in RAW_CONTROLS)


# ---- long text ----------------------------------------------------------------------------------------------
def test_a_100k_character_name_is_one_message_at_once(tmp_path):
    """Issue 59: `config validate` spent 60 CPU-s in rich's highlighter on a 100k-character machine name."""
    p = tmp_path / "m.toml"
    p.write_text(reference_toml_text().replace('name = "berryshaker reference harvester"',
                                               f'name = "{"a1 [b] " * 15_000}"'), encoding="utf-8")
    t0 = time.process_time()
    r = runner.invoke(app, ["config", "validate", str(p)])
    assert r.exit_code == 2 and "machine.name: 105,000 characters, more than the 200" in r.output, r.output[:300]
    assert time.process_time() - t0 < 5.0
    sheet = _hostile_sheet(tmp_path, ["A", "B", "C", "x" * 100_000, "dmg", "block"])
    t0 = time.process_time()
    r = runner.invoke(app, ["doe", "analyze", str(sheet), "--maximize", "dmg"])
    assert r.exit_code == 2 and "column 4: 100,000 characters" in r.output, r.output[:300]
    assert time.process_time() - t0 < 5.0
