"""The symbolic structure of the multiplier solve (berryshaker.multibody.sparsity) and the kernel's planned solve.

Checks that can fail: the Jacobian pattern must contain every entry the kernel's ``constraints`` writes nonzero at
random states (angles anywhere, positions and velocities perturbed) of every mechanism the package builds, with
clearance joints and with their ideal counterparts (revolute, prismatic, point on line, cam roller, driver); the
planned assembly and solve must give W = Phi_q M^-1 Phi_q^T and its solution as a dense NumPy computation does.
"""

from pathlib import Path

import numpy as np
import pytest

from berryshaker.config import reference_machine
from berryshaker.drives import drive_of
from berryshaker.multibody import kernel as mb
from berryshaker.multibody.engine import _state_and_work, compile_mechanism
from berryshaker.multibody.sparsity import jacobian_pattern, solve_plan
from berryshaker.multibody.spec import load_mechanism

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def _specs():
    yield "slider_crank", load_mechanism(EXAMPLES / "slider_crank_clearance.toml")
    for drive in ("groove_cam", "crank_rocker"):
        m = reference_machine(drive)
        yield drive, drive_of(m).mechanism(m, revolutions=1)


CASES = [(name, spec, ideal) for name, spec in _specs() for ideal in (False, True)]


def _random_state(cm, rng):
    q = cm.q0.copy()
    qd = np.zeros_like(q)
    nb = len(cm.model[0])
    q[0:3 * nb:3] += rng.normal(0.0, 0.01, nb)
    q[1:3 * nb:3] += rng.normal(0.0, 0.01, nb)
    q[2:3 * nb:3] = rng.uniform(-np.pi, np.pi, nb)
    qd[:3 * nb] = rng.normal(0.0, 1.0, 3 * nb)
    return q, qd


@pytest.mark.parametrize("name, spec, ideal", CASES, ids=[f"{c[0]}{'-ideal' if c[2] else ''}" for c in CASES])
def test_pattern_contains_every_nonzero_and_solve_matches_dense(name, spec, ideal):
    cm = compile_mechanism(spec, ideal_clearances=ideal)
    (mass, inertia, gravity, ctype, cint, cflt, crow, ftype, fint, fflt, cams, modal_w, modal_z, phi_tab, plant_p,
     laws, plan) = cm.model
    m, n = cm.m, cm.n
    if m == 0:
        pytest.skip("no ideal constraints")
    state, work = _state_and_work(cm)
    phi, jac, nu, gam, _q, _e, _lam, minv, W, rhs = work
    pattern = jacobian_pattern(ctype, cint, cflt, crow, m, n)
    np.testing.assert_array_equal(plan, solve_plan(ctype, cint, cflt, crow, m, n))
    types = {int(t) for t in ctype}
    rng = np.random.default_rng(7)
    seen = np.zeros((m, n), dtype=bool)
    for _ in range(40):
        q, qd = _random_state(cm, rng)
        mb.constraints(0.3, q, qd, ctype, cint, cflt, crow, cams, state[2], phi, jac, nu, gam)
        nz = jac != 0.0
        seen |= nz
        assert not (nz & ~pattern).any(), f"{name}: nonzero Jacobian entries outside the pattern: " \
                                          f"{np.argwhere(nz & ~pattern).tolist()} (constraint types {types})"
        dense_w = (jac * minv) @ jac.T
        b = rng.normal(size=m)
        x_dense = np.linalg.solve(dense_w, b)
        W[:] = 0.0
        mb._schur(plan, jac, minv, W, m)
        np.testing.assert_allclose(np.triu(W), np.triu(dense_w), rtol=1e-13, atol=1e-13 * np.abs(dense_w).max())
        x = b.copy()
        mb._spd_solve(plan, W, x, m)
        np.testing.assert_allclose(x, x_dense, rtol=1e-8, atol=1e-10 * np.abs(x_dense).max())
    # and not a trivially full pattern: every entry it keeps is met at some state
    assert (pattern == seen).all(), f"{name}: pattern entries never nonzero: {np.argwhere(pattern & ~seen).tolist()}"


def test_plan_of_the_harvester_is_the_structure_of_its_joints():
    """The groove-cam harvester's ideal joints each hold one body to the ground; its cam bearing sits at the
    cam's centre: W has two 2 x 2 blocks (the comb shafts) and is otherwise diagonal."""
    m = reference_machine("groove_cam")
    cm = compile_mechanism(drive_of(m).mechanism(m, revolutions=1))
    plan = cm.model[16]
    entries = {(int(a), int(b)) for a, b, _, _ in plan[cm.m:]}
    assert entries == {(i, i) for i in range(cm.m)} | {(4, 5), (6, 7)}, cm.con_names
    assert plan[:cm.m, 0].tolist() == [0, 1, 2, 3, 4, 4, 6, 6, 8]
    assert plan[:cm.m, 1].tolist() == [0, 1, 2, 3, 5, 5, 7, 7, 8]


def test_cases_cover_every_constraint_type():
    types = set()
    for _, spec, ideal in CASES:
        types |= {int(t) for t in compile_mechanism(spec, ideal_clearances=ideal).model[3]}
    assert types == set(mb.CON_ROWS)
