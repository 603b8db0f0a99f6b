"""The engine's kernels specialised to one mechanism structure (berryshaker.multibody.specialised).

Checks that can fail: the generated constraint equations and multiplier solve must give bitwise what the generic
compiled kernel gives (every entry of Phi, Phi_q, nu, gamma, the solved state and the multipliers) at random states
of every mechanism the package builds, with clearance joints and with their ideal counterparts (all five constraint
types), and of synthetic mechanisms with several driven bodies, driver rows anywhere and coordinates beyond the
bodies; whole runs (the slider-crank, the harvester) must be bitwise those of the generic integrator.  The
generated functions are run as Python here (``py_func``: IEEE double arithmetic, as the compiled code without
fast-math), so a generator that reorders one sum fails.
"""

import math
from unittest.mock import patch

import numpy as np
import pytest

from berryshaker.config import reference_machine
from berryshaker.drives.simulation import simulate_multibody
from berryshaker.multibody import kernel
from berryshaker.multibody import specialised as sp
from berryshaker.multibody.compiled import _state_and_work, compile_mechanism
from berryshaker.multibody.constraint_rows import constraints
from berryshaker.multibody.engine import integrator, simulate_mechanism
from berryshaker.multibody.linear_solve import _constrained_solve
from berryshaker.multibody.model import MechanismModel
from berryshaker.multibody.sparsity import solve_plan
from multibody.test_sparsity import _SYNTHETIC, CASES, _random_state, _synthetic


def _model(ctype, cint, crow, plan):
    return MechanismModel(*[None] * 17)._replace(ctype=ctype, cint=cint, crow=crow, plan=plan)


def _check(mod, ctype, cint, cflt, crow, cams, plan, mass, inertia, minv, m, n, q_of, rng, states=15):
    """Generic compiled kernel against the generated functions run as Python, bitwise."""
    gen_c, gen_s = mod.constraints.py_func, mod._constrained_solve.py_func
    for _ in range(states):
        q, qd = q_of(rng)
        outs = []
        for fn in (constraints, gen_c):
            arrs = (np.zeros(m), np.zeros((m, n)), np.zeros(m), np.zeros(m))
            psi = np.full(len(ctype), np.nan)
            fn(0.3, q, qd, ctype, cint, cflt, crow, cams, psi, *arrs)
            outs.append(arrs + (psi,))
        for a, b in zip(*outs):
            np.testing.assert_array_equal(a, b)
        jac = outs[0][1]
        u, g = rng.normal(size=n), rng.normal(size=m)
        sol = []
        for fn in (_constrained_solve, gen_s):
            x, lam = u.copy(), np.zeros(m)
            fn(plan, mass, inertia, cint, crow, jac, minv, np.zeros((m, m)), np.zeros(m), x, np.int64(0), g, lam,
               np.int64(m))
            sol.append((x, lam))
        np.testing.assert_array_equal(sol[0][0], sol[1][0])
        np.testing.assert_array_equal(sol[0][1], sol[1][1])


@pytest.mark.parametrize("name, spec, ideal", CASES, ids=[f"{c[0]}{'-ideal' if c[2] else ''}" for c in CASES])
def test_generated_kernel_is_bitwise_the_generic_one_on_every_mechanism(name, spec, ideal):
    cm = compile_mechanism(spec, ideal_clearances=ideal)
    md = cm.model
    mass, inertia, ctype, cint, cflt, crow = md.mass, md.inertia, md.ctype, md.cint, md.cflt, md.crow
    assert cm.m > 0, f"{name}: no ideal constraints"  # every case has some: one without would test nothing
    _state, work = _state_and_work(cm)
    mod = sp.specialised_module(cm.model, cm.n, cm.m)
    _check(mod, ctype, cint, cflt, crow, cm.model.cams, cm.model.plan, mass, inertia, work[7], cm.m, cm.n,
           lambda rng: _random_state(cm, rng), np.random.default_rng(3))


