"""Command-line polish (issue "A report and a command line an engineer is glad to hand on"): formats from
file names, file modes, help texts, printed "wrote" lines, field-sheet plan/analyze destinations and clean
errors."""

from __future__ import annotations

import json
import os
import re
import stat

import pandas as pd
import pytest
from typer.testing import CliRunner

from berryshaker.cli import app

runner = CliRunner()
FACTORS = ["--factor", "A=0.25,0.5,0.75mm", "--factor", "B=0.2,0.4,0.6mm", "--factor", "C=0.1,0.15,0.2mm",
           "--factor", "F=0.1,0.15,0.2mm"]


def _run(args):
    return runner.invoke(app, args, env={"COLUMNS": "200", "TERM": "dumb"})


def _mode(path) -> int:
    return stat.S_IMODE(os.stat(path).st_mode)


# ---- cam-profile --------------------------------------------------------------------------------------
def test_cam_profile_format_from_extension_and_file_mode(tmp_path):
    mask = os.umask(0o022)
    try:
        r = _run(["cam-profile", "--out", str(tmp_path / "cam.dxf"), "--points", "361"])
        assert r.exit_code == 0, r.output
        assert (tmp_path / "cam.dxf").read_text().lstrip().startswith("0")  # DXF group codes, not CSV
        r = _run(["cam-profile", "--out", str(tmp_path / "cam.csv"), "--points", "361"])
        assert r.exit_code == 0, r.output
        assert (tmp_path / "cam.csv").read_text().startswith("cam_angle_deg,")
        # the DXF gets the same mode as the CSV: 0666 less the umask (it was 0600 from tempfile.mkstemp)
        assert _mode(tmp_path / "cam.dxf") == _mode(tmp_path / "cam.csv") == 0o644
    finally:
        os.umask(mask)


def test_cam_profile_refuses_mismatch_folder_unknown_extension_and_existing(tmp_path):
    r = _run(["cam-profile", "--out", str(tmp_path / "cam.dxf"), "--format", "csv"])
    assert r.exit_code == 2 and "does not match" in r.output and not (tmp_path / "cam.dxf").exists()
    r = _run(["cam-profile", "--out", str(tmp_path)])
    assert r.exit_code == 2 and "is a folder" in r.output
    r = _run(["cam-profile", "--out", str(tmp_path / "cam.txt")])
    assert r.exit_code == 2 and "*.csv or *.dxf" in r.output
    (tmp_path / "g.csv").write_text("mine")
    r = _run(["cam-profile", "--out", str(tmp_path / "g.csv"), "--points", "361"])
    assert r.exit_code == 2 and "--force" in r.output and (tmp_path / "g.csv").read_text() == "mine"
    assert "Traceback" not in r.output


# ---- help texts ---------------------------------------------------------------------------------------
def test_help_keeps_brackets_and_shows_flags_as_flags():
    r = _run(["config", "init", "--help"])
    assert r.exit_code == 0
    assert "[study], [assumed] or [calibrated]" in r.output
    r = _run(["doe", "plan", "--help"])
    assert "NAME=v1,v2,v3[unit]" in r.output
    r = _run(["simulate", "--help"])
    assert "<bool>" not in r.output
    assert re.search(r"--json\s+Print one JSON object", r.output)
    assert re.search(r"--model\s+-m\s+<str>", r.output)  # options with a value keep their placeholder


# ---- simulate ------------------------------------------------------------------------------------------
def test_simulate_multibody_shows_guide_reaction_and_plots_joint_panels(tmp_path):
    r = _run(["simulate", "--model", "multibody", "--revolutions", "2", "--out", str(tmp_path / "sim")])
    assert r.exit_code == 0, r.output
    assert "revolutions 2..2" in r.output and "..N" not in r.output
    flat = " ".join(r.output.split())  # the comb load moment says what it is: per comb, which load model (issue 45)
    assert "one comb at a time; load model: the aggregate bush spring-damper" in flat
    # (the table's columns: clearance, static-equivalent, peak, ...: the guide has neither clearance nor impacts)
    assert re.search(r"guide reaction G\+H \(net normal\)\s*│?\s*│?\s*│?\s*[\d.]+ N", r.output)
    header = (tmp_path / "sim" / "timeseries.csv").read_text().splitlines()[0]
    assert "guide_normal_N" in header.split(",")
    assert (tmp_path / "sim" / "collision_forces.png").exists()
    s = json.loads((tmp_path / "sim" / "summary.json").read_text())
    assert s["guide_reaction_N"]["G+H (net normal)"]["peak"] > 0


