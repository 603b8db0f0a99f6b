"""Replicates over perturbed initial states, effects judged against the replicate (pure) error, the tiered
recommendation that never ranks noise, and the replicated virtual L9 through ``doe virtual --json``."""

import json
import math
from pathlib import Path

import numpy as np
import pydantic
import pytest
from conftest import linear_spring_toml_text
from scipy import stats
from typer.testing import CliRunner

from berryshaker.cli import app
from berryshaker.config import reference_toml_text
from berryshaker.errors import ConfigError
from berryshaker.experiment.analysis_records import CompositeScore, FactorLevels, RangeAnalysis
from berryshaker.experiment.designs import orthogonal_array
from berryshaker.experiment.replicated_records import Choice, ReplicatedResponse
from berryshaker.experiment.replicates import analyze_replicated, replicated_anova
from berryshaker.harvest.spec import COUPLED_RTOL
from berryshaker.study.l9.records import (
    Estimate,
    L9Optimum,
    L9Recommendation,
    L9Run,
    PairedDifference,
    Perturbation,
    ReplicatedL9,
    SequentialStarts,
    TieredChoice,
    ToleranceCheck,
    ToleranceVerdict,
    VirtualL9,
)

L9 = orthogonal_array("L9") + 1
FACTORS = ["A", "B", "C", "F"]
#: five replicate deviations with mean 0 and sample standard deviation exactly 1 (ddof=1)
UNIT_NOISE = np.array([-2.0, -1.0, 0.0, 1.0, 2.0]) / math.sqrt(2.5)


def _replicated(level_offsets: dict[str, tuple[float, float, float]], sigma: float, base: float = 10.0):
    """(9, 5) observations: base + the factors' level offsets + sigma x UNIT_NOISE in every run, so the pure
    error mean square is exactly sigma^2 (9 x 4 dof) and the run means are exactly the model."""
    mu = np.full(9, base)
    for j, f in enumerate(FACTORS):
        if f in level_offsets:
            mu = mu + np.asarray(level_offsets[f])[L9[:, j] - 1]
    return mu[:, None] + sigma * UNIT_NOISE[None, :]


def test_pure_error_decides_half_sigma_is_noise_five_sigma_is_an_effect():
    """Known pure error sigma = 2: a factor whose level means span 0.5 sigma is not significant, one spanning
    5 sigma is; F = MS_factor / MS_PE in closed form (orthogonal array: 15 observations per level)."""
    sigma = 2.0
    small = (-0.25 * sigma, 0.0, 0.25 * sigma)  # range 0.5 sigma
    big = (-2.5 * sigma, 0.0, 2.5 * sigma)  # range 5 sigma
    y = _replicated({"A": small, "B": big}, sigma)
    an = replicated_anova(L9, y, FACTORS)
    assert an["pure_error"]["ms"] == pytest.approx(sigma**2) and an["pure_error"]["df"] == 36
    for f, offs in (("A", small), ("B", big)):
        ms = 15 * sum(o**2 for o in offs) / 2
        assert an["factors"][f]["f"] == pytest.approx(ms / sigma**2)
        assert an["factors"][f]["p"] == pytest.approx(stats.f.sf(ms / sigma**2, 2, 36))
        assert an["factors"][f]["range"] == pytest.approx(offs[2] - offs[0])
    assert not an["factors"]["A"]["significant"] and an["factors"]["A"]["p"] > 0.3
    assert an["factors"]["B"]["significant"] and an["factors"]["B"]["p"] < 1e-10
    lo, hi = an["factors"]["A"]["range_ci"]
    assert lo < 0 < hi  # a 0.5-sigma range is not distinguishable from zero
    assert an["factors"]["B"]["range_ci"][0] > 0
    for f in ("C", "F"):
        assert an["factors"][f]["f"] == pytest.approx(0.0, abs=1e-9) and not an["factors"][f]["significant"]
    # the same numbers with the noise scaled up 10x: the 5-sigma effect of before is now half a sigma
    an10 = replicated_anova(L9, _replicated({"B": big}, 10 * sigma), FACTORS)
    assert not an10["factors"]["B"]["significant"]


