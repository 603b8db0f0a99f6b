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
from berryshaker.multibody import layout as L
from berryshaker.multibody.compiled import _state_and_work, compile_mechanism
from berryshaker.multibody.constraint_rows import constraints
from berryshaker.multibody.dynamics import project
from berryshaker.multibody.linear_solve import _constrained_solve, _schur, _spd_solve
from berryshaker.multibody.sparsity import driven_bodies, jacobian_pattern, solve_plan
from berryshaker.multibody.spec import load_mechanism

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def _specs():
    yield "slider_crank", load_mechanism(EXAMPLES / "slider_crank_clearance.toml")
    for drive in ("groove_cam", "crank_rocker"):
        m = reference_machine(drive)
        yield drive, drive_of(m).mechanism(m, revolutions=1)


CASES = [(name, spec, ideal) for name, spec in _specs() for ideal in (False, True)]


def _random_state(cm, rng):
    q = cm.q0.copy()
    qd = np.zeros_like(q)
    nb = len(cm.model.mass)
    q[0:3 * nb:3] += rng.normal(0.0, 0.01, nb)
    q[1:3 * nb:3] += rng.normal(0.0, 0.01, nb)
    q[2:3 * nb:3] = rng.uniform(-np.pi, np.pi, nb)
    qd[:3 * nb] = rng.normal(0.0, 1.0, 3 * nb)
    return q, qd


@pytest.mark.parametrize("name, spec, ideal", CASES, ids=[f"{c[0]}{'-ideal' if c[2] else ''}" for c in CASES])
def test_pattern_contains_every_nonzero_and_solve_matches_dense(name, spec, ideal):
    cm = compile_mechanism(spec, ideal_clearances=ideal)
    md = cm.model
    ctype, cint, cflt, crow, cams, plan = md.ctype, md.cint, md.cflt, md.crow, md.cams, md.plan
    m, n = cm.m, cm.n
    # every case has ideal constraints (the drive, the ideal joints; with ideal=True the clearance pairs too): a
    # case without any would test nothing, so it fails instead of skipping
    assert m > 0, f"{name}: no ideal constraints"
    state, work = _state_and_work(cm)
    phi, jac, nu, gam, _q, _e, _lam, minv, W, rhs = work
    pattern = jacobian_pattern(ctype, cint, cflt, crow, m, n)
    np.testing.assert_array_equal(plan, solve_plan(ctype, cint, cflt, crow, m, n))
    types = {int(t) for t in ctype}
    rng = np.random.default_rng(7)
    seen = np.zeros((m, n), dtype=bool)
    for _ in range(40):
        q, qd = _random_state(cm, rng)
        constraints(0.3, q, qd, ctype, cint, cflt, crow, cams, state[2], phi, jac, nu, gam)
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
        _schur(plan, jac, minv, W, m)
        np.testing.assert_allclose(np.triu(W), np.triu(reduced_w), rtol=1e-13,
                                   atol=1e-13 * np.abs(reduced_w).max())
        x = rng.normal(size=m)
        b = reduced_w @ x
        _spd_solve(plan, W, b, m)
        np.testing.assert_allclose(b, x, rtol=1e-8, atol=1e-10 * np.abs(x).max())
        # the constrained solve against the dense KKT system [M J^T; J 0] [x; lam] = [M u; g]
        u = rng.normal(size=n)
        g = rng.normal(size=m)
        mdiag = 1.0 / minv
        kkt = np.block([[np.diag(mdiag), jac.T], [jac, np.zeros((m, m))]])
        ref = np.linalg.solve(kkt, np.concatenate([mdiag * u, g]))
        out, lam, rhs_w = np.concatenate([np.zeros(3), u]), np.zeros(m), np.zeros(m)
        W[:] = 0.0
        _constrained_solve(plan, cm.model.mass, cm.model.inertia, cint, crow, jac, minv, W, rhs_w, out, 3, g, lam, m)
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
    plan = cm.model.plan
    ne = int(plan[0, 3])
    entries = {(int(a), int(b)) for a, b, _, _ in plan[cm.m:cm.m + ne]}
    assert entries == {(i, i) for i in range(cm.m)} | {(4, 5), (6, 7)}, cm.con_names
    assert plan[:cm.m, 0].tolist() == [0, 1, 2, 3, 4, 4, 6, 6, 8]
    assert plan[:cm.m, 1].tolist() == [0, 1, 2, 3, 5, 5, 7, 7, 8]
    assert plan[:cm.m, 2].tolist() == [0] * cm.m and len(plan) == cm.m + ne
    ideal = compile_mechanism(drive_of(m).mechanism(m, revolutions=1), ideal_clearances=True)
    plan = ideal.model.plan
    assert plan[ideal.m + plan[0, 3]:, :3].tolist() == [[ideal.body_index["cam"], 0, ideal.m - 1]]


