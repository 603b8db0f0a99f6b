"""Claim verdicts that could pass by construction: model agreement judged on every row, and a recommendation
that only matches the study because a factor was left at the configured (the study's) clearance."""

import numpy as np
from l9_records_data import l9_record

from berryshaker.experiment.agreement import ensemble_agreement, judged_difference, summary_statistics_agreement
from berryshaker.study import claims as C
from berryshaker.study.mechanics_records import ClearanceRows, ModelAgreement
from berryshaker.study.step_result import StudyResults


def _pair(agree=True):
    same = {"mean": 500.0, "rms": 1000.0, "p95": 3000.0, "impulse_per_revolution": 250.0}
    zero = {k: 0.0 for k in same}
    return {"f_statistic": 1.0, "f_critical": 3.2, "alpha": 0.05, "points": 10, "eq18_agree": True, "agree": agree,
            "statistics": {"a": same, "b": same, "relative_difference": zero, "tolerance": dict(same), "agree": agree},
            "nrmse": 0.05, "correlation": 0.9, "peak_ratio": 1.0, "mean_ratio": 1.0,
            "peak_N": {"multibody": 9000.0, "reduced": 9000.0}}


def _results(agreement=None, rows=None):
    """The claims' input from the steps' JSON forms (``agreement``: its ``pairs``; ``rows``: any of its keys)."""
    return StudyResults(
        agreement=None if agreement is None else ModelAgreement.from_json({"clearance_mm": {p: 0.25 for p in "ABCF"},
                                                                           **agreement}),
        rows=ClearanceRows.from_json({"multibody": {}, "mlsd": {}, "starts": {}, **(rows or {})}))


def _force(peak: float) -> dict:
    return {"peak": peak, "mean": peak / 2, "rms": peak / 1.5, "p95": 0.9 * peak}


def _multibody_row(load_moment: dict) -> dict:
    """A multibody row's summary (as :func:`berryshaker.study.runs.multibody_row` gives it) with these moments."""
    pairs = "ABCF"
    return {"model": "multibody", "drive": "groove_cam", "clearance_mm": {p: 0.0 for p in pairs},
            "collision_force_N": {p: _force(1000.0) for p in pairs},
            "pair_state": {p: "ideal joint (reaction force)" for p in pairs},
            "load_moment_Nm": {s: _force(v["rms"] * 1.7) | {"rms": v["rms"]} for s, v in load_moment.items()},
            "drive_moment_Nm": {**_force(45.0), "mean_abs": 11.5}, "load_model": "aggregate (no plant in this run)",
            "steps": 7500, "rejected_steps": 0, "contact_onsets": {p: 0 for p in pairs}, "contact_onsets_located": 0,
            "event_cuts": 0, "wall_time_s": 0.2, "revolutions": 3, "statistics_over": "revolutions 2..3"}


def _runs(scale, spread, n=8):
    """n runs' statistics around mean 500, rms 1000, p95 3000 N x scale, with relative spread +-spread."""
    return [{k: v * scale * (1 + spread * (2 * i / max(n - 1, 1) - 1)) for k, v in
             {"mean": 500.0, "rms": 1000.0, "p95": 3000.0}.items()} for i in range(n)]


def _check(scale_c=1.0, spread=0.01):
    return {"level": 2, "starts": {"multibody": 8, "reduced": 8}, "planned": {"multibody": 8, "reduced": 8},
            "pairs": {p: ensemble_agreement(_runs(scale_c if p == "C" else 1.0, spread), _runs(1.0, spread))
                      for p in "ABCF"}}


def _rows(agree_everywhere: bool, noise=None):
    same = {"mean": 500.0, "rms": 1000.0, "p95": 3000.0}
    ring = {"mean": 800.0, "rms": 1000.0, "p95": 3000.0}  # a stiff MLSD link ringing: mean 60 % off
    per = {}
    for r in ("1", "2", "15"):
        per[r] = {p: summary_statistics_agreement(same, same if agree_everywhere or r != "2" else ring, noise=noise)
                  for p in "ABCF"}
    return {"agreement": per, "model_check": _check()}


def test_summary_agreement_uses_the_stated_tolerances():
    a = {"mean": 100.0, "rms": 200.0, "p95": 400.0}
    assert summary_statistics_agreement(a, {"mean": 109.0, "rms": 228.0, "p95": 490.0})["agree"]
    c = summary_statistics_agreement(a, {"mean": 112.0, "rms": 200.0, "p95": 400.0})
    assert not c["agree"] and c["worst"] == "mean" and c["verdict"] == "differ"