def test_noise_sized_difference_gets_no_weight_in_the_optimum():
    """A harvest index whose level differences are noise-sized (0.5 sigma) does not choose a level: the factor
    is "no meaningful difference" and the composite does not stretch that difference to full weight."""
    sigma = 1.0
    y = {"efficiency": _replicated({"A": (0.0, 0.25, 0.5), "B": (0.0, 5.0, 2.0)}, sigma),
         "damage": _replicated({}, sigma, base=2.0)}
    res = analyze_replicated(L9, L9.astype(float), FACTORS, y, {"efficiency": True, "damage": False},
                             {"efficiency": 0.5, "damage": 0.5})
    ch = res.optimum.choices
    assert ch["A"].level is None and ch["A"].status == "no meaningful difference"
    assert ch["B"].level == 2 and ch["B"].significant_responses == ["efficiency"]
    assert res.optimum.levels["C"] is None and res.optimum.levels["F"] is None


def test_all_noise_harvest_indexes_decide_on_forces_and_torque():
    """Harvest indexes without any effect beyond the noise: the tiered optimum decides on the machine loads
    that do differ (lowest peak force at A1, lowest drive torque at C3) and leaves F undecided."""
    harvest = {"efficiency": _replicated({}, 1.0, base=4.0), "damage": _replicated({}, 0.3, base=2.0),
               "unripe": _replicated({}, 0.2, base=1.0)}
    loads = {"peak_force_A": _replicated({"A": (0.0, 800.0, 1500.0)}, 50.0, base=5000.0),
             "drive_torque_design": _replicated({"C": (30.0, 10.0, 0.0)}, 2.0, base=120.0)}
    senses = {"efficiency": True, "damage": False, "unripe": False, "peak_force_A": False, "drive_torque_design": False}
    res = analyze_replicated(L9, L9.astype(float), FACTORS, {**harvest, **loads}, senses,
                             {"efficiency": 0.5, "damage": 0.3, "unripe": 0.2},
                             fallback_weights={"peak_force_A": 1.0, "drive_torque_design": 1.0})
    for n in harvest:
        assert res.responses[n].significant_factors == []
    ch = res.optimum.choices
    assert ch["A"].level == 1 and ch["A"].tier == "fallback"
    assert ch["C"].level == 3 and ch["C"].tier == "fallback"
    assert ch["F"].level is None and ch["F"].tier == "none"
    assert "never ranking noise" in res.optimum.method
    # a primary tie (levels 2 and 3 of B give the same efficiency) is broken by the loads
    harvest2 = dict(harvest, efficiency=_replicated({"B": (0.0, 6.0, 6.0)}, 1.0))
    loads2 = dict(loads, peak_force_A=_replicated({"B": (0.0, 900.0, 300.0)}, 50.0, base=5000.0))
    res2 = analyze_replicated(L9, L9.astype(float), FACTORS, {**harvest2, **loads2}, senses,
                              {"efficiency": 0.5, "damage": 0.3, "unripe": 0.2},
                              fallback_weights={"peak_force_A": 1.0, "drive_torque_design": 1.0})
    b = res2.optimum.choices["B"]
    assert b.level == 3 and b.tier == "primary + fallback"


def _harvester_spec(machine, revolutions=2):
    from berryshaker.drives import drive_of
    from berryshaker.experiment.clearance_sets import clearance_row

    m = machine.with_clearances(clearance_row(machine, 16))
    return drive_of(m).mechanism(m, revolutions=revolutions)


