"""Compiled (numba) dense linear algebra shared by the in-house QP kernels (:mod:`wbc.solvers.active_set`,
:mod:`wbc.solvers.compiled_id`, :mod:`wbc.formulations.idkernel`): in-place Cholesky factor, forward and backward
substitution, the primal step of a Cholesky/Schur KKT solve, weighted normal equations, the clip of a box into
another, the residuals of equality and inequality rows at a point, and their scaled violations; a working set's
entries at infinite bounds freed.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
from numba.extending import register_jitable

from wbc.compiled import FASTMATH

__all__ = ["backward_substitution", "cholesky_lower", "clip_entry_into", "clip_eq_residual",
           "drop_infinite_active", "equality_residual", "forward_substitution", "primal_from_multipliers",
           "row_violation", "scaled_row_violation", "weighted_normal_equations"]


@register_jitable(inline="always")  # inlined in numba IR (no call, no reference counting); plain Python outside numba
def carve(buf, o, n):
    """The (n,) view buf[o:o + n] of a flat workspace and the next offset o + n (no copy)."""
    return buf[o:o + n], o + n


@register_jitable(inline="always")
def carve2(buf, o, rows, cols):
    """The (rows, cols) C-order view of buf[o:o + rows · cols] of a flat workspace and the next offset (no copy)."""
    return buf[o:o + rows * cols].reshape((rows, cols)), o + rows * cols


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def cholesky_lower(M, k, rel_tol=0.0):
    """In-place lower Cholesky of the leading k×k block of M; False when a pivot is not above ``rel_tol`` times
    its diagonal entry (0: not positive; > 0: a numerically dependent row, as the ID kernel's working set uses)."""
    for j in range(k):
        d0 = M[j, j]
        s = d0
        for p in range(j):
            s -= M[j, p] * M[j, p]
        if not s > rel_tol * d0:
            return False
        d = np.sqrt(s)
        M[j, j] = d
        for i in range(j + 1, k):
            t = M[i, j]
            for p in range(j):
                t -= M[i, p] * M[j, p]
            M[i, j] = t / d
    return True


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def forward_substitution(L, k, v):
    """v ← L⁻¹ v in place, L lower triangular (leading k × k block)."""
    for i in range(k):
        t = v[i]
        for p in range(i):
            t -= L[i, p] * v[p]
        v[i] = t / L[i, i]


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def backward_substitution(L, k, v):
    """v ← L⁻ᵀ v in place, L lower triangular (leading k × k block), by rows of L (contiguous reads)."""
    for i in range(k - 1, -1, -1):
        xi = v[i] / L[i, i]
        v[i] = xi
        Li = L[i]
        for p in range(i):
            v[p] -= xi * Li[p]


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def primal_from_multipliers(L, n, t, Y, nu, m, x):
    """x[:n] ← −L⁻ᵀ (t[:n] + Σ_k<m nu_k Y[k, :n]): the primal step of a Cholesky/Schur KKT solve (H = L Lᵀ, t = L⁻¹ g,
    Y = L⁻¹ Aᵀ row by row, nu the equality multipliers); x may be t itself."""
    for a in range(n):
        x[a] = t[a]
    for k in range(m):
        nk = nu[k]
        yk = Y[k]
        for a in range(n):
            x[a] += yk[a] * nk
    for a in range(n):
        x[a] = -x[a]
    backward_substitution(L, n, x)


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def weighted_normal_equations(J, w, r, damping, H, g):
    """H (n, n) = ε I + Jᵀ diag(w) J and g (n,) = −Jᵀ diag(w) r, written in place: the cost Σ_k w_k (J_k v − r_k)² +
    ε‖v‖² of stacked task rows J (m, n), weights w (m,) ≥ 0, targets r (m,), ε = ``damping``."""
    n = H.shape[0]
    m = J.shape[0]
    for i in range(n):
        for j in range(n):
            H[i, j] = 0.0
        H[i, i] = damping
        g[i] = 0.0
    for k in range(m):
        wk = w[k]
        if wk == 0.0:
            continue
        rk = wk * r[k]
        for i in range(n):
            jki = J[k, i]
            if jki == 0.0:
                continue
            g[i] -= jki * rk
            a = wk * jki
            for j in range(i, n):
                H[i, j] += a * J[k, j]
    for i in range(n):
        for j in range(i + 1, n):
            H[j, i] = H[i, j]


@nb.njit(cache=True, nogil=True, inline="always")
def clip_entry_into(lb, ub, i, lo, hi):
    """Intersect [lo, hi] with the running entry lb[i], ub[i] in place, yielding where it would empty it:
    lb[i] ← min(max(lo, lb[i]), ub[i]), ub[i] ← max(min(hi, ub[i]), lb[i]) (both from the running values)."""
    cl = lb[i]
    cu = ub[i]
    lb[i] = min(max(lo, cl), cu)
    ub[i] = max(min(hi, cu), cl)


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def equality_residual(A, b, x, n, m):
    """Largest equality residual max_k |A_k x − b_k| over the first ``m`` rows of A (n columns used); 0 for m = 0."""
    r = 0.0
    for k in range(m):
        s = -b[k]
        for j in range(n):
            s += A[k, j] * x[j]
        if abs(s) > r:
            r = abs(s)
    return r


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def clip_eq_residual(x, lb, ub, A, b, n, m):
    """Clip x into [lb, ub] in place; return :func:`equality_residual` at the clipped x."""
    for i in range(n):
        if x[i] < lb[i]:
            x[i] = lb[i]
        elif x[i] > ub[i]:
            x[i] = ub[i]
    return equality_residual(A, b, x, n, m)


@nb.njit(cache=True, nogil=True)
def drop_infinite_active(state, lo, hi):
    """Free the entries of a warm-start state (−1 lower, +1 upper, 0 free) held at an infinite bound, in place."""
    for i in range(state.shape[0]):
        if state[i] == -1 and not np.isfinite(lo[i]):
            state[i] = 0
        elif state[i] == 1 and not np.isfinite(hi[i]):
            state[i] = 0


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def row_violation(C, l, u, x, n, p, res):
    """max(``res``, the largest violation of l ≤ C x ≤ u over the first ``p`` rows (n columns used)); rows free on
    both sides are skipped."""
    for r in range(p):
        if l[r] == -np.inf and u[r] == np.inf:
            continue
        s = 0.0
        for j in range(n):
            s += C[r, j] * x[j]
        if l[r] - s > res:
            res = l[r] - s
        elif s - u[r] > res:
            res = s - u[r]
    return res


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True, inline="always")
def _row_value_and_scale(M, i, x):
    """(M_i x, Σ_j |M_ij x_j|) of row i of M (m, n) at x (n,)."""
    s = 0.0
    t = 0.0
    for j in range(x.shape[0]):
        s += M[i, j] * x[j]
        t += abs(M[i, j]) * abs(x[j])
    return s, t