def test_a_difference_counts_only_beyond_its_noise():
    """The verdict on a difference of 15 % against a tolerance of 20 %: agree without noise, undecided with a
    noise band of 10 %, and 26 % differs only while the band stays below 6 %."""
    assert judged_difference(0.15, 0.0, 0.20) == "agree"
    assert judged_difference(0.15, 0.10, 0.20) == "within noise"
    assert judged_difference(0.26, 0.05, 0.20) == "differ"
    assert judged_difference(0.26, 0.07, 0.20) == "within noise"
    a = {"mean": 100.0, "rms": 200.0, "p95": 400.0}
    b = {"mean": 100.0, "rms": 200.0, "p95": 460.0}  # p95 13 % off
    assert summary_statistics_agreement(a, b)["verdict"] == "agree"
    c = summary_statistics_agreement(a, b, noise={"mean": 0.01, "rms": 0.02, "p95": 0.12})
    assert c["verdict"] == "within noise" and not c["agree"] and c["verdicts"]["mean"] == "agree"


def test_ensemble_agreement_judges_means_with_their_standard_errors():
    same = ensemble_agreement(_runs(1.0, 0.05), _runs(1.0, 0.05))
    assert same["verdict"] == "agree" and same["relative_difference"]["mean"] == 0.0
    # 8 runs spread +-5 % of each (SD 3.2 %, SE 1.1 %): equal spreads give Welch's 2 (n - 1) = 14 degrees of
    # freedom, the band t_0.975(14) x sqrt(2) x SE = 2.145 x 1.41 x 1.1 % = 3.4 %
    from scipy import stats

    band = stats.t.ppf(0.975, 14) * (2 ** 0.5) * same["a"]["mean"]["se"] / 500.0
    assert abs(same["noise"]["mean"] - band) < 1e-12 and abs(stats.t.ppf(0.975, 14) - 2.1448) < 1e-4
    off = ensemble_agreement(_runs(1.3, 0.05), _runs(1.0, 0.05))  # 23 % apart: beyond 10 % + noise
    assert off["verdict"] == "differ" and off["verdicts"]["mean"] == "differ"
    near = ensemble_agreement(_runs(1.12, 0.3), _runs(1.0, 0.3))  # 11 % apart, noise ~15 %: cannot tell
    assert near["verdicts"]["mean"] == "within noise" and near["verdict"] == "within noise"
    assert near["single_run_noise"]["mean"] > near["noise"]["mean"] * 2.5  # one run resolves sqrt(8) x less
    try:
        ensemble_agreement(_runs(1.0, 0.1, n=1), _runs(1.0, 0.1))
    except ValueError as exc:
        assert "at least two runs" in str(exc)
    else:
        raise AssertionError("one run has no spread: refused")


def test_claim1_is_partly_when_only_the_model_check_level_agrees():
    res = {"agreement": {"pairs": {p: _pair() for p in "ABCF"}}, "rows": _rows(True)}
    assert C._claim1(_results(**res))[0] == "reproduced"
    res["rows"] = _rows(False)
    verdict, detail = C._claim1(_results(**res))
    assert verdict == "partly reproduced" and "8 of 12 row-pairs agree" in detail and "differ: 2A" in detail
    # the centred run's own verdict does not decide the claim (one draw of a chaotic sequence)
    res["agreement"]["pairs"]["C"] = _pair(False)
    assert C._claim1(_results(**res))[0] == "partly reproduced"
    res["rows"]["model_check"] = _check(scale_c=1.3)
    assert C._claim1(_results(**res))[0] == "not reproduced"


def test_claim1_says_undecided_where_the_noise_decides():
    res = {"agreement": {"pairs": {p: _pair() for p in "ABCF"}}, "rows": _rows(True)}
    res["rows"]["model_check"] = _check(scale_c=1.12, spread=0.3)
    verdict, detail = C._claim1(_results(**res))
    assert verdict == "undecided" and "C within noise" in detail
    # rows within single-run noise: not evidence of agreement
    res["rows"] = _rows(True, noise={"mean": 0.0, "rms": 0.0, "p95": 0.25})
    verdict, detail = C._claim1(_results(**res))
    assert verdict == "partly reproduced" and "within noise: 1A" in detail


def test_claim8_does_not_count_a_factor_kept_at_the_studys_clearance():
    resp = {n: {"best_levels": {"A": 1, "B": 1, "C": 1, "F": 3}, "ranking": ["A", "B", "C", "F"]}
            for n in ("efficiency", "unripe", "damage")}
    rec = {"code": "A1B1C1F3", "same_as_study": True,
           "virtual_harvest": {"efficiency_kg_min": 3.93, "unripe_rate_pct": 0.0, "damage_rate_pct": 2.8},
           "basis": {"A": "machine loads", "B": "machine loads", "C": "machine loads",
                     "F": "no response differs significantly between the levels of F: kept at the configured "
                          "clearance (level 3)"}}
    rep = {n: {"factors": {p: {"significant": False} for p in "ABCF"}} for n in resp}
    l9 = {"responses": resp, "recommended": rec, "replicated": {"responses": rep}}
    verdict, detail = C._claim8(StudyResults(l9=l9_record(l9)))
    assert verdict == "not reproduced" and "F kept at the configured" in detail
    rec["basis"]["F"] = "machine loads"  # decided on evidence: the match counts
    assert C._claim8(StudyResults(l9=l9_record(l9)))[0] == "partly reproduced"