def test_perturbed_start_sits_inside_the_clearances_and_changes_the_impacts(machine):
    """A seeded perturbation starts every clearance joint at its drawn eccentricity (pin in bore: penetration
    |e| - c; slot and groove: inside half their free travel) with the driver turned by its drawn phase; the
    impact-by-impact force history then differs from the centred start while the same seed repeats exactly."""
    from berryshaker.multibody import layout as mb
    from berryshaker.multibody.engine import simulate_mechanism
    from berryshaker.multibody.perturbation import InitialPerturbation, RandomInitialPerturbation

    spec = _harvester_spec(machine)
    period = 2 * math.pi / abs(spec.drivers[0].speed)
    dur = 1.5 * period
    base = simulate_mechanism(spec, duration=dur)
    p = RandomInitialPerturbation(5, 1.0, 0.5)
    drawn = p.for_spec(spec)
    a = simulate_mechanism(spec, duration=dur, initial_perturbation=p)
    b = simulate_mechanism(spec, duration=dur, initial_perturbation=RandomInitialPerturbation(5, 1.0, 0.5))
    cl = {j.name: j for j in spec.joints}
    for name, d in drawn.joint_offsets.items():
        k = a.compiled.frc_names.index(name)
        pen0 = a.elements[0, k, mb.EO_PEN]
        e = math.hypot(*d)
        if cl[name].type == "revolute_clearance":
            assert pen0 == pytest.approx(e - cl[name].clearance, abs=1e-9)
        else:
            assert -0.5 * cl[name].clearance <= pen0 <= e - 0.5 * cl[name].clearance + 1e-9
    cam = a.compiled.body_index[spec.drivers[0].body]
    assert a.y[0, 3 * cam + 2] - base.y[0, 3 * cam + 2] == pytest.approx(drawn.driver_phases["drive"], abs=1e-9)
    np.testing.assert_array_equal(a.elements, b.elements)  # reproducible
    f0, f1 = base.element_force("C"), a.element_force("C")
    assert np.max(np.abs(f1 - f0)) > 0.2 * np.max(np.abs(f0))  # other impacts, impact by impact
    with pytest.raises(ConfigError, match="free radius"):
        simulate_mechanism(spec, duration=dur, initial_perturbation=InitialPerturbation({"C": (1e-3, 0.0)}))
    with pytest.raises(ConfigError, match="not a clearance joint"):
        InitialPerturbation({"nope": (0.0, 0.0)}).for_spec(spec)


@pytest.fixture(scope="module")
def virtual_json(tmp_path_factory):
    """`doe virtual --json` on a fast description: one branch class, 2 replicates, 1 tolerance replicate (9 x 2 + 1
    coupled runs, plus 2 if the recommendation is not an L9 run)."""
    from extra_response import registered, ripe_left
    from fast_machine import fast_text

    text = fast_text(linear_spring_toml_text(reference_toml_text()), harvest__max_replicates="4")
    base = tmp_path_factory.mktemp("virtual")
    cfg = base / "fast.toml"
    cfg.write_text(text)
    with registered(ripe_left()):  # a response added as one row of the response table
        r = CliRunner().invoke(app, ["doe", "virtual", "--config", str(cfg), "--json", "--workers", "2",
                                     "--replicates", "2", "--cache", str(base / "cache")])
    assert r.exit_code == 0, r.output
    return json.loads(r.stdout)


def test_a_response_added_to_the_table_reaches_the_l9_and_its_report(virtual_json):
    """A harvest response registered as one row of the table (tests/extra_response.py) is counted in every start,
    analysed by the L9 (ANOVA, detectability, trade-off), printed in --json and drawn in the report section."""
    from berryshaker.report.l9_replicates import l9_replicates_section

    s = virtual_json
    assert "ripe_left" in s["runs"][0]["replicates"] and "ripe_left" in s["runs"][0]["expected"]
    assert set(s["replicated"]["responses"]["ripe_left"]["factors"]) == set("ABCF")
    assert set(s["detectability"]["ripe_left"]) == set("ABCF") and "ripe_left" in s["tradeoff"][0]
    assert s["response_units"]["ripe_left"] == "kg/min"
    html_parts = "".join(l9_replicates_section(VirtualL9.from_json(_without_version(s)), Path("."), list("ABCF")))
    assert "ripe_left" in html_parts


