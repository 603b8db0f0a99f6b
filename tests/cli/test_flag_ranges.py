"""Every number a user can type is range-checked where it is read, before any work, and every JSON berryshaker
writes is strict (issue 59, "Flags and numbers accepted without a word"): `compare --alpha nan|inf|0|1|2`,
`tolerance --limit` with an unknown joint or a negative limit (every life 0 h), `wear --limit` negative or huge,
`--clearance A=1e-400mm` read as 0 and `A=1e-12mm` accepted (machine files refuse under 1 um), "1e-999 mm" in a
machine file read as 0, a duplicated `--weights` key silently overridden, `calibrate --predict A=1e9mm` starting the
full calibration, `compare --starts 1000000` / `plant --replicates 1000000` with no bound, a 100,000-point sweep
silent while it validates, and NaN in summary.json."""

from __future__ import annotations

import json
import math
import tomllib
from dataclasses import dataclass

import pytest
from typer.testing import CliRunner

from berryshaker.cli import app
from berryshaker.config import machine_from_dict, reference_toml_text
from berryshaker.errors import ConfigError
from berryshaker.records import JsonRecord

cli = CliRunner()


def _refused(args: list[str], *needles: str) -> str:
    r = cli.invoke(app, args)
    assert r.exit_code == 2, (args, r.output, r.exception)
    assert "Traceback" not in r.output and all(n in r.output for n in needles), (args, r.output)
    return r.output


@pytest.mark.parametrize("alpha", ["nan", "inf", "-inf", "0", "1", "2", "-0.1"])
def test_compare_alpha_is_a_probability(alpha):
    _refused(["compare", "--starts", "0", "--alpha", alpha], "--alpha", "(0, 1)")


@pytest.mark.parametrize("flag, value", [("compare", "1000000"), ("plant", "1000000")])
def test_counts_are_bounded_where_read(flag, value):
    args = (["compare", "--starts", value] if flag == "compare" else
            ["plant", "--convergence", "--replicates", value])
    _refused(args, "--starts" if flag == "compare" else "--replicates", "1000")


def test_worker_counts_are_bounded(tmp_path):
    """`study --workers 100000000` started processes until killed (a hang on two cores)."""
    from berryshaker.runs.runner import max_workers

    for args in (["study", "--out", str(tmp_path / "s")], ["sweep", "--param", "clearance.A.size=0.1..0.2mm"]):
        _refused([*args, "--workers", "100000000"], "--workers 100,000,000", f"at most {max_workers()}")
    assert not (tmp_path / "s").exists()


@pytest.mark.parametrize("limit, needle", [
    ("clearance:Z=0.3mm", "'Z' is not a clearance pair"), ("clearance:C=-0.3mm", "positive"),
    ("clearance:C=0mm", "positive"), ("clearance:C=1e9mm", "too large"), ("peak_force:A=-8000N", "positive"),
    ("peak_force:A=1e30N", "too large"),
])
def test_service_limits_name_a_joint_and_a_positive_bounded_value(limit, needle):
    _refused(["tolerance", "--limit", limit, "--points", "2"], "--limit", needle)
    if not limit.startswith("peak_force") or "e30" in limit or "-" in limit:
        _refused(["wear", "--hours", "1", "--limit", limit], "--limit", needle)
    _refused(["wear", "--hours", "1", "--limit", "clearance:C=0.3mm", "--limit", "clearance:C=0.4mm"], "twice")


@pytest.mark.parametrize("size, needle", [("1e-400mm", "underflow"), ("1e-12mm", "too small"),
                                          ("1e9mm", "too large")])
def test_clearance_flags_are_bounded_as_machine_files_are(size, needle):
    _refused(["simulate", "-n", "2", "--clearance", f"A={size}"], needle)


def test_an_underflowing_value_in_a_machine_file_is_refused():
    data = tomllib.loads(reference_toml_text())
    data["clearance"]["A"]["size"] = "1e-999 mm"
    with pytest.raises(ConfigError, match=r"clearance\.A\.size.*underflow"):
        machine_from_dict(data, "test", units_required=True)
    data["clearance"]["A"]["size"] = "0e-999 mm"  # a zero written so is zero
    assert machine_from_dict(data, "test", units_required=True).clearance["A"].size == 0.0


