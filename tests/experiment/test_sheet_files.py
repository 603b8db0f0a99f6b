"""Field sheets from Excel workbooks and the one check of a sheet file (issue 58 item 1, issue 59 "special files"):
an .xlsx reads as its CSV does, cells as strictly (a formula, a date or a boolean where a number belongs is an error
naming the cell), and a FIFO, a device, a folder or an oversized file is refused at once."""

import datetime as dt
import os
import re
import threading
from pathlib import Path

import numpy as np
import pytest
from openpyxl import Workbook
from typer.testing import CliRunner

from berryshaker.errors import ConfigError
from berryshaker.experiment import sheet_files
from berryshaker.experiment.field_results import analyze_sheet
from berryshaker.experiment.field_sheet import parse_factor, plan_table, read_results

SPECS = ["A=0.25,0.5,0.75mm", "B=0.2,0.4,0.6mm", "C=0.1,0.15,0.2mm"]


def _plan(replicates=2):
    df = plan_table("L9", [parse_factor(s) for s in SPECS], randomize=True, seed=4, replicates=replicates)
    noise = np.random.default_rng(2).normal(0.0, 0.05, len(df))
    df["efficiency_kg_min"] = 4.0 - 0.8 * df["A_mm"] + noise
    df["damage_rate_pct"] = 2.0 + 0.5 * df["B_mm"] + noise
    return df.round(9)  # numbers a workbook and a CSV hold alike (openpyxl writes 16 significant digits)


def _workbook(df, path: Path, *, title="Plots", before=(), edit=None) -> Path:
    """``df`` written as a worksheet (numbers as numbers), after the worksheets ``before``; ``edit(ws)`` changes
    cells."""
    wb = Workbook()
    wb.remove(wb.active)
    for name in before:
        wb.create_sheet(name).append(["not", "this", "one"])
    ws = wb.create_sheet(title)
    ws.append(list(df.columns))
    for row in df.itertuples(index=False, name=None):
        ws.append([None if isinstance(v, float) and np.isnan(v) else v for v in row])
    if edit is not None:
        edit(ws)
    wb.save(path)
    return path


def test_an_xlsx_sheet_reads_as_its_csv(tmp_path):
    """Before: `doe analyze results.xlsx` failed with a UTF-8 decode error.  The same plan as .xlsx and as CSV gives
    the same sheet and the same analysis, number for number; a worksheet is chosen by name."""
    df = _plan()
    csv = tmp_path / "plan.csv"
    df.to_csv(csv, index=False, float_format="%.17g")  # every float as it is (the workbook holds them exactly)
    book = _workbook(df, tmp_path / "plan.xlsx", before=["Notes"])
    senses = {"efficiency": True, "damage": False}
    fr_c, res_c = analyze_sheet(csv, senses)
    fr_x, res_x = analyze_sheet(book, senses, sheet="Plots")
    assert res_x.to_json() == res_c.to_json()
    np.testing.assert_array_equal(fr_x.levels, fr_c.levels)
    assert fr_x.level_values == fr_c.level_values and fr_x.units == fr_c.units
    with pytest.raises(ConfigError, match=r"no worksheet 'Plot'; the workbook has 'Notes', 'Plots'"):
        read_results(book, ["efficiency"], sheet="Plot")
    with pytest.raises(ConfigError, match="results sheet 'Notes' has a header but no rows"):  # the first worksheet
        read_results(book, ["efficiency"])
    with pytest.raises(ConfigError, match=r"--sheet 'Plots' names a worksheet of a workbook; .*plan.csv is a CSV"):
        read_results(csv, ["efficiency"], sheet="Plots")


def test_a_workbook_cell_is_named_in_errors(tmp_path):
    """A value that matches no level is named by row, run, column and cell, as Excel names it."""
    df = _plan(1)
    df = df.drop(columns=["A_mm"])
    book = _workbook(df, tmp_path / "p.xlsx", edit=lambda ws: ws.cell(row=5, column=4, value=7))  # D5: A_level
    with pytest.raises(ConfigError, match=r"results sheet 'Plots' row 5 \(run \d\), column 'A_level' \(cell "
                                          r"'Plots'!D5\): 7 matches no level"):
        read_results(book, ["efficiency"])


@pytest.mark.parametrize("value, message", [
    ("=B2*2", r"cell 'Plots'!N3 holds a formula \('=B2\*2'\); berryshaker evaluates no formula"),
    (dt.datetime(2024, 7, 3), r"cell 'Plots'!N3\): '2024-07-03T00:00:00' is a date in the workbook where a number "
                              "belongs"),
    (True, r"cell 'Plots'!N3\): 'TRUE' is a boolean in the workbook where a number belongs"),
])
def test_formulas_dates_and_booleans_are_refused_where_a_number_belongs(tmp_path, value, message):
    df = _plan(1)
    col = list(df.columns).index("efficiency_kg_min") + 1
    assert col == 14  # column N
    book = _workbook(df, tmp_path / "p.xlsx", edit=lambda ws: ws.cell(row=3, column=col, value=value))
    with pytest.raises(ConfigError, match=message):
        read_results(book, ["efficiency"])