def test_doe_virtual_json_carries_spread_significance_and_tradeoff(virtual_json):
    s = virtual_json
    assert len(s["runs"]) == 9 and s["replicated"]["replicates"] == 2
    names = ["efficiency", "ripe_removal", "unripe", "unripe_shed", "damage", "design_force_A", "design_force_B",
             "design_force_C", "design_force_F", "drive_torque_design", "drive_torque_rms"]
    for run in s["runs"]:
        for n in names:
            est = run["replicates"][n]
            assert set(est) >= {"mean", "sd", "ci", "n"} and est["ci"][0] <= est["mean"] <= est["ci"][1]
    # the perturbed starts spread the harvest indexes: finite, non-zero and reported
    sd_eff = s["replicated"]["responses"]["efficiency"]["anova"]["pure_error"]["ms"] ** 0.5
    assert 0 < sd_eff < math.inf
    assert any(run["replicates"]["efficiency"]["sd"] > 0 for run in s["runs"])
    for n in names:
        fac = s["replicated"]["responses"][n]["factors"]
        assert set(fac) == set("ABCF") and all("significant" in fac[f] and "level_ci" in fac[f] for f in fac)
    rec = s["recommended"]
    assert rec["statement"] and set(rec["basis"]) == set("ABCF") and rec["rule"]
    # blocked analysis (the starts are shared by every run) and the paired extreme-level differences with their SE
    assert s["replicated"]["blocks"] is True
    assert s["replicated"]["responses"]["efficiency"]["anova"]["error"]["df"] == 8 * (2 - 1)
    pa = s["paired"]["efficiency"]["A"]
    assert pa["levels"] == [1, 3] and pa["se"] >= 0 and pa["ci"][0] <= pa["difference"] <= pa["ci"][1]
    # the recommended set's starts were extended sequentially (2 -> at most 4) and its SDs come from all of them
    assert rec["starts"] in (2, 4) and rec["sequential"]["stopped"] in ("target met", "max_replicates reached")
    assert rec["replicates"]["efficiency"]["n"] == rec["starts"]
    assert set(rec["fitted"]) <= {"efficiency", "damage", "unripe"}
    assert set(s["optimum"]["levels"]) == set("ABCF") and all(isinstance(v, int) for v in s["optimum"]["levels"].values())
    tc = s["tolerance_check"]
    assert tc["done"] and tc["rtol"] == [COUPLED_RTOL, 1e-7] and "statement" in tc
    assert all({"mean_change", "noise_sd"} <= set(v) for v in tc["responses"].values())
    # the solver's effect is judged on the model's expectation (no counting noise) and on the loads
    harvest = ["efficiency", "ripe_removal", "unripe", "unripe_shed", "damage", "ripe_left"]  # with the added row
    assert set(tc["responses"]) == {f"{n}_expected" for n in harvest} | set(names[5:])
    # one verdict per factor and response: a factor against its own interaction with the starts, and the paired
    # extreme-level difference says the same; beside each harvest effect the field tests it would take to see it
    for n in harvest:
        for f in "ABCF":
            assert s["paired"][n][f]["beyond_noise"] == s["replicated"]["responses"][n]["factors"][f]["significant"]
            assert s["replicated"]["responses"][n]["anova"]["factors"][f]["error"]["df"] == 2 * (2 - 1)
            d = s["detectability"][n][f]
            assert d["field_sd"] > 0 and (d["tests_per_level"] is None or d["tests_per_level"] >= 2)
    for run in s["runs"]:  # the model's expectation beside the counted field results
        assert set(run["expected"]) == set(harvest) and run["expected"]["efficiency"]["mean"] > 0
    rows = s["tradeoff"]
    assert len(rows) in (9, 10) and sum("recommended" in r["name"] for r in rows) == 1
    for col in ("efficiency", "efficiency_lo", "efficiency_hi", "damage", "design_force_N:A", "design_force_N:F_hi",
                "drive_torque_design_Nm", "drive_torque_rms_Nm", "dominated", "dominated_by", "clearance_mm:A"):
        assert col in rows[0] and col in s["tradeoff_columns"]
    assert any(not r["dominated"] for r in rows)
    # the same seeds give the same replicates (explicit seeds, reproducible)
    assert s["replicated"]["seeds"] == [0, 1]  # start numbers of the seed family harvest.seed
    assert s["recommended"]["study"]["code"] == "A1B1C1F3" and set(s["recommended"]["levels"]) == set("ABCF")
    for name in ("efficiency", "unripe", "damage"):  # the study's Table 8 layout of the replicate means
        assert set(s["responses"][name]["factors"]) == set("ABCF")


