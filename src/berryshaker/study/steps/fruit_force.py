"""Study step ``fruit_force``: the fruit force of the machine driving past a branch (rigid-flexible coupling) at the
configured clearances and the level sets (:func:`plan`, :func:`run`, :func:`fruit_start_statistics`), its figures
and its report section (:func:`fruit_force_section`, with the table from the pins to the fruit,
:func:`transmission_parts`).  Its run functions are in :mod:`berryshaker.study.runs`; its data is a
:class:`~berryshaker.study.fruit_force_records.FruitForceStep`.
"""

from __future__ import annotations

import numpy as np

from berryshaker.experiment.clearance_sets import clearance_row, n_rows
from berryshaker.reference_study import FRUIT_FORCE_N
from berryshaker.report.sections import SectionInput, details, maybe_img, num, table
from berryshaker.study.fruit_force_records import DrivePast, FruitForceStep, FruitStartSet
from berryshaker.study.runs import (
    fruit_force_run,
    replicate_run,
)
from berryshaker.study.step_context import PlannedRuns, StudyContext, describe_clearance
from berryshaker.study.step_result import Step, StepResult


def plan(ctx: StudyContext) -> list[PlannedRuns]:
    """Drive-pasts at the configured clearances and at the three level sets (the last three clearance rows).

    Parameters
    ----------
    ctx : StudyContext
        The study's machine, runner, figure folder and failure log.

    Returns
    -------
    list of PlannedRuns
        The drive-pasts (:func:`berryshaker.study.runs.fruit_force_run`) and their perturbed starts
        (:func:`berryshaker.study.runs.replicate_run`).
    """
    last = n_rows(ctx.machine)
    jobs = [dict(machine_data=ctx.data, clearance={})] + [
        dict(machine_data=ctx.data, clearance=clearance_row(ctx.machine, r)) for r in (last - 2, last - 1, last)]
    return [PlannedRuns(fruit_force_run, jobs, "fruit force runs"),
            PlannedRuns(replicate_run, _fruit_start_jobs(ctx), "fruit force: perturbed starts")]


def _fruit_class(machine) -> int:
    """Index of the branch class nearest the reference branch (diameter scale 1): the fruit-force branch."""
    return int(np.argmin([abs(s - 1.0) for s in machine.harvest.branch_classes]))


def _fruit_start_jobs(ctx: StudyContext) -> list[dict]:
    """Perturbed starts (``harvest.replicates``, the virtual harvest's seeds) at the configured clearances and at the
    three level sets: the fruit force's claims judged on replicate means of the fruit-force branch class's tables
    (set-major; the virtual harvest's jobs, shared through the cache)."""
    from berryshaker.harvest.virtual import replicate_starts
    from berryshaker.study.l9 import replicate_jobs

    last = n_rows(ctx.machine)
    seeds = replicate_starts(ctx.machine)
    sets = [ctx.machine.clearance_sizes()] + [clearance_row(ctx.machine, r) for r in (last - 2, last - 1, last)]
    return [j for cl in sets for j in replicate_jobs(ctx.machine, cl, seeds, data=ctx.data)]


