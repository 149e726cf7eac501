"""Compiled (numba) exact solver of the QP of :mod:`wbc.solvers.qp_data` without rows C (H positive definite, A full
row rank), warm-started from the previous call's working set (the variables held at a bound): :func:`solve_box_eq_ws`.
Each tuple argument may be a plain tuple in its namedtuple's order (numba types a plain tuple of arrays faster than a
namedtuple; compiled callers pass them too, to link the one compiled version).

For a working set W the free part F solves the equality-constrained QP by the range-space method (Nocedal & Wright,
*Numerical Optimization*, 2nd ed., §16.2: L Lᵀ = H_FF, S = A_F H_FF⁻¹ A_Fᵀ), refined once on the equality rows. Then
the free variable furthest outside its bounds is fixed at the violated bound, else the fixed variable whose bound
multiplier has the most wrong sign is freed (single-pivot principal pivoting, Júdice & Pires, Comput. Oper. Res.
21(5), 1994). The loop ends only when every KKT condition holds; otherwise a negative exit code
(:mod:`wbc.solvers.status`).
"""

from __future__ import annotations

from collections import namedtuple

import numba as nb
import numpy as np

from wbc.compiled import FASTMATH, once_per_process
from wbc.solvers.linalg import (backward_substitution, cholesky_lower, equality_residual, forward_substitution,
                                primal_from_multipliers)
from wbc.solvers.status import DEPENDENT_EQUALITIES, ITERATION_CAP, NOT_POSITIVE_DEFINITE

__all__ = ["BoxEqArrays", "BoxEqSpace", "clip_eq_residual", "drop_infinite_active", "load_box_eq_kernels",
           "solve_box_eq_ws"]

#: the arrays of :func:`solve_box_eq_ws` (:func:`solve_box_eq_ws`'s Args)
BoxEqArrays = namedtuple("BoxEqArrays", "state x nu z eq_residual")
#: the workspace of :func:`solve_box_eq_ws`: free (n,) int64 (the free variables, then the fixed ones from the end);
#: L (n, n) the factor of H_FF; Y (m, n) = L⁻¹A_Fᵀ by row; S (m, m) the Schur complement's factor; t (n,), rhs (m,)
BoxEqSpace = namedtuple("BoxEqSpace", "free L Y S t rhs")


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def _working_set_step(qp, state, x, nu, rank_tol, space, e):
    """The equality-constrained optimum on the working set ``state`` (module docstring; e (n,) scratch): the held
    variables set in x, x_F in t[:nf] (order of ``free[:nf]``), the multipliers in nu[:m]. Returns nf (≥ 0), or
    NOT_POSITIVE_DEFINITE / DEPENDENT_EQUALITIES."""
    H, g, A, b, lb, ub = qp
    free, L, Y, S, t, rhs = space
    n = H.shape[0]
    m = A.shape[0]
    nf = 0
    nw = n  # the fixed variables are listed from the end of ``free``: free[nw:]
    for i in range(n):
        if state[i] == 0:
            free[nf] = i
            nf += 1
        else:
            nw -= 1
            free[nw] = i
            x[i] = lb[i] if state[i] < 0 else ub[i]
    if nf < m:
        return DEPENDENT_EQUALITIES
    # r = g_F + H_FW x_W ; H_FF
    for a in range(nf):
        i = free[a]
        r = g[i]
        for c in range(nw, n):
            j = free[c]
            r += H[i, j] * x[j]
        t[a] = r
    if nf == n:  # nothing fixed: H_FF = H
        for a in range(n):
            for c in range(a + 1):
                L[a, c] = H[a, c]
    else:
        for a in range(nf):
            i = free[a]
            for c in range(a + 1):
                L[a, c] = H[i, free[c]]
    if not cholesky_lower(L, nf):
        return NOT_POSITIVE_DEFINITE
    forward_substitution(L, nf, t)
    # Y = L⁻¹ A_Fᵀ ; rhs = -(b - A_W x_W) - Yᵀ t
    for k in range(m):
        bw = b[k]
        for c in range(nw, n):
            j = free[c]
            bw -= A[k, j] * x[j]
        col = Y[k]
        for a in range(nf):
            col[a] = A[k, free[a]]
        forward_substitution(L, nf, col)
        s = 0.0
        for a in range(nf):
            s += col[a] * t[a]
        rhs[k] = -bw - s
    smax = 0.0
    for k in range(m):
        for c in range(k + 1):
            s = 0.0
            for a in range(nf):
                s += Y[k, a] * Y[c, a]
            S[k, c] = s
        if S[k, k] > smax:
            smax = S[k, k]
    if m:
        if not cholesky_lower(S, m):
            return DEPENDENT_EQUALITIES
        for k in range(m):
            if S[k, k] * S[k, k] <= rank_tol * smax:
                return DEPENDENT_EQUALITIES
        for k in range(m):
            nu[k] = rhs[k]
        forward_substitution(S, m, nu)
        backward_substitution(S, m, nu)
    # x_F = -L⁻ᵀ (t + Y nu)
    primal_from_multipliers(L, nf, t, Y, nu, m, t)
    if m:
        _refine_equalities(qp, space, nf, nw, x, nu, e)
    return nf


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def _refine_equalities(qp, space, nf, nw, x, nu, e):
    """One step of iterative refinement on the equality rows (Golub & Van Loan, *Matrix Computations*, 4th ed.,
    §3.5.3; S squares A_F's conditioning): d = H_FF⁻¹ A_Fᵀ w, S w = r (the residual), the least-H-norm step onto the
    rows, multipliers nu − w. Reuses ``space``'s factors; t[:nf] refined in place; rhs and e (n,) scratch."""
    H, _, A, b, _, _ = qp
    free, L, Y, S, t, r = space
    n = H.shape[0]
    m = A.shape[0]
    for k in range(m):
        s = b[k]
        for c in range(nw, n):
            j = free[c]
            s -= A[k, j] * x[j]
        for a in range(nf):
            s -= A[k, free[a]] * t[a]
        r[k] = s
    forward_substitution(S, m, r)
    backward_substitution(S, m, r)
    for a in range(nf):
        e[a] = 0.0
    for k in range(m):
        wk = r[k]
        nu[k] -= wk
        yk = Y[k]
        for a in range(nf):
            e[a] += yk[a] * wk
    backward_substitution(L, nf, e)
    for a in range(nf):
        t[a] += e[a]


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def _place_free(free, t, nf, x, lb, ub, primal_tol):
    """x[free[:nf]] = t[:nf]; the bound violated most beyond ``primal_tol``: (violation, index or −1, side)."""
    worst = primal_tol
    worst_i = -1
    worst_side = 0
    for a in range(nf):
        i = free[a]
        v = t[a]
        x[i] = v
        if lb[i] - v > worst:
            worst, worst_i, worst_side = lb[i] - v, i, -1
        elif v - ub[i] > worst:
            worst, worst_i, worst_side = v - ub[i], i, 1
    return worst, worst_i, worst_side


