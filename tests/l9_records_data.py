"""Hand-built virtual L9 records for tests (berryshaker.study.l9.records.VirtualL9): what a test sets, with every
other field filled by a neutral value, read through VirtualL9.from_json (so a misspelt key still fails)."""

from __future__ import annotations

from berryshaker.study.l9.records import VirtualL9

_PERTURBATION = {"initial_eccentricity": 1.0, "start_phase_spread_rad": 0.0, "what": "test starts"}
_TIERED = {"code": "", "name": "", "levels": {}, "l9_run": None}
_CHECK = {"levels": {}, "l9_run": None, "moved": False, "tiered": _TIERED, "dominated_by": [], "better_in": [],
          "statement": "", "rule": ""}
_OPTIMUM = {"levels": {}, "settings": {}, "choices": {}, "values": {}, "intervals": {}, "weights": {}, "method": "",
            "prediction": ""}
_COMPOSITE = {"method": "", "score": [], "factors": {}, "ranking": []}
_SEQUENTIAL = {"reached": None, "stopped": "target met", "target": 0.03, "max": 32, "statement": "the test's starts"}


_ERROR = {"ss": 0.0, "df": 0, "ms": 0.0}
_TERM = {"ss": 0.0, "df": 0, "ms": 0.0, "f": 0.0, "p": 1.0}
_REGRESSION = {"coded_factors": {}, "coding": "", "full_model_terms": [], "runs": 0, "full_model_rank": 0,
               "identifiable": False, "estimable_terms": [], "aliased_terms": [],
               "main_effects_quadratic": {"terms": [], "coefficients": {}, "r2": 0.0, "residual_df": 0, "note": ""},
               "ridge_full_quadratic": {"label": "", "penalty": 0.0, "coefficients": {}, "r2": 0.0, "loo_mse": 0.0}}
_EFFECT = {"K": [], "level_means": [], "range": 0.0, "best_level": 1}
_REPLICATED_EFFECT = {"level_means": [], "level_se": [], "level_ci": [], "range": 0.0, "range_ci": [], "hsd": 0.0,
                      "significant": False, "p": 1.0, "paired": None, "K": [], "best_level": 1,
                      "best_levels_within_noise": [], "verdict": ""}


def _filled(given: dict | None, defaults: dict) -> dict:
    return {**defaults, **(given or {})}


def _each(given: dict | None, defaults: dict) -> dict:
    return {k: _filled(v, defaults) for k, v in (given or {}).items()}


def _regression(reg: dict | None) -> dict:
    out = _filled(reg, _REGRESSION)
    return {**out, **{k: _filled(out[k], _REGRESSION[k]) for k in ("main_effects_quadratic", "ridge_full_quadratic")}}


def _range_analysis(ra: dict) -> dict:
    """A response of the range analysis (RangeAnalysis), partial, completed with neutral values."""
    out = _filled(ra, {"factors": {}, "ranking": [], "maximize": True, "best_levels": {}, "anova": {},
                       "regression": _REGRESSION})
    an = _filled(out["anova"], {"factors": {}, "error": _ERROR, "pooled": [], "ss_all": {}, "total_ss": 0.0})
    return {**out, "factors": _each(out["factors"], _EFFECT), "anova": {**an, "factors": _each(an["factors"], _TERM)},
            "regression": _regression(out["regression"])}


def _replicated_response(ra: dict) -> dict:
    """A response of the replicated analysis (ReplicatedResponse), partial, completed with neutral values."""
    out = _filled(ra, {"maximize": True, "factors": {}, "ranking": [], "run_means": [], "run_sd": [],
                       "best_levels": {}, "significant_factors": [], "anova": {}, "regression": _REGRESSION})
    an = _filled(out["anova"], {"factors": {}, "error": {**_ERROR, "kind": ""}, "blocks": None, "pure_error": _ERROR,
                                "lack_of_fit": _ERROR, "pooled": [], "total_ss": 0.0})
    return {**out, "factors": _each(out["factors"], _REPLICATED_EFFECT),
            "anova": {**an, "factors": _each(an["factors"], {**_TERM, "significant": False})},
            "regression": _regression(out["regression"])}


def l9_record(l9: dict) -> VirtualL9:
    """A VirtualL9 from a partial JSON form: the keys given, the rest neutral (no runs, no analysis).

    Parameters
    ----------
    l9 : dict
        Some of VirtualL9's JSON keys (sub-records partial too: ``runs``' entries, ``replicated``,
        ``recommended`` with its ``check`` and ``sequential``).

    Returns
    -------
    VirtualL9
        The record.
    """
    rep = _filled(l9.get("replicated"), {
        "significance_rule": "", "alpha": 0.05, "confidence": 0.95, "runs": 9, "replicates": 2, "blocks": True,
        "weights": {}, "factors": {}, "responses": {}, "optimum": _OPTIMUM, "notes": [], "seeds": [], "units": {},
        "perturbation": _PERTURBATION, "text": ""})
    rep["responses"] = {n: _replicated_response(ra) for n, ra in rep["responses"].items()}
    rec_given = l9.get("recommended") or {}
    rec = _filled(rec_given, {
        "levels": {}, "code": "", "name": "", "clearance_mm": {}, "l9_run": None, "study": {"code": "A1B1C1F3"},
        "same_as_study": False, "virtual_harvest": {}, "replicates": {}, "starts": 0, "sequential": _SEQUENTIAL,
        "fitted": [], "basis": {}, "rule": "", "statement": "", "check": _CHECK})
    rec["check"] = _filled(rec_given.get("check"), _CHECK)
    rec["check"]["tiered"] = _filled(rec["check"]["tiered"], _TIERED)
    runs = [_filled(r, {"run": i + 1, "levels": {}, "clearance_mm": {}, "name": "", "efficiency": 0.0,
                        "unripe": 0.0, "damage": 0.0, "replicates": {}, "expected": {}})
             for i, r in enumerate(l9.get("runs") or [])]
    full = _filled(l9, {
        "responses": {}, "weights": {}, "factors": {}, "composite": _COMPOSITE,
        "optimum": {**_OPTIMUM, "decided_levels": {}, "tiered_levels": {}}, "runs": [],
        "response_units": {}, "tradeoff": [], "tradeoff_columns": [],
        "tolerance_check": {"done": False, "reason": "not run in this test"}, "paired": {}, "observations": {},
        "detectability": {}})
    full.update(replicated=rep, recommended=rec, runs=runs,
                responses={n: _range_analysis(ra) for n, ra in full["responses"].items()})
    order = ("responses", "weights", "factors", "composite", "optimum", "runs", "replicated", "response_units",
             "tradeoff", "tradeoff_columns", "recommended", "tolerance_check", "paired", "observations", "detectability")
    return VirtualL9.from_json({k: full[k] for k in order} | {k: v for k, v in full.items() if k not in order})
