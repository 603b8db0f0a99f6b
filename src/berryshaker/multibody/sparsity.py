"""The structure of the multiplier solve, found once per mechanism (symbolic factorisation).

Every right-hand side of the engine solves (Phi_q M^-1 Phi_q^T) lambda = Phi_q M^-1 Q - gamma
(docs/multibody.md, "Formulation").  Which entries of W = Phi_q M^-1 Phi_q^T can be nonzero, and therefore
where its factor L can be nonzero, depends only on which constraints act on which bodies and on a few
geometric zeros (a revolute at a body's origin has no angle column), not on the state.  Finding that pattern
once, when the mechanism is compiled, lets the kernel compute only those entries and run the factorisation over
each row's envelope only: the "symbolic factorisation" of sparse direct solvers (George & Liu, Computer Solution
of Large Sparse Positive Definite Systems, 1981, ch. 4-5; Davis, Direct Methods for Sparse Linear Systems,
2006, ch. 4).  For the groove-cam harvester W is 9 x 9 with 11 of its 45 upper entries structurally nonzero (the
ideal joints all hold a body to the ground).

The pattern is a superset of the numerical nonzeros at every state: an entry is left out only if the kernel's
``constraints`` writes an exact zero there whatever the state.  A body pinned to the ground and driven in angle that
another joint also holds (:func:`driven_bodies`) leaves W altogether: its accelerations follow from its own rows,
and the plan gives them a unit diagonal (docs/multibody.md, "Driven bodies are eliminated").  The kernel factors
W as L D L^T over the envelopes; tests/multibody/test_sparsity.py checks the pattern against the kernel's Jacobian,
and the solve against the dense KKT system.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from berryshaker.multibody import layout as L


def jacobian_pattern(ctype: np.ndarray, cint: np.ndarray, cflt: np.ndarray, crow: np.ndarray, m: int,
                     n: int) -> np.ndarray:
    """Where the constraint Jacobian Phi_q can be nonzero, by constraint type (``constraint_rows.constraints``).

    Parameters
    ----------
    ctype, cint, cflt, crow : numpy.ndarray
        The constraint arrays of a compiled mechanism (type, bodies, float parameters in SI, first row of each
        block).
    m, n : int
        Constraint rows and coordinates.

    Returns
    -------
    numpy.ndarray of bool, shape (m, n)
        True where some state gives a nonzero entry.  Structural zeros: a body's angle column where the kernel
        multiplies it by a body-fixed point at the body's origin (revolute, the slider point of a prismatic
        joint, the pin of a slot, the roller of a cam joint), and a coordinate column of a point on a line fixed
        to the ground where the line's normal has no component along it.  Every other entry of a body a block acts
        on counts as nonzero.
    """
    pat = np.zeros((m, n), dtype=bool)

    def xyz(row, body, angle=True, x=True, y=True):
        if body >= 0:
            pat[row, 3 * body] = x
            pat[row, 3 * body + 1] = y
            pat[row, 3 * body + 2] = angle

    def on_line(row, line_body, point_body, point_off_origin, ux, uy):
        # n . (p - l) with n = rot90(A_l u): fixed if the line is on the ground, so a zero component stays zero
        xyz(row, line_body)
        fixed = line_body < 0
        xyz(row, point_body, point_off_origin, x=not fixed or uy != 0.0, y=not fixed or ux != 0.0)

    def off_origin(sx, sy):
        return sx != 0.0 or sy != 0.0

    for k in range(len(ctype)):
        r = int(crow[k])
        bi, bj = int(cint[k, 0]), int(cint[k, 1])
        f = cflt[k]
        typ = int(ctype[k])
        if typ == L.CON_REVOLUTE:
            for row in (r, r + 1):
                if bi >= 0:
                    pat[row, 3 * bi + (row - r)] = True
                    pat[row, 3 * bi + 2] = off_origin(f[L.CF_SIX], f[L.CF_SIY])
                if bj >= 0:
                    pat[row, 3 * bj + (row - r)] = True
                    pat[row, 3 * bj + 2] = off_origin(f[L.CF_SJX], f[L.CF_SJY])
        elif typ == L.CON_PRISMATIC:
            for b in (bi, bj):  # the relative-angle row
                if b >= 0:
                    pat[r, 3 * b + 2] = True
            # slider j's point on the line of body i
            on_line(r + 1, bi, bj, off_origin(f[L.CF_SJX], f[L.CF_SJY]), f[L.CF_UX], f[L.CF_UY])
        elif typ == L.CON_POINT_LINE:  # pin of body i in a slot of body j
            on_line(r, bj, bi, off_origin(f[L.CF_SIX], f[L.CF_SIY]), f[L.CF_UX], f[L.CF_UY])
        elif typ == L.CON_CAM_ROLLER:
            xyz(r, bi, off_origin(f[L.CF_SIX], f[L.CF_SIY]))
            xyz(r, bj)
        elif typ == L.CON_DRIVER:
            pat[r, 3 * bi + 2] = True
        else:
            raise ValueError(f"constraint type {typ} has no Jacobian pattern in multibody.sparsity")
    return pat


def driven_bodies(ctype: np.ndarray, cint: np.ndarray, crow: np.ndarray) -> list[tuple[int, int, int]]:
    """Bodies whose three coordinates their own constraints fix: pinned to the ground and driven in angle.

    A body with a revolute joint to the ground (rows r, r + 1) and an angle driver (row d), and no other
    constraint to the ground, has J_bb x_b = g_b with J_bb = [[s, 0, j], [0, s, j'], [0, 0, 1]], s = +-1, always
    invertible: its accelerations (and projection corrections) follow from its own rows, and the kernel
    eliminates those rows before the multiplier solve (:func:`berryshaker.multibody.linear_solve._constrained_solve`).
    Only a body that some other joint also holds is returned: otherwise its rows are a block of W of their own
    already and eliminating them would only add work (the groove cam, whose groove is a contact).  The crank of
    the slider-crank, the crank of the crank-rocker drive with ideal pins and the cam with an ideal groove are
    such bodies.

    Parameters
    ----------
    ctype : numpy.ndarray of int
        Type of each constraint block (``layout.CON_*``).
    cint : numpy.ndarray of int
        Integer records of the constraint blocks (``layout.CI_*``).
    crow : numpy.ndarray of int
        First row of each constraint block.

    Returns
    -------
    list of (body, r, d)
        Per such body: its index, the first row of its revolute joint to the ground and its driver's row.
    """
    out = []
    blocks: dict[int, list[int]] = {}
    for k in range(len(ctype)):
        bi, bj = int(cint[k, 0]), int(cint[k, 1])
        if int(ctype[k]) == L.CON_DRIVER:
            blocks.setdefault(bi, []).append(k)
        elif (bi < 0) != (bj < 0):  # a joint between a body and the ground
            blocks.setdefault(max(bi, bj), []).append(k)
    for b, ks in sorted(blocks.items()):
        types = sorted(int(ctype[k]) for k in ks)
        if types != sorted((L.CON_REVOLUTE, L.CON_DRIVER)):
            continue
        if not any(b in (int(cint[k, 0]), int(cint[k, 1])) for k in range(len(ctype)) if k not in ks):
            continue  # no other joint holds it: its rows are a block of W of their own already
        kr = next(k for k in ks if int(ctype[k]) == L.CON_REVOLUTE)
        kd = next(k for k in ks if int(ctype[k]) == L.CON_DRIVER)
        out.append((b, int(crow[kr]), int(crow[kd])))
    return out


#: plans remembered (by the constraint arrays' bytes): a run compiles its mechanism twice (the clearance joints as
#: forces, and ideal for the initial assembly), and the points of a clearance sweep share both structures
SOLVE_PLAN_CACHE_SIZE = 64


def solve_plan(ctype: np.ndarray, cint: np.ndarray, cflt: np.ndarray, crow: np.ndarray, m: int,
               n: int) -> np.ndarray:
    """The kernel's plan of the multiplier solve: driven bodies, envelope of each factor row, entries of W.

    Remembered for the last :data:`SOLVE_PLAN_CACHE_SIZE` constraint sets (~0.15 ms each to derive); every call
    returns its own copy.

    Parameters
    ----------
    ctype, cint, cflt, crow : numpy.ndarray
        The constraint arrays of a compiled mechanism (float parameters in SI).
    m, n : int
        Constraint rows and coordinates.

    Returns
    -------
    numpy.ndarray of int64, shape (m + n_entries + n_driven, 4)
        Rows 0..m-1: ``[lo, hi, eliminated, 0]`` (row 0's last column: n_entries), where L's row i is nonzero
        only in columns lo..i (its envelope: the first structurally nonzero entry of W's row i; the
        factorisation fills nothing left of it), L's column i only in rows i..hi, and ``eliminated`` is 1 for a
        driven body's own rows (:func:`driven_bodies`).  Rows m..m + n_entries - 1: one per structurally nonzero
        entry W[a, b], a <= b, in row order: ``[a, b, body_1, body_2]``, the bodies (or -1) whose coordinates
        the kernel sums over, in the order the dense assembly summed them (the first body of a's block if b's
        block shares it, then its second), driven bodies left out; ``[a, a, -2, -2]`` for an eliminated row (a
        unit diagonal).  Last rows: ``[body, r, d, 0]`` per driven body.
    """
    arrays = [np.ascontiguousarray(a) for a in (ctype, cint, cflt, crow)]
    key = tuple((a.dtype.str, a.shape, a.tobytes()) for a in arrays) + (int(m), int(n))
    return _solve_plan(key).copy()


@lru_cache(maxsize=SOLVE_PLAN_CACHE_SIZE)
def _solve_plan(key: tuple) -> np.ndarray:
    (ctype, cint, cflt, crow) = (np.frombuffer(b, dtype=np.dtype(d)).reshape(shape) for d, shape, b in key[:4])
    m, n = key[4], key[5]
    jp = jacobian_pattern(ctype, cint, cflt, crow, m, n)
    driven = driven_bodies(ctype, cint, crow)
    gone = np.zeros(m, dtype=bool)
    for b, r, d in driven:
        gone[[r, r + 1, d]] = True
        jp[:, 3 * b:3 * b + 3] = False  # known accelerations: their columns leave W
    jp[gone] = False
    wp = (jp.astype(np.int64) @ jp.T.astype(np.int64)) > 0  # M is diagonal and positive: W's pattern
    np.fill_diagonal(wp, True)
    block = np.zeros(m, dtype=np.int64)
    for k in range(len(crow)):
        block[int(crow[k]):] = k
    lo = np.array([int(np.argmax(wp[i, :i + 1])) for i in range(m)], dtype=np.int64)
    hi = np.array([max(k for k in range(i, m) if lo[k] <= i) for i in range(m)], dtype=np.int64)
    skip = {b for b, _, _ in driven}
    entries = []
    for a in range(m):
        if gone[a]:
            entries.append((a, a, -2, -2))
            continue
        i1, j1 = int(cint[block[a], 0]), int(cint[block[a], 1])
        if j1 == i1:
            j1 = -1
        for b in range(a, m):
            if not wp[a, b] or gone[b]:
                continue
            i2, j2 = int(cint[block[b], 0]), int(cint[block[b], 1])
            if j2 == i2:
                j2 = -1
            b1 = i1 if i1 >= 0 and i1 not in skip and i1 in (i2, j2) else -1
            b2 = j1 if j1 >= 0 and j1 not in skip and j1 in (i2, j2) else -1
            entries.append((a, b, b1, b2))
    plan = np.zeros((m + len(entries) + len(driven), 4), dtype=np.int64)
    plan[:m, 0] = lo
    plan[:m, 1] = hi
    plan[:m, 2] = gone
    if m:
        plan[0, 3] = len(entries)
    if entries:
        plan[m:m + len(entries)] = np.array(entries, dtype=np.int64)
    for i, (b, r, d) in enumerate(driven):
        plan[m + len(entries) + i, :3] = (b, r, d)
    return plan