def test_slider_crank_crank_is_eliminated():
    """The slider-crank's crank (revolute to the ground and driver) leaves W: a dense 5 x 5 block becomes the
    rod's 2 x 2 block (with the crank's known acceleration on the right-hand side)."""
    cm = compile_mechanism(load_mechanism(EXAMPLES / "slider_crank_clearance.toml"))
    plan = cm.model.plan
    assert plan[:cm.m, 2].tolist() == [1, 1, 0, 0, 0, 0, 1]
    assert plan[:cm.m, 0].tolist() == [0, 1, 2, 2, 4, 5, 6]
    assert plan[cm.m + plan[0, 3]:, :3].tolist() == [[0, 0, 6]]


def test_driven_body_needs_exactly_a_ground_revolute_and_a_driver():
    """A body pinned to the ground, driven and holding another body is eliminated; not without its driver, with a
    second constraint to the ground (over-constrained), or when nothing else holds it (already a block of its
    own)."""
    rev, drv, pri = L.CON_REVOLUTE, L.CON_DRIVER, L.CON_PRISMATIC

    def driven(types, bodies):
        rows = np.cumsum([0] + [L.CON_ROWS[t] for t in types[:-1]])
        cint = np.array([[i, j, 0, 0] for i, j in bodies], dtype=np.int64)
        return driven_bodies(np.array(types, dtype=np.int64), cint, rows.astype(np.int64))

    assert driven([rev, drv, rev], [(-1, 0), (0, -1), (0, 1)]) == [(0, 0, 2)]
    assert driven([rev, drv, rev], [(0, -1), (0, -1), (1, 0)]) == [(0, 0, 2)]  # the body as body_i of either
    assert driven([rev, rev], [(-1, 0), (0, 1)]) == []
    assert driven([rev, drv, rev, pri], [(-1, 0), (0, -1), (0, 1), (-1, 0)]) == []
    assert driven([rev, drv], [(-1, 0), (0, -1)]) == []


def test_cases_cover_every_constraint_type():
    types = set()
    for _, spec, ideal in CASES:
        types |= {int(t) for t in compile_mechanism(spec, ideal_clearances=ideal).model.ctype}
    assert types == set(L.CON_ROWS)


def test_remembered_plan_is_a_copy_per_call():
    """solve_plan is remembered per constraint set; a caller that writes into its plan must not change the next
    caller's (the kernel only reads it, but the model record is the caller's)."""
    cm = compile_mechanism(load_mechanism(EXAMPLES / "slider_crank_clearance.toml"))
    md = cm.model
    ctype, cint, cflt, crow = md.ctype, md.cint, md.cflt, md.crow
    first = solve_plan(ctype, cint, cflt, crow, cm.m, cm.n)
    expected = first.copy()
    first[:] = -7
    np.testing.assert_array_equal(solve_plan(ctype, cint, cflt, crow, cm.m, cm.n), expected)
    moved = cflt.copy()
    moved[1, L.CF_SJX] = 0.0  # the rod's pin at its origin: its angle column, and W[2, 3], leave the pattern
    assert not np.array_equal(solve_plan(ctype, cint, moved, crow, cm.m, cm.n), expected)


def _synthetic(cons, nb, n_extra=0):
    """Constraint arrays of a mechanism given as (type, body_i, body_j, s_ix, s_iy, s_jx, s_jy) per joint."""
    ctype, cint, cflt, crow, row = [], [], [], [], 0
    for typ, bi, bj, six, siy, sjx, sjy in cons:
        f = np.zeros(L.N_CF)
        f[[L.CF_SIX, L.CF_SIY, L.CF_SJX, L.CF_SJY]] = six, siy, sjx, sjy
        f[L.CF_UX], f[L.CF_SPEED] = 1.0, 3.0
        ctype.append(typ)
        cint.append([bi, bj, 0])
        cflt.append(f)
        crow.append(row)
        row += L.CON_ROWS[typ]
    return (np.array(ctype, np.int64), np.array(cint, np.int64), np.array(cflt), np.array(crow, np.int64), row,
            3 * nb + n_extra)


_R, _P, _L, _D = L.CON_REVOLUTE, L.CON_PRISMATIC, L.CON_POINT_LINE, L.CON_DRIVER
_SC = [(_R, -1, 0, 0, 0, -.025, 0), (_R, 0, 1, .025, 0, -.06, 0), (_P, -1, 2, 0, 0, 0, 0), (_R, 1, 2, .06, 0, 0, 0),
       (_D, 0, -1, 0, 0, 0, 0)]