def fruit_start_statistics(machine, outs: list, keys: list[str]) -> dict:
    """Peak stem force of the named fruit (``plant.fruit``: root, middle, end; mass m0) per perturbed start, read
    from each start's stem-force table of the fruit-force branch class (the class nearest diameter scale 1,
    :func:`berryshaker.harvest.virtual.fruit_peak_force`), and its mean, SD and
    SE per set.  ``outs``: :func:`replicate_run` outputs, set-major (equal counts per set; a failed run None);
    ``keys``: the sets' names.

    Parameters
    ----------
    machine : MachineBase
        The machine description (its [plant] fruit).
    outs : list
        :func:`replicate_run` outputs, set-major; None for a failed run.
    keys : list of str
        The sets' names.

    Returns
    -------
    dict
        Set -> ``positions`` (fruit name -> ``mean``, ``sd``, ``se`` in N and ``values`` per start, N or None) and
        ``starts``; sets with fewer than two finished starts are left out.
    """
    from berryshaker.harvest.virtual import fruit_peak_force

    f = machine.plant.fruit
    m0 = f.mass
    n = len(outs) // len(keys)
    c = _fruit_class(machine)
    out = {}
    for i, k in enumerate(keys):
        envs = [None if o is None else np.array(o["envelopes"][c]) for o in outs[i * n:(i + 1) * n]]
        if sum(e is not None for e in envs) < 2:
            continue
        per = {}
        for name, z in zip(f.names, f.positions):
            vals = [None if e is None else float(fruit_peak_force(e, np.array([z]), np.array([m0]), m0)[0])
                    for e in envs]
            v = np.array([x for x in vals if x is not None])
            per[name] = {"mean": float(v.mean()), "sd": float(v.std(ddof=1)), "se": float(v.std(ddof=1) / np.sqrt(v.size)),
                         "values": vals}  # one per planned start, None where the run failed (pairing by position)
        out[k] = {"positions": per, "starts": int(sum(e is not None for e in envs))}
    return out


def run(ctx: StudyContext) -> StepResult:
    """The machine drives past a branch (rigid-flexible coupling): fruit force at the configured clearances and
    at the level sets.

    Parameters
    ----------
    ctx : StudyContext
        The study's machine, runner, figure folder and failure log.

    Returns
    -------
    StepResult
        ``fruit_force``: a :class:`~berryshaker.study.fruit_force_records.FruitForceStep`, the drive-pasts at the
        configured clearances (``chosen``) and the level sets (``rows``), the perturbed starts' peak stem forces (N)
        per set and the branch class; the fruit-force figures.
    """
    from berryshaker.report import plots as P

    ctx.say("fruit force (rigid-flexible coupling)")
    last = n_rows(ctx.machine)
    level_rows = (last - 2, last - 1, last)
    runs, starts = plan(ctx)
    ff = ctx.collect(fruit_force_run, runs.jobs, runs.label, lambda j: "clearances " + describe_clearance(j["clearance"]))
    so = ctx.collect(replicate_run, starts.jobs, starts.label,
                     lambda j: f"start seed {j['seed'][0]}, clearances " + describe_clearance(j["clearance"]))
    starts_stats = fruit_start_statistics(ctx.machine, so, ["chosen"] + [str(r) for r in level_rows])
    data = FruitForceStep(chosen=None if ff[0] is None else DrivePast.from_json(ff[0]),
                          rows={str(r): DrivePast.from_json(v) for r, v in zip(level_rows, ff[1:]) if v is not None},
                          level_rows=list(level_rows),
                          starts={k: FruitStartSet.from_json(v) for k, v in starts_stats.items()},
                          branch_class=ctx.machine.harvest.branch_classes[_fruit_class(ctx.machine)])
    figs = []
    if ff[0] is not None:
        ctx.draw(P.plot_fruit_force, np.array(ff[0]["distance"]), {k: np.array(v) for k, v in ff[0]["forces"].items()},
                           FRUIT_FORCE_N, ctx.figs / "fig24_26_fruit_force.png",
                           "Fruit harvesting force at the chosen clearances (study Figs. 24-26)",
                           peaks=ff[0]["peaks_exact"])
        figs.append("fig24_26_fruit_force.png")
    if all(v is not None for v in ff[1:]):
        ctx.draw(P.plot_bars, {f"level {i + 1}": [ff[i + 1]["peaks_exact"][n] for n in ("root", "middle", "end")]
                     for i, r in enumerate(level_rows)}, ["root", "middle", "end"], "peak fruit force [N]",
                    ctx.figs / "fruit_force_by_level.png",
                    f"Peak fruit force at level sets 1-3 (rows {level_rows[0]}-{level_rows[-1]})")
        figs.append("fruit_force_by_level.png")
    return StepResult("fruit_force", data, figs)


