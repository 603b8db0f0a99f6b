"""The convergence study behind ``drives.base.HARVESTER_VELOCITY_SCALE`` (1 m/s), the velocity scale of a harvester
run's error control on every drive.  Cited by ``src/berryshaker/drives/base.py`` (``HARVESTER_VELOCITY_SCALE``) and
docs/multibody.md ("Integrator").  Writes
benchmarks/studies/results/velocity_scale_<drive>.json (``--out``).

For one drive, ensembles of 8 seeded perturbed starts x 6 cam revolutions at rtol 1e-5 and several velocity
scales (``simulation.velocity_scale``: the velocities' absolute tolerance is rtol x scale) are compared, statistic
by statistic, with the reference ensemble at rtol 1e-7 and the engine's 0.1 m/s, by the criterion of
tests/multibody/test_perturbation.py (``compare``); printed per scale: step attempts, CPU per run, the statistics
failing that criterion, and those whose difference exceeds twice its standard error (a systematic shift).

    .venv/bin/python benchmarks/studies/velocity_scale_study.py groove_cam      # ~3 min
    .venv/bin/python benchmarks/studies/velocity_scale_study.py crank_rocker
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests"))

from _results import default_out, write_results  # noqa: E402  (benchmarks/studies/, the script's own folder)
from test_multibody_convergence import compare, summary_statistics  # noqa: E402

from berryshaker.config import reference_machine  # noqa: E402
from berryshaker.drives import drive_of  # noqa: E402
from berryshaker.drives.simulation import multibody_summary  # noqa: E402
from berryshaker.multibody.engine import simulate_mechanism  # noqa: E402
from berryshaker.multibody.perturbation import RandomInitialPerturbation  # noqa: E402

# the generic kernel unless the caller sets BERRYSHAKER_KERNEL (a run left to choose would take a specialised
# one once compiled on this machine: multibody.specialised)
os.environ.setdefault("BERRYSHAKER_KERNEL", "generic")

STARTS = 8
REVOLUTIONS = 6
SCALES = (0.1, 1.0, 3.0, 10.0)  # m/s


def ensemble(drive: str, rtol: float, scale: float):
    """Summary statistics of every start, mean step attempts and CPU per run."""
    machine = reference_machine(drive)
    spec = drive_of(machine).mechanism(machine, revolutions=REVOLUTIONS)
    spec = spec.model_copy(update={"simulation": spec.simulation.model_copy(update={"velocity_scale": scale})})
    runs, attempts, cpu = [], [], 0.0
    for seed in range(STARTS):
        c0 = time.process_time()
        res = simulate_mechanism(spec, rtol=rtol, initial_perturbation=RandomInitialPerturbation(seed))
        cpu += time.process_time() - c0
        runs.append(summary_statistics(multibody_summary(machine, res)))
        attempts.append(res.info[0] + res.info[1] + res.info[2])
    return {k: np.array([r[k] for r in runs]) for k in runs[0]}, float(np.mean(attempts)), cpu / STARTS


def main(argv=None) -> None:
    """Run the ensembles of one drive, print and write the comparison."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("drive", nargs="?", default="groove_cam", help="groove_cam (default) or crank_rocker")
    ap.add_argument("--out", default=None, help="JSON of the results (default results/velocity_scale_<drive>.json)")
    a = ap.parse_args(argv)
    drive = a.drive
    ref, n_ref, c_ref = ensemble(drive, 1e-7, 0.1)
    print(f"{drive}: reference rtol 1e-7, 0.1 m/s: {n_ref:.0f} step attempts, {c_ref:.3f} s per run")
    data = {"drive": drive, "starts": STARTS, "revolutions": REVOLUTIONS,
            "reference": {"rtol": 1e-7, "velocity_scale_m_s": 0.1, "attempts_per_run": n_ref, "cpu_s_per_run": c_ref},
            "scales": []}
    for scale in SCALES:
        e, n, c = ensemble(drive, 1e-5, scale)
        res = compare(e, ref)
        fails = [k for k, v in res.items() if not v["ok"]]
        shifts = {k: f"{100 * v['difference']:+.2f} +- {100 * v['se']:.2f} %" for k, v in res.items()
                  if abs(v["difference"]) > 2 * v["se"]}
        print(f"rtol 1e-5, {scale:g} m/s: {n:.0f} attempts, {c:.3f} s per run; failing {fails or 'none'}; "
              f"shifts beyond 2 SE ({len(shifts)}): {shifts}", flush=True)
        data["scales"].append({"rtol": 1e-5, "velocity_scale_m_s": scale, "attempts_per_run": n, "cpu_s_per_run": c,
                               "failing": fails, "beyond_2se": sorted(shifts),
                               "statistics": {k: {"difference": v["difference"], "se": v["se"], "ok": bool(v["ok"])}
                                              for k, v in res.items()}})
    write_results(a.out or default_out(f"velocity_scale_{drive}"), "velocity_scale", vars(a), data)


if __name__ == "__main__":
    main()
