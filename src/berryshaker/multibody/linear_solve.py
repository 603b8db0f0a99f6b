"""The linear solves of the compiled core: the multipliers and constrained accelerations of the KKT system
[M Phi_q^T; Phi_q 0] [x; lambda] = [M u; g] through its Schur complement W = Phi_q M^-1 Phi_q^T (docs/multibody.md,
"Formulation" and "Driven bodies are eliminated").

M is diagonal (``minv`` holds M^-1); Phi_q is sparse by blocks (a constraint block touches only its two bodies'
columns, :mod:`berryshaker.multibody.constraint_rows`), and W's structurally nonzero entries and its factor's
envelopes come from the solve plan (:func:`berryshaker.multibody.sparsity.solve_plan`).  The mechanism-specialised
kernels (:mod:`berryshaker.multibody.specialised`) unroll :func:`_constrained_solve` in the same operations and
order.
"""

from __future__ import annotations

from numba import njit

from berryshaker.multibody.constraint_rows import _block_end
from berryshaker.multibody.layout import CI_BODY_I, CI_BODY_J


@njit(cache=True, _nrt=False)
def _row_dot_at(jac, a, bi, bj, v, off):
    """Phi_q[a] . v[off:off + n] over the columns of bodies bi and bj (the only nonzero ones of row a)."""
    acc = 0.0
    if bi >= 0:
        c = 3 * bi
        acc += jac[a, c] * v[off + c] + jac[a, c + 1] * v[off + c + 1] + jac[a, c + 2] * v[off + c + 2]
    if bj >= 0 and bj != bi:
        c = 3 * bj
        acc += jac[a, c] * v[off + c] + jac[a, c + 1] * v[off + c + 1] + jac[a, c + 2] * v[off + c + 2]
    return acc


@njit(cache=True, _nrt=False)
def _body_term(jac, a, b, body, minv):
    """sum_c Phi_q[a, c] M^-1_c Phi_q[b, c] over the three coordinates c of one body."""
    i = 3 * body
    return (jac[a, i] * minv[i] * jac[b, i] + jac[a, i + 1] * minv[i + 1] * jac[b, i + 1]
            + jac[a, i + 2] * minv[i + 2] * jac[b, i + 2])


@njit(cache=True, _nrt=False)
def _schur(plan, jac, minv, W, m):
    """W = Phi_q M^-1 Phi_q^T (M diagonal) over the rows left after the driven bodies: the structurally nonzero
    entries of its upper triangle (a <= b).

    ``plan`` (:func:`berryshaker.multibody.sparsity.solve_plan`) lists them with the bodies they sum over (driven
    bodies left out: their accelerations are known, :func:`_constrained_solve`); each entry costs one or two 3-term
    sums (modal coordinates of a flexible body never enter a constraint).  A driven body's own rows get a unit
    diagonal (bodies -2), so the factorisation passes their right-hand side through.  The rest of the upper
    triangle stays zero from its allocation; :func:`_spd_solve` reads its input there and writes the factor into
    the lower triangle.
    """
    for e in range(m, m + plan[0, 3]):
        a, b, b1, b2 = plan[e, 0], plan[e, 1], plan[e, 2], plan[e, 3]
        if b1 == -2:
            W[a, b] = 1.0
            continue
        acc = 0.0
        if b1 >= 0:
            acc += _body_term(jac, a, b, b1, minv)
        if b2 >= 0:
            acc += _body_term(jac, a, b, b2, minv)
        W[a, b] = acc


