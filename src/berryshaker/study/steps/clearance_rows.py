"""Study step ``clearance_rows``: every clearance row in both models with perturbed starts and the model check
(:func:`plan`, :func:`run`, :func:`row_start_statistics`), its figures and its two report sections (collision force
against clearance, :func:`collision_force_section`; comb load moments, :func:`comb_load_section`).  Its run functions
are in :mod:`berryshaker.study.runs`; its data is a :class:`~berryshaker.study.mechanics_records.ClearanceRows`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from berryshaker.errors import ConfigError
from berryshaker.experiment.clearance_sets import clearance_row, level_set, n_rows
from berryshaker.reference_study import MODEL_CHECK_LEVEL
from berryshaker.report.sections import SectionInput, details, maybe_img, table
from berryshaker.study.mechanics_records import (
    ClearanceRows,
    ModelCheck,
    MultibodyRow,
    ReducedRow,
    RowAgreement,
    RowStarts,
)
from berryshaker.study.runs import (
    model_check_jobs,
    multibody_row,
    reduced_row,
)
from berryshaker.study.step_context import PlannedRuns, StudyContext, describe_clearance
from berryshaker.study.step_result import Step, StepResult

#: perturbed starts of each model at the model-check level: the means claim 1 judges and the noise its row
#: comparisons allow for
MODEL_CHECK_STARTS = 8


def _model_check_jobs(ctx: StudyContext) -> list[dict]:
    return model_check_jobs(ctx.machine, level_set(ctx.machine, MODEL_CHECK_LEVEL), MODEL_CHECK_STARTS)


def plan(ctx: StudyContext) -> list[PlannedRuns]:
    """Every clearance row in the multibody model and, if the drive has one, the reduced model (3 revolutions);
    with a reduced model also :data:`MODEL_CHECK_STARTS` replicate starts of each at the model-check level.

    Parameters
    ----------
    ctx : StudyContext
        The study's machine, runner, figure folder and failure log.

    Returns
    -------
    list of PlannedRuns
        Multibody rows, their perturbed starts and, with a reduced model, its rows and the model check's
        starts of both models (the reduced model's runs do not need the engine).
    """
    last = n_rows(ctx.machine)
    jobs = [dict(machine_data=ctx.data, clearance=clearance_row(ctx.machine, r), revolutions=3)
            for r in range(1, last + 1)]
    plans = [PlannedRuns(multibody_row, jobs, f"rows 1-{last}, multibody"),
             PlannedRuns(multibody_row, _row_start_jobs(ctx, jobs),
                         f"rows 1-{last} x {ctx.machine.harvest.replicates} perturbed starts, multibody")]
    if ctx.drive.reduced_model is not None:
        name = ctx.drive.reduced_model_name.upper()
        plans.append(PlannedRuns(reduced_row, jobs, f"rows 1-{last}, {name}", engine=False))
        try:
            check = _model_check_jobs(ctx)
        except ConfigError:  # replicates that would be copies: no model check (run says why)
            return plans
        plans.append(PlannedRuns(multibody_row, check, f"level {MODEL_CHECK_LEVEL}, {len(check)} perturbed starts, "
                                                       "multibody"))
        # (started with the multibody runs, after the engine step: beside the engine's compilation on two cores
        # they slowed it by more than they took)
        plans.append(PlannedRuns(reduced_row, check, f"level {MODEL_CHECK_LEVEL}, {len(check)} turned starts, {name}"))
    return plans


def _row_start_jobs(ctx: StudyContext, jobs: list[dict]) -> list[dict]:
    """Every row's job from ``harvest.replicates`` perturbed starts (seeds (seed_k, 0): the same starts for every
    row, common random numbers), row-major: the claims on collision forces (2 and 3) are judged on the mean of the
    per-start peaks with its noise, never on one run's peak (the peak of a chaotic impact sequence varies by
    10-30 % between starts)."""
    from berryshaker.harvest.virtual import replicate_starts
    from berryshaker.harvest.virtual.seeds import ROWS

    return [dict(j, seed=[sd, ROWS]) for j in jobs for sd in replicate_starts(ctx.machine)]


def row_start_statistics(summaries: list, pairs, rows: list[int], starts: int) -> dict[str, RowStarts]:
    """Per row and pair, the statistics of the per-start collision-force peaks and means over perturbed starts.

    ``summaries``: :func:`multibody_row` outputs, row-major (``starts`` per row; a failed run None).  Per row and
    pair: ``peak``, ``mean`` and ``static_equivalent`` (the p95 of the run's impact peaks; an ideal joint's: the p95
    of its reaction) each {mean, sd, se, p95 (of the per-start values that ran), values (one per planned
    start, in the starts' order, None where the run failed: paired comparisons match starts by position)},
    ``starts`` (the runs that finished).

    Parameters
    ----------
    summaries : list
        :func:`multibody_row` outputs (forces in N), row-major; None for a failed run.
    pairs : iterable of str
        Clearance pairs.
    rows : list of int
        The rows, in the summaries' order.
    starts : int
        Starts per row.

    Returns
    -------
    dict of str to RowStarts
        Row (as text) -> ``pairs`` (the statistics above, N) and ``starts``; rows with fewer than two finished
        starts are left out.
    """
    out = {}
    for i, r in enumerate(rows):
        chunk = summaries[i * starts:(i + 1) * starts]
        ss = [x for x in chunk if x is not None]
        if len(ss) < 2:
            continue
        per = {}
        for p in pairs:
            st = {}
            for key in ("peak", "mean", "static_equivalent"):
                def value(x, key=key):
                    f = x["collision_force_N"][p]
                    # an ideal joint (zero clearance) has no impacts: its static-equivalent load is the p95 of its
                    # smooth reaction
                    return float(f.get(key, f["p95"]))
                v = np.array([value(x) for x in ss], float)
                st[key] = {"mean": float(v.mean()), "sd": float(v.std(ddof=1)), "se": float(v.std(ddof=1) / np.sqrt(v.size)),
                           "p95": float(np.percentile(v, 95)),
                           "values": [None if x is None else value(x) for x in chunk]}
            per[p] = st
        out[str(r)] = RowStarts.from_json({"pairs": per, "starts": len(ss)})
    return out


def run(ctx: StudyContext) -> StepResult:
    """Every clearance row (single-factor sweeps and level sets) in the multibody and the reduced model.

    Parameters
    ----------
    ctx : StudyContext
        The study's machine, runner, figure folder and failure log.

    Returns
    -------
    StepResult
        ``rows``: a :class:`ClearanceRows`, per row the multibody and reduced-model summaries (forces N, moments
        N m), the perturbed starts' statistics (``starts``), the model check and per-row agreement; the row
        figures and a note.
    """
    last = n_rows(ctx.machine)
    ctx.say(f"clearance rows 1-{last} (single-factor sweeps and level sets)")
    rows = list(range(1, last + 1))
    plans = plan(ctx)
    jobs = plans[0].jobs
    row_of = {id(j): r for j, r in zip(jobs, rows)}

    def describe(j):
        return f"row {row_of[id(j)]}: " + describe_clearance(j["clearance"])

    mb_rows = ctx.collect(multibody_row, jobs, plans[0].label, describe)
    multibody = {str(r): v for r, v in zip(rows, mb_rows) if v is not None}
    starts = ctx.collect(multibody_row, plans[1].jobs, plans[1].label,
                         lambda j: f"start seed {j['seed'][0]}, " + describe_clearance(j["clearance"]))
    start_stats = row_start_statistics(starts, ctx.machine.pair_names, rows, ctx.machine.harvest.replicates)
    mlsd: dict = {}
    check = row_ag = None
    note = ""
    if len(plans) > 2:
        ml_rows = ctx.collect(reduced_row, jobs, plans[2].label, describe)
        mlsd = {str(r): v for r, v in zip(rows, ml_rows) if v is not None}

        def start(j):
            return f"level {MODEL_CHECK_LEVEL}, seed {j['seed'][0]}"

        from berryshaker.experiment.agreement import model_check

        check = None
        if len(plans) > 3:
            check = model_check(ctx.collect(multibody_row, plans[3].jobs, plans[3].label, start),
                                ctx.collect(reduced_row, plans[4].jobs, plans[4].label, start), ctx.machine.pair_names)
        else:
            try:
                _model_check_jobs(ctx)
            except ConfigError as exc:
                note = f"no model check (claim 1 is not comparable): {exc}"
        if check is not None:
            check = ModelCheck.from_json({"level": MODEL_CHECK_LEVEL, **check})
        # model agreement on every row, not only at the model-check level (the same statistics criterion); one
        # run per model and row, so a difference counts only beyond the noise of single runs measured at the
        # model-check level
        from berryshaker.experiment.agreement import summary_statistics_agreement

        noise = {p: check.pairs[p].single_run_noise for p in ctx.machine.pair_names} if check else {}
        row_ag = {
            r: {p: RowAgreement.from_json(summary_statistics_agreement(multibody[r]["collision_force_N"][p],
                                                                       mlsd[r]["collision_force_N"][p],
                                                                       noise=noise.get(p)))
                for p in ctx.machine.pair_names}
            for r in multibody if r in mlsd}
    else:
        note = f"the {ctx.drive.name} drive has no reduced model: rows are multibody only"
    out = ClearanceRows(multibody={r: MultibodyRow.from_json(v) for r, v in multibody.items()},
                        mlsd={r: ReducedRow.from_json(v) for r, v in mlsd.items()}, starts=start_stats,
                        model_check=check, agreement=row_ag)
    figs = _plot_rows(ctx.machine, out, ctx.figs, ctx.draw)
    return StepResult("rows", out, figs, note)


def _plot_rows(machine, rows: ClearanceRows, figs: Path, draw) -> list[str]:
    """The rows' figures (study Figs. 18-23), each drawn by ``draw(fn, *args, **kwargs)`` (``StudyContext.draw``);
    returns their file names."""
    from berryshaker.report import plots as P

    mb, ml = rows.multibody, rows.mlsd
    last = n_rows(machine)
    models = [("multibody", mb)] + ([("MLSD", ml)] if ml else [])
    if not all(str(r) in m for r in range(1, last + 1) for _, m in models):
        return []  # a failed row: the tables and the Failed runs section tell which
    names = []
    levels = machine.clearance_levels()
    for k, p in enumerate(machine.pair_names):
        rr = [1] + [2 + 3 * k + j for j in range(3)]
        labels = ["none"] + [f"{levels[p][j] * 1e3:g} mm" for j in range(3)]
        series = {"multibody peak": [mb[str(r)].collision_force_N[p].peak for r in rr]}
        if ml:
            series["MLSD peak"] = [ml[str(r)].collision_force_N[p].peak for r in rr]
        series["multibody mean"] = [mb[str(r)].collision_force_N[p].mean for r in rr]
        name = f"fig{18 + k}_rows_{p}.png"
        draw(P.plot_bars, series, labels, f"collision force at joint {p} [N]", figs / name,
                    f"Clearance {p} alone (rows {rr[1]}-{rr[-1]}; study Fig. {18 + k})", pair=p, reference_index=0)
        names.append(name)
    rr = [1, last - 2, last - 1, last]
    labels = ["none", "level 1", "level 2", "level 3"]
    for k, side in enumerate(("left", "right")):
        series = {"multibody rms": [mb[str(r)].load_moment_Nm[side].rms for r in rr],
                  "multibody peak": [mb[str(r)].load_moment_Nm[side].peak for r in rr]}
        if ml:
            series["MLSD rms"] = [ml[str(r)].load_moment_Nm[side].rms for r in rr]
        name = f"fig{22 + k}_moment_{side}.png"
        draw(P.plot_bars, series, labels, f"{side} comb load moment [N m]", figs / name,
                    f"{side.capitalize()} comb load moment, row 1 and the level sets (study Fig. {22 + k})")
        names.append(name)
    return names


def _rows_last(inp: SectionInput) -> int:
    """The last clearance row: row 1, three per pair, the three level sets."""
    return 4 + 3 * len(inp.pairs)


def collision_force_section(inp: SectionInput) -> tuple[str, list[str]]:
    """Collision force against clearance on the single-factor rows (study step ``clearance_rows``, its first
    section).

    Parameters
    ----------
    inp : SectionInput
        Results (``rows``: a ``berryshaker.study.mechanics_records.ClearanceRows``, read by attribute; clearances
        in mm, forces in N), machine, figures.

    Returns
    -------
    tuple of (str, list of str)
        Title and HTML parts.
    """
    res, figs, PAIR_NAMES = inp.res, inp.figs, inp.pairs
    last = _rows_last(inp)
    title = f"Collision force against clearance (rows 1-{last - 3}; Figs. 18-21)"
    if res.rows is None:
        return title, ["<p>Not available (see Failed runs).</p>"]
    mb = res.rows.multibody
    rows = []
    for r in range(1, last + 1):
        if str(r) not in mb:
            continue
        s = mb[str(r)]
        rows.append([r, *[s.clearance_mm[p] for p in PAIR_NAMES], *[s.collision_force_N[p].peak for p in PAIR_NAMES],
                     *[s.collision_force_N[p].mean for p in PAIR_NAMES]])
    parts = [table(["row", *[f"{p} mm" for p in PAIR_NAMES], *[f"peak {p} (N)" for p in PAIR_NAMES],
                     *[f"mean {p} (N)" for p in PAIR_NAMES]], rows)]
    bars: list[str] = []
    for i, p in enumerate(PAIR_NAMES):
        maybe_img(bars, figs / f"fig{18 + i}_rows_{p}.png", f"Clearance {p} alone: collision force")
    parts.append(details(f"Figures 18-{17 + len(PAIR_NAMES)}: collision force against each pair's clearance", bars))
    return title, parts


def comb_load_section(inp: SectionInput) -> tuple[str, list[str]]:
    """Comb load moments on row 1 and the three level sets (study step ``clearance_rows``, its second section).

    Parameters
    ----------
    inp : SectionInput
        Results (``rows``: a ``berryshaker.study.mechanics_records.ClearanceRows``, read by attribute; moments in
        N m), machine, figures.

    Returns
    -------
    tuple of (str, list of str)
        Title and HTML parts.
    """
    last = _rows_last(inp)
    lv = (last - 2, last - 1, last)
    title = f"Comb load moments (rows 1, {lv[0]}-{lv[2]}; Figs. 22-23)"
    if inp.res.rows is None:
        return title, ["<p>Not available (see Failed runs).</p>"]
    mb = inp.res.rows.multibody
    parts = ["<p class='small'>These machine-only runs have no plant: the load is the aggregate bush model (a "
             "spring-damper about each comb shaft, 200 N m/rad [assumed]); peak and rms are per comb, about its "
             "shaft.  It loads the combs about 40 times more than the explicit bush of branches in "
             f"{inp.ref('harvest_response_section', 'the harvest-response section')} "
             "(there about 16 N m peak, 1 N m rms; here about 81 N m peak, 48 N m rms; docs/plant.md).</p>"]
    parts.append(table(["row", "left peak (N m)", "left rms", "right peak", "right rms"],
                        [[r, mb[str(r)].load_moment_Nm["left"].peak, mb[str(r)].load_moment_Nm["left"].rms,
                          mb[str(r)].load_moment_Nm["right"].peak, mb[str(r)].load_moment_Nm["right"].rms]
                         for r in (1, *lv) if str(r) in mb]))
    moments: list[str] = []
    for i, side in enumerate(("left", "right")):
        maybe_img(moments, inp.figs / f"fig{22 + i}_moment_{side}.png", f"{side} comb load moment")
    parts.append(details("Figures 22-23: the comb load moments", moments))
    return title, parts


#: the step in the study's step table (:data:`berryshaker.study.steps.STEPS`)
STEP = Step(key="clearance_rows", run=run, result="rows", sections=(collision_force_section, comb_load_section),
            plan=plan)