def fruit_force_section(inp: SectionInput) -> tuple[str, list[str]]:
    """Fruit harvesting force at the chosen clearances and the level sets (study step ``fruit_force``).

    Parameters
    ----------
    inp : SectionInput
        Results (``fruit_force``, a ``berryshaker.study.fruit_force_records.FruitForceStep``: heights in m,
        forces in N), machine, figures.

    Returns
    -------
    tuple of (str, list of str)
        Title and HTML parts.
    """
    res, parts = inp.res, []
    if res.fruit_force is not None and res.fruit_force.chosen is not None:
        pos = res.fruit_force.chosen.summary.positions
        parts.append(table(["fruit", "z (m)", "peak (N)", "study range (N)", "ripe fruit", "unripe fruit"],
                            [[n, d.z_m, d.peak_force_N, "-".join(str(x) for x in d.study_range_N or []),
                              d.eq17.ripe, d.eq17.unripe] for n, d in pos.items()]))
    maybe_img(parts, inp.figs / "fig24_26_fruit_force.png", "Fruit force against machine-to-plant distance")
    by_level: list[str] = []
    maybe_img(by_level, inp.figs / "fruit_force_by_level.png", "Peak fruit force at the three level sets")
    parts.append(details("Figure: the peak fruit force at the three level sets", by_level))
    if res.fruit_force is not None:
        parts.extend(transmission_parts(res.fruit_force))
    return "Fruit harvesting force (eq. 16-17; Figs. 24-26)", parts


def transmission_parts(ff) -> list[str]:
    """The table that follows the clearance impacts from the pins to the fruit at level sets 1 and 3 (the smallest
    and the largest clearances), with the sentence it supports; empty when either drive-past lacks it.

    Parameters
    ----------
    ff : FruitForceStep
        The study step's data (``rows`` by clearance row, ``level_rows``; RMS values in N or m/s^2).

    Returns
    -------
    list of str
        HTML parts.
    """
    from berryshaker.harvest.transmission import IMPACT_BAND_HZ

    lo, hi = (ff.rows.get(str(ff.level_rows[0])), ff.rows.get(str(ff.level_rows[-1])))
    if lo is None or hi is None or lo.transmission is None or hi.transmission is None:
        return []
    a, b = lo.transmission, hi.transmission
    rows = [[link, a[link].unit, f"{num(a[link].shaking_band_rms)} → {num(b[link].shaking_band_rms)}",
             f"{num(a[link].impact_band_rms)} → {num(b[link].impact_band_rms)}",
             f"{100 * a[link].impact_share:.3g} → {100 * b[link].impact_share:.3g}"] for link in a if link in b]
    pins = [v.impact_share for k, v in b.items() if k.startswith("pin ")]
    stems = [v.impact_share for k, v in b.items() if k.startswith("stem ")]
    text = ""
    if pins and stems and "fingers" in b:
        span = f"{100 * min(pins):.0f}" + ("" if f"{100 * min(pins):.0f}" == f"{100 * max(pins):.0f}"
                                           else f"-{100 * max(pins):.0f}")
        text = (f"<p>The clearance impacts (above {IMPACT_BAND_HZ:g} Hz) are {span} % of the pins' force "
                f"fluctuation at level set 3, {100 * b['fingers'].impact_share:.2g} % of the fingers' and at most "
                f"{100 * max(stems):.2g} % of a stem force: fingers, branch and pedicel filter them out, so the "
                "clearances barely move the harvest (docs/harvest.md, \"From the pin to the fruit\").</p>")
    return [text, details(f"Table: from the pin to the fruit, the shaking band (below {IMPACT_BAND_HZ:g} Hz) and "
                           "the impact band (above), level set 1 → level set 3",
                           [table(["link", "unit", "shaking-band RMS", "impact-band RMS",
                                    "impact share of the fluctuation (%)"], rows)])]


#: the step in the study's step table (:data:`berryshaker.study.steps.STEPS`)
STEP = Step(key="fruit_force", run=run, result="fruit_force", sections=(fruit_force_section,), plan=plan)
