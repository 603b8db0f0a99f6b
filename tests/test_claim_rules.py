"""Claim verdicts that could pass by construction: model agreement judged on every row, and a recommendation
that only matches the study because a factor was left at the configured (the study's) clearance."""

from berryshaker.experiment.agreement import summary_statistics_agreement
from berryshaker.study import claims as C


def _pair(agree=True):
    return {"agree": agree, "eq18_agree": True, "f_statistic": 1.0, "f_critical": 3.2, "nrmse": 0.05,
            "peak_ratio": 1.0}


def _rows(agree_everywhere: bool):
    same = {"mean": 500.0, "rms": 1000.0, "p95": 3000.0}
    ring = {"mean": 800.0, "rms": 1000.0, "p95": 3000.0}  # a stiff MLSD link ringing: mean 60 % off
    per = {}
    for r in ("1", "2", "15"):
        per[r] = {p: summary_statistics_agreement(same, same if agree_everywhere or r != "2" else ring)
                  for p in "ABCF"}
    return {"agreement": per}


def test_summary_agreement_uses_the_stated_tolerances():
    a = {"mean": 100.0, "rms": 200.0, "p95": 400.0}
    assert summary_statistics_agreement(a, {"mean": 109.0, "rms": 228.0, "p95": 490.0})["agree"]
    c = summary_statistics_agreement(a, {"mean": 112.0, "rms": 200.0, "p95": 400.0})
    assert not c["agree"] and c["worst"] == "mean"


def test_claim1_is_partly_when_only_the_model_check_level_agrees():
    res = {"agreement": {"pairs": {p: _pair() for p in "ABCF"}}, "rows": _rows(True)}
    assert C._claim1(res)[0] == "reproduced"
    res["rows"] = _rows(False)
    verdict, detail = C._claim1(res)
    assert verdict == "partly reproduced" and "8 of 12 row-pairs agree" in detail
    res["agreement"]["pairs"]["C"] = _pair(False)
    assert C._claim1(res)[0] == "not reproduced"


def test_claim8_does_not_count_a_factor_kept_at_the_studys_clearance():
    resp = {n: {"best_levels": {"A": 1, "B": 1, "C": 1, "F": 3}, "ranking": ["A", "B", "C", "F"],
                "significant_factors": []} for n in ("efficiency", "unripe", "damage")}
    rec = {"code": "A1B1C1F3", "same_as_study": True,
           "virtual_harvest": {"efficiency_kg_min": 3.93, "unripe_rate_pct": 0.0, "damage_rate_pct": 2.8},
           "basis": {"A": "machine loads", "B": "machine loads", "C": "machine loads",
                     "F": "no response differs significantly between the levels of F: kept at the configured "
                          "clearance (level 3)"}}
    rep = {n: {"factors": {p: {"significant": False} for p in "ABCF"}} for n in resp}
    res = {"l9": {"responses": resp, "recommended": rec, "replicated": {"responses": rep}}}
    verdict, detail = C._claim8(res)
    assert verdict == "not reproduced" and "F kept at the configured" in detail
    rec["basis"]["F"] = "machine loads"  # decided on evidence: the match counts
    assert C._claim8(res)[0] == "partly reproduced"


def test_claim8_states_the_p_value_its_verdict_rests_on():
    """A verdict that rests on A's efficiency effect crossing p = 0.05 (3 replicates: it moves with round-off, a
    realisation gave p = 0.021) says how close it is."""
    resp = {n: {"best_levels": {"A": 1, "B": 1, "C": 1, "F": 3}, "ranking": ["A", "B", "C", "F"],
                "significant_factors": []} for n in ("efficiency", "unripe", "damage")}
    rec = {"code": "A1B1C1F3", "same_as_study": True,
           "virtual_harvest": {"efficiency_kg_min": 3.93, "unripe_rate_pct": 0.0, "damage_rate_pct": 2.8},
           "basis": {p: "machine loads" for p in "ABCF"}}
    rep = {n: {"factors": {p: {"significant": p == "A", "p": 0.021 if p == "A" else 0.5} for p in "ABCF"}}
           for n in resp}
    verdict, detail = C._claim8({"l9": {"responses": resp, "recommended": rec, "replicated": {"responses": rep}}})
    assert verdict == "reproduced" and "ANOVA p = 0.021" in detail
    rep["efficiency"]["factors"]["A"].update(significant=False, p=0.06)
    verdict, detail = C._claim8({"l9": {"responses": resp, "recommended": rec, "replicated": {"responses": rep}}})
    assert verdict == "partly reproduced" and "within the noise" in detail and "p = 0.06" in detail