def test_simulate_refuses_a_user_folder_before_any_work(tmp_path):
    (tmp_path / "notes.txt").write_text("mine")
    r = _run(["simulate", "--out", str(tmp_path)])
    assert r.exit_code == 2 and "not empty" in r.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt"]


# ---- plant ---------------------------------------------------------------------------------------------
def test_plant_plot_prints_wrote(tmp_path):
    r = _run(["plant", "--plot", str(tmp_path / "pl")])
    assert r.exit_code == 0, r.output
    assert f"wrote {tmp_path / 'pl' / 'mode_shapes.png'}" in r.output


# ---- doe plan ------------------------------------------------------------------------------------------
def test_doe_plan_html_out_writes_csv_and_html_from_the_stem(tmp_path):
    r = _run(["doe", "plan", *FACTORS, "--out", str(tmp_path / "plan.html")])
    assert r.exit_code == 0, r.output
    assert (tmp_path / "plan.csv").read_text().startswith("run,replicate,order,")
    assert (tmp_path / "plan.html").read_text().lstrip().startswith("<!doctype html>")
    assert "wrote" in r.output and "plan.csv" in r.output
    r = _run(["doe", "plan", *FACTORS, "--out", str(tmp_path / "plan.csv")])
    assert r.exit_code == 2 and "already exists" in r.output
    r = _run(["doe", "plan", *FACTORS, "--out", str(tmp_path / "plan.csv"), "--force"])
    assert r.exit_code == 0, r.output


def test_doe_plan_refuses_folder_and_negative_seed(tmp_path):
    r = _run(["doe", "plan", *FACTORS, "--out", str(tmp_path)])
    assert r.exit_code == 2 and "is a folder" in r.output
    r = _run(["doe", "plan", *FACTORS, "--randomize", "--seed", "-5", "--out", str(tmp_path / "p.csv")])
    assert r.exit_code == 2 and "--seed -5" in r.output and "Traceback" not in r.output
    assert list(tmp_path.iterdir()) == []


# ---- doe analyze ---------------------------------------------------------------------------------------
@pytest.fixture()
def filled(tmp_path):
    r = _run(["doe", "plan", *FACTORS, "--replicates", "1", "--out", str(tmp_path / "plan.csv")])
    assert r.exit_code == 0, r.output
    df = pd.read_csv(tmp_path / "plan.csv")
    df["efficiency_kg_min"] = 4.1 - 0.8 * df["A_mm"] - 0.3 * df["B_mm"] + [0.01, -0.02, 0, 0.03, 0, -0.01, 0.02,
                                                                            0, -0.03]
    df["unripe_rate_pct"] = [3.0, 3.65, 3.2, 3.1, 3.4, 3.0, 3.3, 3.5, 3.2]
    df["damage_rate_pct"] = [2.5, 2.8, 3.0, 2.6, 2.9, 2.7, 3.1, 2.4, 2.6]
    path = tmp_path / "filled.csv"
    df.to_csv(path, index=False)
    return path


def test_doe_analyze_out_html_and_json_with_weights(filled, tmp_path):
    args = ["doe", "analyze", str(filled), "--maximize", "efficiency", "--minimize", "unripe,damage",
            "--weights", "efficiency=0.5,damage=0.3,unripe=0.2"]
    r = _run([*args, "--out", str(tmp_path / "an.html")])
    assert r.exit_code == 0, r.output
    assert "weights: efficiency 0.50, damage 0.30, unripe 0.20" in r.output
    assert f"wrote {tmp_path / 'an.html'}" in r.output
    page = (tmp_path / "an.html").read_text()
    assert "Weights of the composite score: efficiency 0.50, damage 0.30, unripe 0.20" in page
    r = _run([*args, "--out", str(tmp_path / "an.json")])
    assert r.exit_code == 0, r.output
    data = json.loads((tmp_path / "an.json").read_text())
    assert data["weights"] == pytest.approx({"efficiency": 0.5, "damage": 0.3, "unripe": 0.2})
    r = _run([*args, "--out", str(tmp_path / "an.txt")])
    assert r.exit_code == 2 and ".html or .json" in r.output


