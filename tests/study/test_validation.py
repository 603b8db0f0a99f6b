"""The harvest model against the published record (berryshaker.study.validation, ``berryshaker validate``) on a
small machine (one branch class, two starts per case): every published machine result it can
represent gets a model value, an interval and a verdict; inputs and numbers it cannot represent say so."""

import json

import numpy as np
import pytest

from berryshaker.config import load_machine
from berryshaker.harvest.published_record import load_record
from berryshaker.study.validation import cases, validate, yield_factors


@pytest.fixture(scope="module")
def small(small_harvest_machine):
    return small_harvest_machine


@pytest.fixture(scope="module")
def runner(validation_cache):
    from berryshaker.runs.runner import SweepRunner

    with SweepRunner(workers=1, cache_dir=validation_cache, progress=False) as r:
        yield r


@pytest.fixture(scope="module")
def result(small, runner):
    return validate(small, runner, replicates=2)


def test_every_published_number_has_a_row_with_source_interval_and_verdict(result):
    rec = load_record()
    rows = {r["id"]: r for r in result["rows"]}
    held = [r for r in result["rows"] if r["held_out"]]
    assert len(held) >= 6 and result["summary"]["held_out"] == len(held)
    for r in held:
        assert r["source"] and r["lo"] <= r["model"] <= r["hi"] and r["noise_lo"] <= r["model"] <= r["noise_hi"]
        assert r["verdict"] == "consistent" or r["verdict"].startswith("not reproduced (model / published = ")
        assert (r["verdict"] == "consistent") == (r["lo"] <= r["published"] <= r["hi"])
    # the efficiency's interval carries the published yield's range; the shares of the picked mass do not
    lo, hi = yield_factors(rec)
    eff = rows["machine.lyu2024.optimum.efficiency"]
    assert eff["lo"] == pytest.approx(eff["noise_lo"] * lo) and eff["hi"] == pytest.approx(eff["noise_hi"] * hi)
    dmg = rows["machine.lyu2024.optimum.damage"]
    assert (dmg["lo"], dmg["hi"]) == (dmg["noise_lo"], dmg["noise_hi"])
    # "22 % sound or slightly bruised" is compared as 78 % bruised, on a hard catcher: more damage than padded
    assert rows["bruise.sound_share.conventional_machine.brown1996"]["published"] == pytest.approx(78.0)
    assert rows["bruise.sound_share.conventional_machine.brown1996"]["model"] > dmg["model"]
    # inputs are listed and not held out; what cannot be set up says why
    assert rows["bond.ripe.shear.kong2014.blue5d"]["verdict"] == "input"
    assert not rows["bond.ripe.shear.kong2014.blue5d"]["held_out"]
    chen = rows["machine.chen.picking_rate"]
    assert chen["verdict"] == "not represented" and chen["model"] is None and "not in the abstract" in chen["how"]
    assert json.loads(json.dumps(result)) == result  # --json as is


def test_faster_shaking_of_the_same_comb_picks_more(result):
    """The GYL062 case drives this comb at 24 rad/s, twice the reference speed: more removal, more efficiency."""
    rows = {r["id"]: r for r in result["rows"]}
    assert rows["machine.gyl062.hunau2014.efficiency"]["model"] > rows["machine.lyu2024.optimum.efficiency"]["model"]


def test_the_study_case_is_for_the_study_drive_only():
    assert cases(load_machine(None))[0].name.startswith("reference study")
    rocker = load_machine(None, drive="crank_rocker")
    assert not any(c.name.startswith("reference study") for c in cases(rocker))


def test_validate_command_prints_the_table_and_json(small, runner, tmp_path):
    """The command on the same small description (its runs come from the cache of the library call)."""
    import tomllib

    from typer.testing import CliRunner

    from berryshaker.cli import app

    from importlib import resources

    text = (resources.files("berryshaker") / "drives" / "groove_cam" / "reference.toml").read_text("utf-8")
    from fast_machine import with_values

    text = with_values(text, {"harvest.branch_classes": "[1.0]"})
    cfg = tmp_path / "small.toml"
    cfg.write_text(text, encoding="utf-8")
    assert tomllib.loads(text)["harvest"]["branch_classes"] == [1.0]
    res = CliRunner().invoke(app, ["validate", "--config", str(cfg), "--replicates", "2", "--workers", "1",
                                   "--json", "--cache", str(runner.cache_dir)])
    assert res.exit_code == 0, res.output
    data = json.loads(res.stdout)
    assert data["replicates"] == 2 and {"rows", "summary", "version"} <= set(data)
    assert np.isfinite([r["model"] for r in data["rows"] if r["held_out"]]).all()
