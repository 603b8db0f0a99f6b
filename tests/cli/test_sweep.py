"""The sweep's terminal table: a --model harvest sweep prints each point's harvest indexes, not only "ok"
(issue 45)."""

from __future__ import annotations

from types import SimpleNamespace

from rich.console import Console

from berryshaker.cli.study import sweep_display
from berryshaker.report.tables import rich_table
from berryshaker.runs.runner import RunResult
from berryshaker.runs.sweep import tidy_rows


def test_harvest_sweep_prints_removal_shedding_damage_and_efficiency_per_point():
    params = [SimpleNamespace(key="cam.speed", unit="rpm")]
    value = {"ripe_removal_pct": 91.234, "unripe_shed_pct": 12.5, "damage_rate_pct": 3.21, "unripe_rate_pct": 4.0,
             "efficiency_kg_min": 3.6012, "ripe_removal_pct_sd": 1.23, "unripe_shed_pct_sd": 0.8,
             "damage_rate_pct_sd": 0.31, "efficiency_kg_min_sd": 0.11, "replicates": 8}
    results = [RunResult(0, "k0", value, None, False, 1.0), RunResult(1, "k1", None, "diverged", False, 1.0)]
    header, rows = tidy_rows(params, [[120.0], [180.0]], results)
    show, shown = sweep_display(header, rows, 1)
    assert show == ["run", "cam.speed[rpm]", "status", "ripe removal (%)", "unripe shedding (%)", "damage (%)",
                    "efficiency (kg/min)"]
    assert shown[0] == [1, 120.0, "ok", "91.2±1.2", "12.5±0.8", "3.21±0.31", "3.6±0.11"]
    assert shown[1][2] == "failed" and shown[1][3:] == ["", "", "", ""]
    c = Console(width=80, record=True, file=open("/dev/null", "w"))
    c.print(rich_table(show, shown, width=80))
    text = c.export_text()
    assert "91.2±1.2" in text and "3.6±0.11" in text and "┃ run" in text  # one row per point, not stacked


def test_dynamics_sweep_still_shows_peak_forces():
    params = [SimpleNamespace(key="clearance.A.size", unit="mm")]
    value = {"collision_force_N": {"A": {"peak": 1000.0, "mean": 10.0, "rms": 50.0}}}
    header, rows = tidy_rows(params, [[0.25]], [RunResult(0, "k", value, None, False, 1.0)])
    show, shown = sweep_display(header, rows, 1)
    assert show == ["run", "clearance.A.size[mm]", "status", "collision_force_A_peak_N"] and shown[0][-1] == 1000.0
