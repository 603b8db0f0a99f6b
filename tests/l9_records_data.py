"""Hand-built virtual L9 records for tests (berryshaker.study.l9_records.VirtualL9): what a test sets, with every
other field filled by a neutral value, read through VirtualL9.from_json (so a misspelt key still fails)."""

from __future__ import annotations

from berryshaker.study.l9_records import VirtualL9

_PERTURBATION = {"initial_eccentricity": 1.0, "start_phase_spread_rad": 0.0, "what": "test starts"}
_TIERED = {"code": "", "name": "", "levels": {}, "l9_run": None}
_CHECK = {"levels": {}, "l9_run": None, "moved": False, "tiered": _TIERED, "dominated_by": [], "better_in": [],
          "statement": "", "rule": ""}
_SEQUENTIAL = {"reached": None, "stopped": "target met", "target": 0.03, "max": 32, "statement": "the test's starts"}


def _filled(given: dict | None, defaults: dict) -> dict:
    return {**defaults, **(given or {})}


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
        "weights": {}, "factors": {}, "responses": {}, "optimum": {}, "notes": [], "seeds": [], "units": {},
        "perturbation": _PERTURBATION, "text": ""})
    rec_given = l9.get("recommended") or {}
    rec = _filled(rec_given, {
        "levels": {}, "code": "", "name": "", "clearance_mm": {}, "l9_run": None, "study": {"code": "A1B1C1F3"},
        "same_as_study": False, "virtual_harvest": {}, "replicates": {}, "starts": 0, "sequential": _SEQUENTIAL,
        "fitted": [], "basis": {}, "rule": "", "statement": "", "check": _CHECK})
    rec["check"] = _filled(rec_given.get("check"), _CHECK)
    rec["check"]["tiered"] = _filled(rec["check"]["tiered"], _TIERED)
    runs = [_filled(r, {"run": i + 1, "levels": {}, "clearance_mm": {}, "name": "", "efficiency": 0.0,
                        "unripe": 0.0, "damage": 0.0, "replicates": {}}) for i, r in enumerate(l9.get("runs") or [])]
    full = _filled(l9, {
        "responses": {}, "weights": {}, "factors": {}, "composite": {}, "optimum": {}, "runs": [],
        "response_units": {}, "tradeoff": [], "tradeoff_columns": [],
        "tolerance_check": {"done": False, "reason": "not run in this test"}, "paired": {}, "observations": {}})
    full.update(replicated=rep, recommended=rec, runs=runs)
    order = ("responses", "weights", "factors", "composite", "optimum", "runs", "replicated", "response_units",
             "tradeoff", "tradeoff_columns", "recommended", "tolerance_check", "paired", "observations")
    return VirtualL9.from_json({k: full[k] for k in order} | {k: v for k, v in full.items() if k not in order})