@njit(cache=True, _nrt=False)
def _add_jac_t(cint, crow, jac, x, scale, minv, out, off, m):
    """out[off + c] += scale M^-1_c (Phi_q^T x)_c over the body columns of every row (sparse Phi_q^T x).

    Body by body: the three sums of a body are kept in registers while the rows of the blocks that touch it are
    added in row order (the order of a row-by-row sweep, so the sums are bitwise those of one)."""
    nc = crow.shape[0]
    nb = 0
    for k in range(nc):
        if cint[k, CI_BODY_I] >= nb:
            nb = cint[k, CI_BODY_I] + 1
        if cint[k, CI_BODY_J] >= nb:
            nb = cint[k, CI_BODY_J] + 1
    for b in range(nb):
        c = 3 * b
        o0 = out[off + c]
        o1 = out[off + c + 1]
        o2 = out[off + c + 2]
        m0 = minv[c]
        m1 = minv[c + 1]
        m2 = minv[c + 2]
        for k in range(nc):
            if cint[k, CI_BODY_I] != b and cint[k, CI_BODY_J] != b:
                continue
            for a in range(crow[k], _block_end(crow, k, m)):
                xa = scale * x[a]
                o0 += m0 * jac[a, c] * xa
                o1 += m1 * jac[a, c + 1] * xa
                o2 += m2 * jac[a, c + 2] * xa
        out[off + c] = o0
        out[off + c + 1] = o1
        out[off + c + 2] = o2


@njit(cache=True, _nrt=False)
def _spd_solve(plan, W, b, m):
    """Solve W x = b in place (b <- x) for the symmetric positive definite W of :func:`_schur`, by L D L^T.

    Factorisation row by row (left-looking) over each row's envelope ``plan[i, 0]`` .. i (George & Liu, Computer
    Solution of Large Sparse Positive Definite Systems, 1981, ch. 4; Golub & Van Loan, Matrix Computations, 4th
    ed., 2013, sec. 4.1), reading W from the upper triangle and writing the unit lower factor L below the diagonal
    and the pivots' reciprocals 1/d_i on it (so the assembly never has to clear anything): row i first forms
    c_ij = L_ij d_j = W_ji - sum_k c_ik L_jk, then L_ij = c_ij / d_j and d_i = W_ii - sum_j c_ij L_ij.  One
    division per row and no square root: the chain of dependent long-latency operations is about a third of the
    Cholesky factorisation's.  Each row's forward substitution
    (L z = b) runs as soon as the row is factored (split into two passes the harvester's integration was ~4 %
    slower); back substitution L^T x = D^-1 z over each column's extent i .. ``plan[i, 1]``.  A pivot that is not
    positive (a singular constraint set) is replaced by 1e-300.  No scratch array (no allocation).
    """
    for i in range(m):
        lo = plan[i, 0]
        for j in range(lo, i):
            s = W[j, i]
            k0 = lo if lo > plan[j, 0] else plan[j, 0]  # L[j, k] = 0 left of row j's envelope
            for k in range(k0, j):
                s -= W[i, k] * W[j, k]
            W[i, j] = s  # c_ij, scaled to L_ij below
        d = W[i, i]
        for k in range(lo, i):
            c = W[i, k]
            lik = c * W[k, k]
            W[i, k] = lik
            d -= c * lik
        if d <= 0.0:
            d = 1e-300
        W[i, i] = 1.0 / d
        s = b[i]
        for k in range(lo, i):
            s -= W[i, k] * b[k]
        b[i] = s
    for i in range(m - 1, -1, -1):
        s = b[i] * W[i, i]
        for k in range(i + 1, plan[i, 1] + 1):
            if plan[k, 0] <= i:  # inside row k's envelope (outside it L[k, i] = 0, never written)
                s -= W[k, i] * b[k]
        b[i] = s


