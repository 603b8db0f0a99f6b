"""Study step ``powered_drive``: the powered drive against clearance (:func:`plan`, :func:`run`: speed ripple, input
power and energy lost per joint at levels 1-3, replicated from perturbed starts) and its report section
(:func:`powered_drive_section`).  Its data is a :class:`~berryshaker.study.life_drive_records.PoweredDrive`.
"""

from __future__ import annotations

import numpy as np

from berryshaker.experiment.clearance_sets import level_set
from berryshaker.experiment.replicates import replicate_trend
from berryshaker.report.sections import SectionInput, table
from berryshaker.study.life_drive_records import (
    PoweredDrive,
    PoweredLevel,
)
from berryshaker.study.runs import (
    powered_row,
)
from berryshaker.study.statistic_records import DriveMoment, SpeedRange
from berryshaker.study.step_context import PlannedRuns, StudyContext, describe_clearance
from berryshaker.study.step_result import Step, StepResult
from berryshaker.user_text import html_text

#: replicates of each powered-drive level: seeded perturbed starts (docs/driveline.md sec. 5).  Over 3 revolutions
#: a single run's ripple scatters by 0.2-1.2 percentage points and its clearance energy loss by 0.014-0.047 J/rev
#: between starts (reference machine, 6 starts per level, measured); 4 replicates resolve the level-to-level steps
#: (13.0 -> 17.2 -> 22.5 %, 0.42 -> 0.81 -> 1.23 J/rev) many times over their standard error.
POWERED_REPLICATES = 4


def _replicate_mean(values: list):
    """Mean of each numeric leaf over replicate summaries of the same shape (dicts of numbers)."""
    first = values[0]
    if isinstance(first, dict):
        return {k: _replicate_mean([v[k] for v in values]) for k in first}
    return float(np.mean(values))


def _trend_text(name: str, unit: str, tr: dict, levels: list[str]) -> str:
    vals = " -> ".join(f"{m:.3g} +- {s:.2g}{unit}" for m, s in zip(tr["mean"], tr["sd"]))
    if tr["grows"]:
        return f"{name} grows with clearance ({vals} at levels {', '.join(levels)}, replicate mean +- SD)"
    flat = [f"{levels[i]}->{levels[i + 1]}" for i, s in enumerate(tr["steps"]) if s["verdict"] != "up"]
    return (f"{name} does not grow significantly at every level step ({vals}; no significant rise at "
            f"{', '.join(flat)}, Welch p >= {tr['alpha']:g} or a fall)")


POWERED_LEVELS = (1, 2, 3)


def plan(ctx: StudyContext) -> list[PlannedRuns]:
    """Powered-drive runs: levels 1-3, :data:`POWERED_REPLICATES` seeded perturbed starts each (3 revolutions).

    Parameters
    ----------
    ctx : StudyContext
        The study's machine, runner, figure folder and failure log.

    Returns
    -------
    list of PlannedRuns
        One: :func:`berryshaker.study.runs.powered_row` at levels 1-3 x :data:`POWERED_REPLICATES`
        starts.
    """
    from berryshaker.harvest.virtual import replicate_starts
    from berryshaker.harvest.virtual.seeds import POWERED

    seeds = replicate_starts(ctx.machine, POWERED_REPLICATES)
    jobs = [dict(machine_data=ctx.data, clearance=level_set(ctx.machine, lv), revolutions=3, seed=[sd, POWERED, lv])
            for lv in POWERED_LEVELS for sd in seeds]
    return [PlannedRuns(powered_row, jobs, f"powered drive, levels 1-3 x {len(seeds)} replicates")]


