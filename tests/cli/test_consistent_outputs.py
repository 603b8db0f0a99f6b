"""Every output consistent (#58): the drive moment named by the drive, the table's and the figure's peaks one
statistic, progress on stderr while --json keeps stdout pure JSON, and unresolved Sobol indices named with the N
to try in --json runs too."""

from __future__ import annotations

import json
import re
from pathlib import Path

from typer.testing import CliRunner

from berryshaker.cli import app

runner = CliRunner()
CRANK = str(Path(__file__).parents[2] / "examples" / "crank_rocker_harvester.toml")


def test_the_crank_rockers_table_and_figure_give_one_peak(tmp_path, monkeypatch):
    """#58: its table said "cam drive moment" and its figure's peaks were the written samples' (C 7,062 N), the
    table's over every integrator step (10,200 N)."""
    import berryshaker.report.plots as plots

    seen = {}
    real = plots.plot_joint_forces

    def spy(*args, **kwargs):  # the real figure, its arguments kept
        seen.update(kwargs.get("peaks") or {})
        seen["drawn"] = real(*args, **kwargs, return_figure=False)
        return seen["drawn"]

    monkeypatch.setattr(plots, "plot_joint_forces", spy)
    r = runner.invoke(app, ["simulate", "--model", "multibody", "--config", CRANK, "--revolutions", "2",
                            "--out", str(tmp_path / "run")], env={"COLUMNS": "200"})
    assert r.exit_code == 0, r.output
    assert "crank drive moment" in r.stdout and "cam drive moment" not in r.stdout
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    for pair, st in summary["collision_force_N"].items():
        assert re.search(rf"collision force {pair}\s.*\s{st['peak']:.1f} N", r.stdout)  # the table's peak ...
        assert seen[pair] == st["peak"] == seen["drawn"]["series"][pair]["stated_peak"]  # ... is the figure's
        assert seen["drawn"]["series"][pair]["peak_abs"] <= st["peak"]  # the samples drawn can miss it
    r = runner.invoke(app, ["simulate", "--revolutions", "2"], env={"COLUMNS": "200"})
    assert r.exit_code == 0 and "cam drive moment" in r.stdout  # the groove cam's driver


def test_json_runs_show_progress_on_stderr_and_name_unresolved_sobol_indices(tmp_path):
    """#58: `--json` runs printed no progress at all, and `sensitivity -N 16 --json` gave negative indices with
    intervals wider than the estimates without a word.  stdout stays one JSON object."""
    r = runner.invoke(app, ["sensitivity", "-N", "2", "--revolutions", "2", "--output", "collision_force_C_peak",
                            "--workers", "1", "--cache", str(tmp_path / "cache"), "--json"])
    assert r.exit_code == 0, r.output
    res = json.loads(r.stdout)
    rz = res["resolution"]["collision_force_C_peak"]
    assert rz["unresolved"] and rz["suggested_samples"] > 2
    assert "sensitivity" in r.stderr and "12/12" in r.stderr  # the runs' progress
    assert f"does not resolve {len(rz['unresolved'])} index(es)" in r.stderr
    assert f"Try -N {rz['suggested_samples']}" in r.stderr