@nb.njit("f8(f8[:], f8[:], f8[:, :], f8[:], f8[:, :], f8[:], f8[:], f8[:], f8[:])", cache=True, fastmath=FASTMATH,
         nogil=True)
def scaled_row_violation(x, xc, A, b, C, l, u, lb, ub):
    """The compiled body of :meth:`wbc.solvers.base.QPBackend.scaled_violation` (x (n,), its projection xc onto
    [lb, ub], the QP's rows): bound excess / max(1, |the crossed bound|), each row's residual or excess at xc /
    max(1, |its right-hand side or nearer bound| (1 when infinite), Σ_j |a_ij xc_j|). A NaN entry is skipped."""
    worst = 0.0
    n = x.shape[0]
    for j in range(n):
        d = abs(x[j] - xc[j])
        if d > 0.0:
            ref = abs(ub[j]) if x[j] > xc[j] else abs(lb[j])
            v = d / max(1.0, ref)
            if v > worst:
                worst = v
    for i in range(A.shape[0]):
        s, t = _row_value_and_scale(A, i, xc)
        v = abs(s - b[i]) / max(max(1.0, abs(b[i])), t)
        if v > worst:
            worst = v
    for i in range(C.shape[0]):
        s, t = _row_value_and_scale(C, i, xc)
        lo = l[i] - s
        hi = s - u[i]
        ex = max(lo, hi)
        if not ex > 0.0:
            continue
        ref = abs(l[i]) if lo > hi else abs(u[i])
        if not math.isfinite(ref):
            ref = 1.0
        v = ex / max(1.0, max(ref, t))
        if v > worst:
            worst = v
    return worst
