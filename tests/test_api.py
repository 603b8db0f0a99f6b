"""The Python API (berryshaker.api, issue 45 item 4): each function returns the documented pandas object with the
documented columns and units, and its numbers are those of the library function it wraps, called with the same
inputs.  Cheap: the reduced model over two revolutions, a three-point sweep, tables; the multibody functions
(``wear``, ``validate``, ``simulate(model="multibody")``) are covered by their library's own tests and only
checked here for their argument errors."""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
import pytest

from berryshaker import api
from berryshaker.api import names, simulation
from berryshaker.errors import BerryshakerError, ConfigError


@pytest.fixture(scope="module")
def machine():
    return api.load_machine()


def test_load_machine_is_the_library_function():
    from berryshaker.config import load_machine

    assert api.load_machine is load_machine
    assert api.load_machine(drive="crank_rocker").DRIVE == "crank_rocker"


def test_public_names_are_the_documented_ones():
    assert set(api.__all__) == {"analyze_field_sheet", "fit_table", "kinematics", "load_machine", "plan_field_sheet",
                                "service_limits", "simulate", "sweep", "validate", "wear"}
    assert all(callable(getattr(api, n)) for n in api.__all__)


# ---- kinematics ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("drive", ["groove_cam", "crank_rocker"])
def test_kinematics_is_the_drives_check_per_angle(drive):
    from berryshaker.drives import drive_of

    m = api.load_machine(drive=drive)
    df = api.kinematics(m)
    kin = drive_of(m).check(m)
    assert isinstance(df, pd.DataFrame)
    assert df.index.name == "drive_angle [deg]"
    np.testing.assert_array_equal(df.index.to_numpy(), np.degrees(kin.phi))
    fields = [f.name for f in dataclasses.fields(kin) if f.name != "phi"]
    assert len(df.columns) == len(fields)
    for name in fields:  # every field of the drive's kinematics is named with its unit
        col = simulation._KINEMATICS_COLUMNS[name]
        assert col == "assembled" or col.endswith("]"), col
        np.testing.assert_array_equal(df[col].to_numpy(), getattr(kin, name))
    assert {"time [s]", "left_comb_angle [rad]", "right_comb_rate [rad/s]", "transmission_angle [rad]"} <= set(df)


def test_kinematics_of_the_groove_cam_has_its_push_rod(machine):
    df = api.kinematics(machine)
    for col in ("push_rod_displacement [m]", "push_rod_velocity [m/s]", "push_rod_acceleration [m/s^2]",
                "push_rod_jerk [m/s^3]", "pressure_angle [rad]", "pitch_curvature [1/m]"):
        assert col in df and df[col].dtype == float
    assert df["assembled"].all()


# ---- simulate --------------------------------------------------------------------------------------------
SUMMARY_COLUMNS = ["kind", "clearance [mm]", "static_equivalent_force [N]", "peak_force [N]", "mean_force [N]", "rms_force [N]", "p95_force [N]",
                   "contact_onsets"]


def test_simulate_mlsd_is_the_reduced_model(machine):
    from berryshaker.drives import drive_of
    from berryshaker.drives.groove_cam.mlsd import RESULT_COLUMNS

    summary, series = api.simulate(machine, clearance={"A": "0.3 mm", "C": 0.15e-3}, revolutions=2)
    result = drive_of(machine).reduced_model(machine, {"A": 0.3e-3, "C": 0.15e-3}, revolutions=2)
    ref = result.summary()
    assert list(summary.columns) == SUMMARY_COLUMNS
    assert list(summary.index) == ["A", "B", "C", "F", "G", "H"] and summary.index.name == "joint"
    for pair, st in ref["collision_force_N"].items():
        row = summary.loc[pair]
        assert row["kind"] == "clearance pair"
        assert row["clearance [mm]"] == ref["clearance_mm"][pair]
        assert (row["peak_force [N]"], row["mean_force [N]"], row["rms_force [N]"], row["p95_force [N]"]) == (
            st["peak"], st["mean"], st["rms"], st["p95"])
        assert row["contact_onsets"] == ref["contact_onsets"][pair]
    assert summary.loc["A", "clearance [mm]"] == pytest.approx(0.3)
    assert summary.loc["C", "clearance [mm]"] == pytest.approx(0.15)
    for b, st in ref["bearing_reaction_N"].items():
        assert summary.loc[b, "peak_force [N]"] == st["peak"] and np.isnan(summary.loc[b, "clearance [mm]"])
    # the whole summary rides along: moments in N m
    assert summary.attrs["summary"]["drive_moment_Nm"]["peak"] == ref["drive_moment_Nm"]["peak"]
    # the time series: SI, units in the names, the same samples
    assert series.index.name == "time [s]"
    np.testing.assert_array_equal(series.index.to_numpy(), result.t)
    for key, (idx, unit) in RESULT_COLUMNS.items():  # F_A_N -> "F_A [N]", drive_moment_Nm -> "drive_moment [N m]"
        base = key.removesuffix("_Nm") if key.endswith("_Nm") else key.rsplit("_", 1)[0]
        np.testing.assert_array_equal(series[f"{base} [{unit}]"].to_numpy(), result.results[:, idx])
    np.testing.assert_array_equal(series["F_A [N]"].to_numpy(), result.series("F_A_N"))
    np.testing.assert_array_equal(series["drive_moment [N m]"].to_numpy(), result.series("drive_moment_Nm"))
    np.testing.assert_array_equal(series["T_l [N m]"].to_numpy(), result.series("T_l_Nm"))
    np.testing.assert_array_equal(series["r_A_x [m]"].to_numpy(), result.series("r_A_x_m"))
    np.testing.assert_array_equal(series["push_rod_x [m]"].to_numpy(), result.state[:, 0])
    assert series["cam_angle [deg]"].iloc[-1] == pytest.approx(720.0)