def test_doe_analyze_values_print_with_consistent_decimals(filled):
    r = _run(["doe", "analyze", str(filled), "--maximize", "efficiency", "--minimize", "unripe"])
    assert r.exit_code == 0, r.output
    line = next(ln for ln in r.output.splitlines() if "weighted optimum" in ln)
    numbers = re.findall(r"(?:efficiency|unripe) (\d+\.\d+)", line)
    assert len(numbers) == 2 and all(len(n.split(".")[1]) == 3 for n in numbers), line
    assert "(0.25 mm)" in line or "(0.75 mm)" in line or "(0.5 mm)" in line  # level values with units
    assert "equal: no --weights given" in r.output


def test_doe_analyze_accepts_plain_factor_columns(filled, tmp_path):
    df = pd.read_csv(filled)
    plain = df[["run", "A_mm", "B_mm", "C_mm", "F_mm", "efficiency_kg_min"]].rename(
        columns={"A_mm": "A", "B_mm": "B", "C_mm": "C", "F_mm": "F"})
    path = tmp_path / "plain.csv"
    plain.to_csv(path, index=False)
    r = _run(["doe", "analyze", str(path), "--maximize", "efficiency", "--json"])
    assert r.exit_code == 0, r.output
    s = json.loads(r.stdout)
    assert set(s["optimum"]["levels"]) == set("ABCF")
    assert s["factors"]["A"]["values"] == [0.25, 0.5, 0.75]


@pytest.mark.parametrize("extra, message", [
    (["--maximize", "efficiency", "--weights", "efficiency=0"], "must be a finite number > 0"),
    (["--maximize", "bogus"], "unknown response 'bogus'"),
    (["--maximize", "efficiency", "--weights", "efficiency"], "is not NAME=VALUE"),
    (["--maximize", "efficiency", "--minimize", "efficiency"], "both --maximize and --minimize"),
])
def test_doe_analyze_clean_errors(filled, extra, message):
    r = _run(["doe", "analyze", str(filled), *extra])
    assert r.exit_code == 2, r.output
    assert message in r.output and "Traceback" not in r.output


# ---- README --------------------------------------------------------------------------------------------
def test_readme_command_table_is_one_table_and_cites_docs_study():
    from pathlib import Path

    text = (Path(__file__).resolve().parents[2] / "README.md").read_text()
    section = text.split("## Commands", 1)[1].split("\n## ", 1)[0]
    lines = section.strip().splitlines()
    start = next(i for i, ln in enumerate(lines) if ln.startswith("| command"))
    end = next(i for i in range(start, len(lines)) if not lines[i].startswith("|"))
    assert not any(ln.startswith("| `berryshaker") for ln in lines[end:]), "a blank line splits the table"
    assert "STUDY.md" not in text and "docs/study.md" in text
    assert "nothing you made or changed" in " ".join(text.split())
    assert len(text.splitlines()) < 150  # a page or two: history lives in CHANGELOG.md


def test_readme_lists_every_command_a_user_install_what_the_tests_need_and_the_study_time():
    """#58: no time for a first study, only the test install shown, calibrate and compare-machines missing from the
    command table, the tests' Chromium and pdftotext said by CI only, "a repeated one takes seconds" (73 CPU-s), no
    local Dask cluster step by step."""
    import re
    from pathlib import Path

    import typer

    text = (Path(__file__).resolve().parents[2] / "README.md").read_text()
    table = text.split("## Commands", 1)[1].split("\n## ", 1)[0]
    listed = set(re.findall(r"^\| `berryshaker ([a-z-]+)", table, flags=re.M))
    listed |= {w.strip().strip("`") for row in re.findall(r"^\| `berryshaker ([^|]*)\|", table, flags=re.M)
               for w in row.split(",") if w.strip().startswith("`")}
    commands = {c.name or c.callback.__name__.replace("_", "-") for c in app.registered_commands}
    groups = {g.name for g in app.registered_groups}
    missing = sorted((commands | groups) - listed)
    assert not missing, f"commands missing from the README's table: {missing}"
    assert isinstance(app, typer.Typer)
    assert re.search(r"pip install -e \.\s", text) and 'pip install -e ".[test]"' in text
    assert "chromium" in text and "poppler" in text and "pdftotext" in text and ".ci/run" in text
    assert re.search(r"first study\b.*took [0-9.]+ min", " ".join(text.split()))
    assert "takes seconds" not in text
    assert "dask scheduler" in text and "dask worker" in text and "--scheduler tcp://127.0.0.1" in text
