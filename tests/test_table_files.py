"""Tables as CSV and .xlsx through one writer (report/table_files.py, issue 45)."""

from __future__ import annotations

import csv

import numpy as np

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