@pytest.mark.parametrize("name", list(_SYNTHETIC))
def test_generated_kernel_is_bitwise_the_generic_one_on_synthetic_mechanisms(name):
    cons, nb, n_extra, _ = _SYNTHETIC[name]
    ctype, cint, cflt, crow, m, n = _synthetic(cons, nb, n_extra)
    plan = solve_plan(ctype, cint, cflt, crow, m, n)
    rng = np.random.default_rng(5)
    mass, inertia = rng.uniform(0.1, 2.0, nb), rng.uniform(1e-4, 1e-2, nb)
    minv = np.ones(n)
    minv[0:3 * nb:3], minv[1:3 * nb:3], minv[2:3 * nb:3] = 1 / mass, 1 / mass, 1 / inertia
    mod = sp.specialised_module(_model(ctype, cint, crow, plan), n, m)
    _check(mod, ctype, cint, cflt, crow, np.zeros((1, 8)), plan, mass, inertia, minv, m, n,
           lambda r: (r.normal(0, 0.3, n), r.normal(0, 1, n)), rng)


def test_structure_key_follows_the_structure_not_the_values():
    cons, nb, n_extra, _ = _SYNTHETIC["crank body_j"]
    ctype, cint, cflt, crow, m, n = _synthetic(cons, nb, n_extra)
    plan = solve_plan(ctype, cint, cflt, crow, m, n)
    key = sp.structure_key(_model(ctype, cint, crow, plan), n)
    assert sp.structure_key(_model(ctype.copy(), cint.copy(), crow.copy(), plan.copy()), n) == key
    other = cint.copy()
    other[1, 1] = 2  # the rod's revolute now on the slider
    assert sp.structure_key(_model(ctype, other, crow, plan), n) != key
    assert sp.structure_key(_model(ctype, cint, crow, plan), n + 1) != key


def test_source_is_rewritten_when_it_differs(tmp_path):
    path = tmp_path / "bs_specialised_x.py"
    sp.write_source(path, "a = 1\n")
    stamp = path.stat().st_mtime_ns
    sp.write_source(path, "a = 1\n")
    assert path.stat().st_mtime_ns == stamp  # unchanged: numba's cache entry for it stays valid
    path.write_text("a = 1\nb = ")  # half-written or edited by hand
    sp.write_source(path, "a = 1\n")
    assert path.read_text() == "a = 1\n"
    assert [p.name for p in tmp_path.iterdir()] == [path.name]  # no temporary file left


def test_specialised_slider_crank_run_is_bitwise_the_generic_run():
    from pathlib import Path

    from berryshaker.multibody.spec import load_mechanism

    spec = load_mechanism(Path(__file__).resolve().parents[2] / "examples" / "slider_crank_clearance.toml")
    duration = 2 * math.pi / abs(spec.drivers[0].speed)
    a = simulate_mechanism(spec, duration=duration, rtol=1e-7, specialised=False)  # not "auto": it may be compiled
    b = simulate_mechanism(spec, duration=duration, rtol=1e-7, specialised=True)
    assert integrator(compile_mechanism(spec), True) is not kernel.integrate
    assert integrator(compile_mechanism(spec), False) is kernel.integrate
    for x, y in ((a.y, b.y), (a.elements, b.elements), (a.multipliers, b.multipliers), (a.peaks, b.peaks), (a.first, b.first), (a.info, b.info)):
        np.testing.assert_array_equal(x, y)


def _markers_in(folder, monkeypatch):
    """This machine's record of compiled structures moved to ``folder`` (empty: nothing compiled), and runs left to
    choose by the default rule (conftest.py sets generic for the suite)."""
    monkeypatch.setattr(sp, "_compiled_marker", lambda model, n: folder / f"{sp.structure_key(model, n)}.compiled")
    monkeypatch.delenv("BERRYSHAKER_KERNEL", raising=False)