def run(ctx: StudyContext) -> StepResult:
    """Powered drive: speed ripple, input power and energy lost per joint against clearance (levels 1-3), the
    driveline of ``[driveline]`` (or its defaults) turning the drive shaft (docs/driveline.md sec. 5).  Each
    level is run from :data:`POWERED_REPLICATES` seeded perturbed starts; the table shows replicate means and
    a trend is stated only where the level-to-level step exceeds the replicate spread (:func:`replicate_trend`).

    Parameters
    ----------
    ctx : StudyContext
        The study's machine, runner, figure folder and failure log.

    Returns
    -------
    StepResult
        ``powered_drive``: a :class:`~berryshaker.study.life_drive_records.PoweredDrive`, per level the
        replicate means (speed ripple %, input power W, energy per revolution J, drive moment N m) with their SDs,
        the trends and the finding; no data when fewer than two levels ran.
    """
    from berryshaker.harvest.virtual import replicate_starts

    ctx.say(f"powered drive at clearance levels 1-3, {POWERED_REPLICATES} perturbed starts each")
    levels = POWERED_LEVELS
    seeds = replicate_starts(ctx.machine, POWERED_REPLICATES)
    (runs,) = plan(ctx)
    outs = ctx.collect(powered_row, runs.jobs, runs.label,
                       lambda j: f"{describe_clearance(j['clearance'])}, start seed {j['seed']}")
    data, ripples, losts = {}, {}, {}
    pairs = ctx.machine.pair_names
    for i, lv in enumerate(levels):
        reps = [s for s in outs[i * len(seeds):(i + 1) * len(seeds)] if s is not None]
        if len(reps) < 2:
            continue
        keys = ("cam_speed_rpm", "speed_ripple_percent", "input_power_W", "energy_per_revolution_J", "drive_moment_Nm")
        d = {"clearance_mm": reps[0]["clearance_mm"], **{k: _replicate_mean([r[k] for r in reps]) for k in keys}}
        d["replicates"] = len(reps)
        d["audit_relative_residual"] = max(r["energy_audit"]["relative_residual"] for r in reps)
        ripples[str(lv)] = [r["speed_ripple_percent"] for r in reps]
        losts[str(lv)] = [sum(v for j, v in r["energy_per_revolution_J"].items() if j in pairs) for r in reps]
        d["speed_ripple_sd_percent"] = float(np.std(ripples[str(lv)], ddof=1))
        d["clearance_energy_sd_J"] = float(np.std(losts[str(lv)], ddof=1))
        data[str(lv)] = PoweredLevel(**{**d, "cam_speed_rpm": SpeedRange(**d["cam_speed_rpm"]),
                                              "drive_moment_Nm": DriveMoment(**d["drive_moment_Nm"])})
    if len(data) < 2:
        return StepResult("powered_drive", None, note="the powered-drive runs failed (see Failed runs)")
    names = sorted(data)
    ripple_tr = replicate_trend([ripples[k] for k in names])
    lost_tr = replicate_trend([losts[k] for k in names])
    lost = {k: m for k, m in zip(names, lost_tr["mean"])}
    text = _trend_text("The drive-shaft speed ripple", " %", ripple_tr, names)
    verdict = (text + ": larger clearances give faster impacts and larger drive-moment peaks, which the compliant "
               "mesh and belt pass to the shaft's speed." if ripple_tr["grows"] else
               text + ": at these levels the swing of the drive moment over the cam cycle, not the impacts, sets "
               "the ripple.")
    verdict += " " + _trend_text("The energy lost in the clearance joints", " J/rev", lost_tr, names) + "."
    return StepResult("powered_drive", PoweredDrive(
        levels=data, replicates=len(seeds), seeds=seeds, ripple_grows_with_clearance=ripple_tr["grows"],
        ripple_trend=ripple_tr, clearance_energy_per_revolution_J=lost, energy_trend=lost_tr,
        energy_grows_with_clearance=lost_tr["grows"], finding=verdict))


def powered_drive_section(inp: SectionInput) -> tuple[str, list[str]]:
    """The powered driveline at clearance levels 1-3 (study step ``powered_drive``).

    Parameters
    ----------
    inp : SectionInput
        Results (``powered_drive``, a ``berryshaker.study.life_drive_records.PoweredDrive``: clearances in mm,
        speeds r/min, ripple %, power W, energy J/rev), machine.

    Returns
    -------
    tuple of (str, list of str)
        Title and HTML parts: the table, then the finding (none but the title when the step has no results).
    """
    title = "Powered drive: speed ripple, input power and energy lost per joint (docs/driveline.md)"
    pw, pairs = inp.res.powered_drive, inp.pairs
    if pw is None:
        return title, []
    rows = []
    for lv, d in pw.levels.items():
        e, sp = d.energy_per_revolution_J, d.cam_speed_rpm
        ripple = f"{d.speed_ripple_percent:.3g} +- {d.speed_ripple_sd_percent:.2g}"
        rows.append([lv, ", ".join(f"{p} {d.clearance_mm[p]:g}" for p in pairs),
                     f"{sp.min:.1f} .. {sp.max:.1f} ({sp.mean:.2f})", ripple,
                     d.input_power_W, *[e[p] for p in pairs], e.get("belt", 0.0), e.get("mesh", 0.0),
                     d.audit_relative_residual])
    parts = [table(["level", "clearance (mm)", "shaft speed min .. max (mean), r/min, replicate means", "ripple (%)",
                     "input power (W)", *[f"lost in {p} (J/rev)" for p in pairs], "belt (J/rev)",
                     "mesh (J/rev)", "energy audit residual"], rows, left=(0, 1, 2, 3))]
    reps = pw.replicates
    rep_text = (f" Every level is the mean of {reps} runs from seeded perturbed starts (clearance joints off centre, "
                "seeds in summary.json); ripple is shown as mean +- SD, and a trend is stated only where Welch's "
                "t-test between consecutive levels finds it beyond that spread." if reps else "")
    parts.append(f"<p>{html_text(pw.finding)} Energy lost per revolution is the work of each joint's contact "
                 "damping and friction, integrated with the motion; the audit residual is the largest over the "
                 "replicates of |motor work - kinetic, stored and dissipated energy| / motor work over revolutions "
                 f"2-3.{rep_text}</p>")
    return title, parts


#: the step in the study's step table (:data:`berryshaker.study.steps.STEPS`)
STEP = Step(key="powered_drive", run=run, result="powered_drive", sections=(powered_drive_section,),
            plan=plan)
