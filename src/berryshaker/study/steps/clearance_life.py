"""Study step ``clearance_life``: a cheap summary of joint wear, service life and fit choice for the report
(:func:`run`, :func:`step_life`), with its report section (:func:`clearance_life_section`).

Three clearances per pair from the tightest candidate fit to the pair's service limit, each from
``harvest.replicates`` perturbed starts (one pair varied at a time, cached through the study's runner), give each
pair's Archard growth rate and mean static-equivalent collision force against its own clearance (the tolerance
design's surrogate, :mod:`berryshaker.life.clearance_response`).  From it: the clearance of every pair over 2000
operating hours from the description's sizes (the worn levels studied), every pair's service life by mechanism
from the new machine's clearance (:func:`berryshaker.life.service_life.joint_life`: wear by mode, contact fatigue,
ISO 281 where the pair is a rolling bearing; the loads re-evaluated as the clearance grows), the fits on the
drawing and the fits recommended by NSGA-II on the surrogate, each evaluated (new clearance, load, life).  Coarse
on purpose (3 points per pair, runs of 2 revolutions); ``berryshaker wear`` re-simulates at every state and
``berryshaker tolerance`` uses a finer grid.
"""

from __future__ import annotations

import numpy as np

from berryshaker.report.life_tables import life_parts
from berryshaker.report.sections import SectionInput, details, maybe_img
from berryshaker.study.life_drive_records import (
    ClearanceGrowth,
    ClearanceLife,
    FitLife,
    RecommendedFits,
)
from berryshaker.study.step_context import StudyContext
from berryshaker.study.step_result import FailedRun, Step, StepResult
from berryshaker.user_text import html_text


def run(ctx: StudyContext) -> StepResult:
    """Clearance over the machine's life: wear growth of each joint and the recommended fits (life/).

    Parameters
    ----------
    ctx : StudyContext
        The study's machine, runner, figure folder and failure log.

    Returns
    -------
    StepResult
        ``clearance_life``: :func:`step_life`'s result (a
        :class:`~berryshaker.study.life_drive_records.ClearanceLife`); no data (a note, and a failure logged) when
        it fails.
    """
    ctx.say("clearance life (wear, fits)")
    try:
        return step_life(ctx)
    except Exception as exc:  # noqa: BLE001 - a life estimate must not sink the whole study
        ctx.failures.append(FailedRun(step="clearance life", run="", inputs="wear and fit surrogate",
                                      error=f"{type(exc).__name__}: {exc}"))
        return StepResult("clearance_life", None, note=f"the clearance-life step failed: {exc}")


HORIZON_H = 2000.0


def _growth_to_limit(hours: np.ndarray, c: np.ndarray, limit: float) -> ClearanceGrowth:
    """A joint's clearance (m) over the hours (h), ended where it reaches its service limit (the joint is serviced
    there: no clearance beyond it is drawn), the crossing interpolated."""
    over = np.nonzero(c >= limit)[0]
    if over.size:
        i = int(over[0])
        if i == 0:
            hours, c = hours[:1], np.array([c[0]])
        else:
            h = float(np.interp(limit, [c[i - 1], c[i]], [hours[i - 1], hours[i]]))
            hours, c = np.append(hours[:i], h), np.append(c[:i], limit)
    return ClearanceGrowth(hours=[float(x) for x in hours], clearance_mm=[float(x) * 1e3 for x in c])


def fit_life(machine, joint: str, fit: str, source: str, response, limit: float) -> FitLife:
    """A fit evaluated on a joint's surrogate: its new-machine clearance (ISO 286 limits), the joint's
    static-equivalent load at its mean and its service life from there.

    Parameters
    ----------
    machine : MachineBase
        The machine description (the joint's geometry).
    joint : str
        The pair.
    fit : str
        ISO 286 fit designation at the joint's diameter.
    source : str
        "drawing" or "recommended".
    response : ClearanceResponse
        The joint's surrogate (N, m/h against m).
    limit : float
        The joint's service limit (m).

    Returns
    -------
    FitLife
        Clearances (mm), load (N) and life.
    """
    from berryshaker.life.fits import parse_fit
    from berryshaker.life.joint_loads import joint_geometry
    from berryshaker.life.service_life import joint_life
    from berryshaker.life.wear import clearance_size_from_fit

    g = joint_geometry(machine, joint)
    f = parse_fit(fit, g.diameter * 1e3)
    kind = "revolute" if g.is_pin else "point-line"
    lo, mean, hi = (clearance_size_from_fit(f, kind, w) for w in ("min", "mean", "max"))
    se = None
    if response.design_force_se is not None and response.starts > 1:
        se = float(np.interp(mean, response.clearance, response.design_force_se))
    rating = getattr(machine.clearance[joint], "dynamic_load_rating", None)
    life = joint_life(response, g, mean, limit, f"the {source} fit {fit} (mean of its ISO 286 limits)", rating)
    return FitLife(fit, source, lo * 1e3, mean * 1e3, hi * 1e3, float(response.force(mean)), life, se,
                   int(response.starts) if se is not None else None)


