"""Sizing torques that converge: the design torque (p95 of the per-revolution peaks of the drive moment), the RMS
torque and the fatigue-equivalent torque of the virtual L9's starts against the solver tolerance, the bush modes and
the number of starts, beside the single largest moment they replace.

The study behind ``drive_torque_design`` (berryshaker.multibody.drive_loads; docs/life.md "Sizing loads", "The
drive torque"; the suite's share is tests/multibody/test_drive_loads_convergence.py).  Writes
benchmarks/studies/results/drive_torque.json.

Each start is a start of the virtual L9: the drive-pasts of the three branch classes from
``RandomInitialPerturbation((harvest.seed + 1000 k, 0), ...)`` at the configured clearances, pooled (9 whole
revolutions).  Variants (rtol, bush modes): the defaults (1e-5, 8), a tighter rtol (1e-6, 8) and more modes
(1e-5, 16).  For every statistic: the mean over the starts with its SE (SD / sqrt(n)), each variant's difference
from the default with its SE and verdict (|difference| < 2 SE), and the default's mean over the first 8 starts (the
L9's count per run).

Usage::

    .venv/bin/python benchmarks/studies/drive_torque_study.py [PATH] [--starts 24]   # ~3 CPU-min
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from pathlib import Path

import numpy as np

os.environ.setdefault("BERRYSHAKER_KERNEL", "generic")
sys.path.insert(0, str(Path(__file__).resolve().parent))
from _results import default_out, write_results  # noqa: E402

STATS = ("design", "revolution_mean", "single_max", "rms", "fatigue_equivalent")
VARIANTS = {"default": (1e-5, 8), "tighter_rtol": (1e-6, 8), "more_modes": (1e-5, 16)}


def start_row(machine, k: int, rtol: float) -> dict:
    """The torque statistics of start ``k`` (its branch classes' drive-pasts pooled; N m)."""
    from berryshaker.harvest.virtual import stem_force_envelope_run
    from berryshaker.multibody.drive_loads import design_torque, fatigue_equivalent_torque, revolution_peaks
    from berryshaker.multibody.perturbation import RandomInitialPerturbation

    h = machine.harvest
    peaks, moments = [], []
    for scale in h.branch_classes:
        pert = RandomInitialPerturbation((h.seed + 1000 * k, 0), h.initial_eccentricity, h.start_phase_spread)
        _, res = stem_force_envelope_run(machine, machine.clearance_sizes(), scale, pert, rtol)
        sel = res.t >= res.stats_from - 1e-12
        m = res.reaction("drive")[sel]
        peaks.append(revolution_peaks(res.t[sel], m, res.stats_from, 2 * math.pi / machine.drive_speed))
        moments.append(m)
    p, m = np.concatenate(peaks), np.concatenate(moments)
    return {"design": design_torque(p), "revolution_mean": float(p.mean()), "single_max": float(p.max()),
            "rms": float(np.sqrt(np.mean(m**2))), "fatigue_equivalent": fatigue_equivalent_torque(m),
            "revolutions": int(p.size)}


def compare(runs: dict) -> dict:
    """Mean +- SE per variant; each variant's difference from the default with its SE and verdict."""
    table = {}
    for s in STATS:
        base = np.array([r[s] for r in runs["default"]], float)
        mb, sb = float(base.mean()), float(base.std(ddof=1) / math.sqrt(base.size))
        entry = {"default_first_8": float(base[:8].mean())}
        for name, rows in runs.items():
            v = np.array([r[s] for r in rows], float)
            m, se = float(v.mean()), float(v.std(ddof=1) / math.sqrt(v.size))
            entry[name] = {"mean": m, "se": se}
            if name != "default":
                d, se_d = m - mb, math.hypot(se, sb)
                entry[name].update(diff=d, rel_diff=d / mb, se_diff=se_d, converged=bool(abs(d) < 2 * se_d))
        table[s] = entry
    return table


def main() -> None:
    """Run every variant and write the JSON."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("path", nargs="?", default=str(default_out("drive_torque")))
    ap.add_argument("--starts", type=int, default=24)
    a = ap.parse_args()
    from berryshaker.config import load_machine, machine_from_dict

    m0 = load_machine(None)
    runs = {}
    for name, (rtol, modes) in VARIANTS.items():
        d = m0.model_dump()
        d["plant"]["contact"]["n_modes"] = modes
        m = machine_from_dict(d)
        runs[name] = [start_row(m, k, rtol) for k in range(a.starts)]
        print(name, "done", flush=True)
    data = compare(runs)
    write_results(a.path, "drive_torque", {"starts": a.starts}, data)
    for key, e in data.items():
        cells = [f"{v['mean']:8.4g} +- {v['se']:6.3g}{'' if v.get('converged', True) else ' *'}"
                 for k, v in e.items() if isinstance(v, dict)]
        print(f"{key:20s}", " | ".join(cells))


if __name__ == "__main__":
    main()
