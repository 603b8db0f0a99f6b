"""The virtual L9's tiered choice confirmed against the trade-off table of its runs (:data:`CONFIRMATION_RULE`,
:func:`confirm_recommendation`, docs/harvest.md "Trade-off table"): a candidate dominates another only beyond the
ANOVA's own noise (Tukey-Kramer margins on the blocked error), and a tested run that dominates the choice becomes
the recommendation; the table as JSON records (:func:`tradeoff_records`).
"""

from __future__ import annotations

import json

import numpy as np

from berryshaker.experiment.clearance_sets import level_code
from berryshaker.report.design import level_set_name
from berryshaker.study.replicate_responses import CONFIDENCE, HARVEST_RESPONSES, interval

#: how the tiered choice is checked against the trade-off table (docs/harvest.md, "Trade-off table")
CONFIRMATION_RULE = ("the tiered choice is confirmed against the trade-off table, judged with the ANOVA's own noise "
                     "model: a candidate dominates another only if it is no worse in every judged response and better "
                     "in at least one by more than the Tukey-Kramer margin q(0.95; candidates, error dof) / "
                     "sqrt(2) sqrt(MS_E (1/n_a + 1/n_b)) (the ANOVA's error, blocked on the starts, and simultaneous confidence of the level "
                     "comparisons); if a tested L9 run dominates the tiered choice, the recommendation moves to that "
                     "run (measured evidence outranks the additive main-effect prediction) and the report says so")


def confirm_recommendation(run_levels: list[dict], run_clearance: list[dict], y: dict[str, np.ndarray],
                           rec_levels: dict[str, int], rec_clearance: dict[str, float],
                           rec_y: dict[str, np.ndarray] | None, pe: dict[str, tuple[float, int]], pairs: list[str],
                           confidence: float = CONFIDENCE) -> dict:
    """The trade-off table of the L9 runs and the tiered choice, and the choice confirmed against it
    (:data:`CONFIRMATION_RULE`).

    Parameters
    ----------
    run_levels, run_clearance : list of dict
        Per L9 run: levels (1-based) and clearances (m) per pair.
    y : dict name -> ndarray (runs, replicates)
        Every response's replicates (its unit: :func:`~berryshaker.study.replicate_responses.response_units`).
    rec_levels, rec_clearance : dict
        The tiered choice.
    rec_y : dict name -> ndarray (replicates,) or None
        Its replicates if it is not an L9 run (None: it is one of them); units of
        :func:`~berryshaker.study.replicate_responses.response_units`.
    pe : dict name -> (MS_E, dof)
        The ANOVA's error of every response (blocked on the starts: run x start), its mean square and dof.
    pairs : list of str
        The clearance pairs (factors).
    confidence : float
        Simultaneous confidence of the comparisons (the ANOVA's).

    Returns
    -------
    dict
        ``records`` / ``columns`` (the final trade-off table: the recommended row's name ends in
        ", recommended"; a tiered choice that is not an L9 run is the row "tiered choice (its clearances)" or, if kept,
        "recommended (its clearances)"), ``levels`` (recommended), ``l9_run`` (1-based or None), ``moved``, ``tiered``
        {code, levels, l9_run}, ``dominated_by`` (names of the candidates that dominate the tiered choice),
        ``better_in`` (columns in which the new recommendation beats the tiered choice), ``statement``, ``rule``.
    """
    import pandas as pd

    from berryshaker.experiment.tradeoff import better_columns, tradeoff_table

    names = list(y)
    nrun = len(run_levels)
    row = next((i for i, lv in enumerate(run_levels) if dict(lv) == dict(rec_levels)), None)
    if row is None and rec_y is None:
        raise ValueError("confirm_recommendation: the tiered choice is not an L9 run, give its replicates rec_y")
    k = nrun + (row is None)
    run_names = [f"run {i + 1} ({level_set_name({p: run_clearance[i][p] * 1e3 for p in pairs})})" for i in range(nrun)]
    cands = [_candidate(run_names[i], run_clearance[i], {n: y[n][i] for n in names}, names, pairs, pe, k, confidence)
             for i in range(nrun)]
    code = level_code(rec_levels)
    rec_name = level_set_name({p: rec_clearance[p] * 1e3 for p in pairs})
    if row is None:
        cands.append(_candidate(f"tiered choice ({rec_name})", rec_clearance, rec_y, names, pairs, pe, k, confidence))
    start = nrun if row is None else row
    df = pd.DataFrame(tradeoff_table(cands, senses=TRADEOFF_SENSES, rtol=0.01))
    pos = {nm: i for i, nm in enumerate(df["name"])}
    doms = {nm: [d for d in str(by).split("; ") if d] for nm, by in zip(df["name"], df["dominated_by"])}
    tiered_name = cands[start]["name"]
    cur, seen = tiered_name, {tiered_name}
    while doms[cur]:  # follow the dominating tested runs (table order: non-dominated first) to an undominated one
        nxt = next((d for d in df["name"] if d in doms[cur] and d not in seen and d in run_names), None)
        if nxt is None:
            break
        cur = nxt
        seen.add(cur)
    moved = cur != tiered_name
    final = run_names.index(cur) if moved else row
    better = better_columns(df, pos[cur], pos[tiered_name], TRADEOFF_SENSES, 0.01) if moved else []
    for i, c in enumerate(cands):
        if i == final:
            c["name"] += ", recommended"
        elif i == nrun and not moved:
            c["name"] = f"recommended ({rec_name})"
    records, columns = tradeoff_records(cands)
    tiered = {"code": code, "name": rec_name,
              "levels": dict(rec_levels), "l9_run": None if row is None else row + 1}
    if moved:
        # the dominating runs by number (their clearances are in the L9's table)
        by = ", ".join(d.split(" (")[0] for d in doms[tiered_name])
        statement = (f"The tiered choice ({rec_name}) is dominated beyond the noise by the tested {by}; the "
                     f"recommendation is {cur}, no worse in every judged "
                     f"response and better in {', '.join(better)} by more than the Tukey-Kramer margin on the "
                     "ANOVA's blocked error (the additive main-effect model does not hold there: an interaction the L9 cannot "
                     "resolve).")
    elif doms[tiered_name]:
        statement = (f"The tiered choice ({rec_name}) is dominated beyond the noise only by "
                     + "; ".join(doms[tiered_name]) + "; no tested run is undominated among them, so it is kept.")
    else:
        statement = (f"No candidate dominates the tiered choice ({rec_name}) beyond the noise (Tukey-Kramer margins on the "
                     "ANOVA's error, as the ANOVA): it is confirmed.")
    return {"records": records, "columns": columns, "levels": dict(run_levels[final]) if moved else dict(rec_levels),
            "l9_run": None if final is None else final + 1, "moved": moved, "tiered": tiered,
            "dominated_by": doms[tiered_name], "better_in": better, "statement": statement,
            "rule": CONFIRMATION_RULE}


