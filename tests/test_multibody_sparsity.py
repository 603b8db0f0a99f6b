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
from berryshaker.multibody.sparsity import driven_bodies, jacobian_pattern, solve_plan
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
        # the planned W: Phi_q M^-1 Phi_q^T without the driven bodies' rows and columns, unit diagonal there
        jr = jac.copy()
        for b, r, d in plan[m + plan[0, 3]:, :3]:
            jr[[r, r + 1, d], :] = 0.0
            jr[:, 3 * b:3 * b + 3] = 0.0
        gone = plan[:m, 2] == 1
        reduced_w = (jr * minv) @ jr.T + np.diag(gone.astype(float))
        W[:] = 0.0
        mb._schur(plan, jac, minv, W, m)
        np.testing.assert_allclose(np.triu(W), np.triu(reduced_w), rtol=1e-13,
                                   atol=1e-13 * np.abs(reduced_w).max())
        x = rng.normal(size=m)
        b = reduced_w @ x
        mb._spd_solve(plan, W, b, m)
        np.testing.assert_allclose(b, x, rtol=1e-8, atol=1e-10 * np.abs(x).max())
        # the constrained solve against the dense KKT system [M J^T; J 0] [x; lam] = [M u; g]
        u = rng.normal(size=n)
        g = rng.normal(size=m)
        mdiag = 1.0 / minv
        kkt = np.block([[np.diag(mdiag), jac.T], [jac, np.zeros((m, m))]])
        ref = np.linalg.solve(kkt, np.concatenate([mdiag * u, g]))
        out, lam, rhs_w = np.concatenate([np.zeros(3), u]), np.zeros(m), np.zeros(m)
        W[:] = 0.0
        mb._constrained_solve(plan, cm.model[0], cm.model[1], cint, crow, jac, minv, W, rhs_w, out, 3, g, lam, m)
        np.testing.assert_allclose(out[3:], ref[:n], rtol=1e-8, atol=1e-10 * np.abs(ref[:n]).max())
        np.testing.assert_allclose(lam, ref[n:], rtol=1e-8, atol=1e-10 * np.abs(ref[n:]).max())
    # and not a trivially full pattern: every entry it keeps is met at some state
    assert (pattern == seen).all(), f"{name}: pattern entries never nonzero: {np.argwhere(pattern & ~seen).tolist()}"


def test_plan_of_the_harvester_is_the_structure_of_its_joints():
    """The groove-cam harvester's ideal joints each hold one body to the ground; its cam bearing sits at the
    cam's centre: W has two 2 x 2 blocks (the comb shafts) and is otherwise diagonal.  The cam is pinned and
    driven, but no other joint holds it (the groove is a contact), so it is not eliminated; with the groove
    ideal (a cam-roller constraint on the cam) it is."""
    m = reference_machine("groove_cam")
    cm = compile_mechanism(drive_of(m).mechanism(m, revolutions=1))
    plan = cm.model[16]
    ne = int(plan[0, 3])
    entries = {(int(a), int(b)) for a, b, _, _ in plan[cm.m:cm.m + ne]}
    assert entries == {(i, i) for i in range(cm.m)} | {(4, 5), (6, 7)}, cm.con_names
    assert plan[:cm.m, 0].tolist() == [0, 1, 2, 3, 4, 4, 6, 6, 8]
    assert plan[:cm.m, 1].tolist() == [0, 1, 2, 3, 5, 5, 7, 7, 8]
    assert plan[:cm.m, 2].tolist() == [0] * cm.m and len(plan) == cm.m + ne
    ideal = compile_mechanism(drive_of(m).mechanism(m, revolutions=1), ideal_clearances=True)
    plan = ideal.model[16]
    assert plan[ideal.m + plan[0, 3]:, :3].tolist() == [[ideal.body_index["cam"], 0, ideal.m - 1]]


def test_slider_crank_crank_is_eliminated():
    """The slider-crank's crank (revolute to the ground and driver) leaves W: a dense 5 x 5 block becomes the
    rod's 2 x 2 block (with the crank's known acceleration on the right-hand side)."""
    cm = compile_mechanism(load_mechanism(EXAMPLES / "slider_crank_clearance.toml"))
    plan = cm.model[16]
    assert plan[:cm.m, 2].tolist() == [1, 1, 0, 0, 0, 0, 1]
    assert plan[:cm.m, 0].tolist() == [0, 1, 2, 2, 4, 5, 6]
    assert plan[cm.m + plan[0, 3]:, :3].tolist() == [[0, 0, 6]]


def test_driven_body_needs_exactly_a_ground_revolute_and_a_driver():
    """A body pinned to the ground, driven and holding another body is eliminated; not without its driver, with a
    second constraint to the ground (over-constrained), or when nothing else holds it (already a block of its
    own)."""
    rev, drv, pri = mb.CON_REVOLUTE, mb.CON_DRIVER, mb.CON_PRISMATIC

    def driven(types, bodies):
        rows = np.cumsum([0] + [mb.CON_ROWS[t] for t in types[:-1]])
        cint = np.array([[i, j, 0, 0] for i, j in bodies], dtype=np.int64)
        return driven_bodies(np.array(types, dtype=np.int64), cint, rows.astype(np.int64))

    assert driven([rev, drv, rev], [(-1, 0), (0, -1), (0, 1)]) == [(0, 0, 2)]
    assert driven([rev, rev], [(-1, 0), (0, 1)]) == []
    assert driven([rev, drv, rev, pri], [(-1, 0), (0, -1), (0, 1), (-1, 0)]) == []
    assert driven([rev, drv], [(-1, 0), (0, -1)]) == []


def test_cases_cover_every_constraint_type():
    types = set()
    for _, spec, ideal in CASES:
        types |= {int(t) for t in compile_mechanism(spec, ideal_clearances=ideal).model[3]}
    assert types == set(mb.CON_ROWS)


def test_remembered_plan_is_a_copy_per_call():
    """solve_plan is remembered per constraint set; a caller that writes into its plan must not change the next
    caller's (the kernel only reads it, but the model tuple is the caller's)."""
    cm = compile_mechanism(load_mechanism(EXAMPLES / "slider_crank_clearance.toml"))
    ctype, cint, cflt, crow = cm.model[3:7]
    first = solve_plan(ctype, cint, cflt, crow, cm.m, cm.n)
    expected = first.copy()
    first[:] = -7
    np.testing.assert_array_equal(solve_plan(ctype, cint, cflt, crow, cm.m, cm.n), expected)
    moved = cflt.copy()
    moved[1, mb.CF_SJX] = 0.0  # the rod's pin at its origin: its angle column, and W[2, 3], leave the pattern
    assert not np.array_equal(solve_plan(ctype, cint, moved, crow, cm.m, cm.n), expected)