def test_the_multibody_summary_reads_the_same_way():
    """The multibody summary (berryshaker.drives.simulation.multibody_summary: pair_state, no guide bearings) gives
    the same columns; a pair of zero clearance is an ideal joint reporting its reaction force."""
    st = {"peak": 10.0, "mean": 2.0, "rms": 3.0, "p95": 5.0}
    summary = {"clearance_mm": {"A": 0.25, "B": 0.0}, "collision_force_N": {"A": st, "B": st},
               "pair_state": {"A": "clearance", "B": "ideal joint (reaction force)"},
               "contact_onsets": {"A": 7, "B": 0}, "drive_moment_Nm": st}
    df = simulation._joint_summary(summary)
    assert list(df.columns) == SUMMARY_COLUMNS and list(df.index) == ["A", "B"]
    assert list(df["kind"]) == ["clearance pair", "ideal joint (reaction force)"]
    assert df.loc["A", "peak_force [N]"] == 10.0 and df.loc["A", "contact_onsets"] == 7
    assert df.attrs["summary"] is summary


def test_simulate_takes_the_clearance_texts_of_the_command(machine):
    by_text, _ = api.simulate(machine, clearance="A=0.3mm,C=0.15mm", revolutions=2)
    by_dict, _ = api.simulate(machine, clearance={"A": 0.3e-3, "C": "0.15 mm"}, revolutions=2)
    pd.testing.assert_frame_equal(by_text, by_dict)


def test_simulate_refuses_with_the_argument_named(machine):
    with pytest.raises(BerryshakerError, match="model='fem'"):
        api.simulate(machine, model="fem")
    with pytest.raises(BerryshakerError, match="no reduced model"):
        api.simulate(api.load_machine(drive="crank_rocker"))
    with pytest.raises(ConfigError, match="revolutions=1"):
        api.simulate(machine, revolutions=1)
    with pytest.raises(ConfigError, match="unknown pair 'Z'"):
        api.simulate(machine, clearance={"Z": "0.1 mm"})
    with pytest.raises(ConfigError, match=r"clearance\['A'\]"):
        api.simulate(machine, clearance={"A": [0.1]})
    with pytest.raises(BerryshakerError, match="multibody"):
        api.simulate(machine, driveline="powered")


# ---- sweep -----------------------------------------------------------------------------------------------
def test_sweep_is_the_commands_table(machine, tmp_path):
    from berryshaker.runs.runner import SweepRunner
    from berryshaker.runs.sweep import model_run, overrides_of, parse_param, sample_params, tidy_rows

    df = api.sweep(machine, {"clearance.A.size": ["0.1 mm", "0.2 mm", "0.3 mm"]}, revolutions=2, workers=1,
                   cache=tmp_path)
    assert len(df) == 3
    assert list(df.columns[:4]) == ["run", "clearance.A.size [mm]", "status", "error"]
    assert list(df["clearance.A.size [mm]"]) == [0.1, 0.2, 0.3] and (df["status"] == "ok").all()
    for pair in machine.pair_names:
        for stat in ("peak", "mean", "rms"):
            assert df[f"collision_force_{pair}_{stat} [N]"].dtype == float
    assert {"load_moment_left_peak [N m]", "drive_moment_peak [N m]", "drive_moment_rms [N m]"} <= set(df)
    # the same runs made by hand, as the command makes them
    params = [parse_param("clearance.A.size=0.1,0.2,0.3mm", machine)]
    pts = sample_params(params, "grid", 3, 0)
    with SweepRunner(workers=1, cache_dir=tmp_path / "own", progress=False) as runner:
        results = runner.map(model_run, [dict(machine_data=machine.model_dump(mode="json"),
                                              overrides=overrides_of(params, pt), model="mlsd", revolutions=2)
                                         for pt in pts])
    header, rows = tidy_rows(params, pts, results)
    for k, row in enumerate(rows):
        ref = dict(zip(header, row))
        assert df.loc[k, "collision_force_C_peak [N]"] == ref["collision_force_C_peak_N"]
        assert df.loc[k, "drive_moment_rms [N m]"] == ref["drive_moment_rms_Nm"]
        assert df.loc[k, "load_moment_right_rms [N m]"] == ref["load_moment_right_rms_Nm"]


