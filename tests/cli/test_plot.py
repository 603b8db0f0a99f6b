"""``berryshaker plot`` and ``berryshaker animate`` on a run saved by ``simulate --out`` (#58: an ADAMS user plots
any saved signal against time or another signal, and keeps an animation of the run)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from berryshaker.cli import app

runner = CliRunner()


@pytest.fixture(scope="module")
def saved_run(tmp_path_factory):
    """An MLSD run of the reference machine over two revolutions, saved as simulate --out saves it."""
    folder = tmp_path_factory.mktemp("run") / "run"
    r = runner.invoke(app, ["simulate", "--revolutions", "2", "--out", str(folder)])
    assert r.exit_code == 0, r.output
    return folder


def _csv(folder):
    with open(folder / "timeseries.csv") as fh:
        header = fh.readline().strip().split(",")
    return header, np.loadtxt(folder / "timeseries.csv", delimiter=",", skiprows=1)


def test_any_saved_signal_against_time_or_another_signal(saved_run, tmp_path, monkeypatch):
    header, rows = _csv(saved_run)
    r = runner.invoke(app, ["plot", str(saved_run), "--y", "F_A,F_C_N,drive_moment", "--out",
                            str(tmp_path / "f.png"), "--json"])
    assert r.exit_code == 0, r.output
    res = json.loads(r.stdout)
    assert (tmp_path / "f.png").stat().st_size > 10_000 and res["x"] == {"signal": "time_s", "unit": "s"}
    for name, column, unit in (("F_A", "F_A_N", "N"), ("F_C", "F_C_N", "N"), ("drive_moment", "drive_moment_Nm",
                                                                                "N m")):
        assert res["y"][name]["unit"] == unit
        assert res["y"][name]["peak_abs"] == pytest.approx(np.max(np.abs(rows[:, header.index(column)])))
    # a phase plot, the default file name in the current folder
    monkeypatch.chdir(tmp_path)
    r = runner.invoke(app, ["plot", str(saved_run), "--x", "theta_D", "--y", "T_l"])
    assert r.exit_code == 0, r.output
    assert "T_l (peak |value|" in r.stdout and "against theta_D [rad]" in r.stdout
    assert (tmp_path / "T_l_vs_theta_D.png").is_file()
    again = runner.invoke(app, ["plot", str(saved_run), "--x", "theta_D", "--y", "T_l"])
    assert again.exit_code == 2 and "--force" in again.output  # never overwritten without --force


def test_plot_refuses_what_the_run_does_not_have(saved_run, tmp_path):
    r = runner.invoke(app, ["plot", str(saved_run), "--y", "F_Z", "--out", str(tmp_path / "z.png")])
    assert r.exit_code == 2 and "'F_Z' is not a signal" in r.output and "F_A" in r.output
    assert not (tmp_path / "z.png").exists()
    r = runner.invoke(app, ["plot", str(tmp_path), "--y", "F_A"])
    assert r.exit_code == 2 and "summary.json is missing" in r.output


def test_a_saved_run_is_animated_after_its_rerun_reproduces_it(saved_run, tmp_path):
    from PIL import Image

    r = runner.invoke(app, ["animate", str(saved_run), "--out", str(tmp_path / "a.gif"), "--frames", "4", "--json"])
    assert r.exit_code == 0, r.output
    res = json.loads(r.stdout)
    with Image.open(tmp_path / "a.gif") as im:
        assert im.n_frames == 4 and im.size[0] >= 400
    assert res["reproduced_max_force_difference_N"] < 1e-3 and 1 <= res["magnify"] <= res["largest_magnify"]
    # a run whose saved forces the model does not give is refused, nothing written
    tampered = tmp_path / "tampered"
    tampered.mkdir()
    (tampered / "summary.json").write_text((saved_run / "summary.json").read_text())
    header, rows = _csv(saved_run)
    rows[len(rows) // 2, header.index("F_C_N")] += 500.0
    np.savetxt(tampered / "timeseries.csv", rows, delimiter=",", header=",".join(header), comments="", fmt="%.9g")
    r = runner.invoke(app, ["animate", str(tampered), "--out", str(tmp_path / "b.gif"), "--frames", "4"])
    assert r.exit_code == 2 and "collision force at C differs from the saved one" in r.output
    assert not (tmp_path / "b.gif").exists()
    r = runner.invoke(app, ["animate", str(saved_run), "--out", str(tmp_path / "c.avi")])
    assert r.exit_code == 2 and ".gif" in r.output
