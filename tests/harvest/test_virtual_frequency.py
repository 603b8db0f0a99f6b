"""Harvest against shaking frequency: ``sweep --model harvest`` (removal curve and figure), calibration table."""

from __future__ import annotations

import csv

import pytest
from typer.testing import CliRunner

from berryshaker.cli import app

runner = CliRunner()


#: the test's machine: the reference with one branch class and two replicates (two coupled runs per speed instead
#: of the description's nine: 3 classes x 3 replicates); every other value as described
TEST_HARVEST = {"harvest.branch_classes": "[1.0]", "harvest.replicates": "2", "harvest.max_replicates": "2"}


@pytest.fixture(scope="module")
def frequency_sweep(tmp_path_factory):
    """One sweep over 60-150 r/min (three speeds; each point the replicate mean over two perturbed starts of one
    branch class, the calibration's seeds)."""
    from fast_machine import with_values

    from berryshaker.config import reference_toml_text

    d = tmp_path_factory.mktemp("freq")
    (d / "machine.toml").write_text(with_values(reference_toml_text(), TEST_HARVEST))
    res = runner.invoke(app, ["sweep", "--model", "harvest", "--param", "cam.speed=60..150rpm", "--points", "3",
                              "--config", str(d / "machine.toml"), "--workers", "2", "--cache", str(d / "cache"),
                              "--out", str(d / "removal.csv"), "--figure", str(d / "removal.png")])
    return d, res


def test_sweep_draws_removal_against_frequency(frequency_sweep):
    d, res = frequency_sweep
    assert res.exit_code == 0, res.output
    png = (d / "removal.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10_000
    assert "wrote" in res.output


def test_removal_rises_with_frequency(frequency_sweep):
    """As in the vibratory-harvesting literature: more ripe fruit comes off the faster the combs shake
    (the stem force grows with the branch's acceleration, about the square of the frequency)."""
    d, res = frequency_sweep
    rows = list(csv.DictReader((d / "removal.csv").open()))
    assert [r["status"] for r in rows] == ["ok"] * 3
    speed = [float(r["cam.speed[rpm]"]) for r in rows]
    removal = [float(r["ripe_removal_pct"]) for r in rows]
    freq = [float(r["shaking_frequency_hz"]) for r in rows]
    assert speed == pytest.approx([60.0, 105.0, 150.0])
    assert freq == pytest.approx([s / 60.0 for s in speed])  # one comb cycle per cam revolution
    assert all(b > a for a, b in zip(removal, removal[1:])), removal
    assert removal[-1] > 2 * removal[0]  # measured: 20 % at 60 r/min, 56 % at 150 (the model's expectation)
    for r in rows:
        assert 0.0 <= float(r["unripe_shed_pct"]) <= 100.0 and float(r["damage_rate_pct"]) >= 0.0
        # each point is a replicate mean over perturbed starts, with the SD over the replicates
        assert int(float(r["replicates"])) == 2 and float(r["ripe_removal_pct_sd"]) >= 0.0


def test_figure_needs_the_harvest_model_and_one_parameter(tmp_path):
    res = runner.invoke(app, ["sweep", "--param", "cam.speed=60..150rpm", "--figure", str(tmp_path / "f.png")])
    assert res.exit_code == 2 and "--model harvest" in res.output
    res = runner.invoke(app, ["sweep", "--model", "harvest", "--param", "cam.speed=60..150rpm",
                              "--figure", str(tmp_path / "f.pdf")])
    assert res.exit_code == 2 and not (tmp_path / "f.pdf").exists()


def test_calibration_lists_fitted_and_held_out():
    """Every calibrated parameter names its target; the unripe rate and the fruit-force ranges are held out."""
    from berryshaker.config import load_machine
    from berryshaker.harvest.calibration import calibration_table

    m = load_machine(None)
    fruit = {"positions": {"root": {"peak_force_N": 0.07}, "middle": {"peak_force_N": 0.7},
                           "end": {"peak_force_N": 0.3}}}
    fit = {"fitted": {"efficiency_kg_min": "yield_per_bush"}, "check": {"efficiency_kg_min": 3.93},
           "held_out": {"unripe_rate_pct": {"model": 0.1, "study": 3.1}}, "yield_per_bush_kg": 1.0}
    t = calibration_table(m, fruit, fit)
    tags = {p["parameter"]: p["tag"] for p in t["parameters"]}
    calibrated = [p for p in t["parameters"] if p["tag"] == "[calibrated]"]
    assert {p["parameter"] for p in calibrated} == {"yield per bush"}  # only what the fit fitted
    assert all("[study]" in p["target_or_source"] for p in calibrated)
    assert tags["unripe fraction (green + pink + red)"] == tags["unripe stage mix green / pink / red"] == "[assumed]"
    assert tags["pink / red pull strength"] == "[assumed]"
    assert tags["ripe pull / shear strength"] == "[published]"
    assert tags["bruising: extensive above (hard) / safe up to (padded)"] == "[published]"
    assert tags["bruising: P(bruise) at those heights; median hard / padded"] == "[assumed]"
    assert tags["fruit struck by a finger"] == "[assumed]"
    # without a fit nothing is calibrated: the description's values come from published data
    assert not [p for p in calibration_table(m, fruit, {})["parameters"] if p["tag"] == "[calibrated]"]
    held = {h["quantity"]: h for h in t["held_out"]}
    assert held["middle fruit peak force (N)"]["inside"] is True
    assert held["root fruit peak force (N)"]["inside"] is False
    assert held["unripe_rate_pct"]["study"] == "3.1"
    assert "(refit here: 1)" in next(p["target_or_source"] for p in calibrated if p["parameter"] == "yield per bush")
