"""Before/after check of the multibody engine: the reference runs' numbers, saved as JSON and compared.

Run once on the old code and once on the new one (same venv; PYTHONPATH selects the source tree), then
compare:

    PYTHONPATH=/path/to/old/src .venv/bin/python benchmarks/compare_engine_results.py save /tmp/before.json
    .venv/bin/python benchmarks/compare_engine_results.py save /tmp/after.json
    .venv/bin/python benchmarks/compare_engine_results.py compare /tmp/before.json /tmp/after.json

Cases (each also records its CPU time, best of ``--repeat``):

* ``harvester``: the reference machine, clearances A B C F at their reference sizes, 2 cam revolutions,
  multibody (``drives.simulation.simulate_multibody``, rtol 1e-6): peak, mean and RMS of every pair's
  collision force, the comb load moments and the drive moment;
* ``slider_crank``: examples/slider_crank_clearance.toml, 2 crank revolutions at rtol 1e-7: first impact
  (time, velocity, peak) and force statistics of every joint;
* ``coupled``: the harvester driven past the reference branch (``harvest.coupled.simulate_fruit_force``,
  the run the study repeats 30 times): fruit-force peaks and RMS, comb-branch contact peaks.

``save --restitution-velocity 0`` runs the machine's pairs with that restitution velocity (m/s) instead of
their default (0: the published hysteresis laws, as before benchmarks/README.md sec. 6).

The comparison prints the relative difference of every number, the largest per case and whether every output
sample (states, element outputs, multipliers; SHA-256 of their bytes) is bitwise the same; the tolerances
to hold it against are those of the validation tests (tests/test_multibody.py: peaks to 1-2 %, mean and
RMS to 1 %).  The statistics over revolutions of the clearance joints are chaotic at the 1 % level (see
benchmarks/README.md), so differences of that size between two correct engines are expected there;
first impacts agree much more closely.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
from pathlib import Path

import numpy as np

from cpu_timing import best_cpu_time  # benchmarks/ (the script's own folder) is on sys.path

ROOT = Path(__file__).resolve().parent.parent


def _flat(prefix: str, obj, out: dict) -> None:
    if isinstance(obj, dict):
        for k, v in obj.items():
            _flat(f"{prefix}.{k}" if prefix else str(k), v, out)
    elif isinstance(obj, (int, float)) and not isinstance(obj, bool):
        out[prefix] = float(obj)


#: restitution velocity (m/s) set on every pair of the reference machine; None: the pairs' default
RESTITUTION_VELOCITY: float | None = None


def _reference_machine():
    from berryshaker.config import reference_machine

    m = reference_machine()
    if RESTITUTION_VELOCITY is None:
        return m
    cl = {p: m.clearance[p].model_copy(update={"restitution_velocity": RESTITUTION_VELOCITY}) for p in m.pair_names}
    return m.model_copy(update={"clearance": cl})


def _digest(*arrays) -> str:
    """SHA-256 of the arrays' bytes: equal digests = bitwise equal outputs (every sample, not only statistics).
    Of ``first`` the callers pass the first-impact columns only, which every engine version has (the impact count
    of column 4 is new)."""
    import hashlib

    h = hashlib.sha256()
    for a in arrays:
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()




def harvester(repeat: int) -> dict:
    from berryshaker.drives.simulation import simulate_multibody

    m = _reference_machine()
    (res, summ), cpu = best_cpu_time(lambda: simulate_multibody(m, dict(m.clearance_sizes()), revolutions=2), repeat)
    vals: dict = {}
    for key in ("collision_force_N", "load_moment_Nm", "drive_moment_Nm"):
        _flat(key, summ[key], vals)
    return {"values": vals, "steps": summ["steps"], "rejected": summ["rejected_steps"], "cpu_s": cpu,
            "digest": _digest(res.y, res.elements, res.multipliers, res.peaks, res.first[:, :4])}


def slider_crank(repeat: int) -> dict:
    from berryshaker.multibody.engine import simulate_mechanism
    from berryshaker.multibody.spec import load_mechanism

    spec = load_mechanism(ROOT / "examples" / "slider_crank_clearance.toml")
    dur = 2 * 2 * math.pi / abs(spec.drivers[0].speed)
    res, cpu = best_cpu_time(lambda: simulate_mechanism(spec, duration=dur, rtol=1e-7, output_step=1e-5), repeat)
    s = res.summary()
    vals: dict = {}
    _flat("joints", s["joints"], vals)
    _flat("drivers", s["drivers"], vals)
    return {"values": vals, "steps": s["steps"], "rejected": s["rejected_steps"], "cpu_s": cpu,
            "digest": _digest(res.y, res.elements, res.multipliers, res.peaks, res.first[:, :4])}


def coupled(repeat: int) -> dict:
    from berryshaker.harvest.coupled import simulate_fruit_force

    m = _reference_machine()
    res, cpu = best_cpu_time(lambda: simulate_fruit_force(m, None), repeat)
    vals: dict = {}
    for name, f in res.fruit_force.items():
        f = np.abs(np.asarray(f))
        vals[f"fruit.{name}.peak"] = float(f.max())
        vals[f"fruit.{name}.rms"] = float(np.sqrt(np.mean(f**2)))
    for name, f in res.contact_force.items():
        f = np.abs(np.asarray(f))
        vals[f"contact.{name}.peak"] = float(f.max())
        vals[f"contact.{name}.rms"] = float(np.sqrt(np.mean(f**2)))
    info = res.result.info
    return {"values": vals, "steps": int(info[0]), "rejected": int(info[1]), "cpu_s": cpu,
            "digest": _digest(res.result.y, res.result.elements, res.result.multipliers)}


CASES = {"harvester": harvester, "slider_crank": slider_crank, "coupled": coupled}


def compare(a: dict, b: dict) -> None:
    for case in a:
        if case not in b:
            continue
        va, vb = a[case]["values"], b[case]["values"]
        print(f"\n== {case}: steps {a[case]['steps']} -> {b[case]['steps']}, rejected {a[case]['rejected']} -> "
              f"{b[case]['rejected']}, CPU {a[case]['cpu_s'] * 1e3:.0f} ms -> {b[case]['cpu_s'] * 1e3:.0f} ms "
              f"({a[case]['cpu_s'] / b[case]['cpu_s']:.2f}x)")
        worst = (0.0, "")
        for k in va:
            if k not in vb:
                continue
            x, y = va[k], vb[k]
            scale = max(abs(x), abs(y), 1e-12)
            rel = abs(x - y) / scale
            if rel > worst[0]:
                worst = (rel, k)
            print(f"  {k:55s} {x:14.6g} {y:14.6g}  {rel:9.2e}")
        print(f"  largest relative difference: {worst[0]:.2e} ({worst[1]})")
        if "digest" in a[case] and "digest" in b[case]:
            same = a[case]["digest"] == b[case]["digest"]
            print(f"  every output sample (states, element outputs, multipliers) bitwise equal: {'yes' if same else 'NO'}")


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    s = sub.add_parser("save")
    s.add_argument("path")
    s.add_argument("--cases", default=",".join(CASES))
    s.add_argument("--repeat", type=int, default=3)
    s.add_argument("--restitution-velocity", type=float, default=None,
                   help="m/s on every pair of the reference machine (default: the pairs' own)")
    c = sub.add_parser("compare")
    c.add_argument("before")
    c.add_argument("after")
    args = p.parse_args(argv)
    # CPU times of the generic kernel unless the caller says otherwise (results are bitwise the same either way)
    os.environ.setdefault("BERRYSHAKER_KERNEL", "generic")
    if args.cmd == "save":
        global RESTITUTION_VELOCITY
        RESTITUTION_VELOCITY = args.restitution_velocity
        out = {}
        for name in args.cases.split(","):
            out[name] = CASES[name](args.repeat)
            print(f"{name}: {out[name]['steps']} steps, {out[name]['cpu_s'] * 1e3:.0f} ms CPU", file=sys.stderr)
        Path(args.path).write_text(json.dumps(out, indent=1))
    else:
        compare(json.loads(Path(args.before).read_text()), json.loads(Path(args.after).read_text()))


if __name__ == "__main__":
    main()
