"""Study step "Clearance life": a cheap summary of joint wear and fit choice for the report.

Three clearances per pair, each from ``harvest.replicates`` perturbed starts (one pair varied at a time, cached
through the study's runner), give each pair's Archard growth rate and mean peak collision force against its own
clearance (the tolerance design's surrogate, :mod:`berryshaker.life.clearance_response`).
From it: the clearance of every pair over 2000 operating hours from the description's sizes
(dc/dh = r(c) on the interpolant), the hours to each pair's service limit (life.service.service_limits, docs/life.md 4a), and the fit recommended by
NSGA-II on the surrogate.  Coarse on purpose (3 points per pair, runs of 2 revolutions); ``berryshaker wear``
re-simulates at every state and ``berryshaker tolerance`` uses a finer grid.
"""

from __future__ import annotations

import numpy as np

from berryshaker.study.life_drive_records import ClearanceGrowth, ClearanceLife, RecommendedFits
from berryshaker.study.step_result import StepResult

HORIZON_H = 2000.0


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
        clearance_mm[]), ``hours_to_limit[pair]``, ``recommended`` (fits, cost, peak force, maintenance interval),
        ``front_size``, ``simulations``, ``notes``; one figure.
    """
    from berryshaker.life.service import service_limits
    from berryshaker.life.tolerance import (
        clearance_responses,
        joint_candidates,
        nsga2_front,
        compromise_index,
        force_fall_notes,
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
    growth = {j: ClearanceGrowth(hours=hours.tolist(), clearance_mm=(resp[j].grow(sizes[j], hours) * 1e3).tolist())
              for j in joints}
    to_limit = {j: resp[j].hours_to(sizes[j], limits[j]) for j in joints}
    x, f = nsga2_front(joints, cands, resp, limits, pop_size=40, generations=40, seed=1)
    best = compromise_index(f)
    rec = RecommendedFits(fits={j: cands[j].fits[x[best][k]].designation for k, j in enumerate(joints)},
                          cost=float(f[best, 0]), peak_force_N=float(f[best, 1]),
                          maintenance_interval_h=float(-f[best, 2]))
    data = ClearanceLife(
        horizon_h=HORIZON_H, growth=growth, hours_to_limit=to_limit,
        clearance_limit_mm={j: v * 1e3 for j, v in limits.items()}, recommended=rec,
        front_size=int(len(x)), simulations=len(joints) * 3 * m.harvest.replicates,
        surrogate={j: r.to_dict() for j, r in resp.items()},
        notes=[f"3 clearances per pair, one pair at a time, each the mean over {m.harvest.replicates} perturbed starts "
               "(2 revolutions each); growth integrated on the interpolated rate (no re-simulation per state)",
               *force_fall_notes(resp, m),
               "Archard k and H of the material pairs dominate the uncertainty (docs/life.md)"])
    from berryshaker.report.plots.life import plot_clearance_growth

    figs = []
    try:
        ctx.figs.mkdir(parents=True, exist_ok=True)
        plot_clearance_growth({j: g.to_json() for j, g in growth.items()}, {j: v * 1e3 for j, v in limits.items()}, ctx.figs / "life_clearance_growth.png",
                              "Clearance growth by wear (coarse surrogate; dotted: limits)")
        figs.append("life_clearance_growth.png")
    except OSError:  # a folder that cannot be written: the step's numbers stand without the figure
        pass
    return StepResult("clearance_life", data, figs,
                      "coarse surrogate of the wear and the fit choice; run `berryshaker wear` and "
                      "`berryshaker tolerance` for the full analyses")
