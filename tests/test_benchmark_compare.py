"""The benchmark comparison CI runs (benchmarks/compare_baseline.py): a median more than 25 % slower than the stored
baseline is reported, a faster or equal one is not, and nothing fails the run."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "compare_baseline.py"
_spec = importlib.util.spec_from_file_location("compare_baseline", SCRIPT)
assert _spec is not None and _spec.loader is not None
compare_baseline = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(compare_baseline)


def _write(path: Path, medians: dict[str, float]) -> Path:
    path.write_text(json.dumps({"benchmarks": [{"name": k, "stats": {"median": v}} for k, v in medians.items()]}))
    return path


def test_a_median_slower_by_more_than_the_threshold_is_reported_and_nothing_fails(tmp_path, capsys):
    base = _write(tmp_path / "base.json", {"a": 0.100, "b": 0.100, "c": 0.100, "gone": 1.0})
    now = _write(tmp_path / "now.json", {"a": 0.126, "b": 0.124, "c": 0.050, "new": 1.0})
    assert compare_baseline.main([str(now), "--baseline", str(base)]) == 0
    out = capsys.readouterr().out
    lines = {ln.split()[-1]: ln.split()[0] for ln in out.splitlines() if ln.startswith(("ok", "SLOWER"))}
    assert lines == {"a": "SLOWER", "b": "ok", "c": "ok"}  # only benchmarks present in both are compared
    assert "1 of 3 benchmarks are more than 25% slower" in out


def test_the_stored_baseline_is_found_and_read():
    assert compare_baseline.BASELINE is not None and compare_baseline.BASELINE.is_file()
    medians = compare_baseline.medians(compare_baseline.BASELINE)
    assert "test_harvester_run[multibody]" in medians and all(v > 0 for v in medians.values())
