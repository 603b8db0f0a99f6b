"""The benchmark suite's settings and its ratios (benchmarks/README.md).

The suite is not part of the test suite (``pytest`` collects ``tests/`` only, ``testpaths``); run it with
``pytest -n 0 benchmarks/suite`` (one process: timings are not shared with other workers).  Runs left to choose
take the generic kernel here, as in ``tests/`` (a run left to choose would take the kernel specialised to its structure once that is compiled on this machine:
``multibody.specialised``); the cases of the specialised kernel ask for it.

After the run the suite prints, and ``--benchmark-save`` stores under ``"ratios"`` in its JSON, the ratios it
exists for (:data:`RATIOS`): medians, per accepted step where the two sides take different steps.

The timer is CPU time (``time.process_time``) unless ``--benchmark-timer`` names another: the machines this runs on
are shared, and CPU time does not count the time the process waited for a core (every case here runs on one
thread).
"""

from __future__ import annotations

import os

import pytest

os.environ["BERRYSHAKER_KERNEL"] = "generic"
os.environ.setdefault("MPLBACKEND", "Agg")

#: (label, numerator, denominator, per_step): ratio of the numerator benchmark's median to the denominator's
#: (per accepted step, ``extra_info["steps"]``, when ``per_step``)
RATIOS = (
    ("Exudyn / engine, slider-crank first-impact peak to 1e-3 (matched accuracy)",
     "test_exudyn_slider_crank[exudyn-1e-3]", "test_exudyn_slider_crank[engine-1e-3]", False),
    ("Exudyn / engine, slider-crank first-impact peak to 1e-4",
     "test_exudyn_slider_crank[exudyn-1e-4]", "test_exudyn_slider_crank[engine-1e-4]", False),
    ("engine (generic kernel) / hand-reduced slider-crank, time per accepted step",
     "test_slider_crank_per_step[generic]", "test_reduced_slider_crank_per_step", True),
    ("engine (specialised kernel) / hand-reduced slider-crank, time per accepted step",
     "test_slider_crank_per_step[specialised]", "test_reduced_slider_crank_per_step", True),
    ("harvester run, multibody / MLSD", "test_harvester_run[multibody]", "test_harvester_run[mlsd]", False),
    ("stem-force table of a drive-past, with the Miner-Basquin channels / peaks only",
     "test_stem_force_table[miner]", "test_stem_force_table[peaks]", False),
    ("run-cache entry read of a replicate start, decimal JSON re-encoded to check / as the cache stores it",
     "test_cache_entry_read[decimal]", "test_cache_entry_read[bytes]", False),
    ("calibrate's emulator at 20 walkers x an L9's 9 settings, a GP call per setting / the settings' GPs stacked",
     "test_emulator_at_walkers[per-setting]", "test_emulator_at_walkers[stacked]", False),
    ("bruise probability of a start's 6,120 fruit at 12 parameter rows, every fruit / each of its 68 places once",
     "test_impact_damage[per-fruit]", "test_impact_damage[places]", False),
    ("a start's responses from its cached run, computed from its tables / read as the run keeps them",
     "test_start_cell[computed]", "test_start_cell[stored]", False),
)


@pytest.hookimpl(tryfirst=True)
def pytest_configure(config):
    """CPU time as the default timer (before pytest-benchmark reads it)."""
    from pytest_benchmark.timers import default_timer
    from pytest_benchmark.utils import NameWrapper

    if getattr(config.option, "benchmark_timer", None) == str(NameWrapper(default_timer)):
        config.option.benchmark_timer = "time.process_time"


def _by_name(config):
    session = getattr(config, "_benchmarksession", None)
    return {b.name: b for b in getattr(session, "benchmarks", [])} if session else {}


def suite_ratios(config) -> list[dict]:
    """The ratios of :data:`RATIOS` whose two benchmarks ran (medians, s)."""
    found, out = _by_name(config), []
    for label, num, den, per_step in RATIOS:
        if num not in found or den not in found:
            continue
        a, b = found[num], found[den]
        ma, mb = a.stats.median, b.stats.median
        if per_step:
            ma, mb = ma / a.extra_info["steps"], mb / b.extra_info["steps"]
        out.append({"label": label, "numerator": num, "denominator": den, "per_step": per_step,
                    "numerator_median_s": ma, "denominator_median_s": mb, "ratio": ma / mb})
    return out


def pytest_benchmark_update_json(config, benchmarks, output_json):
    """Store the ratios beside the benchmarks in the saved JSON."""
    output_json["ratios"] = suite_ratios(config)


def pytest_terminal_summary(terminalreporter, exitstatus, config):
    """Print the ratios (medians) after pytest-benchmark's tables."""
    rows = suite_ratios(config)
    if rows:
        terminalreporter.section("berryshaker benchmark ratios (medians)")
        for r in rows:
            scale, unit = (1e6, "us per step") if r["per_step"] else (1e3, "ms")
            terminalreporter.line(f"{r['ratio']:8.2f}x  {r['label']}  ({r['numerator_median_s'] * scale:.4g} / "
                                  f"{r['denominator_median_s'] * scale:.4g} {unit})")
