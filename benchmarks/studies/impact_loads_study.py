"""Sizing loads that converge: the per-impact statistics of every clearance pair against the solver tolerance and
the bush modes, beside the single largest force they replace.

The study behind the static-equivalent load (the p95 of the impact peaks, ``multibody.impacts.STATIC_FRACTILE``)
and the fatigue-equivalent load (``multibody.impacts.FATIGUE_EXPONENT``) that the design answers, ``tolerance``,
the virtual L9's trade-off table and the claims read (docs/life.md "Sizing loads"; the suite's share is
tests/multibody/test_impacts_convergence.py).  Writes benchmarks/studies/results/impact_loads.json.

Two parts, each over ``--starts`` perturbed starts:

* ``coupled``: the drive-past of the virtual L9's replicates (branch class 0, start k from
  ``RandomInitialPerturbation((harvest.seed + 1000 k, 0), ...)``)
  at the configured clearances (independent perturbed starts), at (rtol, bush modes) = the defaults (1e-5, 8), a tighter rtol (1e-6, 8) and more
  modes (1e-5, 16);
* ``machine``: the machine alone (``drives.simulation``'s mechanism, 3 cam revolutions: statistics over 2) at rtol
  1e-5 and 1e-6, the runs ``tolerance`` and the life step read.

For every pair and statistic: the mean over the starts and its standard error (SD / sqrt(n)); a variant is
"converged" against the default where |difference| < 2 SE of the difference (independent starts: a changed step
sequence decorrelates the chaotic runs).  CPU seconds per start are recorded (issue #57 reads them).

Usage::

    .venv/bin/python benchmarks/studies/impact_loads_study.py [PATH] [--starts 12]   # ~2 min on 2 cores
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

os.environ.setdefault("BERRYSHAKER_KERNEL", "generic")
sys.path.insert(0, str(Path(__file__).resolve().parent))
from _results import default_out, write_results  # noqa: E402

STATS = ("impacts", "p50", "p95", "p99", "static_equivalent", "fatigue_equivalent", "impulse_p95", "extreme",
         "single_max")
COUPLED_VARIANTS = {"default": (1e-5, 8), "tighter_rtol": (1e-6, 8), "more_modes": (1e-5, 16)}
MACHINE_VARIANTS = {"default": 1e-5, "tighter_rtol": 1e-6}


def row_of(res, pairs) -> dict:
    """The statistics of one run per pair (N, N s, counts)."""
    from berryshaker.multibody.impacts import impact_loads

    out = {}
    for p in pairs:
        il = impact_loads([res.contact_episodes(p)])
        out[p] = {"impacts": il.impacts, "p50": il.peak_N["p50"], "p95": il.peak_N["p95"], "p99": il.peak_N["p99"],
                  "static_equivalent": il.static_equivalent_N, "fatigue_equivalent": il.fatigue_equivalent_N,
                  "impulse_p95": il.impulse_Ns["p95"], "extreme": il.extreme_N,
                  "single_max": float(res.peaks[res.compiled.frc_names.index(p)])}
    return out


def compare(runs: dict, pairs) -> dict:
    """Mean +- SE per variant, and each variant's difference from the default with its SE and verdict."""
    table = {}
    for p in pairs:
        for s in STATS:
            base = np.array([r[p][s] for r in runs["default"]], float)
            entry = {}
            for name, rows in runs.items():
                v = np.array([r[p][s] for r in rows], float)
                m, se = float(v.mean()), float(v.std(ddof=1) / math.sqrt(v.size))
                entry[name] = {"mean": m, "se": se}
                if name != "default":
                    d = m - float(base.mean())
                    se_d = math.hypot(se, float(base.std(ddof=1) / math.sqrt(base.size)))
                    entry[name].update(diff=d, rel_diff=d / float(base.mean()), se_diff=se_d,
                                       converged=bool(abs(d) < 2 * se_d))
            table[f"{p}.{s}"] = entry
    return table


def main() -> None:
    """Run both parts and write the JSON."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("path", nargs="?", default=str(default_out("impact_loads")))
    ap.add_argument("--starts", type=int, default=12)
    a = ap.parse_args()
    from berryshaker.config import load_machine, machine_from_dict
    from berryshaker.drives import drive_of
    from berryshaker.harvest.virtual import stem_force_envelope_run
    from berryshaker.multibody.engine import simulate_mechanism
    from berryshaker.multibody.perturbation import RandomInitialPerturbation

    m0 = load_machine(None)
    h, pairs = m0.harvest, list(m0.pair_names)
    data = {"coupled": {}, "machine": {}, "cpu_s_per_start": {}}
    runs = {}
    for name, (rtol, modes) in COUPLED_VARIANTS.items():
        d = m0.model_dump()
        d["plant"]["contact"]["n_modes"] = modes
        m = machine_from_dict(d)
        stem_force_envelope_run(m, m.clearance_sizes(), 1.0, RandomInitialPerturbation((0, 0)), rtol)  # warm-up
        cpu = []
        for k in range(a.starts):
            pert = RandomInitialPerturbation((h.seed + 1000 * k, 0), h.initial_eccentricity, h.start_phase_spread)
            c0 = time.process_time()
            _, res = stem_force_envelope_run(m, m.clearance_sizes(), 1.0, pert, rtol)
            cpu.append(time.process_time() - c0)
            runs.setdefault(name, []).append(row_of(res, pairs))
        data["cpu_s_per_start"][f"coupled.{name}"] = float(np.median(cpu))
        print(name, "done", flush=True)
    data["coupled"] = compare(runs, pairs)
    spec = drive_of(m0).mechanism(m0, revolutions=3)
    runs = {}
    for name, rtol in MACHINE_VARIANTS.items():
        cpu = []
        for k in range(a.starts):
            pert = RandomInitialPerturbation((h.seed + 1000 * k, 0), h.initial_eccentricity, h.start_phase_spread)
            c0 = time.process_time()
            res = simulate_mechanism(spec, rtol=rtol, initial_perturbation=pert, series="statistics")
            cpu.append(time.process_time() - c0)
            runs.setdefault(name, []).append(row_of(res, pairs))
        data["cpu_s_per_start"][f"machine.{name}"] = float(np.median(cpu[1:] or cpu))
    data["machine"] = compare(runs, pairs)
    write_results(a.path, "impact_loads", {"starts": a.starts}, data)
    for part in ("coupled", "machine"):
        print(f"\n{part}: mean +- SE per variant; * = beyond 2 SE of the default")
        for key, e in data[part].items():
            cells = [f"{v['mean']:10.4g} +- {v['se']:7.3g}{'' if v.get('converged', True) else ' *'}"
                     for v in e.values()]
            print(f"{key:26s}", " | ".join(cells))


if __name__ == "__main__":
    main()