def test_study_summary_and_report_sections(virtual_json, tmp_path):
    """summary.json entries and the report section built from a replicated L9."""
    from berryshaker.report.l9_replicates import l9_replicates_section
    from berryshaker.report.plots import plot_replicated_effects, plot_tradeoff
    from berryshaker.study.pipeline import l9_summary

    s = virtual_json
    summ = l9_summary(VirtualL9.from_json(_without_version(s)))
    assert summ["tradeoff"] == s["tradeoff"] and summ["l9_replicates"]["replicates"] == 2
    assert "replicate_sd" in summ["l9_replicates"]["responses"]["efficiency"]
    d = plot_tradeoff(s["tradeoff"], tmp_path / "l9_tradeoff.png")
    assert len(d["points"]) == len(s["tradeoff"])
    e = plot_replicated_effects(s["replicated"], ["efficiency", "design_force_A"], tmp_path / "l9_effects_harvest.png",
                                units=s["response_units"])
    ra = s["replicated"]["responses"]["efficiency"]["factors"]["A"]
    np.testing.assert_allclose(e["responses"]["efficiency"]["factors"]["A"]["errors"],
                               [(hi - lo) / 2 for lo, hi in ra["level_ci"]])
    html = "\n".join(l9_replicates_section(VirtualL9.from_json(_without_version(s)), tmp_path, list("ABCF")))
    for text in ("Replicate spread and significance", "Trade-off of the candidate clearance sets",
                 "Solver-tolerance check", "Recommendation and its basis", "data:image/png;base64,"):
        assert text in html


def _without_version(s: dict) -> dict:
    """`doe virtual --json` without what the command adds (``version``; ``null_values``, whose NaN are put back
    where it wrote null): the JSON form of the VirtualL9 record."""
    import copy
    import re

    out = copy.deepcopy({k: v for k, v in s.items() if k not in ("version", "null_values")})
    for path in s.get("null_values", {}):
        keys = [int(t[1:-1]) if t.startswith("[") else t for t in re.findall(r"\[\d+\]|[^.\[\]]+", path)]
        node = out
        for k in keys[:-1]:
            node = node[k]
        assert node[keys[-1]] is None
        node[keys[-1]] = float("nan")
    return out


def test_virtual_l9_output_reads_back_as_its_typed_record(virtual_json):
    """virtual_l9's output (here its JSON, printed by `doe virtual --json`) is a VirtualL9 whose JSON form is the
    output, key for key and in order; its sub-records are typed."""
    data = _without_version(virtual_json)
    rec = VirtualL9.from_json(data)
    assert json.dumps(rec.to_json()) == json.dumps(data) and list(rec.to_json()) == list(data)
    assert isinstance(rec.runs[0], L9Run) and isinstance(rec.runs[0].replicates["efficiency"], Estimate)
    assert isinstance(rec.recommended, L9Recommendation) and isinstance(rec.recommended.check.tiered, TieredChoice)
    assert isinstance(rec.replicated, ReplicatedL9) and isinstance(rec.replicated.perturbation, Perturbation)
    assert isinstance(rec.tolerance_check, ToleranceCheck)
    assert isinstance(rec.tolerance_check.responses["efficiency_expected"], ToleranceVerdict)
    assert isinstance(rec.paired["efficiency"]["A"], PairedDifference)
    assert isinstance(rec.recommended.sequential, SequentialStarts)
    assert rec.recommended.replicates["efficiency"].n == rec.recommended.starts
    # the analyses' parts are the experiment layer's records, not dicts
    assert isinstance(rec.responses["efficiency"], RangeAnalysis) and isinstance(rec.composite, CompositeScore)
    assert isinstance(rec.factors["A"], FactorLevels) and isinstance(rec.optimum, L9Optimum)
    assert isinstance(rec.optimum.choices["A"], Choice) and set(rec.optimum.tiered_levels) == set("ABCF")
    assert isinstance(rec.replicated.responses["efficiency"], ReplicatedResponse)
    assert rec.replicated.responses["efficiency"].anova.error.df == data["replicated"]["responses"]["efficiency"][
        "anova"]["error"]["df"]


