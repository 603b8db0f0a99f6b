"""Figures have one home (issue 46): every figure is a function of berryshaker.report.plots over report/style.py; the
life commands and the study's life step call them; the plots modules stay under 700 lines each."""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest

import berryshaker
from berryshaker.report import plots as P
from berryshaker.report.style import audit_figure, canvas_overflow, pyplot

SRC = Path(berryshaker.__file__).parent


@pytest.mark.parametrize("rel", ["cli/life.py", "study/steps/clearance_life.py"])
def test_life_figures_are_drawn_by_report_plots_not_raw_matplotlib(rel):
    tree = ast.parse((SRC / rel).read_text(encoding="utf-8"))
    mods = {a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
    mods |= {n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.module}
    assert not [m for m in mods if m.startswith("matplotlib")], f"{rel} draws with matplotlib itself"
    assert "berryshaker.report.plots.life" in mods


def test_plots_modules_under_700_lines_and_the_old_names_still_import():
    files = sorted((SRC / "report" / "plots").glob("*.py"))
    assert len(files) >= 4
    for f in files:
        assert f.read_text(encoding="utf-8").count("\n") < 700, f
    for name in ("plot_bars", "plot_fruit_force", "plot_groove", "plot_harvest_response", "plot_joint_forces",
                 "plot_main_effects", "plot_mode_shapes", "plot_replicated_effects", "plot_response_surfaces",
                 "plot_svaj", "plot_time_series", "plot_tradeoff", "write_kinematics_figures"):
        assert callable(getattr(P, name))


def test_life_figures_draw_their_data_in_the_style(tmp_path):
    from berryshaker.report.plots.life import plot_clearance_growth, plot_fit_front, plot_sobol

    hours = np.linspace(0, 2000, 5)
    growth = {"A": {"hours": hours, "clearance_mm": 0.25 + 1e-4 * hours},
              "C": {"hours": hours, "clearance_mm": 0.1 + 2e-4 * hours}}
    d = plot_clearance_growth(growth, {"A": 0.75, "C": None}, tmp_path / "g.png", return_figure=True)
    assert d["limits"] == {"A": 0.75}
    np.testing.assert_array_equal(d["series"]["C"]["clearance_mm"], growth["C"]["clearance_mm"])
    ind = {"clearance.A.size": {"S1": 0.6, "S1_conf": 0.1, "ST": 0.7, "ST_conf": 0.1},
           "clearance.B.size": {"S1": None, "S1_conf": None, "ST": 0.05, "ST_conf": 0.02}}
    s = plot_sobol(ind, "collision_force_A_peak", tmp_path / "s.png", return_figure=True)
    assert s["bars"] == {"S1": [0.6, 0.0], "ST": [0.7, 0.05]}
    front = [{"cost": 1.0, "design_force_N": 5000.0, "life_h": 800.0}, {"cost": 2.0, "design_force_N": 4000.0,
                                                                        "life_h": 1500.0}]
    f = plot_fit_front(front, {"cost": 2.0, "design_force_N": 4000.0, "fits": {"A": "H7/f7"}}, tmp_path / "f.png",
                       return_figure=True)
    np.testing.assert_array_equal(f["points"]["life_h"], [800.0, 1500.0])
    for data in (d, s, f):
        fig = data["figure"]
        assert audit_figure(fig) == []
        assert max(canvas_overflow(fig)) == 0.0
        assert Path(data["svg"]).is_file() and Path(data["path"]).is_file()
        pyplot().close(fig)