_SYNTHETIC = {
    "crank body_j": (_SC, 3, 0, 1),
    "crank body_i": ([(_R, 0, -1, -.025, 0, 0, 0)] + _SC[1:], 3, 0, 1),
    "driver row first": ([_SC[4]] + _SC[:4], 3, 0, 1),
    "driver row between": ([_SC[0], _SC[4]] + _SC[1:4], 3, 0, 1),
    "coordinates beyond the bodies": (_SC, 3, 4, 1),
    "two driven bodies on one coupler": ([(_R, -1, 0, 0, 0, -.02, 0), (_D, 0, -1, 0, 0, 0, 0), (_R, 0, 1, .02, 0, -.05, 0),
                                          (_R, 2, -1, -.03, 0, .2, 0), (_D, 2, -1, 0, 0, 0, 0),
                                          (_L, 2, 1, .03, 0, .05, 0)], 3, 0, 2),
    "two slider-cranks": (_SC + [(t, bi + 3 if bi >= 0 else -1, bj + 3 if bj >= 0 else -1, a, b, c, d)
                                 for t, bi, bj, a, b, c, d in _SC], 6, 0, 2),
}


@pytest.mark.parametrize("name", list(_SYNTHETIC))
def test_constrained_solve_matches_dense_kkt_on_synthetic_mechanisms(name):
    cons, nb, n_extra, n_driven = _SYNTHETIC[name]
    ctype, cint, cflt, crow, m, n = _synthetic(cons, nb, n_extra)
    plan = solve_plan(ctype, cint, cflt, crow, m, n)
    assert len(plan) - m - plan[0, 3] == n_driven  # the elimination is exercised, not bypassed
    rng = np.random.default_rng(11)
    mass, inertia = rng.uniform(0.1, 2.0, nb), rng.uniform(1e-4, 1e-2, nb)
    minv = np.ones(n)
    minv[0:3 * nb:3], minv[1:3 * nb:3], minv[2:3 * nb:3] = 1 / mass, 1 / mass, 1 / inertia
    phi, jac, nu, gam = np.zeros(m), np.zeros((m, n)), np.zeros(m), np.zeros(m)
    for _ in range(10):
        q, qd = rng.normal(0, 0.3, n), rng.normal(0, 1, n)
        constraints(0.1, q, qd, ctype, cint, cflt, crow, np.zeros((1, 8)), np.zeros(len(ctype)), phi, jac, nu, gam)
        u, g = rng.normal(size=n), rng.normal(size=m)
        kkt = np.block([[np.diag(1 / minv), jac.T], [jac, np.zeros((m, m))]])
        ref = np.linalg.solve(kkt, np.concatenate([u / minv, g]))
        x, lam = u.copy(), np.zeros(m)
        _constrained_solve(plan, mass, inertia, cint, crow, jac, minv, np.zeros((m, m)), np.zeros(m), x, 0, g,
                           lam, m)
        np.testing.assert_allclose(x, ref[:n], rtol=1e-9, atol=1e-11 * np.abs(ref[:n]).max())
        np.testing.assert_allclose(lam, ref[n:], rtol=1e-9, atol=1e-11 * np.abs(ref[n:]).max())


@pytest.mark.parametrize("crank_as", ["body_j", "body_i"])
def test_projection_matches_dense_mass_weighted_projection(crank_as, tmp_path):
    """One Newton step on the positions and the velocity projection (the crank eliminated) equal the dense
    mass-weighted ones: dq = -M^-1 J^T W^-1 Phi, then q' <- q' - M^-1 J^T W^-1 (J q' - nu)."""
    text = (EXAMPLES / "slider_crank_clearance.toml").read_text()
    if crank_as == "body_i":
        old = 'body_i = "ground"\nbody_j = "crank"\npoint_i = ["0 m", "0 m"]\npoint_j = ["-0.025 m", "0 m"]'
        assert old in text
        text = text.replace(old, 'body_i = "crank"\nbody_j = "ground"\npoint_i = ["-0.025 m", "0 m"]\n'
                                 'point_j = ["0 m", "0 m"]')
    path = tmp_path / "slider_crank.toml"
    path.write_text(text)
    cm = compile_mechanism(load_mechanism(path), ideal_clearances=True)
    plan = cm.model.plan
    assert plan[cm.m + plan[0, 3]:, 0].tolist() == [cm.body_index["crank"]]
    state, work = _state_and_work(cm)
    minv = work[7]
    rng = np.random.default_rng(3)
    y = np.concatenate([cm.q0 + rng.normal(0, 1e-3, cm.n), rng.normal(0, 1.0, cm.n)])
    n, m, md = cm.n, cm.m, cm.model
    phi, jac, nu, gam = np.zeros(m), np.zeros((m, n)), np.zeros(m), np.zeros(m)

    def at(q, qd):
        constraints(0.01, q, qd, md[3], md[4], md[5], md[6], md[10], state[2].copy(), phi, jac, nu, gam)
        return (jac * minv) @ jac.T

    q, qd = y[:n].copy(), y[n:].copy()
    q -= minv * (jac.T @ np.linalg.solve(at(q, qd), phi))
    w = at(q, qd)
    qd -= minv * (jac.T @ np.linalg.solve(w, jac @ qd - nu))
    project(0.01, y, md, state, work, np.int64(1))
    np.testing.assert_allclose(y, np.concatenate([q, qd]), rtol=1e-9, atol=1e-12)
