"""The whole study on the second registered drive (the crank-rocker, examples/crank_rocker_harvester.toml): a drive
with no reduced model, so the steps' records take their other paths (no model agreement, rows without the MLSD, the
model check and the per-row agreement; a crank instead of a cam in the kinematics), and the claims about the
reference machine's pairs are not comparable.  The study runs through, and its saved results read back as the
typed records, key for key."""

import json
from pathlib import Path

from typer.testing import CliRunner

from berryshaker.cli import app
from berryshaker.study.step_result import StudyResults

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "crank_rocker_harvester.toml"


def _fast(text: str) -> str:
    """The example machine, made cheap the way the reference study's pipeline test makes its machine cheap: one
    branch class, two starts per setting."""
    from fast_machine import fast_text

    return fast_text(text, insert=True)  # the example leaves the starts at their defaults


def test_a_drive_without_a_reduced_model_runs_the_whole_study(tmp_path):
    cfg = tmp_path / "crank.toml"
    cfg.write_text(_fast(EXAMPLE.read_text(encoding="utf-8")), encoding="utf-8")
    assert "branch_classes = [1.0]" in cfg.read_text() and "replicates = 2" in cfg.read_text()
    out = tmp_path / "out"
    r = CliRunner().invoke(app, ["study", "--config", str(cfg), "--out", str(out), "--cache", str(tmp_path / "cache"),
                                 "--workers", "2", "--json"])
    assert r.exit_code == 0, r.output
    saved = json.loads((out / "summary.json").read_text())
    assert saved["drive"] == "crank_rocker" and saved["failures"] == []
    res = StudyResults.from_json(saved["results"])
    from berryshaker.outputs import finite_json

    assert json.dumps(finite_json(res.to_json())) == json.dumps(saved["results"])  # strict JSON: a NaN is null
    assert res.agreement is None and res.rows.mlsd == {} and res.rows.model_check is None
    assert res.kinematics.crank is not None and res.kinematics.cam is None
    assert res.l9.recommended.starts >= 2 and res.clearance_life is not None and res.validation is not None
    assert all(c.verdict == "not comparable" for c in res.claims if c.id not in (5, 6))
    text = (out / "report.html").read_text()
    assert "Design answers not available" not in text and "Not available" not in text
