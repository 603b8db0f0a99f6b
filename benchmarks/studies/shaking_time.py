"""Removal against shaking time (docs/harvest.md, "Detachment over load cycles"): how much of the ripe fruit the
model detaches after 0.5, 1, 2, 3 and 4 s of shaking, against Malladi, Vashisth & NeSmith (2013, HortScience 48(3):
394-397: a handheld shaker on blueberry branches detached most fruit within 3-4 s, more than 75 % of a branch's).

The reference machine (drive speed, stroke, clearances) at a travel speed slow enough that the instrumented branch
stays in the comb for 4.8 s (10 m/min over the 0.8 m span), so the comb shakes it as a stationary shaker would,
one coupled drive-past per branch class and start (``--starts`` of the description's family).  Shaking time is
counted from the first finger contact on the branch; the stem-load tables are those of the motion up to each time
(berryshaker.harvest.virtual.stem_force_table on the truncated branch motion), read at Miner exponents 3, 8
(the default), 30 and 1e9 (the peak-only law).  Each start's ripe removal is the model's expectation
(berryshaker.harvest.virtual.start_responses); the mean over the starts with its SE.
Writes benchmarks/studies/results/shaking_time.json.

Usage::

    .venv/bin/python benchmarks/studies/shaking_time.py [--starts 4] [--workers 2] [--speed 10]
"""

from __future__ import annotations

import argparse
import math
from concurrent.futures import ProcessPoolExecutor

import numpy as np
from _results import default_out, write_results

TIMES = (0.5, 1.0, 2.0, 3.0, 4.0)
#: Miner exponents read; 1e9 is the peak-only law (a description's exponent is finite)
EXPONENTS = (3.0, 8.0, 30.0, 1e9)


def _machine(speed_m_min: float):
    from berryshaker.config import machine_from_dict, reference_machine

    d = reference_machine().model_dump(mode="json")
    d["operation"]["walking_speed"] = speed_m_min / 60.0
    return machine_from_dict(d)


def class_tables(job: tuple) -> dict:
    """Stem-load tables of one (start, branch class) at each shaking time (nested lists) and the run's end."""
    from berryshaker.harvest.coupled import drive_past
    from berryshaker.harvest.coupled_branch import BranchMotion
    from berryshaker.harvest.virtual import (
        ENVELOPE_OUTPUT_STEP,
        MACHINE,
        branch_class_machine,
        machine_start,
        stem_force_table,
    )

    speed, start, c = job
    m = _machine(speed)
    mc = branch_class_machine(m, m.harvest.branch_classes[c])
    _, mo = drive_past(mc, None, initial_perturbation=machine_start(m, (start, MACHINE, c)),
                       output_step=ENVELOPE_OUTPUT_STEP)
    touching = np.any([np.asarray(f) > 0 for f in mo.contact_force.values()], axis=0)
    t0 = float(mo.t[np.argmax(touching)]) if np.any(touching) else float(mo.t[0])
    out = {"first_contact_s": t0, "end_s": float(mo.t[-1]), "tables": {}}
    for tau in (*TIMES, None):
        n = mo.t.size if tau is None else int(np.searchsorted(mo.t, t0 + tau, side="right"))
        cut = BranchMotion(mo.t[:n], mo.modes, mo.eta[:n], mo.etad[:n], mo.etadd[:n],
                           {k: v[:n] for k, v in mo.contact_force.items()})
        out["tables"]["pass" if tau is None else f"{tau:g}"] = stem_force_table(mc, cut).tolist()
    return out


def main() -> None:
    from berryshaker.harvest.virtual import replicate_starts, start_responses

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--starts", type=int, default=4)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--speed", type=float, default=10.0, help="travel speed (m/min)")
    a = ap.parse_args()
    m = _machine(a.speed)
    seeds = replicate_starts(m, a.starts)
    nc = len(m.harvest.branch_classes)
    jobs = [(a.speed, k, c) for k in seeds for c in range(nc)]
    with ProcessPoolExecutor(a.workers) as ex:
        runs = list(ex.map(class_tables, jobs))
    labels = [f"{t:g}" for t in TIMES] + ["pass"]
    data: dict = {"speed_m_min": a.speed, "times_s": list(TIMES),
                  "first_contact_s": [r["first_contact_s"] for r in runs], "end_s": runs[0]["end_s"], "removal": {}}
    for beta in EXPONENTS:
        d = m.model_dump(mode="json")
        d["harvest"]["miner_exponent"] = beta
        from berryshaker.config import machine_from_dict

        mb = machine_from_dict(d)
        rows = {}
        for lab in labels:
            each = [start_responses(mb, [np.asarray(runs[i * nc + c]["tables"][lab]) for c in range(nc)],
                                    k)["expected"]["ripe_removal"] for i, k in enumerate(seeds)]
            x = np.array(each, float)
            rows[lab] = {"mean": float(np.mean(x)), "se": float(np.std(x, ddof=1) / math.sqrt(x.size)),
                         "each": x.tolist()}
        data["removal"]["peak-only" if beta > 1e6 else f"{beta:g}"] = rows
        print(f"beta {beta:g}: " + ", ".join(f"{lab} s {rows[lab]['mean']:.1f} +- {rows[lab]['se']:.1f} %"
                                             for lab in labels))
    write_results(default_out("shaking_time"), "shaking_time", {"starts": a.starts, "speed_m_min": a.speed}, data)


if __name__ == "__main__":
    main()