def test_sweep_values_as_numbers_are_si_and_ranges_are_spread(machine, tmp_path):
    si = api.sweep(machine, {"clearance.A.size": [0.2e-3]}, revolutions=2, workers=1, cache=tmp_path)
    mm = api.sweep(machine, {"clearance.A.size": ["0.2 mm"]}, revolutions=2, workers=1, cache=tmp_path)
    assert list(si.columns)[1] == "clearance.A.size [m]" and si.iloc[0, 1] == pytest.approx(0.2e-3)
    assert si["collision_force_A_peak [N]"].iloc[0] == mm["collision_force_A_peak [N]"].iloc[0]
    rng = api.sweep(machine, {"clearance.A.size": "0.1..0.3mm"}, points=3, revolutions=2, workers=1, cache=tmp_path)
    assert list(rng["clearance.A.size [mm]"]) == pytest.approx([0.1, 0.2, 0.3])


def test_sweep_refuses_with_the_argument_named(machine):
    with pytest.raises(ConfigError, match="model='fem'"):
        api.sweep(machine, {"clearance.A.size": ["0.1 mm"]}, model="fem")
    with pytest.raises(ConfigError, match="params="):
        api.sweep(machine, {})
    with pytest.raises(ConfigError, match="not a mix"):
        api.sweep(machine, {"clearance.A.size": ["0.1 mm", 0.2e-3]})
    with pytest.raises(ConfigError, match="clearance.Z"):
        api.sweep(machine, {"clearance.Z.size": ["0.1 mm"]})


def test_unit_names_of_the_library_keys():
    assert names._unit_name("collision_force_A_peak_N") == "collision_force_A_peak [N]"
    assert names._unit_name("drive_moment_rms_Nm") == "drive_moment_rms [N m]"
    assert names._unit_name("ripe_removal_pct_sd") == "ripe_removal_sd [%]"
    assert names._unit_name("efficiency_kg_min") == "efficiency [kg/min]"
    assert names._unit_name("energy_lost_belt_J_per_rev") == "energy_lost_belt [J/rev]"
    assert names._unit_name("speed_ripple_percent") == "speed_ripple [%]"
    assert names._unit_name("shaking_frequency_hz") == "shaking_frequency [Hz]"
    assert names._unit_name("replicates") == "replicates"


# ---- life ------------------------------------------------------------------------------------------------
def test_fit_table_is_fit_summary():
    from berryshaker.life.fits import fit_summary, parse_fit
    from berryshaker.life.tolerance import CANDIDATE_FITS

    df = api.fit_table(20.0, ["H7/f7", "H8/e8", "0.02..0.06 mm"])
    assert list(df.index) == ["H7/f7", "H8/e8", "0.02..0.06 mm"] and df.index.name == "fit"
    assert list(df.columns) == [
        "nominal [mm]", "kind", "basis", "hole", "hole_upper_deviation [um]", "hole_lower_deviation [um]",
        "hole_tolerance [um]", "shaft", "shaft_upper_deviation [um]", "shaft_lower_deviation [um]",
        "shaft_tolerance [um]", "clearance_min [mm]", "clearance_max [mm]", "clearance_mean [mm]",
        "radial_clearance_min [mm]", "radial_clearance_max [mm]"]
    s = fit_summary(parse_fit("H7/f7", 20.0))
    row = df.loc["H7/f7"]
    assert row["hole"] == "H7" and row["shaft"] == "f7" and row["nominal [mm]"] == 20.0
    assert row["shaft_upper_deviation [um]"] == s["shaft"]["upper_deviation_um"] == -20.0
    assert row["clearance_max [mm]"] == s["clearance_max_mm"]
    assert row["radial_clearance_min [mm]"] == s["radial_clearance_min_mm"]
    assert np.isnan(df.loc["0.02..0.06 mm", "hole_tolerance [um]"])
    assert np.isnan(df.loc["0.02..0.06 mm", "nominal [mm]"])
    assert list(api.fit_table(20.0).index) == list(CANDIDATE_FITS)
    assert list(api.fit_table(20.0, "H7/f7, H8/e8").index) == ["H7/f7", "H8/e8"]
    with pytest.raises(ConfigError, match="size_mm"):
        api.fit_table("20")
    with pytest.raises(ConfigError):
        api.fit_table(20.0, ["H7/zz"])


