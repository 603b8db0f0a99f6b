"""Tables as CSV and .xlsx through one writer (report/table_files.py, issue 45)."""

from __future__ import annotations

import csv

import numpy as np
import pytest

from berryshaker.report.table_files import read_xlsx, write_table


def test_write_table_writes_the_same_rows_as_csv_and_xlsx(tmp_path):
    header = ["pair", "peak_N", "agrees", "ratio"]
    rows = [["A", np.float64(5227.5), True, float("nan")], ["B", 4982, np.bool_(False), np.float32(0.5)]]
    c, x = write_table(tmp_path / "forces.csv", header, rows)
    assert c.name == "forces.csv" and x.name == "forces.xlsx" and x.exists()
    with c.open(encoding="utf-8") as fh:
        got = list(csv.reader(fh))
    assert got == [header, ["A", "5227.5", "yes", ""], ["B", "4982", "no", "0.5"]]
    h, body = read_xlsx(x)
    assert h == header
    assert body == [["A", 5227.5, "yes", None], ["B", 4982, "no", 0.5]]
    assert isinstance(body[0][1], float)  # numbers stay numbers in the workbook
    # a stem without suffix gets both suffixes; a rewrite replaces both
    c2, x2 = write_table(tmp_path / "other", ["x"], [[1]])
    assert (c2.name, x2.name) == ("other.csv", "other.xlsx")
    write_table(tmp_path / "other", ["x"], [[2]])
    assert read_xlsx(x2)[1] == [[2]]
    assert not list(tmp_path.glob(".*.tmp"))


def test_doe_analyze_tables_as_csv_and_xlsx(tmp_path):
    from pathlib import Path

    from berryshaker.experiment.field_results import analyze_sheet
    from berryshaker.report.table_files import write_doe_tables

    sheet = Path(__file__).parents[1] / "data" / "minitab_l9_replicated.csv"
    _, res = analyze_sheet(sheet, {"efficiency": True, "damage": False})
    files = write_doe_tables(res, tmp_path)
    assert sorted(f.name for f in files) == sorted(f"{s}.{e}" for s in ("range_efficiency", "range_damage", "optimum")
                                                   for e in ("csv", "xlsx"))
    header, rows = read_xlsx(tmp_path / "range_efficiency.xlsx")
    assert header[:2] == ["factor", "k1 (kg/min)"]
    ra = res.responses["efficiency"]
    for row in rows:  # the workbook holds the analysis' numbers
        assert row[1:4] == pytest.approx(ra.factors[row[0]].level_means, rel=1e-14)  # Excel: 15 digits
        assert row[6] == pytest.approx(ra.anova.factors[row[0]].f, rel=1e-14)
    _, opt = read_xlsx(tmp_path / "optimum.xlsx")
    pred = next(r for r in opt if r[:2] == ["predicted", "efficiency"])
    assert pred[2] == pytest.approx(res.optimum.values["efficiency"], rel=1e-14) and pred[3] == "kg/min"