def test_specialised_harvester_run_and_sweep_point_are_bitwise_the_generic_ones(tmp_path, monkeypatch):
    from berryshaker.runs.sweep import model_run

    _markers_in(tmp_path, monkeypatch)

    m = reference_machine()
    (ra, sa), (rb, sb) = (simulate_multibody(m, revolutions=2, specialised=s) for s in (False, True))
    np.testing.assert_array_equal(ra.y, rb.y)
    np.testing.assert_array_equal(ra.elements, rb.elements)
    untimed = lambda d: {k: v for k, v in d.items() if k != "wall_time_s"}  # noqa: E731
    assert untimed(sa) == untimed(sb)
    data = m.model_dump(mode="json")
    kw = [dict(machine_data=data, overrides={"clearance.C.size": c}, model="multibody", revolutions=2)
          for c in (1.2e-4, 1.8e-4)]
    used = []

    def spy(cm, specialised=False):
        fn = integrator(cm, specialised)
        used.append((specialised, fn is not kernel.integrate))
        return fn

    with patch("berryshaker.multibody.engine.integrator", spy):
        generic = [model_run(**k, specialised=False) for k in kw]
        _markers_in(tmp_path / "later", monkeypatch)  # forget the mark of the single run above
        special = [model_run(**k, specialised=True) for k in kw]
        auto = [model_run(**k) for k in kw]  # left to choose: marked by the sweep's runs just now, so specialised
    # the sweep's runs ran the integrator asked for
    assert used == [(False, False)] * 2 + [(True, True)] * 2 + [(None, True)] * 2
    assert [untimed(d) for d in generic] == [untimed(d) for d in special]  # equal floats, not close
    assert [untimed(d) for d in auto] == [untimed(d) for d in special]


def test_generated_row_product_counts_a_body_once_when_a_block_joins_it_to_itself():
    # linear_solve._row_dot_at adds body j's columns only when it differs from body i (solve_plan allows the case)
    src = "\n".join(sp._solve_source(np.array([[0, 0, 0]]), np.array([0]), np.array([[0, 0, 0, 1], [0, 0, 0, -1]]),
                                      1))
    assert src.count("jac[0, 0] * u[off + 0]") == 1


def test_sweep_picks_the_specialised_kernel_when_compiled_or_when_it_pays(tmp_path, monkeypatch):
    from berryshaker.runs.sweep import SPECIALISE_FROM_RUNS_PER_WORKER, choose_specialised

    _markers_in(tmp_path, monkeypatch)  # a machine that has compiled nothing
    data = reference_machine().model_dump(mode="json")
    over = {"clearance.A.size": 3e-4}
    few, why = choose_specialised(data, over, 2, None, runs=40, workers=2)
    assert few is False and "20 runs per worker" in why and "--specialised" in why
    many, why = choose_specialised(data, over, 2, None, runs=2 * SPECIALISE_FROM_RUNS_PER_WORKER, workers=2)
    assert many is True and "pay" in why
    m = reference_machine()
    from berryshaker.drives import drive_of

    cm = compile_mechanism(drive_of(m).mechanism(m, revolutions=2))
    sp.mark_compiled(cm.model, cm.n)
    ready, why = choose_specialised(data, over, 2, None, runs=40, workers=2)
    assert ready is True and "compiled" in why
    powered, _ = choose_specialised(data, over, 2, "powered", runs=40, workers=2)
    assert powered is False  # another structure (the driveline's coordinates): not compiled
    monkeypatch.setenv("BERRYSHAKER_KERNEL", "generic")
    assert choose_specialised(data, over, 2, None, runs=40, workers=2) == (False, "BERRYSHAKER_KERNEL=generic")


def test_a_run_left_to_choose_takes_the_specialised_kernel_once_this_machine_compiled_it(tmp_path, monkeypatch):
    from pathlib import Path

    from berryshaker.errors import ConfigError
    from berryshaker.multibody.spec import load_mechanism

    spec = load_mechanism(Path(__file__).resolve().parents[2] / "examples" / "slider_crank_clearance.toml")
    cm = compile_mechanism(spec)
    assert spec.simulation.specialised is None  # the default: left to choose
    _markers_in(tmp_path, monkeypatch)  # a machine that has compiled nothing
    assert integrator(cm, None) is integrator(cm) is kernel.integrate
    simulate_mechanism(spec, duration=1e-4, specialised=False)
    assert not sp.is_compiled(cm.model, cm.n)  # a generic run marks nothing
    simulate_mechanism(spec, duration=1e-4, specialised=True)  # compiled (or loaded), then marked for later runs
    assert sp.is_compiled(cm.model, cm.n)
    assert integrator(cm, None) is integrator(cm, True) is not kernel.integrate
    assert integrator(cm, False) is kernel.integrate  # asked for explicitly: always the generic one
    monkeypatch.setenv("BERRYSHAKER_KERNEL", "Generic ")
    assert integrator(cm, None) is kernel.integrate
    _markers_in(tmp_path / "none", monkeypatch)
    monkeypatch.setenv("BERRYSHAKER_KERNEL", "specialised")  # whether compiled or not
    assert integrator(cm, None) is not kernel.integrate
    monkeypatch.setenv("BERRYSHAKER_KERNEL", "fast")
    with pytest.raises(ConfigError, match="BERRYSHAKER_KERNEL='fast'.*auto, generic, specialised.*unset it"):
        integrator(cm, None)