def test_claim8_states_the_p_value_its_verdict_rests_on():
    """A verdict that rests on A's efficiency effect crossing p = 0.05 (3 replicates: it moves with round-off, a
    realisation gave p = 0.021) says how close it is."""
    resp = {n: {"best_levels": {"A": 1, "B": 1, "C": 1, "F": 3}, "ranking": ["A", "B", "C", "F"]}
            for n in ("efficiency", "unripe", "damage")}
    rec = {"code": "A1B1C1F3", "same_as_study": True,
           "virtual_harvest": {"efficiency_kg_min": 3.93, "unripe_rate_pct": 0.0, "damage_rate_pct": 2.8},
           "basis": {p: "machine loads" for p in "ABCF"}}
    rep = {n: {"factors": {p: {"significant": p == "A", "p": 0.021 if p == "A" else 0.5} for p in "ABCF"}}
           for n in resp}
    verdict, detail = C._claim8(StudyResults(l9=l9_record({"responses": resp, "recommended": rec,
                                                             "replicated": {"responses": rep}})))
    assert verdict == "reproduced" and "ANOVA p = 0.021" in detail
    rep["efficiency"]["factors"]["A"].update(significant=False, p=0.06)
    verdict, detail = C._claim8(StudyResults(l9=l9_record({"responses": resp, "recommended": rec,
                                                             "replicated": {"responses": rep}})))
    assert verdict == "partly reproduced" and "within the noise" in detail and "p = 0.06" in detail


def test_claim1_needs_no_centred_run_and_says_when_starts_failed():
    res = {"agreement": None, "rows": _rows(True)}
    verdict, detail = C._claim1(_results(**res))
    assert verdict == "reproduced" and "eq. 18 (centred runs): not run" in detail
    res["rows"]["model_check"]["planned"] = {"multibody": 10, "reduced": 8}
    assert "of 10 / 8 planned" in C._claim1(_results(**res))[1]


def test_model_check_refuses_replicates_that_would_be_copies():
    import pytest

    from berryshaker.config import machine_from_dict, reference_machine
    from berryshaker.errors import ConfigError
    from berryshaker.study.runs import model_check_jobs

    d = reference_machine().model_dump()
    assert len(model_check_jobs(machine_from_dict(d), {}, 3)) == 3
    d["harvest"]["start_phase_spread"] = 0.0
    with pytest.raises(ConfigError, match="start_phase_spread is 0"):
        model_check_jobs(machine_from_dict(d), {}, 8)


def test_trend_claims_count_only_steps_beyond_the_noise():
    """Claims 2, 3 and 5 judge means over perturbed starts step by step (paired t): a step inside the noise is no
    rise; a rise beyond it is; the same numbers from one start each could not be judged at all."""
    from berryshaker.study.claims import _claim3, paired_steps

    rng = np.random.default_rng(2)
    start = rng.normal(0, 300, 8)  # the start-to-start spread, shared by every row (common random numbers)
    up = [list(1000.0 * k + start + rng.normal(0, 30, 8)) for k in range(4)]
    flat = [list(5000.0 + start + rng.normal(0, 30, 8)) for _ in range(4)]
    assert [s["verdict"] for s in paired_steps(up)] == ["up"] * 3
    assert all(s["verdict"] == "within noise" for s in paired_steps(flat))

    def rows_for(series):
        st = {}
        for k, p in enumerate("ABCF"):
            for i, r in enumerate([1] + [2 + 3 * k + j for j in range(3)]):
                v = [float(x) for x in series[i]]
                stat = {"mean": float(np.mean(v)), "sd": float(np.std(v, ddof=1)), "se": 0.0, "p95": max(v),
                        "values": v}
                st.setdefault(str(r), {"pairs": {}, "starts": 8})["pairs"][p] = {"peak": stat, "mean": stat}
        return _results(rows={"starts": st})

    assert _claim3(rows_for(up))[0] == "reproduced"
    verdict, detail = _claim3(rows_for(flat))
    assert verdict == "partly reproduced" and "within noise" in detail


def test_a_claim_that_holds_by_construction_is_not_tested():
    from berryshaker.study.claims import _claim4

    lm = {"left": {"rms": 16.0}, "right": {"rms": 15.0}}
    res = {"rows": {"multibody": {str(r): _multibody_row(lm) for r in (1, 14, 15, 16)}}}
    assert _claim4(_results(**res))[0] == "not tested"
