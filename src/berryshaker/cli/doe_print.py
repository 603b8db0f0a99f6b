"""The terminal view of ``doe analyze``'s analysis: per response the range analysis table, the weighted optimum with
its intervals, the weights, the lost plots and the desirability optimum (user text printed without markup)."""

from __future__ import annotations

from berryshaker.cli.app import out, print_table


def _decimals(values) -> int:
    """Decimals that give the largest |value| of a group four significant digits; the whole group is printed
    with them, so 3 and 3.65 read "3.000" and "3.650", never "3" beside "3.65"."""
    import math

    vals = [abs(float(v)) for v in values if v is not None and math.isfinite(float(v))]
    top = max(vals, default=0.0)
    if top == 0.0:
        return 3
    return max(0, min(6, 3 - int(math.floor(math.log10(top)))))


def _unit(response: str, res=None) -> str:
    """" <unit>" of a response: the sheet's own (``res.response_units``) before the package's defaults."""
    from berryshaker.report.style import RESPONSE_UNITS

    own = getattr(res, "response_units", None) or {}
    u = {**RESPONSE_UNITS, **{k: v for k, v in own.items() if v}}.get(response, "")
    return f" {u}" if u else ""


def weights_text(res) -> str:
    """The composite's weights as one line, e.g. "efficiency 0.50, damage 0.30, unripe 0.20 (given, scaled
    to sum 1)".

    Parameters
    ----------
    res : DoeAnalysis or SheetReplicatedAnalysis
        A DOE analysis (:func:`berryshaker.experiment.field_results.analyze_sheet`) with ``weights`` (response ->
        weight, (1)) and ``weights_given``.

    Returns
    -------
    str
        "name weight, ..." with the weights to two decimals, and whether they were given or equal.
    """
    how = "given with --weights, scaled to sum 1" if res.weights_given else "equal: no --weights given"
    return ", ".join(f"{k} {v:.2f}" for k, v in res.weights.items()) + f" ({how})"


def _print_doe(res) -> None:
    from berryshaker.experiment.replicated_records import ReplicatedAnalysis

    for name, ra in res.responses.items():
        nlev = len(next(iter(ra.factors.values())).level_means)
        rows = []
        an = ra.anova.factors
        dec = _decimals([v for d in ra.factors.values() for v in d.level_means])
        for f, d in ra.factors.items():
            a = an.get(f)
            rep = res.factors.get(f)
            best = str(d.best_level) + (f" ({rep.labels[d.best_level - 1]})" if rep and rep.labels
                                         and rep.values is not None else "")
            rows.append([f, *[f"{v:.{dec}f}" for v in d.level_means], f"{d.range:.{dec}f}", best,
                         f"{a.f:.3g}" if a else "pooled", f"{a.p:.3g}" if a else ""])
        print_table(["factor", *[f"k{j + 1}" for j in range(nlev)], "R", "best", "ANOVA F", "p"], rows,
                    title=f"{name}{_unit(name, res)} ({'maximise' if ra.maximize else 'minimise'}): range analysis")
        reg = ra.regression
        out.print(f"  ranking {' > '.join(ra.ranking)}; eq. 19 full quadratic: rank {reg.full_model_rank} "
                  f"of {len(reg.full_model_terms)} terms, aliased: {', '.join(reg.aliased_terms) or 'none'}; "
                  f"main-effects quadratic R² = {reg.main_effects_quadratic.r2:.3f} with "
                  f"{reg.main_effects_quadratic.residual_df} residual df", markup=False)
    o = res.optimum
    settings = o.settings or {}
    lv = " ".join((f"{f}{n}" if n is not None else f"{f}: no meaningful difference")
                  + (f" ({settings[f]})" if n is not None and settings.get(f) and not str(settings[f]).startswith(
                      "level") else "") for f, n in o.levels.items())
    out.print("weighted optimum: " + lv + "; predicted " + _predicted(o.values, o.intervals, res), markup=False,
              highlight=False)
    out.print(f"weights: {weights_text(res)}", markup=False, highlight=False)
    if isinstance(res, ReplicatedAnalysis):  # replicated sheet: effects judged against the replicate spread
        out.print(f"{res.runs} runs x {res.replicates} replicates; {res.significance_rule}", markup=False,
                  highlight=False)
    lost = getattr(res, "lost_plots", None)
    if lost is not None:
        from berryshaker.experiment.unbalanced import describe_lost

        what = "replicate" if res.block_column in (None, "replicate") else "block"
        for line in describe_lost(lost.to_json(), what):
            out.print(line, markup=False, highlight=False)
    d = getattr(res, "desirability", None)
    if d is not None:
        lv = " ".join(f"{f}{n}" + (f" ({d.settings[f]})" if d.settings.get(f) and not str(d.settings[f]).startswith(
            "level") else "") for f, n in d.levels.items() if n is not None) or "none"
        out.print(f"desirability optimum (D = {d.overall:.3f}): {lv}; predicted "
                  + _predicted(d.values, d.intervals, res) + "; d: "
                  + ", ".join(f"{k} {v:.3f}" for k, v in d.desirability.items()), markup=False, highlight=False)
        if d.note:
            out.print(f"  {d.note}", markup=False, highlight=False)


def _predicted(values: dict, intervals: dict | None, res) -> str:
    """"efficiency 3.786 kg/min [3.72, 3.85]" per response (the interval where there is one)."""
    parts = []
    for k, v in values.items():
        dec = _decimals([v])
        iv = (intervals or {}).get(k)
        parts.append(f"{k} {v:.{dec}f}{_unit(k, res)}" + (f" [{iv[0]:.{dec}f}, {iv[1]:.{dec}f}]" if iv else ""))
    return ", ".join(parts) + (" (95 % intervals)" if intervals else "")