def test_a_date_in_a_notes_column_and_an_error_value_anywhere(tmp_path):
    df = _plan(1)
    df["date"] = None

    def dated(ws):
        for r in range(2, 11):
            ws.cell(row=r, column=len(df.columns), value=dt.date(2024, 7, r))

    fr = read_results(_workbook(df, tmp_path / "d.xlsx", edit=dated), ["efficiency"])
    assert len(fr.levels) == 9  # a date is text where text belongs

    def broken(ws):
        ws["N4"] = "#DIV/0!"
        ws["N4"].data_type = "e"

    with pytest.raises(ConfigError, match=r"cell 'Plots'!N4 holds the spreadsheet error '#DIV/0!'"):
        read_results(_workbook(_plan(1), tmp_path / "e.xlsx", edit=broken), ["efficiency"])


def test_legacy_xls_damaged_workbooks_and_zip_bombs_are_refused(tmp_path, monkeypatch):
    xls = tmp_path / "old.xls"
    xls.write_bytes(b"\xd0\xcf\x11\xe0\xa1\xb1\x1a\xe1" + b"\0" * 512)
    with pytest.raises(ConfigError, match=r"legacy Excel workbook \(.xls\); save it as .xlsx"):
        read_results(xls, ["efficiency"])
    bad = tmp_path / "bad.xlsx"
    bad.write_bytes(b"PK\x03\x04" + b"x" * 100)
    with pytest.raises(ConfigError, match="not a readable one; save it again"):
        read_results(bad, ["efficiency"])
    book = _workbook(_plan(1), tmp_path / "p.xlsx")
    monkeypatch.setattr(sheet_files, "MAX_WORKBOOK_BYTES", 1000)
    with pytest.raises(ConfigError, match=r"the workbook unpacks to [\d,]+ bytes, more than the 1,000"):
        read_results(book, ["efficiency"])


def _refused_in_time(path, match) -> None:
    """read_results(path) raises a ConfigError matching ``match`` within 10 s (a FIFO used to block forever)."""
    got = {}

    def work():
        try:
            read_results(path, ["efficiency"])
        except Exception as exc:  # noqa: BLE001 - reported below
            got["exc"] = exc

    t = threading.Thread(target=work, daemon=True)
    t.start()
    t.join(10)
    assert not t.is_alive(), f"reading {path} hangs"
    assert isinstance(got.get("exc"), ConfigError), got  # a clean error, no traceback
    assert re.search(match, str(got["exc"])), str(got["exc"])


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
def test_special_files_are_refused_at_once(tmp_path, monkeypatch):
    """Issue 59: a FIFO as a sheet blocked `doe analyze` and `calibrate` forever; /dev/zero grew the memory."""
    fifo = tmp_path / "sheet.csv"
    os.mkfifo(fifo)
    _refused_in_time(fifo, r"is a FIFO \(named pipe\); give the sheet's file")
    if Path("/dev/zero").exists():
        _refused_in_time("/dev/zero", r"/dev/zero is a device")
    _refused_in_time(tmp_path, r"is a folder")
    _refused_in_time(tmp_path / "missing.csv", r"results file not found")
    big = tmp_path / "big.csv"
    big.write_text(_plan(1).to_csv(index=False))
    monkeypatch.setattr(sheet_files.read_sheet_bytes, "__defaults__", ("results file", 100))
    _refused_in_time(big, r"has [\d,]+ bytes, more than the 100 a field sheet can have")


def test_doe_analyze_and_calibrate_read_a_workbook_from_the_command_line(tmp_path):
    """The CLI: `doe analyze results.xlsx [--sheet NAME]` analyses it; `calibrate results.xlsx --sheet NAME` reads it
    (an unknown worksheet is refused before any simulation)."""
    from berryshaker.cli import app

    df = _plan()
    book = _workbook(df, tmp_path / "results.xlsx", before=["Notes"])
    runner = CliRunner()
    r = runner.invoke(app, ["doe", "analyze", str(book), "--sheet", "Plots", "--maximize", "efficiency", "--json"])
    assert r.exit_code == 0, r.output
    assert '"replicates": 2' in r.stdout
    r = runner.invoke(app, ["calibrate", str(book), "--sheet", "Plot"])
    assert r.exit_code == 2 and "no worksheet 'Plot'" in r.output and "Traceback" not in r.output
    from berryshaker.config import load_machine
    from berryshaker.study.field_calibration import read_sheet

    fs = read_sheet(_workbook(df, tmp_path / "cal.xlsx"), load_machine(None), None)
    assert fs.replicates == 2 and [t.pair for t in fs.targets] == ["A", "B", "C"]