def _candidate(name, cl, yc, names, pairs, pe, k, confidence=CONFIDENCE) -> dict:
    """One trade-off candidate: harvest indexes and loads, each with its 95 % interval (pooled replicate error)
    and its comparison half-width (Tukey-Kramer over the k candidates, :func:`comparison_half_width`)."""
    from berryshaker.experiment.error_terms import comparison_half_width

    def est(n):
        s = interval(yc[n])
        return {"mean": s["mean"], "ci": s["ci"],
                "noise": comparison_half_width(pe[n][0], int(pe[n][1]), k, s["n"], confidence)}

    c = {"name": name, "clearance_mm": {p: cl[p] * 1e3 for p in pairs},
         "harvest": {n: est(n) for n in HARVEST_RESPONSES if n in names},
         "design_force_N": {p: est(f"design_force_{p}") for p in pairs if f"design_force_{p}" in names}}
    for n, key in (("drive_torque_design", "drive_torque_design_Nm"), ("drive_torque_rms", "drive_torque_rms_Nm")):
        if n in names:
            c[key] = est(n)
    return c


#: senses of the trade-off table that differ from :data:`berryshaker.experiment.tradeoff.SENSE_PATTERNS`
TRADEOFF_SENSES = {"ripe_removal": True}


def tradeoff_records(candidates: list[dict]) -> tuple[list[dict], list[str]]:
    """The trade-off table (:func:`berryshaker.experiment.tradeoff.tradeoff_table`) as JSON records and its
    column order (ripe removal larger is better; efficiency larger, the rest smaller).

    Parameters
    ----------
    candidates : list of dict
        Trade-off candidates (name, clearances, harvest and load estimates with intervals).

    Returns
    -------
    records : list of dict
        The table's rows as JSON records.
    columns : list of str
        Its column order.
    """
    from berryshaker.experiment.tradeoff import tradeoff_table

    df = tradeoff_table(candidates, senses=TRADEOFF_SENSES, rtol=0.01)
    return json.loads(df.to_json(orient="records")), list(df.columns)
