"""Impact-velocity floor of lubricated pairs: is a restitution velocity v_floor a converged regularisation?

The study behind the lubricated (greased) pairs' default ``restitution_velocity`` of 1 mm/s (the largest floor with
no effect; 3 mm/s raises the collision forces' 95th percentiles): cited by ``src/berryshaker/contact/pair_law.py``,
docs/contact.md sec. 6.4 and tests/contact/test_pair_law_velocity_floor.py.
Writes benchmarks/studies/results/impact_velocity_floor.json (the ``run`` command's path; ~25 min).

The hysteresis laws divide their damping by max(v_imp, v_ref) (docs/contact.md sec. 6.4).  For each
``v_floor`` of ``--floors`` (m/s; 0 = the published law, with the kernel's own 1e-6 m/s floor on v_imp) the
reference machine runs with ``restitution_velocity = v_floor`` on all four pairs:

* ``plain``: harvester runs (``drives.simulation.simulate_multibody``, 2 cam revolutions, rtol 1e-6, output
  0.1 ms) over the reference clearances and ``--sets`` sets drawn uniformly 0.8-1.25x around them (seed 2):
  mean / RMS / p95 / peak collision force of each pair over revolution 2, mean drive moment, steps, CPU;
* ``coupled``: the drive-pasts of the virtual L9's replicates (``harvest.virtual.replicate_starts``, replicate k
  of branch class c from ``RandomInitialPerturbation((seed_k, c), ...)``, one run per class (the L9 carries them as
  probes of one run);
  ``harvest.coupled.simulate_fruit_force`` and ``harvest.virtual.stem_force_table``, rtol 1e-6,
  output step ``harvest.virtual.ENVELOPE_OUTPUT_STEP``, at the configured clearances): fruit-force peaks root / middle / end, comb-branch contact
  peaks, steps, CPU, and per replicate the harvest indexes (efficiency kg/min, damage %, unripe %) of
  ``harvest_indexes`` on the replicate's population, as the calibration and the L9 compute them.

Every floor runs on the same sets / seeds, so floors are compared by the paired difference to ``v_floor = 0``
(and to the next smaller floor): mean difference over the sets / runs / replicates and its standard error
(SD / sqrt(n)); "no difference" where |diff| < 2 SE.  Runs are made one at a time in this process, floors
interleaved within each set / run (one machine load for all floors); CPU time by ``time.process_time`` after a
warm-up (numba compile or cache load excluded).  Results are appended to a JSON file after every run, so an
interrupted measurement resumes.

Usage::

    .venv/bin/python benchmarks/studies/impact_velocity_floor_study.py run [PATH] [--part plain|coupled|both]
        [--floors 0 1e-5 3e-5 1e-4 3e-4 1e-3] [--sets 8] [--replicates 6]
    .venv/bin/python benchmarks/studies/impact_velocity_floor_study.py table PATH [MORE_PATHS ...]

PATH defaults to benchmarks/studies/results/impact_velocity_floor.json.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import time
from pathlib import Path

import numpy as np

# the generic kernel unless the caller sets BERRYSHAKER_KERNEL (a run left to choose would take a specialised
# one once compiled on this machine: multibody.specialised)
os.environ.setdefault("BERRYSHAKER_KERNEL", "generic")

RESULTS = Path(__file__).resolve().parent / "results" / "impact_velocity_floor.json"

FLOORS = (0.0, 1e-5, 3e-5, 1e-4, 3e-4, 1e-3)
HARVEST_KEYS = ("efficiency", "damage", "unripe")


def with_floor(machine, v_floor: float):
    """The machine with ``restitution_velocity`` = v_floor (m/s) on every clearance pair."""
    cl = {p: machine.clearance[p].model_copy(update={"restitution_velocity": float(v_floor)})
          for p in machine.pair_names}
    return machine.model_copy(update={"clearance": cl})


def clearance_sets(machine, n_drawn: int, seed: int = 2) -> list[dict]:
    """The reference clearances and ``n_drawn`` sets drawn uniformly 0.8-1.25x around them."""
    ref = dict(machine.clearance_sizes())
    rng = np.random.default_rng(seed)
    return [ref] + [{k: float(v * rng.uniform(0.8, 1.25)) for k, v in ref.items()} for _ in range(n_drawn)]


def plain_run(machine, clearance: dict) -> dict:
    """One harvester run: per-pair force statistics, drive moment, steps, CPU."""
    from berryshaker.drives.simulation import simulate_multibody

    c0 = time.process_time()
    _, s = simulate_multibody(machine, clearance, revolutions=2, rtol=1e-6)
    cpu = time.process_time() - c0
    vals = {f"{p}.{k}": v for p, st in s["collision_force_N"].items() for k, v in st.items()}
    vals["drive_moment.mean"] = s["drive_moment_Nm"]["mean"]
    return {"values": vals, "steps": s["steps"], "rejected": s["rejected_steps"], "cpu_s": cpu}


def coupled_run(machine, seed: int, cls: int) -> dict:
    """Replicate ``seed``'s drive-past of branch class ``cls``: peaks, envelope, steps, CPU."""
    from berryshaker.harvest.coupled import simulate_fruit_force
    from berryshaker.harvest.virtual import (
        ENVELOPE_OUTPUT_STEP,
        MACHINE,
        branch_class_machine,
        machine_start,
        stem_force_table,
    )

    h = machine.harvest
    pert = machine_start(machine, (int(seed), MACHINE, int(cls)))
    c0 = time.process_time()
    m = branch_class_machine(machine, h.branch_classes[cls])
    r = simulate_fruit_force(m, None, rtol=1e-6, initial_perturbation=pert, output_step=ENVELOPE_OUTPUT_STEP)
    table = stem_force_table(m, r.motion)
    cpu = time.process_time() - c0
    vals = {f"fruit.{n}.peak": float(np.max(np.abs(f))) for n, f in r.fruit_force.items()}
    vals.update({f"contact.{n}.peak": float(np.max(np.abs(f))) for n, f in r.contact_force.items()})
    info = r.result.info
    return {"values": vals, "steps": int(info[0]), "rejected": int(info[1]), "cpu_s": cpu,
            "envelope": table.tolist()}


