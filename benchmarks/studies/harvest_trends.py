"""Harvest trends against the three operating knobs (docs/harvest.md, "Trends"): shaking frequency (drive speed),
stroke and travel speed, on the reference machine at its configured clearances.

Every point is the replicate statistic of the study (``harvest.replicates`` perturbed starts, the same seeds at
every point: common random numbers), so a step between two points is judged by the paired differences over the
starts (mean, SE, t p-value), not by the spread of either.  Beside the responses, what explains a step in the
detachment (docs/harvest.md "Trends"), from the same tables: the ripe removal under the peak-only law
(``harvest.miner_exponent`` = 1e9) and at the prior's steepest law (3), and over the ripe fruit's quadrature nodes the geometric means of the peak load
ratio (``peak_load``) and of the gain of the Miner-Basquin equivalent over it (``miner_gain``: g_eq / max g at the
described exponent).  Writes benchmarks/studies/results/harvest_trends.json.
Usage: ``python benchmarks/studies/harvest_trends.py [--workers N] [--cache DIR] [--replicates R]``.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np
from scipy import stats

from berryshaker.config import machine_from_dict, reference_machine
from berryshaker.harvest.virtual import RESPONSES, load_grid, replicate_starts, shaking_amplitude, start_responses
from berryshaker.plant.pedicel import miner_load
from berryshaker.runs.runner import SweepRunner
from berryshaker.study.l9 import replicate_envelopes, replicate_jobs
from berryshaker.study.runs import replicate_run

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _results import default_out, write_results  # noqa: E402

#: knob -> (dotted key, SI values, unit label, SI -> label factor)
KNOBS = {
    "drive speed": ("cam.speed", [r * 2 * math.pi / 60 for r in (60, 90, 120, 150, 180)], "r/min", 60 / (2 * math.pi)),
    "stroke": ("cam.stroke", [0.030, 0.040, 0.050], "mm", 1e3),
    "travel speed": ("operation.walking_speed", [20 / 60, 30 / 60, 40 / 60], "m/min", 60.0),
}


def variant(data: dict, key: str, value: float) -> dict:
    sec, name = key.split(".")
    d = dict(data)
    d[sec] = dict(d[sec], **{name: value})
    return d


#: the explanatory columns beside the responses (module docstring)
EXTRA = ("ripe_removal_peak_only", "ripe_removal_beta3", "peak_load", "miner_gain")


def explain(m, env, seed) -> dict:
    """The explanatory columns (:data:`EXTRA`) of one start's tables ``env`` on machine ``m``."""
    def removal(beta):
        d = m.model_dump(mode="json")
        d["harvest"]["miner_exponent"] = beta
        return start_responses(machine_from_dict(d), env, seed)["expected"]["ripe_removal"]

    g = load_grid(m, [np.asarray(e, float) for e in env])
    w = g.weight / g.weight.sum()
    peak = g.channels_ripe[0]
    gain = miner_load(g.channels_ripe, m.harvest.miner_exponent) / peak
    return {"ripe_removal_peak_only": removal(1e9), "ripe_removal_beta3": removal(3.0), "peak_load": float(np.exp(np.sum(w * np.log(peak)))),
            "miner_gain": float(np.exp(np.sum(w * np.log(gain))))}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workers", type=int, default=None)
    ap.add_argument("--cache", default=None)
    ap.add_argument("--replicates", type=int, default=None)
    a = ap.parse_args()
    machine = reference_machine()
    data = machine.model_dump(mode="json")
    seeds = replicate_starts(machine, a.replicates)
    out = {}
    with SweepRunner(workers=a.workers, cache_dir=a.cache) as runner:
        for knob, (key, values, unit, factor) in KNOBS.items():
            points = []
            for v in values:
                d = variant(data, key, v)
                m = machine_from_dict(d)
                outs = runner.values(replicate_run, replicate_jobs(m, m.clearance_sizes(), seeds, data=d),
                                     f"{knob} {v * factor:g} {unit}")
                reps = replicate_envelopes(m, outs, seeds)
                each = [{**start_responses(m, env, sd)["expected"], **explain(m, env, sd)} for env, sd in reps]
                points.append({"value": v * factor, "seeds": [sd for _, sd in reps],
                               "each": {k: [e[k] for e in each] for k in (*RESPONSES, *EXTRA)},
                               "finger_amplitude_mm": shaking_amplitude(m)["finger_amplitude_mm"]})
            rows = []
            for i, p in enumerate(points):
                row = {"value": p["value"], "finger_amplitude_mm": p["finger_amplitude_mm"]}
                for k in (*RESPONSES, *EXTRA):
                    x = np.array(p["each"][k], float)
                    row[k] = float(np.nanmean(x))
                    row[f"{k}_sd"] = float(np.nanstd(x, ddof=1))
                    if i:  # paired step from the previous point, over the shared starts
                        prev = dict(zip(points[i - 1]["seeds"], points[i - 1]["each"][k]))
                        diff = np.array([x_ - prev[s] for s, x_ in zip(p["seeds"], x) if s in prev], float)
                        diff = diff[np.isfinite(diff)]
                        se = float(np.std(diff, ddof=1) / math.sqrt(diff.size)) if diff.size > 1 else float("nan")
                        t = float(np.mean(diff)) / se if se > 0 else float("nan")
                        row[f"{k}_step"] = {"mean": float(np.mean(diff)), "se": se,
                                            "p": float(2 * stats.t.sf(abs(t), diff.size - 1)) if se > 0 else None}
                rows.append(row)
            out[knob] = {"key": key, "unit": unit, "rows": rows}
            print(knob)
            for r in rows:
                print(f"  {r['value']:g} {unit}: " + ", ".join(
                    f"{k} {r[k]:.3g} +- {r[k + '_sd']:.2g}" + (f" (step {r[k + '_step']['mean']:+.3g} +- "
                                                                  f"{r[k + '_step']['se']:.2g})" if k + "_step" in r
                                                                  else "")
                    for k in ("ripe_removal", "unripe_shed", "damage", *EXTRA)))
    write_results(default_out("harvest_trends"), "harvest_trends", {"replicates": len(seeds)}, out)


if __name__ == "__main__":
    main()