@njit(cache=True, _nrt=False, inline="always")
def _constrained_solve(plan, mass, inertia, cint, crow, jac, minv, W, rhs, u, off, g, lam, m):
    """x = u - M^-1 Phi_q^T lambda with Phi_q x = g, in place (u[off:off + n] <- x), lambda into ``lam``.

    The accelerations (u = M^-1 Q, g = gamma), the position correction of the projection (u = 0, g = -Phi) and
    its velocity correction (u = q', g = nu) are all this problem: the KKT system
    [M Phi_q^T; Phi_q 0] [x; lambda] = [M u; g] (docs/multibody.md, "Formulation").

    A **driven body** (``plan``'s last rows ``[body, r, d, 0]``: a revolute to the ground in rows r, r + 1 and an
    angle driver in row d) has its three coordinates fixed by its own rows: J_bb x_b = g_b, with
    J_bb = [[s, 0, j_r], [0, s, j_r1], [0, 0, 1]] and s = +-1 (kernel ``constraints``), solved by substitution
    (multiplying by s is dividing by it).  Eliminating these rows from the KKT system leaves exactly the Schur
    system of the other bodies, W_o lambda_o = Phi_o x' - g_o with W_o = Phi_oo M_o^-1 Phi_oo^T (the coupling
    terms J_ob M_b^-1 J_ob^T cancel identically, George & Liu's block elimination), where x' is u with the driven
    bodies' x_b in place; the driven rows' multipliers then follow from the driven body's equations of motion,
    J_bb^T lambda_b = M_b (u_b - x_b) - J_ob^T lambda_o.  For the slider-crank (crank pinned and driven) W's dense
    5 x 5 block becomes the rod's 2 x 2 block (the slider's two rows stay 1 x 1 blocks).  ``rhs`` and ``W`` are
    work arrays.
    """
    ne = plan[0, 3]
    for e in range(m + ne, plan.shape[0]):
        b, r, d = plan[e, 0], plan[e, 1], plan[e, 2]
        c = off + 3 * b
        cj = 3 * b
        x2 = g[d]
        x0 = (g[r] - jac[r, cj + 2] * x2) * jac[r, cj]
        x1 = (g[r + 1] - jac[r + 1, cj + 2] * x2) * jac[r + 1, cj + 1]
        lam[r] = u[c] - x0  # kept for the multipliers below
        lam[r + 1] = u[c + 1] - x1
        lam[d] = u[c + 2] - x2
        u[c] = x0
        u[c + 1] = x1
        u[c + 2] = x2
    for k in range(crow.shape[0]):
        bi, bj = cint[k, CI_BODY_I], cint[k, CI_BODY_J]
        for a in range(crow[k], _block_end(crow, k, m)):
            # (a driven body's own rows too: their unit rows of the factor pass any finite value through
            # untouched, multiplied by exact zeros everywhere else, and it is overwritten below)
            rhs[a] = _row_dot_at(jac, a, bi, bj, u, off) - g[a]
    _schur(plan, jac, minv, W, m)
    _spd_solve(plan, W, rhs, m)
    for e in range(m + ne, plan.shape[0]):
        b, r, d = plan[e, 0], plan[e, 1], plan[e, 2]
        cj = 3 * b
        t0 = mass[b] * lam[r]
        t1 = mass[b] * lam[r + 1]
        t2 = inertia[b] * lam[d]
        for k in range(crow.shape[0]):
            if cint[k, CI_BODY_I] != b and cint[k, CI_BODY_J] != b:
                continue
            for a in range(crow[k], _block_end(crow, k, m)):
                if plan[a, 2] == 0:
                    t0 -= jac[a, cj] * rhs[a]
                    t1 -= jac[a, cj + 1] * rhs[a]
                    t2 -= jac[a, cj + 2] * rhs[a]
        lr = t0 * jac[r, cj]
        lr1 = t1 * jac[r + 1, cj + 1]
        rhs[r] = lr
        rhs[r + 1] = lr1
        rhs[d] = t2 - jac[r, cj + 2] * lr - jac[r + 1, cj + 2] * lr1
        c = off + cj
        lam[r] = u[c]  # x_b, put back after the other bodies' update below
        lam[r + 1] = u[c + 1]
        lam[d] = u[c + 2]
    _add_jac_t(cint, crow, jac, rhs, -1.0, minv, u, off, m)
    for e in range(m + ne, plan.shape[0]):
        b, r, d = plan[e, 0], plan[e, 1], plan[e, 2]
        c = off + 3 * b
        u[c] = lam[r]
        u[c + 1] = lam[r + 1]
        u[c + 2] = lam[d]
    for a in range(m):
        lam[a] = rhs[a]
