"""The solver-tolerance check of the virtual L9's recommendation: its first ``harvest.tolerance_replicates``
starts re-run at a tighter relative tolerance (:data:`RTOL_CHECK`), each response's mean change judged against the
replicate noise (:func:`tolerance_verdict`, :func:`check_solver_tolerance`; docs/harvest.md).
"""

from __future__ import annotations

import math

import numpy as np
from scipy import special

from berryshaker.harvest.spec import COUPLED_VELOCITY_SCALE
from berryshaker.study.l9.records import ToleranceCheck, ToleranceVerdict
from berryshaker.study.replicate_responses import RTOL_RUN
from berryshaker.study.runs import replicate_run
from berryshaker.units import format_tolerance

#: the tighter relative tolerance the check re-runs at (the runs' own: :data:`RTOL_RUN`)
RTOL_CHECK = 1e-7

#: family-wise false-alarm probability of the whole check (all responses together): a converged tolerance is flagged
#: "NOT within" for some response with this probability, whatever the number of responses checked
FAMILY_ALPHA = 0.05


def band_z(responses: int) -> float:
    """Half-width of the check's band in noise SDs: the two-sided Bonferroni quantile z = Phi^-1(1 - alpha / (2 m))
    of :data:`FAMILY_ALPHA` over the ``m`` responses checked (1.96 for one response, 2.84 for eleven).

    Testing m responses each at 5 % flags one of them on noise alone with probability 1 - 0.95^m (43 % for the
    L9's eleven); Bonferroni's bound (Dunn 1961, J. Am. Stat. Assoc. 56(293), 52-64) holds the whole check's
    false-alarm probability at or below :data:`FAMILY_ALPHA` without assuming the responses independent (the
    loads of one start are correlated).

    Parameters
    ----------
    responses : int
        Number of responses checked together (m >= 1).

    Returns
    -------
    float
        z (dimensionless).
    """
    return float(special.ndtri(1.0 - FAMILY_ALPHA / (2.0 * max(int(responses), 1))))


def tolerance_verdict(changes, replicate_sd: float, responses: int = 1) -> dict:
    """Whether a response's change between two solver tolerances is within the replicate noise.

    ``changes``: the change of the response for each of k replicates re-run at the tighter tolerance (same seeds);
    ``replicate_sd``: its per-start standard deviation (at the recommended set, over all its starts).  The coupled runs are
    chaotic, so a replicate re-run at another tolerance is another draw of the same noise: the change of one
    replicate is then ~sqrt(2) SD at random, and comparing single changes with one SD (this check's first form)
    failed on noise for 48 % of single changes, 73 % of responses with k = 2.  The mean change of the k
    replicates has standard deviation sqrt(2 / k) SD when the two tolerances' replicates are independent draws (less when they stay correlated, as
    the harvest indexes do), so "within" is |mean change| <= z sqrt(2 / k) SD with z = :func:`band_z` of the
    ``responses`` checked together (1.96 for one, 2.84 for the L9's eleven): a solver bias that large is flagged,
    noise is not, for the check as a whole (tests/study/test_l9.py, ``test_tolerance_verdict_is_noise_aware``).
    With k = 2 and eleven responses that resolves a bias of ~3 SD only; the tolerance itself is validated on 16
    replicates by tests/harvest/test_coupled_tolerance.py.

    Parameters
    ----------
    changes : array_like
        The response's change per replicate (the response's unit).
    replicate_sd : float
        Its per-start standard deviation (the response's unit).
    responses : int
        Number of responses the check judges together (sets the band, :func:`band_z`).

    Returns
    -------
    dict
        ``changes``, ``max_abs_change``, ``mean_change``, ``replicate_sd``, ``noise_sd`` (sqrt(2/k) SD) in the
        response's unit, and ``within_replicate_spread`` (|mean change| <= z noise_sd).
    """
    d = np.asarray(changes, float)
    k = d.size
    mean = float(np.mean(d))
    noise = math.sqrt(2.0 / k) * float(replicate_sd)
    within = bool(abs(mean) <= band_z(responses) * noise)
    return {"changes": d.tolist(), "max_abs_change": float(np.max(np.abs(d))), "mean_change": mean,
            "replicate_sd": float(replicate_sd), "noise_sd": noise, "within_replicate_spread": within}


def check_solver_tolerance(machine, runner, jobs_for, cells, best_cl, seeds, rec_cells, sds, names
                           ) -> ToleranceCheck:
    """The recommended set's first ``harvest.tolerance_replicates`` replicates re-run at :data:`RTOL_CHECK`: each
    response's mean change against the noise of k replicates (:func:`tolerance_verdict`, ``sds``: the per-start
    standard deviation of each response at the recommended set).

    Parameters
    ----------
    machine : Machine
        Machine description (its ``harvest.tolerance_replicates``).
    runner : SweepRunner
        Runs the coupled drive-pasts (cached).
    jobs_for : callable
        ``jobs_for(clearance, seeds, rtol)``: the replicate jobs of a clearance set
        (:func:`berryshaker.study.replicate_responses.replicate_jobs`).
    cells : callable
        ``cells(outputs, seeds)``: every start's responses from its run outputs.
    best_cl : dict
        The recommended clearance size (m) per pair.
    seeds : list of int
        The recommended set's start numbers.
    rec_cells : list of dict
        The recommended set's responses per start at :data:`RTOL_RUN` (each response's unit).
    sds : dict of str to float
        Per-start standard deviation of each response at the recommended set (the response's unit).
    names : list of str
        The responses checked.

    Returns
    -------
    ToleranceCheck
        ``done`` (False, with the ``reason``, when ``harvest.tolerance_replicates`` is 0), ``rtol`` (run and check,
        dimensionless), ``velocity_scale_m_s`` (m/s), ``replicates``, ``responses`` (:func:`tolerance_verdict` per
        response), ``all_within`` and ``statement``.
    """
    k = min(machine.harvest.tolerance_replicates, len(seeds))
    if k == 0:
        return ToleranceCheck(done=False, reason="harvest.tolerance_replicates = 0")
    s = seeds[:k]
    o = runner.values(replicate_run, jobs_for(best_cl, s, RTOL_CHECK), f"tolerance check: {k} replicates at rtol {format_tolerance(RTOL_CHECK)}")
    tight = cells(o, s)
    verdicts = {n: ToleranceVerdict(**tolerance_verdict([tight[j][n] - rec_cells[j][n] for j in range(k)], sds[n],
                                                        len(names)))
                for n in names}
    bad = [n for n, v in verdicts.items() if not v.within_replicate_spread]
    change = f"the change from rtol {format_tolerance(RTOL_RUN)} to {format_tolerance(RTOL_CHECK)}"
    band = (f"mean change of {k} replicate(s) within {band_z(len(names)):.2f} x sqrt(2/{k}) replicate SD, "
            f"{FAMILY_ALPHA:.0%} false alarms over all {len(names)}")
    statement = (f"{change} is within the replicate noise for every response ({band})" if not bad else
                 f"{change} is NOT within the replicate noise ({band}) for: " + ", ".join(bad)
                 + " (a solver bias comparable to the noise there)")
    return ToleranceCheck(done=True, rtol=[RTOL_RUN, RTOL_CHECK], velocity_scale_m_s=COUPLED_VELOCITY_SCALE,
                          replicates=k, responses=verdicts, all_within=not bad, statement=statement)