def test_service_limits_are_the_librarys(machine):
    from berryshaker.life.service import service_limits

    df = api.service_limits(machine)
    ref = service_limits(machine)
    assert list(df.columns) == ["design_size [mm]", "largest_test_level [mm]", "service_limit [mm]"]
    assert list(df.index) == list(machine.pair_names)
    for j, v in ref.items():
        assert df.loc[j, "service_limit [mm]"] == v * 1e3
        assert df.loc[j, "design_size [mm]"] == machine.clearance_sizes()[j] * 1e3
    assert list(api.service_limits(machine, "C").index) == ["C"]
    with pytest.raises(ConfigError, match="Z"):
        api.service_limits(machine, ["Z"])


def test_wear_refuses_before_any_run(machine):
    with pytest.raises(ConfigError, match="hours=0"):
        api.wear(machine, hours=0)
    with pytest.raises(ConfigError, match="joints: Z"):
        api.wear(machine, joints=["Z"])


def test_wear_is_machine_wear(machine, tmp_path):
    """api.wear over 20 h of joint C: machine_wear's result laid out as two DataFrames, the same numbers (the library
    call on the same runs, read from the cache the API call filled)."""
    from berryshaker.life.service import machine_wear
    from berryshaker.runs.runner import SweepRunner

    joints, history = api.wear(machine, hours=20.0, joints=["C"], cache=tmp_path)
    with SweepRunner(workers=1, cache_dir=tmp_path, progress=False) as r:
        res = machine_wear(machine, 20.0, runner=r, joints=["C"])
    assert list(joints.columns) == ["wears", "material_pair", "size_convention", "fit", "diameter [mm]",
                                    "bearing_length [mm]", "start_clearance [mm]", "end_clearance [mm]",
                                    "maintenance_interval [h]"]
    c = res["joints"]["C"]
    assert joints.loc["C", "start_clearance [mm]"] == c["clearance_mm"][0]
    assert joints.loc["C", "end_clearance [mm]"] == c["clearance_mm"][-1] > c["clearance_mm"][0]
    assert list(history.columns) == ["joint", "hours [h]", "clearance [mm]", "design_force [N]", "peak_force [N]",
                                     "mean_force [N]",
                                     "growth_rate [um/h]"]
    hc = history[history["joint"] == "C"]
    assert list(hc["clearance [mm]"]) == c["clearance_mm"] and list(hc["hours [h]"]) == c["hours"]
    assert history[history["joint"] == "A"]["peak_force [N]"].isna().all()  # not worn: no force recorded