def test_the_compiled_marker_needs_numba_to_have_saved_the_kernel_and_names_the_target(tmp_path, monkeypatch):
    from types import SimpleNamespace

    monkeypatch.setattr(sp, "source_folder", lambda: tmp_path / "not made yet")
    model, n = _model(np.array([0]), np.array([[0, 0, 0]]), np.array([0]), np.zeros((0, 4), np.int64)), 3
    unsaved = SimpleNamespace(_cache=SimpleNamespace(_cache_file=SimpleNamespace(_index_path=str(tmp_path / "x.nbi"))))
    sp.mark_compiled(model, n, unsaved)
    assert not sp.is_compiled(model, n)  # numba's index is missing: it did not save the machine code
    (tmp_path / "x.nbi").write_text("")
    sp.mark_compiled(model, n, unsaved)
    assert sp.is_compiled(model, n)  # the folder is made (the module may have been loaded from elsewhere)
    marker = sp._compiled_marker(model, n).name
    assert marker.startswith(f"bs_specialised_{sp.structure_key(model, n)}.") and marker.endswith(".compiled")
    monkeypatch.setattr(sp, "_TARGET", ["another-numba-or-cpu"])
    assert not sp.is_compiled(model, n)  # numba's cache entries would not fit: not taken for compiled


def test_the_run_cache_finds_a_sweep_point_whichever_kernel_computed_it():
    from berryshaker.runs.runner import run_key
    from berryshaker.runs.sweep import model_run

    kw = dict(machine_data={"a": 1}, overrides={"clearance.C.size": 1e-4}, model="multibody", revolutions=2)
    keys = {run_key(model_run, dict(kw, **extra)) for extra in ({}, {"specialised": True}, {"specialised": False})}
    assert len(keys) == 1  # the kernel does not change the value (bitwise), so not the key
    assert run_key(model_run, dict(kw, revolutions=3)) not in keys  # what does change it still does


def test_generated_module_calls_its_own_right_hand_side_everywhere(monkeypatch):
    """Every generic function on the integrator's path that calls the right-hand side is compiled again in the
    generated module, calling the generated constraint rows and solve; the generator refuses a list that misses
    one (the specialised integrator would quietly run the generic right-hand side there)."""
    cons, nb, n_extra, _ = _SYNTHETIC["crank body_j"]
    ctype, cint, cflt, crow, m, n = _synthetic(cons, nb, n_extra)
    model = _model(ctype, cint, crow, solve_plan(ctype, cint, cflt, crow, m, n))
    mod = sp.specialised_module(model, n, m)
    for fn in sp.GENERIC_SOURCES:
        own = getattr(mod, fn.py_func.__name__)
        assert own is not fn and own.py_func.__globals__ is vars(mod), fn.py_func.__name__
    assert mod.accelerations.py_func.__globals__["constraints"] is mod.constraints
    assert mod.integrate_resumable.py_func.__globals__["accelerations"] is mod.accelerations
    assert mod.integrate.py_func.__globals__["integrate_resumable"] is mod.integrate_resumable
    without_rhs = tuple(fn for fn in sp.GENERIC_SOURCES if fn.py_func.__name__ != "accelerations")
    monkeypatch.setattr(sp, "GENERIC_SOURCES", without_rhs)
    with pytest.raises(RuntimeError, match="integrate_resumable calls accelerations.*GENERIC_SOURCES"):
        sp.specialised_source(model, n, m)
