"""The one terminal table writer at 80 columns: no number or word is ever split (headers wrap at word and dot
boundaries, rows fold at spaces, or the columns stack), and every CLI table goes through it (issue 45)."""

from __future__ import annotations

import re
from pathlib import Path

from rich.console import Console
from typer.testing import CliRunner

from berryshaker.cli import app
from berryshaker.report.tables import rich_table

cli = CliRunner()
NUMBER = re.compile(r"[-+]?\d+(?:\.\d+)?(?:e[-+]\d+)?")


def _render(table, width=80) -> str:
    c = Console(width=width, record=True, file=open("/dev/null", "w"))
    c.print(table)
    return c.export_text()


def _lines_cells(text: str) -> list[str]:
    """Every cell fragment of every rendered line (box characters removed)."""
    return [frag.strip() for ln in text.splitlines() for frag in re.split(r"[│┃]", ln) if frag.strip()]


def test_numbers_and_words_stay_whole_at_80_columns():
    header = ["run", "clearance.A.size[mm]", "clearance.C.size[mm]", "efficiency", "growth rate (start)", "status"]
    rows = [[1, 0.25, 0.1, 1.20512345e4, "0.0498 µm/h", "ok"],
            [2, 0.5, 0.15, -3.2e-5, "does not wear", "steel-on-bronze-greased"]]
    text = _render(rich_table(header, rows, title="sweep", width=80))
    frags = _lines_cells(text)
    for value in ("1.205e+04", "-3.2e-05", "0.0498", "0.25", "0.15"):
        assert value in frags or any(value in f.split() for f in frags), (value, text)
    for word in ("clearance.", "size[mm]", "wear", "growth", "(start)"):
        assert any(word in f for f in frags), (word, text)
    assert "clearanc" not in [f.split()[-1] for f in frags if f.split()]  # no "clearanc / e.C.size"
    assert max(len(ln) for ln in text.splitlines()) <= 80


def test_too_many_columns_stack_instead_of_splitting():
    header = [f"collision_force_{p}_peak_N" for p in "ABCDEFGH"]
    text = _render(rich_table(header, [[12345.678] * 8], width=80))
    assert text.count("1.235e+04") == 8 and "collision_force_H_peak_N" in text


def test_every_cli_table_goes_through_the_one_writer():
    src = Path(__file__).parents[2] / "src" / "berryshaker" / "cli"
    direct = [f"{p.name}:{i + 1}" for p in sorted(src.glob("*.py"))
              for i, ln in enumerate(p.read_text("utf-8").splitlines()) if re.search(r"\bTable\(", ln)]
    assert not direct, f"rich Table( built directly, not through print_table/rich_table: {direct}"


def test_cli_tables_at_80_columns_keep_numbers_whole():
    r = cli.invoke(app, ["fits", "H7/f7", "--diameter", "20mm"], env={"COLUMNS": "80"})
    assert r.exit_code == 0, r.output
    assert "20.021 mm" in r.output and "19.959 mm" in r.output
    r = cli.invoke(app, ["config", "show"], env={"COLUMNS": "80"})
    assert r.exit_code == 0, r.output
    assert max(len(ln) for ln in r.output.splitlines()) <= 80
    assert "[study]" in r.output and "\\[" not in r.output  # brackets as written, no escape left over


def test_a_mean_plus_minus_sd_stays_on_one_line():
    text = _render(rich_table(["quantity", "a", "b"], [["x", "12.5 ± 1.3 N", "0.5 +- 0.25 %"]], width=24))
    assert "12.5 ± 1.3" in text and "0.5 +- 0.25" in text, text