# ---- field tests -----------------------------------------------------------------------------------------
def _filled_sheet() -> pd.DataFrame:
    """An L9 sheet of three factors, two replicates, responses made from the levels plus a fixed wobble."""
    sheet = api.plan_field_sheet({"A": "0.25,0.5,0.75mm", "B": "0.1,0.2,0.3mm", "C": "0.1,0.2,0.3mm"}, replicates=2)
    wobble = np.tile([0.01, -0.01], len(sheet) // 2) * np.arange(1, len(sheet) + 1) / len(sheet)
    sheet["efficiency_kg_min"] = 3.0 + 0.4 * sheet["C_level"] - 0.1 * sheet["A_level"] + wobble
    sheet["damage_rate_pct"] = 2.0 + 0.3 * sheet["A_level"] - 0.05 * sheet["B_level"] - wobble
    return sheet


def test_plan_field_sheet_is_plan_table():
    from berryshaker.experiment.field_sheet import parse_factor, plan_table

    sheet = api.plan_field_sheet({"A": "0.25,0.5,0.75mm", "B": "1,2,3kg"}, replicates=2, randomize=True, seed=3)
    ref = plan_table("L9", [parse_factor("A=0.25,0.5,0.75mm"), parse_factor("B=1,2,3kg")], True, 3, replicates=2)
    pd.testing.assert_frame_equal(sheet, ref)
    assert {"run", "replicate", "order", "A_level", "A_mm", "B_kg", "efficiency_kg_min"} <= set(sheet)
    with pytest.raises(ConfigError, match="factors="):
        api.plan_field_sheet({})


def test_analyze_field_sheet_is_analyze_sheet(tmp_path):
    from berryshaker.experiment.field_results import analyze_sheet

    sheet = _filled_sheet()
    tables = api.analyze_field_sheet(sheet, maximize="efficiency", minimize=["damage"])
    path = tmp_path / "sheet.csv"
    sheet.to_csv(path, index=False)
    assert tables.keys() == api.analyze_field_sheet(path, "efficiency", "damage").keys()
    _, res = analyze_sheet(str(path), {"efficiency": True, "damage": False})
    assert set(tables) == {"range_efficiency", "range_damage", "optimum_levels", "optimum_predicted"}
    eff = tables["range_efficiency"]
    assert eff.index.name == "factor" and list(eff.index) == ["A", "B", "C"]
    assert list(eff.columns) == ["k1 [kg/min]", "k2 [kg/min]", "k3 [kg/min]", "R [kg/min]", "best_level",
                                 "anova_F [1]", "p [1]"]
    assert list(tables["range_damage"].columns)[:4] == ["k1 [%]", "k2 [%]", "k3 [%]", "R [%]"]
    for f, d in res.responses["efficiency"].factors.items():
        assert list(eff.loc[f, ["k1 [kg/min]", "k2 [kg/min]", "k3 [kg/min]"]]) == d.level_means
        assert eff.loc[f, "R [kg/min]"] == d.range and eff.loc[f, "best_level"] == d.best_level
        an = res.responses["efficiency"].anova.factors.get(f)
        assert (np.isnan(eff.loc[f, "anova_F [1]"]) if an is None else eff.loc[f, "anova_F [1]"] == an.f)
    assert eff["R [kg/min]"].idxmax() == "C"  # the factor built into the responses
    lv = tables["optimum_levels"]
    assert list(lv.columns) == ["level", "setting"] and str(lv["level"].dtype) == "Int64"
    for f, n in res.optimum.levels.items():
        assert (pd.isna(lv.loc[f, "level"]) if n is None else lv.loc[f, "level"] == n)
    pred = tables["optimum_predicted"]
    assert list(pred.columns) == ["value", "lo", "hi", "unit"]  # the 95 % interval (issue 58)
    assert pred.loc["efficiency", "value"] == res.optimum.values["efficiency"]
    assert [pred.loc["efficiency", "lo"], pred.loc["efficiency", "hi"]] == res.optimum.intervals["efficiency"]
    assert pred.loc["efficiency", "unit"] == "kg/min"


def test_analyze_field_sheet_refuses_with_the_argument_named():
    with pytest.raises(ConfigError, match="maximize or minimize"):
        api.analyze_field_sheet(_filled_sheet())
    with pytest.raises(ConfigError, match="both maximize and minimize"):
        api.analyze_field_sheet(_filled_sheet(), maximize="efficiency", minimize="efficiency")


# ---- validate --------------------------------------------------------------------------------------------
def test_validate_is_the_librarys_rows(small_harvest_machine, validation_cache):
    """api.validate on the small machine (one branch class, four bushes, two starts): the rows of
    berryshaker.study.validation.validate as a DataFrame indexed by id.  Its coupled runs are the same jobs as
    tests/study/test_validation.py's and come from the shared cache when that ran first."""
    from berryshaker.runs.runner import SweepRunner
    from berryshaker.study.validation import validate

    df = api.validate(small_harvest_machine, replicates=2, workers=1, cache=validation_cache)
    with SweepRunner(workers=1, cache_dir=validation_cache, progress=False) as r:
        res = validate(small_harvest_machine, r, replicates=2)
    assert df.index.name == "id" and list(df.index) == [row["id"] for row in res["rows"]]
    assert list(df.columns) == ["quantity", "case", "source", "source_key", "unit", "published", "model", "lo", "hi",
                                "noise_lo", "noise_hi", "verdict", "held_out", "how", "confidence"]
    for row in res["rows"]:
        got = df.loc[row["id"]]
        assert got["verdict"] == row["verdict"] and bool(got["held_out"]) == row["held_out"]
        assert (np.isnan(got["model"]) if row["model"] is None else got["model"] == row["model"])
    assert df["lo"].dtype == float and df.attrs["summary"] == res["summary"] and df.attrs["replicates"] == 2


def test_validate_needs_a_plant(machine):
    with pytest.raises(BerryshakerError, match=r"\[plant\]"):
        api.validate(machine.model_copy(update={"plant": None}))
