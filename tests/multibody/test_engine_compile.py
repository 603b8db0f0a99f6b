"""engine.compile_engine: the parts it compiles are the specialisations a run uses (else a cold study would compile
them twice, in parallel for nothing), for every kind of mechanism; an unknown part is an error."""

import json
import os
import subprocess
import sys
import textwrap
from concurrent.futures import Future

import pytest

from berryshaker.errors import ConfigError
from berryshaker.multibody.engine import ENGINE_PARTS, compile_engine

# in a fresh process (a test process holds whatever specialisations earlier tests made) with an empty numba cache
# (an integrator loaded from the cache brings its callees' code along and types none of them): compile the parts
# for the harvester, count every compiled function's specialisations, then run a harvester, a harvester with the
# bush's modes, the powered drive and both on the crank-rocker drive, and count again
SCRIPT = textwrap.dedent("""
    import importlib
    import json
    import pkgutil
    import numba
    import berryshaker.multibody as package
    from berryshaker.config import reference_machine
    from berryshaker.drives import drive_of
    from berryshaker.drives.simulation import simulate_multibody
    from berryshaker.harvest.coupled import coupled_mechanism
    from berryshaker.multibody import kernel
    from berryshaker.multibody.engine import ENGINE_PARTS, compile_engine, simulate_mechanism

    m = reference_machine()
    seconds = compile_engine(drive_of(m).mechanism(m, revolutions=2), ENGINE_PARTS)
    fns = {}
    for info in pkgutil.iter_modules(package.__path__):
        mod = importlib.import_module(f"berryshaker.multibody.{info.name}")
        for name, f in vars(mod).items():
            if isinstance(f, numba.core.registry.CPUDispatcher) and f.py_func.__module__ == mod.__name__:
                assert name not in fns, name
                fns[name] = f
    before = {name: len(f.signatures) for name, f in fns.items()}
    simulate_multibody(m, revolutions=2)
    simulate_mechanism(coupled_mechanism(m)[0], duration=0.01)
    simulate_multibody(m, revolutions=2, driveline="powered")
    crank = reference_machine("crank_rocker")
    simulate_multibody(crank, revolutions=2)
    simulate_multibody(crank, revolutions=2, driveline="powered")
    after = {name: len(f.signatures) for name, f in fns.items()}
    g = kernel.integrate_resumable.py_func.__globals__
    called = {n: g[n] for n in kernel.integrate_resumable.py_func.__code__.co_names
              if isinstance(g.get(n), numba.core.registry.CPUDispatcher)}
    inlined = sorted(n for n, f in called.items() if f.targetoptions.get("inline") == "always")
    callees = sorted(set(called) - set(inlined))
    # what the inlined functions call is the loop's too
    for n in inlined:
        fg = called[n].py_func.__globals__
        callees += [c for c in called[n].py_func.__code__.co_names
                    if isinstance(fg.get(c), numba.core.registry.CPUDispatcher)
                    and fg[c].targetoptions.get("inline") != "always" and c not in callees]
    print(json.dumps({"seconds": seconds, "before": before, "after": after, "callees": sorted(callees),
                      "inlined": inlined}))
""")


@pytest.fixture(scope="module")
def counts(tmp_path_factory):
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path_factory.mktemp("numba_cache")))
    out = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True, timeout=900, env=env)
    assert out.returncode == 0, out.stderr[-3000:]
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_compiled_parts_are_what_runs_use(counts):
    compiled = {f for f, n in counts["before"].items() if n}
    parts = {"project", "forces", "accelerations", "fint_is_contact", "_onset_fraction", "_crossing_rate",
             "first_onset_fraction", "_dense_state", "_write_sample", "rejected_step_size", "onset_cut_size",
             "next_step_size", "record_step_size", "save_resume", "load_resume", "_step_force_bound",
             "_interior_peak", "record_contacts"}
    assert parts <= compiled, parts - compiled
    # the parts compile everything the integrator's loop calls, so that a run compiles only the loop itself; what
    # numba inlines into the loop is compiled by the loop alone (a compilation of its own would serve nothing)
    assert set(counts["callees"]) - {"integrate_resumable"} <= compiled, set(counts["callees"]) - compiled
    assert not set(counts["inlined"]) & compiled, counts["inlined"]
    assert {"stage_state", "error_norm", "dense_coefficients", "constraint_residuals", "sample_inside",
            "sample_at_end", "interior_peak_forces"} <= set(counts["inlined"]), counts["inlined"]
    assert all(counts["before"][f] == 1 for f in compiled), counts["before"]
    # every run (harvester, with modal plant, powered, crank-rocker) used those same specialisations: none was added
    assert {f: counts["after"][f] for f in compiled} == {f: 1 for f in compiled}, counts["after"]
    assert counts["after"]["integrate_resumable"] == 1  # what every run integrates with (in chunks)
    assert set(counts["seconds"]) == set(ENGINE_PARTS)


def test_unknown_part_is_a_config_error():
    from berryshaker.config import reference_machine
    from berryshaker.drives import drive_of

    m = reference_machine()
    with pytest.raises(ConfigError, match="unknown part.*'integrator'.*projection"):
        compile_engine(drive_of(m).mechanism(m), ("integrator",))


class _Spy(Future):
    """A worker's future that records whether anyone waited for it."""

    waited = False

    def result(self, timeout=None):
        self.waited = True
        raise RuntimeError("the worker died")


def test_compile_beside_waits_only_for_a_cold_cache_and_never_fails_the_study(monkeypatch):
    from berryshaker.config import reference_machine
    from berryshaker.drives import drive_of
    from berryshaker.study import pipeline

    m = reference_machine()
    compile_engine(drive_of(m).mechanism(m, revolutions=2))  # every part compiled (or loaded) in this process
    spy = _Spy()
    assert pipeline.compile_engine_beside(m, spy) is None and not spy.waited  # in the cache: no wait

    real = pipeline.compile_engine
    monkeypatch.setattr(pipeline, "compile_engine",
                        lambda spec, parts: {**real(spec, parts), "projection": 5.0})  # as if it had compiled
    spy = _Spy()
    assert pipeline.compile_engine_beside(m, spy) == "RuntimeError: the worker died" and spy.waited

    def broken(machine):
        raise ConfigError("no mechanism for this drive")

    monkeypatch.setattr(pipeline, "drive_of", broken)
    assert "no mechanism" in pipeline.compile_engine_beside(m, _Spy())