def test_l9_records_refuse_unknown_keys_missing_fields_and_wrong_types():
    from l9_records_data import l9_record

    good = l9_record({"runs": [{"run": 1, "levels": {"A": 1}, "clearance_mm": {"A": 0.25}, "name": "A 0.25 mm",
                                 "efficiency": 3.9, "unripe": 0.1, "damage": 2.8,
                                 "replicates": {"efficiency": {"mean": 3.9, "sd": 0.1, "ci": [3.8, 4.0], "n": 8,
                                                               "interval_from": "this run's replicates (7 dof)"}}}],
                      "paired": {"efficiency": {"A": {"levels": [1, 3], "difference": 0.1, "se": 0.05,
                                                      "ci": [0.0, 0.2], "p": 0.09, "beyond_noise": False}}}}).to_json()
    assert VirtualL9.from_json(good).to_json() == good
    with pytest.raises(pydantic.ValidationError, match="colour"):
        VirtualL9.from_json({**good, "colour": "red"})
    with pytest.raises(pydantic.ValidationError, match="colour"):  # in a run
        VirtualL9.from_json({**good, "runs": [{**good["runs"][0], "colour": "red"}]})
    with pytest.raises(pydantic.ValidationError, match="interval_from"):  # an Estimate missing a field
        L9Run.from_json({**good["runs"][0], "replicates": {"efficiency": {"mean": 1.0, "sd": 0.1, "ci": [0.9, 1.1],
                                                                           "n": 8}}})
    with pytest.raises(pydantic.ValidationError, match="starts"):  # a L9Recommendation's field of the wrong type
        L9Recommendation.from_json({**good["recommended"], "starts": "many"})
    with pytest.raises(pydantic.ValidationError, match="what"):  # the perturbation without its text
        ReplicatedL9.from_json({**good["replicated"], "perturbation": {"initial_eccentricity": 1.0,
                                                                       "start_phase_spread_rad": 0.0}})
    with pytest.raises(pydantic.ValidationError, match="mean_change"):  # a tolerance verdict missing a field
        ToleranceCheck.from_json({"done": True, "responses": {"efficiency": {
            "changes": [0.0], "max_abs_change": 0.0, "replicate_sd": 0.1, "noise_sd": 0.1,
            "within_replicate_spread": True}}})
    with pytest.raises(pydantic.ValidationError, match="beyond_noise"):
        PairedDifference.from_json({**good["paired"]["efficiency"]["A"], "beyond_noise": "perhaps"})
    # the tiered optimum as the L9 records it: the replicated analysis' optimum and the levels decided on the way
    with pytest.raises(pydantic.ValidationError, match="colour"):
        L9Optimum.from_json({**good["optimum"], "colour": "red"})
    with pytest.raises(pydantic.ValidationError, match="tiered_levels"):
        L9Optimum.from_json({k: v for k, v in good["optimum"].items() if k != "tiered_levels"})
    with pytest.raises(pydantic.ValidationError, match="optimum"):  # the replicated analysis' optimum is a record
        ReplicatedL9.from_json({**good["replicated"], "optimum": {"levels": {}}})
    # a check that was not run keeps only done and reason; the fallback weights are left out when absent
    assert ToleranceCheck(done=False, reason="off").to_json() == {"done": False, "reason": "off"}
    assert "fallback_weights" not in good["replicated"]