def _load(path: Path) -> dict:
    return json.loads(path.read_text()) if path.exists() else {"plain": {}, "coupled": {}}


def _save(path: Path, data: dict) -> None:
    from berryshaker.outputs import write_json_atomic

    write_json_atomic(path, data)


def run(args) -> None:
    from berryshaker.config import reference_machine
    from berryshaker.harvest.virtual import replicate_starts

    path = Path(args.path)
    data = _load(path)
    m0 = reference_machine()
    machines = {f"{v:g}": with_floor(m0, v) for v in args.floors}
    plain_run(machines[f"{args.floors[0]:g}"], dict(m0.clearance_sizes()))  # warm-up: compile / load the cache
    if args.part in ("plain", "both"):
        for i, c in enumerate(clearance_sets(m0, args.sets)):
            for key, m in machines.items():
                tag = f"{key}|{i}"
                if tag in data["plain"]:
                    continue
                data["plain"][tag] = plain_run(m, c)
                r = data["plain"][tag]
                print(f"plain set {i} v_floor {key:>6}: steps {r['steps']:8d} CPU {r['cpu_s']:6.2f} s", flush=True)
                _save(path, data)
    if args.part in ("coupled", "both"):
        seeds = replicate_starts(m0, args.replicates)
        for sd in seeds:
            for c in range(len(m0.harvest.branch_classes)):
                for key, m in machines.items():
                    tag = f"{key}|{sd}|{c}"
                    if tag in data["coupled"]:
                        continue
                    data["coupled"][tag] = coupled_run(m, sd, c)
                    r = data["coupled"][tag]
                    print(f"coupled seed {sd} class {c} v_floor {key:>6}: steps {r['steps']:9d} "
                          f"CPU {r['cpu_s']:6.2f} s", flush=True)
                    _save(path, data)


def _by_floor(runs: dict) -> dict[str, dict[str, dict]]:
    """{floor: {unit: run}} from the ``floor|unit`` keys."""
    out: dict[str, dict[str, dict]] = {}
    for tag, r in runs.items():
        fl, unit = tag.split("|", 1)
        out.setdefault(fl, {})[unit] = r
    return out


def harvest_by_replicate(runs: dict) -> dict[str, dict[str, dict[str, float]]]:
    """{floor: {seed: harvest indexes}} for every replicate whose branch classes all ran."""
    from berryshaker.config import reference_machine
    from berryshaker.harvest.virtual import start_responses

    m = reference_machine()
    nc = len(m.harvest.branch_classes)
    out: dict[str, dict[str, dict[str, float]]] = {}
    for fl, units in _by_floor(runs).items():
        for sd in sorted({u.split("|")[0] for u in units}, key=int):
            envs = [units.get(f"{sd}|{c}") for c in range(nc)]
            if any(e is None for e in envs):
                continue
            h = start_responses(m, [np.array(e["envelope"]) for e in envs], int(sd))["expected"]
            out.setdefault(fl, {})[sd] = {k: float(h[k]) for k in HARVEST_KEYS}
    return out