def test_a_weight_given_twice_is_refused(tmp_path):
    _refused(["doe", "analyze", str(tmp_path / "missing.csv"), "--maximize", "efficiency", "--weights",
              "efficiency=0.5,efficiency=0.7"], "--weights", "twice")


def test_calibrate_refuses_an_impossible_prediction_before_any_work(tmp_path, monkeypatch):
    import berryshaker.study.field_calibration as fc

    def never(*a, **k):
        raise AssertionError("the calibration started")

    monkeypatch.setattr(fc, "calibrate", never)
    sheet = tmp_path / "sheet.csv"
    r = cli.invoke(app, ["doe", "plan", "--array", "L4", "--factor", "A=0.1,0.2mm", "--factor", "C=0.1,0.2mm",
                         "--replicates", "2", "--out", str(sheet)])
    assert r.exit_code == 0, r.output
    lines = sheet.read_text().strip().split("\n")
    head = lines[0].split(",")
    k = head.index("efficiency_kg_min")
    rows = [ln.split(",") for ln in lines[1:]]
    for i, row in enumerate(rows):
        row[k] = f"{2.0 + 0.1 * i:.2f}"
    sheet.write_text("\n".join([lines[0]] + [",".join(r) for r in rows]) + "\n")
    for predict, needle in (("A=1e9mm", "--predict"), ("A=1e-12mm", "too small"), ("A=-1mm", "> 0")):
        _refused(["calibrate", str(sheet), "--predict", predict], needle)


def test_a_long_sweep_says_what_it_prepares(monkeypatch, capsys):
    """`sweep --points 100000` spent 143 CPU-s building a machine per point before printing anything."""
    import berryshaker.runs.sweep as sweep
    from berryshaker.config import reference_machine

    monkeypatch.setattr(sweep, "VALIDATE_PROGRESS_FROM", 3)
    m = reference_machine()
    params = [sweep.parse_param("clearance.A.size=0.1..0.3mm", m)]
    sweep.validate_points(m, params, sweep.sample_params(params, "grid", 4, 0), 2, progress=False)
    assert "validating 4 sweep points before any run" in capsys.readouterr().err


# ---- strict JSON --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class _Stat(JsonRecord):
    """A record with a float that may be NaN.

    Attributes
    ----------
    mean : float
        A mean.
    sd : float or None
        Its SD, when known.
    """

    mean: float
    sd: float | None = None


def _strict(text: str):
    def bad(c):
        raise ValueError(f"{c} is not JSON")

    return json.loads(text, parse_constant=bad)


def test_json_outputs_are_strict_and_say_what_was_null(tmp_path):
    """summary.json held 11 NaN values, which strict parsers reject: now null, each listed with its reason, and
    read back as NaN where the record's field is a float."""
    from berryshaker.outputs import strict_json_text, write_json_atomic

    obj = {"results": {"a": _Stat(math.nan).to_json(), "b": [1.0, math.inf]}, "n": 3}
    write_json_atomic(tmp_path / "summary.json", obj)
    saved = _strict((tmp_path / "summary.json").read_text())
    assert saved["results"]["a"]["mean"] is None and saved["results"]["b"][1] is None
    assert saved["null_values"] == {"results.a.mean": "not a finite number (nan): written as null",
                                    "results.b[1]": "not a finite number (inf): written as null"}
    back = _Stat.from_json(saved["results"]["a"])
    assert math.isnan(back.mean) and back.sd is None
    with pytest.raises(Exception, match="not a finite number"):
        strict_json_text([math.nan])


def test_every_json_a_command_writes_is_strict(tmp_path):
    r = cli.invoke(app, ["simulate", "-n", "2", "--out", str(tmp_path / "run")])
    assert r.exit_code == 0, r.output
    r = cli.invoke(app, ["kinematics", "--json"])
    assert r.exit_code == 0, r.output
    _strict(r.stdout)
    files = list(tmp_path.rglob("*.json"))
    assert len(files) >= 2  # summary.json and the output marker
    for f in files:
        _strict(f.read_text())
