"""Convergence of the fruit force with the number of branch modes kept in the coupled simulation.

The study's eq. 16 (m0 x branch acceleration) does not converge with modes under the comb's point
impacts: the branch acceleration at the fruit contains the direct (feed-through) response to the
sub-millisecond contact force, sum_k phi_k(z_m) phi_k(z_c) F(t), whose terms do not decay with k (it
tends to a spatial delta function).  The stem force of a fruit on a compliant pedicel
(berryshaker.plant.pedicel) sees the branch through the transfer function (k + i w c)/(k - m w^2 + i w c),
which falls as 1/w^2 above the stem frequency, so each added mode contributes less: the force converges.

What is compared is the statistic the harvest uses (docs/harvest.md, "Replicates"): the replicate mean over
seeded perturbed starts (clearance joints off centre, drive phase at the bush's arrival; the seeds of the
calibration's and the virtual L9's replicates, :func:`berryshaker.harvest.virtual.replicate_starts`).  With the
bush as the combs' load the lightly loaded combs rattle in their clearances, and any change of the integrator's
step sequence -- as a change of the modes kept makes -- moves one run's peak stem force by a few per cent: the
sensitivity of the clearance chain, not truncation.  :func:`fruit_force_convergence` separates the two: by default
every mode count is carried in the same run as a probe branch (:func:`berryshaker.harvest.coupled.coupled_mechanism`;
the instrumented branch never acts back on the combs, so all probes see the same comb motion and differ only by
their modal truncation); ``shared_run=False`` runs each mode count on its own at the same seeds (the truncation
error plus the step-sequence sensitivity).  docs/plant.md, "Convergence with modes", has the measured tables.
"""

from __future__ import annotations

import math
import time

import numpy as np
from scipy import stats

from berryshaker.config import Machine, machine_from_dict
from berryshaker.harvest.spec import COUPLED_RTOL

#: fruit-force quantities compared (FruitForceResult attribute -> row key suffix)
_QUANTITIES = {"fruit_force": "stem", "rigid_force": "rigid"}


def _with_modes(machine: Machine, n: int) -> Machine:
    d = machine.model_dump()
    d["plant"]["contact"]["n_modes"] = int(n)
    return machine_from_dict(d)


def _peaks(res) -> dict:
    """Peak |force| (N) per fruit name and quantity of one coupled result."""
    return {f"{name}_{tag}": float(np.max(np.abs(series)))
            for attr, tag in _QUANTITIES.items() for name, series in getattr(res, attr).items()}