def paired(a: dict[str, float], b: dict[str, float]) -> tuple[float, float, int]:
    """Mean of b - a over the units both have, its standard error and n."""
    common = sorted(set(a) & set(b))
    d = np.array([b[u] - a[u] for u in common])
    se = float(np.std(d, ddof=1) / math.sqrt(d.size)) if d.size > 1 else math.nan
    return float(d.mean()), se, int(d.size)


def _table(title: str, per_floor: dict[str, dict[str, dict[str, float]]], keys: list[str]) -> None:
    """Replicate mean (SE) per floor and the paired difference to floor 0 and to the next smaller floor."""
    floors = sorted(per_floor, key=float)
    print(f"\n## {title}\n")
    print("| statistic | " + " | ".join(f"v_floor {f}" for f in floors) + " |")
    print("|---|" + "---|" * len(floors))
    flags = {f: [] for f in floors}
    for k in keys:
        cells = []
        base = {u: v[k] for u, v in per_floor[floors[0]].items() if k in v}
        for i, f in enumerate(floors):
            x = {u: v[k] for u, v in per_floor[f].items() if k in v}
            arr = np.array(list(x.values()))
            cell = f"{arr.mean():.4g} ({np.std(arr, ddof=1) / math.sqrt(arr.size):.2g})"
            if i > 0:
                d0, se0, _ = paired(base, x)
                prev = {u: v[k] for u, v in per_floor[floors[i - 1]].items() if k in v}
                d1, se1, _ = paired(prev, x)
                s0 = "" if abs(d0) < 2 * se0 or d0 == se0 == 0 else "*"
                s1 = "" if abs(d1) < 2 * se1 or d1 == se1 == 0 else "†"
                if s0:
                    flags[f].append(k)
                cell += f"; Δ0 {d0:+.3g}±{se0:.2g}{s0}; Δprev {d1:+.3g}±{se1:.2g}{s1}"
            cells.append(cell)
        print(f"| {k} | " + " | ".join(cells) + " |")
    print("\n(* |Δ0| >= 2 SE against v_floor 0; † |Δprev| >= 2 SE against the next smaller floor)")
    for f in floors[1:]:
        print(f"v_floor {f}: differs from 0 in {len(flags[f])} of {len(keys)}: {', '.join(flags[f]) or '-'}")


def _cost(title: str, runs: dict) -> None:
    print(f"\n## cost, {title}\n")
    print("| v_floor | runs | steps mean | steps max | CPU mean (s) | CPU max (s) |")
    print("|---|---|---|---|---|---|")
    for f, units in sorted(_by_floor(runs).items(), key=lambda kv: float(kv[0])):
        st = np.array([r["steps"] for r in units.values()])
        cpu = np.array([r["cpu_s"] for r in units.values()])
        print(f"| {f} | {len(st)} | {st.mean():,.0f} | {st.max():,} | {cpu.mean():.2f} | {cpu.max():.2f} |")


def table(args) -> None:
    data = {"plain": {}, "coupled": {}}
    for path in args.paths:  # several measurements (e.g. further floors) merge: keys are floor|unit
        d = _load(Path(path))
        for part in data:
            data[part].update(d.get(part, {}))
    for part in ("plain", "coupled"):
        if not data[part]:
            continue
        per = {f: {u: r["values"] for u, r in units.items()} for f, units in _by_floor(data[part]).items()}
        keys = sorted(next(iter(next(iter(per.values())).values())))
        _table(f"{part} runs (mean over units, SE in brackets)", per, keys)
        _cost(part, data[part])
    if data["coupled"]:
        _table("harvest indexes per replicate", harvest_by_replicate(data["coupled"]), list(HARVEST_KEYS))


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run", help="measure (resumes from the JSON file)")
    r.add_argument("path", nargs="?", default=str(RESULTS))
    r.add_argument("--part", choices=("plain", "coupled", "both"), default="both")
    r.add_argument("--floors", type=float, nargs="+", default=list(FLOORS))
    r.add_argument("--sets", type=int, default=8, help="drawn clearance sets besides the reference (plain)")
    r.add_argument("--replicates", type=int, default=6, help="L9 replicates (coupled)")
    t = sub.add_parser("table", help="print the tables of one or more measurements (merged)")
    t.add_argument("paths", nargs="+")
    args = ap.parse_args(argv)
    run(args) if args.cmd == "run" else table(args)


if __name__ == "__main__":
    main()