def step_life(ctx):
    """Clearance growth over 2000 h and the recommended fits (coarse surrogate; see the module docstring).

    Parameters
    ----------
    ctx : StudyContext
        The study's machine, runner, figure folder and console.

    Returns
    -------
    StepResult
        ``data``: a :class:`~berryshaker.study.life_drive_records.ClearanceLife`, ``growth[pair]`` (hours[],
        clearance_mm[]), ``hours_to_limit[pair]``, ``recommended`` (fits, cost, static-equivalent force,
        maintenance interval), ``front_size``, ``simulations``, ``notes``, ``life[pair]`` (by mechanism, from the
        new machine), ``drawing_fits`` and ``recommended_fits`` (each fit evaluated); one figure.
    """
    from berryshaker.life.service import service_limits
    from berryshaker.life.tolerance import (
        clearance_responses,
        compromise_index,
        force_fall_notes,
        joint_candidates,
        nsga2_front,
        response_grid,
    )

    m = ctx.machine
    joints = list(m.pair_names)
    ctx.say("clearance life (wear surrogate and fit choice)")
    limits = service_limits(m, joints)
    sizes = m.clearance_sizes()
    cands = joint_candidates(m, joints)
    lo = {j: min(float(cands[j].size.min()), sizes[j]) for j in joints}
    grid = response_grid(m, joints, limits, lo, n_points=3)
    resp = clearance_responses(m, joints, grid, ctx.runner, revolutions=2, label="clearance life grid",
                               starts=m.harvest.replicates)
    hours = np.linspace(0.0, HORIZON_H, 21)
    growth = {j: _growth_to_limit(hours, resp[j].grow(sizes[j], hours * resp[j].wear_scale), limits[j]) for j in joints}
    from berryshaker.life.joint_loads import joint_geometry
    from berryshaker.life.service_life import DESIGN_LIFE_H, joint_life

    to_limit = {}
    for j in joints:
        h = resp[j].service_hours(sizes[j], limits[j])
        to_limit[j] = None if h > DESIGN_LIFE_H else h
    drawing = {j: fit_life(m, j, m.clearance[j].fit, "drawing", resp[j], limits[j]) for j in joints
               if getattr(m.clearance[j], "fit", None)}
    life = {}
    for j in joints:
        if j in drawing:
            life[j] = drawing[j].life
        else:
            life[j] = joint_life(resp[j], joint_geometry(m, j), sizes[j], limits[j],
                                 "the described size (no fit on the drawing)",
                                 getattr(m.clearance[j], "dynamic_load_rating", None))
    x, f = nsga2_front(joints, cands, resp, limits, pop_size=40, generations=40, seed=1)
    best = compromise_index(f)
    rec = RecommendedFits(fits={j: cands[j].fits[x[best][k]].designation for k, j in enumerate(joints)},
                          cost=float(f[best, 0]), design_force_N=float(f[best, 1]),
                          maintenance_interval_h=float(-f[best, 2]))
    recommended = {j: fit_life(m, j, rec.fits[j], "recommended", resp[j], limits[j]) for j in joints}
    data = ClearanceLife(
        horizon_h=HORIZON_H, growth=growth, hours_to_limit=to_limit,
        clearance_limit_mm={j: v * 1e3 for j, v in limits.items()}, recommended=rec,
        front_size=int(len(x)), simulations=len(joints) * 3 * m.harvest.replicates,
        surrogate={j: r.to_dict() for j, r in resp.items()}, life=life, drawing_fits=drawing or None,
        recommended_fits=recommended,
        notes=[f"3 clearances per pair, one pair at a time, each the mean over {m.harvest.replicates} perturbed starts "
               "(2 revolutions each); growth integrated on the interpolated rate of the faster wear mode (no "
               "re-simulation per state)",
               *force_fall_notes(resp, m),
               "service life from the new machine's clearance by mechanism: lubricated and abrasive wear, contact "
               "fatigue, ISO 281 where a roller runs on a rolling bearing; the governing one's interval names its "
               "dominant uncertainty (Archard k for wear, docs/life.md)"])
    from berryshaker.report.plots.life import plot_clearance_growth

    figs = []
    try:
        ctx.figs.mkdir(parents=True, exist_ok=True)
        ctx.draw(plot_clearance_growth, {j: g.to_json() for j, g in growth.items()},
                 {j: v * 1e3 for j, v in limits.items()}, ctx.figs / "life_clearance_growth.png",
                 "Clearance growth by wear (coarse surrogate; dotted: limits)")
        figs.append("life_clearance_growth.png")
    except OSError:  # a folder that cannot be written: the step's numbers stand without the figure
        pass
    return StepResult("clearance_life", data, figs,
                      "coarse surrogate of the wear and the fit choice; run `berryshaker wear` and "
                      "`berryshaker tolerance` for the full analyses")


def clearance_life_section(inp: SectionInput) -> tuple[str, list[str]]:
    """Clearance over the machine's life (study step ``clearance_life``): wear growth, service life and fits.

    Parameters
    ----------
    inp : SectionInput
        Results (``clearance_life``, a ``berryshaker.study.life_drive_records.ClearanceLife``: clearances in mm,
        hours h), machine, figures.

    Returns
    -------
    tuple of (str, list of str)
        Title and HTML parts (none but the title when the step has no results).
    """
    parts = []
    life = inp.res.clearance_life
    if life is not None:
        parts += life_parts(life)
        more = ["<p class='small'>" + "; ".join(html_text(n) for n in life.notes) + "</p>"]
        maybe_img(more, inp.figs / "life_clearance_growth.png", "Clearance growth by wear against operating hours")
        parts.append(details("How the life was found (notes) and the clearance growth against hours (figure)", more))
    return "Clearance life: wear and fits (docs/life.md)", parts


#: the step in the study's step table (:data:`berryshaker.study.steps.STEPS`)
STEP = Step(key="clearance_life", run=run, result="clearance_life", sections=(clearance_life_section,))
