"""Compiled (numba) exact solver of a QP with equality rows and bounds only:

    min_x ½ xᵀ H x + gᵀ x   s.t.   A x = b,   lb ≤ x ≤ ub

(H symmetric positive definite, A full row rank), warm-started from the previous call's working set (the variables
held at a bound): :func:`solve_box_eq_ws` (workspace given) and :func:`solve_box_eq` (allocating).

Their arguments, as those of :func:`wbc.solvers.active_set.solve_qp_ws`: the QP (H, g, A, b, lb, ub: the order of
:class:`~wbc.solvers.qp_data.QPData` without its rows C, l, u), a :data:`BoxEqArrays` (working set and outputs),
the limits (a :data:`wbc.solvers.active_set.QPLimits`) and, for :func:`solve_box_eq_ws`, a :data:`BoxEqSpace`.
Each may be a plain tuple in that order instead (the kernels unpack them by position): numba's dispatcher types a
plain tuple of arrays by its fingerprint, a namedtuple through Python's typeof, so the Python callers pass plain
tuples; compiled callers pass them too, to link the one compiled version.

For a fixed working set W the free part F solves the equality-constrained QP through its KKT system, eliminated with
a Cholesky factor L Lᵀ = H_FF and the Schur complement S = A_F H_FF⁻¹ A_Fᵀ (Nocedal & Wright, *Numerical
Optimization*, 2nd ed., §16.2, eq. 16.16 "range-space method"), refined once on the equality rows (the Schur
complement squares their conditioning). The working set is then corrected: the free variable
furthest outside its bounds is fixed at the violated bound; otherwise the fixed variable whose bound multiplier has
the wrong sign (most negative) is freed (single-pivot principal pivoting, Júdice & Pires, Comput. Oper. Res. 21(5),
1994). The loop ends only when every KKT condition holds, so the returned x is the exact optimum; otherwise a
negative exit code (:mod:`wbc.solvers.status`).
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
           "solve_box_eq", "solve_box_eq_ws"]

#: the arrays of :func:`solve_box_eq_ws` / :func:`solve_box_eq` (n variables, m equality rows): state (n,) int8 the
#: working set (in/out, read as the warm start); x (n,), nu (m,), z (n,), eq_residual (1,) the outputs. A plain tuple
#: in this order is taken as well (module docstring)
BoxEqArrays = namedtuple("BoxEqArrays", "state x nu z eq_residual")
#: the workspace of :func:`solve_box_eq_ws`: free (n,) int64 (the free variables, then the fixed ones from the end);
#: L (n, n) the Cholesky factor of H_FF; Y (m, n) = L⁻¹A_Fᵀ by row; S (m, m) the Schur complement and its factor;
#: t (n,), rhs (m,) vectors. Or a plain tuple in this order
BoxEqSpace = namedtuple("BoxEqSpace", "free L Y S t rhs")


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def solve_box_eq(qp, arrays, limits):
    """Allocating form of :func:`solve_box_eq_ws` (same arguments, no workspace)."""
    n, m = qp[0].shape[0], qp[2].shape[0]
    return solve_box_eq_ws(qp, arrays, limits, (np.empty(n, np.int64), np.empty((n, n)), np.empty((m, n)),
                                                np.empty((m, m)), np.empty(n), np.empty(m)))


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def _working_set_step(qp, state, x, nu, rank_tol, space, e):
    """One equality-constrained solve for a fixed working set: the variables held at a bound (``state`` ≠ 0) are
    set onto it in x, and the free ones minimise ½xᵀHx + gᵀx subject to ``A x = b`` (qp = (H, g, A, b, lb, ub)),
    through the Cholesky factor L of H_FF and the Schur complement S = A_F H_FF⁻¹ A_Fᵀ (range-space method; Nocedal
    & Wright 2006, §16.2), refined once on the equality rows (:func:`_refine_equalities`; e (n,) is scratch), in the
    :data:`BoxEqSpace` ``space``. On return t[:nf] holds x_F (in the order of ``free[:nf]``) and nu[:m] the
    multipliers.

    Returns:
        nf, the number of free variables (≥ 0), or NOT_POSITIVE_DEFINITE / DEPENDENT_EQUALITIES.
    """
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
    """One step of iterative refinement of the range-space solve on its equality rows (Golub & Van Loan, *Matrix
    Computations*, 4th ed., §3.5.3): the Schur complement S = A_F H_FF⁻¹ A_Fᵀ squares the conditioning of A_F, so
    A_F x_F = b − A_W x_W holds only to ≈ ε·cond(S) after one solve. With the residual r, the correction
    d = H_FF⁻¹ A_Fᵀ w, S w = r, is the least-H-norm step onto the rows (A_F d = r); it keeps stationarity with the
    multipliers nu − w. Reuses the factors L (of H_FF), Y = L⁻¹A_Fᵀ and S's Cholesky factor of the
    :data:`BoxEqSpace` ``space`` (free[:nf] the free variables, free[nw:] the fixed ones, t[:nf] x_F, refined in
    place); its rhs (m,), as r, and e (n,) are scratch."""
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
    """Write the free-variable solution ``t[:nf]`` into ``x[free[:nf]]`` and return the bound it violates most
    beyond ``primal_tol``: ``(violation, variable index or −1, −1 lower / +1 upper / 0)``."""
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
    """A warm-start state (−1 at the lower, +1 at the upper bound, 0 free) is only valid where that bound is
    finite: free the others, in place."""
    for i in range(state.shape[0]):
        if state[i] == -1 and not np.isfinite(lo[i]):
            state[i] = 0
        elif state[i] == 1 and not np.isfinite(hi[i]):
            state[i] = 0


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def clip_eq_residual(x, lb, ub, A, b, n, m):
    """Clip x into [lb, ub] in place (the kernel's KKT point is within rounding of its bounds) and return the
    largest equality residual max_k |A_k x − b_k|."""
    for i in range(n):
        if x[i] < lb[i]:
            x[i] = lb[i]
        elif x[i] > ub[i]:
            x[i] = ub[i]
    return equality_residual(A, b, x, n, m)


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def _bound_multipliers(H, g, A, m, nu, state, x, z, worst):
    """Bound multipliers z = −(H x + g + A[:m]ᵀ nu) on the variables held at a bound (0 on the free ones), and the
    variable whose multiplier has the largest wrong sign above ``worst`` (z > 0 at a lower bound, z < 0 at an upper
    one). Returns (that magnitude or ``worst``, its index or −1)."""
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
        qp: H, g, A, b, lb, ub (a tuple; :class:`~wbc.solvers.qp_data.QPData`'s order without C, l, u), of shapes
            (n, n), (n,), (m, n), (m,), (n,), (n,) (±inf for free entries).
        arrays: a :data:`BoxEqArrays` (or a plain tuple in its order): state (n,) int8, in/out: working set (0 free,
            -1 held at lb, +1 held at ub), read as the warm start; x (n,), nu (m,), z (n,): out — solution,
            equality multipliers, bound multipliers (stationarity H x + g + Aᵀ nu + z = 0; z ≤ 0 at a lower bound,
            z ≥ 0 at an upper bound, 0 when free); eq_residual (1,): out — max |A x − b| of the returned x.
        limits: a :data:`wbc.solvers.active_set.QPLimits` (or a plain tuple in its order): max_iter: working-set
            iterations allowed. primal_tol: bound violation (absolute) that makes a free variable be fixed.
            dual_tol: wrong-sign multiplier magnitude that makes a fixed variable be freed. rank_tol: relative
            pivot of the Schur complement below which the equalities count as dependent.
        space: a :data:`BoxEqSpace` (or a plain tuple in its order): free (n,) int64, L (n, n), Y (m, n),
            S (m, m), t (n,), rhs (m,), the workspace.

    On success x lies inside [lb, ub] exactly (free entries within ``primal_tol`` of a bound are clipped onto it).

    Returns:
        iterations (≥ 1) on success, or a negative exit code.
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
    """Compile (or load from the on-disk cache), once per process, :func:`solve_box_eq_ws` for the argument types
    its callers give it (plain tuples: the QP's C-contiguous float64 arrays, the int8 working set and the outputs,
    the limits, the workspace with its int64 free list) — the ``fast`` backend (:mod:`wbc.solvers.fast`) and the
    kinematic tick (:mod:`wbc.formulations.velocity_kernel`), whose loaders run after this one (``wbc compile``'s
    :data:`wbc.cli.kernels.AFTER`) and link this version."""
    n, m = 2, 1
    solve_box_eq_ws((np.eye(n), np.ones(n), np.ones((m, n)), np.ones(m), -np.ones(n), np.ones(n)),
                    (np.zeros(n, np.int8), np.empty(n), np.empty(m), np.empty(n), np.empty(1)),
                    (10, 1e-12, 1e-12, 1e-24),
                    (np.empty(n, np.int64), np.empty((n, n)), np.empty((m, n)), np.empty((m, m)), np.empty(n),
                     np.empty(m)))