@nb.njit(cache=True, nogil=True)
def drop_infinite_active(state, lo, hi):
    """Free the entries of a warm-start state (−1 lower, +1 upper, 0 free) held at an infinite bound, in place."""
    for i in range(state.shape[0]):
        if state[i] == -1 and not np.isfinite(lo[i]):
            state[i] = 0
        elif state[i] == 1 and not np.isfinite(hi[i]):
            state[i] = 0


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def clip_eq_residual(x, lb, ub, A, b, n, m):
    """Clip x into [lb, ub] in place; return max_k |A_k x − b_k|."""
    for i in range(n):
        if x[i] < lb[i]:
            x[i] = lb[i]
        elif x[i] > ub[i]:
            x[i] = ub[i]
    return equality_residual(A, b, x, n, m)


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def _bound_multipliers(H, g, A, m, nu, state, x, z, worst):
    """z = −(H x + g + A[:m]ᵀ nu) on the held variables (0 on the free ones); returns (largest wrong sign above
    ``worst``, its index or −1)."""
    n = H.shape[0]
    worst_i = -1
    for i in range(n):
        if state[i] == 0:
            z[i] = 0.0
            continue
        s = g[i]
        for j in range(n):
            s += H[i, j] * x[j]
        for k in range(m):
            s += A[k, i] * nu[k]
        z[i] = -s
        wrong = z[i] if state[i] < 0 else -z[i]
        if wrong > worst:
            worst = wrong
            worst_i = i
    return worst, worst_i


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def solve_box_eq_ws(qp, arrays, limits, space):
    """Exact solution of min ½xᵀHx + gᵀx s.t. Ax = b, lb ≤ x ≤ ub (module docstring).

    Args:
        qp: H, g, A, b, lb, ub (QPData's order without C, l, u): (n, n), (n,), (m, n), (m,), (n,), (n,).
        arrays: a :data:`BoxEqArrays`: state (n,) int8, in/out: working set (0 free, −1 at lb, +1 at ub), read as the
            warm start; out: x (n,), nu (m,), z (n,) (H x + g + Aᵀ nu + z = 0; z ≤ 0 at a lower bound, ≥ 0 at an
            upper one), eq_residual (1,): max |A x − b|.
        limits: a :data:`wbc.solvers.active_set.QPLimits`: max_iter; primal_tol: bound violation that fixes a
            variable; dual_tol: wrong-sign multiplier that frees one; rank_tol: relative pivot of S below which the
            equalities count as dependent.
        space: a :data:`BoxEqSpace`.

    Returns:
        iterations (≥ 1) on success, x inside [lb, ub] exactly; or a negative exit code.
    """
    H, g, A, b, lb, ub = qp
    state, x, nu, z, eq_residual = arrays
    max_iter, primal_tol, dual_tol, rank_tol = limits
    free, _, _, _, t, _ = space
    n = H.shape[0]
    m = A.shape[0]
    drop_infinite_active(state, lb, ub)
    for it in range(1, max_iter + 1):
        nf = _working_set_step(qp, state, x, nu, rank_tol, space, z)
        if nf < 0:
            return nf
        worst, worst_i, worst_side = _place_free(free, t, nf, x, lb, ub, primal_tol)
        if worst_i >= 0:
            state[worst_i] = worst_side
            continue
        # bound multipliers z = -(H x + g + Aᵀ nu) on the fixed set; the worst wrong sign is freed
        worst, worst_i = _bound_multipliers(H, g, A, m, nu, state, x, z, dual_tol)
        if worst_i < 0:
            eq_residual[0] = clip_eq_residual(x, lb, ub, A, b, n, m)
            return it
        state[worst_i] = 0
    return ITERATION_CAP


@once_per_process
def load_box_eq_kernels() -> None:
    """Compile (or load), once per process, :func:`solve_box_eq_ws` for its callers' argument types (plain tuples):
    the ``fast`` backend's and the kinematic tick's loaders run after this one and link this version."""
    n, m = 2, 1
    solve_box_eq_ws((np.eye(n), np.ones(n), np.ones((m, n)), np.ones(m), -np.ones(n), np.ones(n)),
                    (np.zeros(n, np.int8), np.empty(n), np.empty(m), np.empty(n), np.empty(1)),
                    (10, 1e-12, 1e-12, 1e-24),
                    (np.empty(n, np.int64), np.empty((n, n)), np.empty((m, n)), np.empty((m, m)), np.empty(n),
                     np.empty(m)))