def fruit_force_convergence(machine: Machine, modes=(4, 8, 16, 32), clearance: dict | None = None,
                            rtol: float = COUPLED_RTOL, replicates: int | None = None, shared_run: bool = True,
                            tolerance: float = 0.03, confidence: float = 0.95, say=None) -> dict:
    """Replicate means of the peak stem force (and eq. 16) at each fruit position against the modes kept.

    For replicate start k (the calibration's and the L9's start numbers, berryshaker.harvest.virtual.replicate_starts)
    the machine starts from :func:`berryshaker.harvest.virtual.machine_start` ``(k, MACHINE, c)``
    (:class:`berryshaker.multibody.perturbation.RandomInitialPerturbation` with ``harvest.initial_eccentricity`` and
    ``harvest.start_phase_spread``), c the index of the reference branch class (scale 1) in
    ``harvest.branch_classes``: the drive phase at which the virtual harvest's drive-past meets that class (its
    eccentricities are the virtual harvest's only when its run starts from that class).  Per
    mode count n and fruit position the row gives the replicate mean F_n = (1/R) sum_k F_n,k and its standard
    error SE_n = s_n / sqrt(R) (s_n the sample SD over the replicates: the harvest statistic's own noise), the
    relative difference from the most modes N, d_n = F_n / F_N - 1, and the standard error of that difference
    from the paired replicates, SE(d_n) = sd_k(F_n,k - F_N,k) / (sqrt(R) F_N).  Verdict (``tolerance`` tol,
    t = Student's t quantile at ``confidence`` with R - 1 degrees of freedom):

    * ``converged``: |d_n| + t SE(d_n) <= tol (the difference, with its noise, inside the tolerance);
    * ``not converged``: |d_n| - t SE(d_n) > tol (outside it beyond the noise);
    * ``unresolved``: otherwise (more replicates needed).

    ``no_difference`` marks |d_n| <= SE_n/F_n: the difference is inside the replicate mean's own standard
    error, i.e. it cannot be seen in the harvest's statistic.

    Parameters
    ----------
    machine : Machine
        Machine description with a [plant] and a [harvest] block (its load model as described: the bush by
        default).
    modes : sequence of int
        Mode counts of the instrumented branch (``plant.contact.n_modes``, up to 64); the last row with the
        most modes is the reference.
    clearance : dict, optional
        Clearance sizes (m) for the runs.
    rtol : float
        Relative integrator tolerance (dimensionless).
    replicates : int, optional
        R, default ``harvest.replicates`` (the calibration's count); at least 2.
    shared_run : bool
        True (default): one run per replicate carrying every mode count as a probe (truncation alone);
        False: one run per replicate and mode count (truncation plus the step-sequence sensitivity).
    tolerance, confidence : float
        The convergence tolerance (a relative difference, dimensionless) and the confidence of the t bound (a
        fraction, e.g. 0.95).
    say : callable, optional
        Called with a short progress text before each replicate ("replicate 3 of 8").

    Returns
    -------
    dict
        ``rows`` (one per mode count: ``n_modes``, ``highest_mode_hz``, per fruit name ``<name>_stem_N`` (replicate
        mean), ``<name>_stem_se_N``, ``<name>_stem_runs_N`` (per replicate), ``<name>_stem_rel`` (d_n),
        ``<name>_stem_rel_se`` (SE(d_n)), ``<name>_verdict``, ``<name>_no_difference``, the same ``_rigid_``
        keys for eq. 16 (mean, se, runs, rel), and ``verdict``: the worst over the fruit positions),
        ``replicates``, ``seeds``, ``method``, ``load_model``, ``tolerance``, ``confidence``, ``t_factor``,
        ``cpu_s`` (CPU time of all runs) and ``runs``.
    """
    from berryshaker.errors import ConfigError
    from berryshaker.harvest.coupled import simulate_fruit_force
    from berryshaker.harvest.virtual import MACHINE, machine_start, replicate_starts
    from berryshaker.plant.modes import branch_modes

    modes = [int(n) for n in modes]
    if len(modes) < 2 or len(set(modes)) != len(modes):
        raise ConfigError(f"modes={modes}: give at least two different mode counts")
    h = machine.harvest
    r = int(h.replicates if replicates is None else replicates)
    if r < 2:
        raise ConfigError(f"replicates={r}: give at least 2 (a standard error needs two)")
    seeds = replicate_starts(machine, r)
    classes = list(h.branch_classes)
    c_ref = classes.index(1.0) if 1.0 in classes else 0
    machines = [_with_modes(machine, n) for n in modes]
    peaks = {n: [] for n in modes}
    t0, runs = time.process_time(), 0
    for k, sd in enumerate(seeds):
        if say is not None:
            say(f"replicate {k + 1} of {r}")
        pert = machine_start(machine, (sd, MACHINE, c_ref))
        if shared_run:
            res = simulate_fruit_force(machines[0], clearance, rtol=rtol, initial_perturbation=pert,
                                       probes=tuple(machines[1:]))
            runs += 1
            for n, each in zip(modes, [res, *res.probes]):
                peaks[n].append(_peaks(each))
        else:
            for n, m in zip(modes, machines):
                peaks[n].append(_peaks(simulate_fruit_force(m, clearance, rtol=rtol, initial_perturbation=pert)))
                runs += 1
    cpu = time.process_time() - t0
    t_factor = float(stats.t.ppf(0.5 + confidence / 2, r - 1))
    ref_n = max(modes)
    keys = list(peaks[ref_n][0])
    ref = {k: np.array([p[k] for p in peaks[ref_n]]) for k in keys}
    rows = []
    rank = {"converged": 0, "unresolved": 1, "not converged": 2}
    for n in modes:
        row = {"n_modes": n, "highest_mode_hz": float(branch_modes(machine.plant.branch, n).frequency_hz[-1])}
        worst = "converged"
        for k in keys:
            v = np.array([p[k] for p in peaks[n]])
            mean, se = float(v.mean()), float(v.std(ddof=1) / math.sqrt(r))
            d = mean / float(ref[k].mean()) - 1.0
            se_d = float((v - ref[k]).std(ddof=1) / math.sqrt(r) / ref[k].mean())
            row.update({f"{k}_N": mean, f"{k}_se_N": se, f"{k}_runs_N": v.tolist(), f"{k}_rel": d,
                        f"{k}_rel_se": se_d})
            if k.endswith("_stem"):
                name = k[:-len("_stem")]
                verdict = ("converged" if abs(d) + t_factor * se_d <= tolerance else
                           "not converged" if abs(d) - t_factor * se_d > tolerance else "unresolved")
                row[f"{name}_verdict"] = verdict
                row[f"{name}_no_difference"] = bool(abs(d) <= se / mean) if mean > 0 else True
                worst = max(worst, verdict, key=rank.get)
        row["verdict"] = worst
        rows.append(row)
    return {"rows": rows, "replicates": r, "seeds": [[sd, c_ref] for sd in seeds],
            "method": "shared run (every mode count a probe of the same run)" if shared_run else
                      "separate runs (one per mode count, same seeds)",
            "load_model": machine.combs.load_model, "tolerance": tolerance, "confidence": confidence,
            "t_factor": t_factor, "cpu_s": cpu, "runs": runs}


def smallest_converged_modes(table: dict) -> int:
    """Smallest mode count from which on every row below the most modes is ``converged`` at every fruit position
    (:func:`fruit_force_convergence`: the replicate-mean difference from the most modes, with its noise, inside
    the tolerance).  Raises when none is.

    Parameters
    ----------
    table : dict
        :func:`fruit_force_convergence`'s result (its ``rows``, each with ``n_modes`` and ``verdict``, and
        ``tolerance``).

    Returns
    -------
    int
        The smallest mode count n such that every row from n on, up to (not including) the most modes, is
        ``converged``.

    Raises
    ------
    ConfigError
        No mode count below the most converged.
    """
    from berryshaker.errors import ConfigError

    rows = sorted(table["rows"], key=lambda r: r["n_modes"])[:-1]
    ok = [r["n_modes"] for i, r in enumerate(rows) if all(x["verdict"] == "converged" for x in rows[i:])]
    if not ok:
        raise ConfigError(f"no mode count below {max(r['n_modes'] for r in table['rows'])} converged within "
                          f"{table['tolerance']:.0%}: add modes or replicates")
    return min(ok)
