"""The harvest model against the published record (berryshaker.study.validation, ``berryshaker validate``) on a
small machine (one branch class, two starts per case): every published machine result it can
represent gets a model value, an interval and a verdict; inputs and numbers it cannot represent say so."""

import json

import numpy as np
import pytest

from berryshaker.config import load_machine
from berryshaker.harvest.published_record import load_record
from berryshaker.study.validation import NO_VERDICT_SPAN, cases, validate, yield_factors


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
    assert len(rows) >= 10 and result["summary"]["held_out"] == sum(r["held_out"] for r in rows.values())
    judged = [r for r in rows.values() if r["verdict"] == "consistent" or r["verdict"].startswith("not reproduced")]
    assert len(judged) >= 4  # two starts per case here: the wider intervals of the study's eight decide more
    for r in judged:
        assert r["held_out"] and r["source"] and r["lo"] <= r["model"] <= r["hi"]
        if r["verdict"] == "consistent" and r["lo"] > 0:  # a "consistent" that could have failed
            assert r["hi"] / r["lo"] <= NO_VERDICT_SPAN
    # the efficiency's interval carries the published yield's range, more than a factor of ten: no verdict, and the
    # yield at which the model would match is said
    lo, hi = yield_factors(rec)
    eff = rows["machine.lyu2024.optimum.efficiency"]
    assert eff["lo"] == pytest.approx(eff["noise_lo"] * lo) and eff["hi"] == pytest.approx(eff["noise_hi"] * hi)
    assert eff["verdict"].startswith("no verdict") and "kg of fruit per bush" in eff["verdict"]
    dmg = rows["machine.lyu2024.optimum.damage"]
    assert (dmg["lo"], dmg["hi"]) == (dmg["noise_lo"], dmg["noise_hi"])
    inside = dmg["lo"] <= dmg["published"] <= dmg["hi"]
    assert inside != dmg["verdict"].startswith("not reproduced")
    if inside:  # "consistent" only where it could have failed
        wide = dmg["hi"] > NO_VERDICT_SPAN * dmg["lo"]
        assert dmg["verdict"].startswith("no verdict") if wide else dmg["verdict"] == "consistent"
    # "22 % sound or slightly bruised" is compared as 78 % bruised, on a hard catcher: more damage than padded
    assert rows["bruise.sound_share.conventional_machine.brown1996"]["published"] == pytest.approx(78.0)
    assert rows["bruise.sound_share.conventional_machine.brown1996"]["model"] > dmg["model"]
    # pack-out on a padded catcher bounds the published one from above; soft against hard is a paired difference
    duke = rows["machine.modified_otr.devetter2019.packout_duke"]
    assert duke["model"] == pytest.approx(100 - rows["machine.lyu2024.optimum.unripe"]["model"] - dmg["model"])
    assert (duke["verdict"] == "consistent") == (duke["published"] <= duke["hi"])
    soft_hard = rows["machine.modified_otr.devetter2019.soft_vs_hard"]
    assert soft_hard["published"] == 0 and soft_hard["model"] > 0  # a hard catcher bruises more
    assert (soft_hard["verdict"] == "consistent") == (soft_hard["lo"] <= 0 <= soft_hard["hi"])
    # inputs are listed and not held out; what the description does not represent says why and runs nothing
    assert rows["bond.ripe.shear.kong2014.blue5d"]["verdict"] == "input"
    assert not rows["bond.ripe.shear.kong2014.blue5d"]["held_out"]
    for rid in ("machine.chen.picking_rate", "machine.gyl062.hunau2014.fruit_damage",
                "machine.handheld.takeda2017.packable_max", "shake.immature_fraction.malladi2013.shb_max"):
        assert rows[rid]["verdict"] == "not comparable" and rows[rid]["model"] is None, rid
        assert rows[rid]["held_out"] and rows[rid]["how"].startswith("not comparable: "), rid
    assert json.loads(json.dumps(result)) == result  # --json as is


def test_the_study_case_is_for_the_study_drive_only():
    assert cases(load_machine(None))[0].name.startswith("reference study")
    rocker = load_machine(None, drive="crank_rocker")
    assert not any(c.name.startswith("reference study") for c in cases(rocker))


def test_validate_command_prints_the_table_and_json(small, runner, tmp_path):
    """The command on the same small description (its runs come from the cache of the library call)."""
    import tomllib
    from importlib import resources

    from typer.testing import CliRunner

    from berryshaker.cli import app

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
    assert np.isfinite([r["model"] for r in data["rows"] if r["held_out"] and r["verdict"] != "not comparable"]).all()