def _l9_with_interaction(delta_rms: float, sigma: float = 0.4):
    """Nine runs x 3 replicates (pure error exactly sigma^2 on the drive torque RMS): harvest indexes without
    any effect, peak force at A and drive torque RMS moved by A only (F has no main effect on anything); the
    tiered choice A1B1C1F3 (A on loads, B, C, F kept at the configured levels 1, 1, 3) is not an L9 run and
    measures like run 1 (A1B1C1F1) except a drive torque RMS higher by ``delta_rms``."""
    noise3 = np.array([-1.0, 0.0, 1.0])  # sample SD exactly 1
    r3 = {}
    for n, (base, offs, s) in {"efficiency": (4.0, {}, 0.1), "ripe_removal": (36.0, {}, 1.0),
                               "unripe": (1.0, {}, 0.05), "unripe_shed": (0.5, {}, 0.05), "damage": (2.8, {}, 0.05),
                               "peak_force_A": (9000.0, {"A": (0.0, 900.0, 1800.0)}, 100.0),
                               "drive_torque_rms": (20.0, {"A": (0.0, 3.0, 6.0)}, sigma)}.items():
        mu = np.full(9, base)
        for j, f in enumerate(FACTORS):
            if f in offs:
                mu = mu + np.asarray(offs[f])[L9[:, j] - 1]
        r3[n] = mu[:, None] + s * noise3[None, :]
    senses = {"efficiency": True, "ripe_removal": True, "unripe": False, "unripe_shed": False, "damage": False,
              "peak_force_A": False, "drive_torque_rms": False}
    rep = analyze_replicated(L9, L9.astype(float), FACTORS, r3, senses, {"efficiency": 0.5, "damage": 0.3,
                                                                         "unripe": 0.2},
                             fallback_weights={"peak_force_A": 1.0, "drive_torque_rms": 1.0})
    pe = {n: (rep.responses[n].anova.pure_error.ms, rep.responses[n].anova.pure_error.df)
          for n in r3}
    levels_m = (0.1e-3, 0.2e-3, 0.3e-3)
    run_levels = [{f: int(L9[i, j]) for j, f in enumerate(FACTORS)} for i in range(9)]
    run_cl = [{f: levels_m[lv[f] - 1] for f in FACTORS} for lv in run_levels]
    tiered = {f: (rep.optimum.levels[f] or {"B": 1, "C": 1, "F": 3}[f]) for f in FACTORS}
    rec_y = {n: v[0].copy() for n, v in r3.items()}
    rec_y["drive_torque_rms"] = rec_y["drive_torque_rms"] + delta_rms
    return r3, rep, pe, run_levels, run_cl, tiered, {f: levels_m[tiered[f] - 1] for f in FACTORS}, rec_y


def test_tradeoff_dominance_uses_the_anovas_noise_and_never_contradicts_it():
    """The recommended set A1B1C1F3 differs from run 1 (A1B1C1F1) only in F, which the ANOVA finds no effect of.
    A drive-torque difference just beyond the old per-pair 95 % intervals (unadjusted, what the table used) but
    inside the Tukey-Kramer margin on the error is noise: the table does not draw the recommendation as dominated
    and F stays at its configured level."""
    from berryshaker.study.l9 import confirm_recommendation

    sigma, r, k = 0.4, 3, 10
    t = stats.t.ppf(0.975, 18)
    old_margin = t * sigma * math.sqrt(2 / r)  # sqrt(h_a^2 + h_b^2) of two 95 % intervals, pooled error
    tukey = stats.studentized_range.ppf(0.95, k, 18) / math.sqrt(2) * sigma * math.sqrt(2 / r)
    assert tukey > 1.6 * old_margin
    delta = 1.1 * old_margin
    y, rep, pe, lv, cl, tiered, tiered_cl, rec_y = _l9_with_interaction(delta, sigma)
    assert tiered == {"A": 1, "B": 1, "C": 1, "F": 3} and rep.optimum.levels["F"] is None
    assert all("F" not in rep.responses[n].significant_factors for n in y)
    # the unified rule: same pure error, simultaneous (Tukey-Kramer) margin -> not dominated, kept
    chk = confirm_recommendation(lv, cl, y, tiered, tiered_cl, rec_y, pe, FACTORS)
    recs = {rr["name"]: rr for rr in chk["records"]}
    rec = recs["recommended (A 0.1 mm, B 0.1 mm, C 0.1 mm, F 0.3 mm)"]
    assert not rec["dominated"] and not chk["moved"] and chk["levels"] == tiered and chk["l9_run"] is None
    assert rec["drive_torque_rms_Nm_noise"] == pytest.approx(tukey / math.sqrt(2))
    assert "run 1" not in rec["dominated_by"] and "confirmed" in chk["statement"]
    assert sum("recommended" in n for n in recs) == 1


