"""Compiled (numba) exact solver of a QP with equality rows, two-sided inequality rows and bounds:

    min_x ½ xᵀ H x + gᵀ x   s.t.   A x = b,   l ≤ C x ≤ u,   lb ≤ x ≤ ub

(H positive definite): :func:`solve_qp_ws`, the dual active-set method of Goldfarb & Idnani (Math. Program. 27,
1983) in range-space form, H factored once per call and the working set (equalities, rows and bounds alike) kept
through L⁻¹Nᵀ and the Cholesky factor of its Gram matrix, warm-started from the previous call's working set. Its
dual steps drop a working constraint when the one being added is linearly dependent on the working set — the case
of the self-collision rows (nearly parallel rows of the thighs, which the contacts fix; arm rows on joints held at
velocity bounds) that make the principal pivoting of :mod:`wbc.solvers.box_eq` stop. The loop ends only when every
KKT condition holds, so the returned x is the exact optimum; otherwise a negative exit code
(:mod:`wbc.solvers.status`).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from wbc.compiled import FASTMATH
from wbc.solvers.box_eq import clip_eq_residual, drop_infinite_active
from wbc.solvers.linalg import backward_substitution, cholesky_lower, forward_substitution, primal_from_multipliers
from wbc.solvers.status import DEPENDENT_EQUALITIES, INFEASIBLE, ITERATION_CAP, NOT_POSITIVE_DEFINITE

__all__ = ["solve_qp_ws"]


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def _normal_image(L, n, C, q, is_row, out):
    """out = L⁻¹ a: a = C[q] (a row) or the unit vector e_q (a bound; the substitution starts at q)."""
    if is_row:
        for j in range(n):
            out[j] = C[q, j]
        forward_substitution(L, n, out)
        return
    for j in range(q):
        out[j] = 0.0
    out[q] = 1.0 / L[q, q]
    for i in range(q + 1, n):
        s = 0.0
        for k in range(q, i):
            s -= L[i, k] * out[k]
        out[i] = s / L[i, i]


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def _ws_add(Yw, Sm, mw, y, n):
    """Append y (n,) as working row mw of Y = L⁻¹Nᵀ and its products to S = Y Yᵀ (unfactored)."""
    for j in range(n):
        Yw[mw, j] = y[j]
    for k in range(mw + 1):
        s = 0.0
        for j in range(n):
            s += Yw[k, j] * y[j]
        Sm[mw, k] = s
        Sm[k, mw] = s


@nb.njit(cache=True, nogil=True)
def _ws_remove(k, mw, n, Yw, Sm, kind, idx, side, bw, uw):
    """Remove working entry k (the last one takes its place); returns the new size."""
    e = mw - 1
    if k != e:
        for j in range(n):
            Yw[k, j] = Yw[e, j]
        for j in range(mw):
            Sm[k, j] = Sm[e, j]
        for j in range(mw):
            Sm[j, k] = Sm[j, e]
        Sm[k, k] = Sm[e, e]
        kind[k], idx[k], side[k], bw[k], uw[k] = kind[e], idx[e], side[e], bw[e], uw[e]
    return e


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def _ws_factor(Sm, Sf, mw, rank_tol):
    """Sf = Cholesky factor of S = Sm[:mw, :mw]; False when S is numerically singular (dependent rows)."""
    smax = 0.0
    for k in range(mw):
        for c in range(k + 1):
            Sf[k, c] = Sm[k, c]
        if Sm[k, k] > smax:
            smax = Sm[k, k]
    if not cholesky_lower(Sf, mw):
        return False
    for k in range(mw):
        if Sf[k, k] * Sf[k, k] <= rank_tol * smax:
            return False
    return True


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def _ws_eqp(L, t0, Yw, Sf, bw, mw, n, nuw, x):
    """Equality-constrained optimum on the working set (range-space method, Nocedal & Wright 2006 eq. 16.16 with
    H = L Lᵀ, Y = L⁻¹Nᵀ): S ν = −(b_W + Y L⁻¹g), x = −L⁻ᵀ (L⁻¹g + Yᵀν); ν in nuw[:mw] (Hx + g + Nᵀν = 0)."""
    for k in range(mw):
        s = bw[k]
        for j in range(n):
            s += Yw[k, j] * t0[j]
        nuw[k] = -s
    forward_substitution(Sf, mw, nuw)
    backward_substitution(Sf, mw, nuw)
    primal_from_multipliers(L, n, t0, Yw, nuw, mw, x)


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def solve_qp_ws(H, g, A, b, C, l, u, lb, ub, state, rstate, x, nu, mu, z, max_iter, primal_tol, dual_tol,
                rank_tol, eq_residual):
    """Exact solution of min ½xᵀHx + gᵀx s.t. Ax = b, l ≤ Cx ≤ u, lb ≤ x ≤ ub (H positive definite) by the dual
    active-set method of Goldfarb & Idnani ("A numerically stable dual method for solving strictly convex
    quadratic programs", Math. Program. 27, 1983, §3) in range-space form, warm-started from a working set.

    H = L Lᵀ is factored once per call. The working set W holds the equality rows, the rows of C and the bounds
    held at one side (normals N: rows of A, C or unit vectors); it is kept through Y = L⁻¹Nᵀ and the Cholesky
    factor of S = Y Yᵀ (a new member costs one substitution and a row of S, a leaving one a permutation, then
    S is refactored, |W|³/6). Start: the equality-constrained optimum on the warm start (a dependent one is
    emptied), whose inequality with the most negative multiplier leaves until none is negative (a dual-feasible
    point). Then, while an inequality is violated by more than ``primal_tol``, the most violated, p (inward
    normal n_p), is approached along z = L⁻ᵀ(w − Yᵀr), w = L⁻¹n_p, r = S⁻¹Yw (the direction keeping W's
    constraints at their bounds, n_p = Nᵀr + Hz), the working multipliers decreasing by t·r: the step t is the
    smaller of the full step (p joins W) and the first working multiplier to reach 0 (that one leaves; the step
    toward p goes on). When n_p is dependent on W (z = 0: e.g. self-collision rows of the thighs, which the
    contacts fix, nearly parallel) only the second kind exists; when no multiplier can decrease either, the
    constraints admit no solution (INFEASIBLE). Multipliers stay ≥ 0, so the method ends in finitely many steps
    in exact arithmetic. At the end x and the multipliers are recomputed on the final W and every KKT condition
    is checked (a failed check continues the method).

    Args:
        H, g, A, b, C, l, u, lb, ub: the QP, of shapes (n, n), (n,), (m, n), (m,), (p, n), (p,), (p,), (n,), (n,)
            (±inf for absent sides).
        state (n,) int8, rstate (p,) int8, in/out: working set (0 out, −1 held at the lower, +1 at the upper
            side); read as the warm start.
        x (n,), nu (m,), mu (p,), z (n,): out — solution and multipliers (H x + g + Aᵀnu + Cᵀmu + z = 0;
            mu, z ≤ 0 at a lower side, ≥ 0 at an upper one, 0 out of the working set).
        max_iter: steps allowed (drops and GI steps). primal_tol: violation that counts. dual_tol: negative
            multiplier that counts. rank_tol: relative pivot of S² below which W counts as dependent.
        eq_residual (1,): out — largest residual of the rows (equalities, inequalities) at the returned x.

    On success x lies inside [lb, ub] exactly (clipped: it is within rounding of them).

    Returns:
        steps (≥ 1) on success, or DEPENDENT_EQUALITIES / NOT_POSITIVE_DEFINITE / ITERATION_CAP / INFEASIBLE.
    """
    n = H.shape[0]
    m = A.shape[0]
    p = C.shape[0]
    drop_infinite_active(state, lb, ub)
    drop_infinite_active(rstate, l, u)
    K = n + m + 1  # a working set of independent constraints has at most n members
    fw = np.empty(n * n + K * n + 2 * K * K + 4 * n + 5 * K)  # one allocation, views below
    iw = np.empty(3 * K, np.int64)
    o = 0
    L = fw[o:o + n * n].reshape((n, n))
    o += n * n
    Yw = fw[o:o + K * n].reshape((K, n))
    o += K * n
    Sm = fw[o:o + K * K].reshape((K, K))
    o += K * K
    Sf = fw[o:o + K * K].reshape((K, K))
    o += K * K
    t0 = fw[o:o + n]
    y = fw[o + n:o + 2 * n]
    w = fw[o + 2 * n:o + 3 * n]
    zd = fw[o + 3 * n:o + 4 * n]
    o += 4 * n
    bw = fw[o:o + K]
    uw = fw[o + K:o + 2 * K]  # multipliers of the working inequalities on their inward normals (≥ 0)
    nuw = fw[o + 2 * K:o + 3 * K]
    r = fw[o + 3 * K:o + 4 * K]
    tmp = fw[o + 4 * K:o + 5 * K]
    kind = iw[:K]  # 0 equality, 1 row of C, 2 bound
    idx = iw[K:2 * K]
    side = iw[2 * K:]
    for i in range(n):
        for j in range(i + 1):
            L[i, j] = H[i, j]
    if not cholesky_lower(L, n):
        return NOT_POSITIVE_DEFINITE
    for i in range(n):
        t0[i] = g[i]
    forward_substitution(L, n, t0)
    # the warm start: equality rows, rows of C, bounds
    for attempt in range(2):
        mw = 0
        for k in range(m):
            for j in range(n):
                y[j] = A[k, j]
            forward_substitution(L, n, y)
            _ws_add(Yw, Sm, mw, y, n)
            kind[mw], idx[mw], side[mw], bw[mw] = 0, k, 0, b[k]
            mw += 1
        if attempt == 0:
            for q in range(p):
                if rstate[q] != 0:
                    _normal_image(L, n, C, q, True, y)
                    _ws_add(Yw, Sm, mw, y, n)
                    kind[mw], idx[mw], side[mw] = 1, q, rstate[q]
                    bw[mw] = l[q] if rstate[q] < 0 else u[q]
                    mw += 1
                    if mw == K:
                        break
            for i in range(n):
                if state[i] != 0 and mw < K:
                    _normal_image(L, n, C, i, False, y)
                    _ws_add(Yw, Sm, mw, y, n)
                    kind[mw], idx[mw], side[mw] = 2, i, state[i]
                    bw[mw] = lb[i] if state[i] < 0 else ub[i]
                    mw += 1
        if mw <= n and _ws_factor(Sm, Sf, mw, rank_tol):
            break
        if attempt == 1:
            return DEPENDENT_EQUALITIES
        state[:] = 0  # a dependent warm start: from the equality-constrained optimum instead
        rstate[:] = 0
    steps = 0
    need_eqp = True
    exact = False
    while True:
        if need_eqp:
            # x, multipliers on W; the inequality with the most negative multiplier leaves until none is
            _ws_eqp(L, t0, Yw, Sf, bw, mw, n, nuw, x)
            worst = dual_tol
            kw = -1
            for k in range(m, mw):
                uw[k] = side[k] * nuw[k]
                if -uw[k] > worst:
                    worst, kw = -uw[k], k
            if kw >= 0:
                steps += 1
                if steps > max_iter:
                    return ITERATION_CAP
                if kind[kw] == 1:
                    rstate[idx[kw]] = 0
                else:
                    state[idx[kw]] = 0
                mw = _ws_remove(kw, mw, n, Yw, Sm, kind, idx, side, bw, uw)
                if not _ws_factor(Sm, Sf, mw, rank_tol):
                    return DEPENDENT_EQUALITIES
                continue
            for k in range(m, mw):
                if uw[k] < 0.0:
                    uw[k] = 0.0
            need_eqp = False
            exact = True
        # the most violated inequality out of W
        worst = primal_tol
        pi = -1
        pside = 0
        is_row = False
        for i in range(n):
            if state[i] == 0:
                if lb[i] - x[i] > worst:
                    worst, pi, pside, is_row = lb[i] - x[i], i, -1, False
                elif x[i] - ub[i] > worst:
                    worst, pi, pside, is_row = x[i] - ub[i], i, 1, False
        for q in range(p):
            if rstate[q] != 0 or (l[q] == -np.inf and u[q] == np.inf):
                continue
            s = 0.0
            for j in range(n):
                s += C[q, j] * x[j]
            if l[q] - s > worst:
                worst, pi, pside, is_row = l[q] - s, q, -1, True
            elif s - u[q] > worst:
                worst, pi, pside, is_row = s - u[q], q, 1, True
        if pi < 0:
            if exact:
                break  # x and the multipliers are those of the equality-constrained optimum on W: KKT holds
            need_eqp = True  # after steps: recomputed on the final W and checked again
            continue
        # approach p: n_p = sp · a_p, the constraint n_p·x ≥ bp
        sp = -float(pside)
        bp = sp * ((l[pi] if pside < 0 else u[pi]) if is_row else (lb[pi] if pside < 0 else ub[pi]))
        _normal_image(L, n, C, pi, is_row, y)
        ww = 0.0
        for j in range(n):
            w[j] = sp * y[j]
            ww += w[j] * w[j]
        tp = 0.0
        exact = False
        while True:
            steps += 1
            if steps > max_iter:
                return ITERATION_CAP
            # r = S⁻¹ Y w ; z = L⁻ᵀ (w − Yᵀ r) ; n_p·z = wᵀw − (Yw)ᵀr
            for k in range(mw):
                s = 0.0
                for j in range(n):
                    s += Yw[k, j] * w[j]
                tmp[k] = s
                r[k] = s
            forward_substitution(Sf, mw, r)
            backward_substitution(Sf, mw, r)
            nz = ww
            for k in range(mw):
                nz -= tmp[k] * r[k]
            for j in range(n):
                zd[j] = w[j]
            for k in range(mw):
                rk = r[k]
                for j in range(n):
                    zd[j] -= Yw[k, j] * rk
            backward_substitution(L, n, zd)
            # the first working multiplier to reach 0 (r on the inward normals: −side·r)
            rmax = 0.0
            for k in range(m, mw):
                if abs(r[k]) > rmax:
                    rmax = abs(r[k])
            t1 = np.inf
            kb = -1
            for k in range(m, mw):
                rk = -side[k] * r[k]
                if rk > 1e-9 * rmax and uw[k] / rk < t1:
                    t1, kb = uw[k] / rk, k
            full = False
            if nz > 1e-10 * ww:
                s = 0.0
                if is_row:
                    for j in range(n):
                        s += C[pi, j] * x[j]
                else:
                    s = x[pi]
                t2 = (bp - sp * s) / nz
                if t2 <= t1:
                    full = True
                    step = max(t2, 0.0)
                else:
                    step = t1
            elif kb < 0:
                return INFEASIBLE
            else:
                step = t1
            for j in range(n):
                x[j] += step * zd[j]
            for k in range(m, mw):
                uw[k] -= step * (-side[k] * r[k])
                if uw[k] < 0.0:
                    uw[k] = 0.0
            tp += step
            if full:
                if mw == K:
                    return DEPENDENT_EQUALITIES
                _ws_add(Yw, Sm, mw, y, n)
                kind[mw], idx[mw], side[mw], uw[mw] = (1 if is_row else 2), pi, pside, tp
                bw[mw] = (l[pi] if pside < 0 else u[pi]) if is_row else (lb[pi] if pside < 0 else ub[pi])
                mw += 1
                if is_row:
                    rstate[pi] = pside
                else:
                    state[pi] = pside
                    x[pi] = bw[mw - 1]
                if not _ws_factor(Sm, Sf, mw, rank_tol):
                    return DEPENDENT_EQUALITIES
                break
            if kind[kb] == 1:
                rstate[idx[kb]] = 0
            else:
                state[idx[kb]] = 0
            mw = _ws_remove(kb, mw, n, Yw, Sm, kind, idx, side, bw, uw)
            if not _ws_factor(Sm, Sf, mw, rank_tol):
                return DEPENDENT_EQUALITIES
    # outputs: multipliers by constraint, x clipped into the bounds, residual of the rows
    for k in range(m):
        nu[k] = nuw[k]
    for q in range(p):
        mu[q] = 0.0
    for i in range(n):
        z[i] = 0.0
    for k in range(m, mw):
        if kind[k] == 1:
            mu[idx[k]] = nuw[k]
        else:
            z[idx[k]] = nuw[k]
            x[idx[k]] = bw[k]
    res = clip_eq_residual(x, lb, ub, A, b, n, m)
    for q in range(p):
        if l[q] == -np.inf and u[q] == np.inf:
            continue
        s = 0.0
        for j in range(n):
            s += C[q, j] * x[j]
        if l[q] - s > res:
            res = l[q] - s
        elif s - u[q] > res:
            res = s - u[q]
    eq_residual[0] = res
    return max(steps, 1)
