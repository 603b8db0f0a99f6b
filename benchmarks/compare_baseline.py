"""Report the benchmarks whose median is slower than the stored baseline's by more than a threshold.

``python benchmarks/compare_baseline.py NOW.json [--baseline FILE] [--threshold 0.25]`` reads a pytest-benchmark
JSON (``--benchmark-json``) and the stored baseline (benchmarks/results/*/0001_baseline.json) and prints one line
per benchmark present in both: the two medians (CPU time) and their ratio, marking the ones slower by more than the
threshold.  It reports and never fails (exit 0 whatever it finds; 2 only for an unreadable file): CPU time on a
shared machine moves by 10-30 % between runs (benchmarks/README.md), so a slower median is a reason to look, not
a verdict.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

BASELINE = next(iter(sorted((Path(__file__).resolve().parent / "results").glob("*/0001_baseline.json"))), None)


def medians(path: Path) -> dict[str, float]:
    """Median (s) per benchmark name (``test_x[param]``) of a pytest-benchmark JSON file."""
    data = json.loads(Path(path).read_text(encoding="utf-8"))
    return {b["name"]: float(b["stats"]["median"]) for b in data["benchmarks"]}


def compare(now: dict[str, float], base: dict[str, float], threshold: float) -> tuple[list[str], list[str]]:
    """The report's lines and the names slower than ``base`` by more than ``threshold`` (a fraction)."""
    lines, slower = [], []
    for name in sorted(set(now) & set(base)):
        ratio = now[name] / base[name]
        flag = ratio > 1 + threshold
        slower += [name] if flag else []
        lines.append(f"{'SLOWER' if flag else 'ok':6s} {ratio:5.2f}x  {now[name] * 1e3:10.2f} ms  "
                     f"(baseline {base[name] * 1e3:.2f} ms)  {name}")
    return lines, slower


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("now", type=Path, help="pytest-benchmark JSON of this run (--benchmark-json)")
    parser.add_argument("--baseline", type=Path, default=BASELINE, help="stored baseline JSON")
    parser.add_argument("--threshold", type=float, default=0.25, help="report medians slower by more than this")
    args = parser.parse_args(argv)
    try:
        now, base = medians(args.now), medians(args.baseline)
    except (OSError, ValueError, KeyError, TypeError) as exc:
        print(f"benchmark comparison: cannot read {args.now} or {args.baseline}: {exc}")
        return 2
    lines, slower = compare(now, base, args.threshold)
    print(f"benchmarks against {args.baseline.name} (CPU-time medians; > {args.threshold:.0%} slower is reported):")
    print("\n".join(lines))
    if slower:
        print(f"note: {len(slower)} of {len(lines)} benchmarks are more than {args.threshold:.0%} slower than the "
              "baseline (reported, not failed: rerun on an idle machine before reading much into it)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