def test_a_tested_run_that_dominates_beyond_the_anovas_noise_becomes_the_recommendation():
    """The same set-up with a drive-torque difference three times the Tukey-Kramer margin (an interaction the
    main effects miss): run 1 dominates the tiered choice beyond the ANOVA's own noise, so the recommendation
    moves to run 1, which the table shows undominated, and the statement says why."""
    from berryshaker.study.l9 import confirm_recommendation

    sigma = 0.4
    tukey = stats.studentized_range.ppf(0.95, 10, 18) / math.sqrt(2) * sigma * math.sqrt(2 / 3)
    y, rep, pe, lv, cl, tiered, tiered_cl, rec_y = _l9_with_interaction(3 * tukey, sigma)
    chk = confirm_recommendation(lv, cl, y, tiered, tiered_cl, rec_y, pe, FACTORS)
    assert chk["moved"] and chk["l9_run"] == 1 and chk["levels"] == {"A": 1, "B": 1, "C": 1, "F": 1}
    # runs 1-3 (all A1, the only factor that matters) measure alike; the table order (then name) picks run 1
    assert chk["dominated_by"] == ["run 1 (A 0.1 mm, B 0.1 mm, C 0.1 mm, F 0.1 mm)", "run 2 (A 0.1 mm, B 0.2 mm, C 0.2 mm, F 0.2 mm)", "run 3 (A 0.1 mm, B 0.3 mm, C 0.3 mm, F 0.3 mm)"]
    assert chk["better_in"] == ["drive_torque_rms_Nm"]
    recs = {rr["name"]: rr for rr in chk["records"]}
    assert not recs["run 1 (A 0.1 mm, B 0.1 mm, C 0.1 mm, F 0.1 mm), recommended"]["dominated"]
    assert recs["tiered choice (A 0.1 mm, B 0.1 mm, C 0.1 mm, F 0.3 mm)"]["dominated_by"].startswith("run 1 (A 0.1 mm, B 0.1 mm, C 0.1 mm, F 0.1 mm), recommended")
    assert "(A 0.1 mm, B 0.1 mm, C 0.1 mm, F 0.3 mm) is dominated" in chk["statement"] and "interaction" in chk["statement"]
    # a tiered choice that is an L9 run and dominated by nothing stays, named in its run's row
    chk2 = confirm_recommendation(lv, cl, y, lv[0], cl[0], None, pe, FACTORS)
    assert not chk2["moved"] and chk2["l9_run"] == 1
    assert any(rr["name"] == "run 1 (A 0.1 mm, B 0.1 mm, C 0.1 mm, F 0.1 mm), recommended" for rr in chk2["records"])


def test_tolerance_verdict_is_noise_aware():
    """The study's solver-tolerance check flags a solver bias, not the noise of re-drawn chaotic replicates.

    Each re-run replicate at the tighter tolerance is modelled as an independent draw (what the peak forces of the
    coupled runs are, tests/test_coupled_tolerance.py).  One response: the check passes ~95 % of such draws for
    k = 2 and k = 8 (the band narrows as sqrt(2 / k); the first form, every single change within one SD, flagged
    73 % at k = 2).  Eleven responses judged together (the L9's): the whole check still passes ~95 % of draws
    (a 2-SD band on each flagged one of them 43 % of the time), and flags a bias of 5 replicate SD (k = 2) or
    2.5 SD (k = 8) in one response almost always; equal constants (SD 0) are within."""
    from berryshaker.study.l9 import tolerance_verdict
    from berryshaker.study.l9.tolerance_check import band_z

    assert band_z(1) == pytest.approx(1.959964, abs=1e-6) and band_z(11) == pytest.approx(2.8376, abs=1e-3)
    rng = np.random.default_rng(7)
    sd, n, m = 3.0, 4000, 11
    for k, bias in ((2, 5.0), (8, 2.5)):
        run, tight = rng.normal(10.0, sd, (n, k)), rng.normal(10.0, sd, (n, k))
        single = np.mean([not tolerance_verdict(tight[i] - run[i], sd)["within_replicate_spread"] for i in range(n)])
        assert 0.03 < single < 0.07, (k, single)
        run, tight = rng.normal(10.0, sd, (n, m, k)), rng.normal(10.0, sd, (n, m, k))
        family = np.mean([any(not tolerance_verdict(tight[i, j] - run[i, j], sd, m)["within_replicate_spread"]
                              for j in range(m)) for i in range(n)])
        assert 0.03 < family < 0.07, (k, family)
        biased = np.mean([not tolerance_verdict(tight[i, 0] + bias * sd - run[i, 0], sd, m)["within_replicate_spread"]
                          for i in range(n)])
        assert biased > 0.95, (k, biased)
    v = tolerance_verdict([0.0, 0.0], 0.0)
    assert v["within_replicate_spread"] and v["noise_sd"] == 0.0
