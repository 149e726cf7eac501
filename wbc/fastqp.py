"""Compiled (numba) exact solver for the common QP of the kinematic tick, with DAQP as fallback.

Solves

    min_x ½ xᵀ H x + gᵀ x   s.t.   A x = b,   l ≤ C x ≤ u,   lb ≤ x ≤ ub

(H symmetric positive definite, A full row rank) by active-set methods warm-started from the previous call's
working set (the constraints held at a bound).

Without rows of C (:func:`solve_box_eq_ws`), for a fixed working set W (variables held at a bound) the free part F
solves the equality-constrained QP through its KKT system, eliminated with a Cholesky factor L Lᵀ = H_FF and the
Schur complement S = A_F H_FF⁻¹ A_Fᵀ (Nocedal & Wright, *Numerical Optimization*, 2nd ed., §16.2, eq. 16.16
"range-space method"). The working set is then corrected: the free variable furthest outside its bounds is fixed at
the violated bound; otherwise the fixed variable whose bound multiplier has the wrong sign (most negative) is freed
(single-pivot principal pivoting, Júdice & Pires, Comput. Oper. Res. 21(5), 1994).

With rows of C (:func:`solve_qp_ws`): the dual active-set method of Goldfarb & Idnani (Math. Program. 27, 1983)
in range-space form, H factored once per call and the working set (equalities, rows and bounds alike) kept through
L⁻¹Nᵀ and the Cholesky factor of its Gram matrix. Its dual steps drop a working constraint when the one being
added is linearly dependent on the working set — the case of the self-collision rows (nearly parallel rows of
the thighs, which the contacts fix; arm rows on joints held at velocity bounds) that made the principal pivoting
above stop: on the Talos hand-through-torso drive it answered 167 of 605 QPs, this method all 605.

Either loop ends only when every KKT condition holds (stationarity by construction, primal feasibility, dual sign,
complementarity since constraints out of the working set carry no multiplier), so the returned x is the exact
optimum; when it does not end within the iteration cap, when H is not positive definite or when the equalities are
dependent, the call is handed to :class:`wbc.qp.DaqpBackend`.

:func:`form_qp` forms the kinematic controller's cost (H, g) from its stacked task rows (posture diagonal, damping):
the one cost formation of every kinematic route. :func:`kinematic_solve` is the compiled solver of the assembled
kinematic QP (H, g, A, b, C, l, u, lb, ub): the floating base eliminated through a contact's 6 equality rows (H, g
and the other rows reduced by the substitution), the methods above on the reduced problem, the residuals of the
original rows checked; :func:`kinematic_pack` packs the QP's buffers and its workspace into two arrays for
:func:`kinematic_solve_packed`. When its solver gives up, the reduced problem (:func:`kinematic_reduced_packed`) can
be solved by another solver and the solve completed from that answer (:func:`kinematic_finish_packed`).

The kernels are compiled on first use and cached on disk (``cache=True``); :func:`warm_up` compiles (or loads)
them eagerly and returns the seconds it took.
"""

from __future__ import annotations

import time

import numba as nb
import numpy as np

from wbc.compiled import FASTMATH, once_per_process
from wbc.qp import DaqpBackend
from wbc.solver_status import SolverStatus

__all__ = ["FastBackend", "backward_substitution", "cholesky_lower", "clip_box_into", "contact_drift",
           "ensure_compiled", "form_qp", "forward_substitution", "kinematic_finish_packed", "kinematic_pack",
           "kinematic_reduced_packed", "kinematic_solve", "kinematic_solve_packed", "kinematic_workspace",
           "primal_from_multipliers", "solve_box_eq", "solve_box_eq_ws", "solve_qp_ws", "translation_gap", "warm_up",
           "weighted_normal_equations", "weighted_rows"]

#: exit codes (the shared :class:`~wbc.solver_status.SolverStatus` values as plain ints, frozen by numba at compile
#: time) of :func:`solve_box_eq` (≥ 0: number of working-set iterations)
NOT_POSITIVE_DEFINITE = int(SolverStatus.NOT_POSITIVE_DEFINITE)
DEPENDENT_EQUALITIES = int(SolverStatus.DEPENDENT_ROWS)
ITERATION_CAP = int(SolverStatus.ITERATION_CAP)
#: exit codes of :func:`kinematic_solve`: the floating base cannot be eliminated (a bound on a base velocity, a
#: singular eliminating block); the solution's equality or inequality residual is above the tolerance
NOT_REDUCIBLE = int(SolverStatus.NOT_REDUCIBLE)
RESIDUAL = int(SolverStatus.RESIDUAL)
#: exit code of the dual active set (:func:`solve_qp_ws`): a violated constraint that no working inequality can
#: make room for (the constraints admit no solution; the caller's general solver confirms)
INFEASIBLE = int(SolverStatus.INFEASIBLE)



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
    """v ← L⁻¹ v in place, L lower triangular (leading k × k block), forward substitution (compiled)."""
    for i in range(k):
        t = v[i]
        for p in range(i):
            t -= L[i, p] * v[p]
        v[i] = t / L[i, i]


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def backward_substitution(L, k, v):
    """v ← L⁻ᵀ v in place, L lower triangular (leading k × k block), backward substitution (compiled), by rows of L
    (x_i = v_i / L_ii, then v[:i] −= x_i L[i, :i]: contiguous, where the column form reads L with a stride)."""
    for i in range(k - 1, -1, -1):
        xi = v[i] / L[i, i]
        v[i] = xi
        Li = L[i]
        for p in range(i):
            v[p] -= xi * Li[p]


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def primal_from_multipliers(L, n, t, Y, nu, m, x):
    """x[:n] ← −L⁻ᵀ (t[:n] + Σ_k<m nu_k Y[k, :n]): the primal step of a Cholesky/Schur KKT solve (H = L Lᵀ, t = L⁻¹ g,
    Y = L⁻¹ Aᵀ row by row, nu the equality multipliers), compiled; x may be t itself."""
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
    """H = ε I + Jᵀ diag(w) J and g = −Jᵀ diag(w) r: the weighted least-squares cost Σ_k w_k (J_k v − r_k)² + ε‖v‖²
    of stacked task rows (the constant term dropped), written into H and g.

    Args:
        J (m, n): stacked task Jacobians; w (m,): row weights (≥ 0); r (m,): row velocity targets v*;
        damping: ε; H (n, n), g (n,): out.
    """
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


@nb.njit(cache=True, nogil=True)
def clip_box_into(lb, ub, start, lo, hi):
    """Intersect the box [lo, hi] with the running box lb[start:start+k], ub[start:start+k] (k = lo.size), the
    new box clipped into the running one so that it yields where it would empty it:
    lb ← min(max(lo, lb), ub), ub ← max(min(hi, ub), lb) (both computed from the running values)."""
    for i in range(lo.shape[0]):
        cl = lb[start + i]
        cu = ub[start + i]
        lb[start + i] = min(max(lo[i], cl), cu)
        ub[start + i] = max(min(hi[i], cu), cl)


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def solve_box_eq(H, g, A, b, lb, ub, state, x, nu, z, max_iter, primal_tol, dual_tol, rank_tol):
    """Allocating form of :func:`solve_box_eq_ws` (same arguments, no workspace)."""
    n, m = H.shape[0], A.shape[0]
    return solve_box_eq_ws(H, g, A, b, lb, ub, state, x, nu, z, max_iter, primal_tol, dual_tol, rank_tol,
                           np.empty(n, np.int64), np.empty((n, n)), np.empty((m, n)), np.empty((m, m)),
                           np.empty(n), np.empty(m), np.empty(1))


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def _working_set_step(H, g, A, b, m, lb, ub, state, x, nu, rank_tol, free, L, Y, S, t, rhs):
    """One equality-constrained solve for a fixed working set: the variables held at a bound (``state`` ≠ 0) are
    set onto it in x, and the free ones minimise ½xᵀHx + gᵀx subject to the first m rows of ``A x = b``, through
    the Cholesky factor L of H_FF and the Schur complement S = A_F H_FF⁻¹ A_Fᵀ (range-space method; Nocedal &
    Wright 2006, §16.2). On return t[:nf] holds x_F (in the order of ``free[:nf]``) and nu[:m] the multipliers.

    Returns:
        nf, the number of free variables (≥ 0), or NOT_POSITIVE_DEFINITE / DEPENDENT_EQUALITIES.
    """
    n = H.shape[0]
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
    return nf


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
def _drop_infinite_active(state, lo, hi):
    """A warm-start state (−1 at the lower, +1 at the upper bound, 0 free) is only valid where that bound is
    finite: free the others, in place."""
    for i in range(state.shape[0]):
        if state[i] == -1 and not np.isfinite(lo[i]):
            state[i] = 0
        elif state[i] == 1 and not np.isfinite(hi[i]):
            state[i] = 0


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def _clip_eq_residual(x, lb, ub, A, b, n, m):
    """Clip x into [lb, ub] in place (the kernel's KKT point is within rounding of its bounds) and return the
    largest equality residual max_k |A_k x − b_k|."""
    for i in range(n):
        if x[i] < lb[i]:
            x[i] = lb[i]
        elif x[i] > ub[i]:
            x[i] = ub[i]
    r = 0.0
    for k in range(m):
        s = -b[k]
        for j in range(n):
            s += A[k, j] * x[j]
        if abs(s) > r:
            r = abs(s)
    return r


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
def solve_box_eq_ws(H, g, A, b, lb, ub, state, x, nu, z, max_iter, primal_tol, dual_tol, rank_tol,
                    free, L, Y, S, t, rhs, eq_residual):
    """Exact solution of min ½xᵀHx + gᵀx s.t. Ax = b, lb ≤ x ≤ ub (module docstring).

    Args:
        H, g, A, b, lb, ub: the QP, of shapes (n, n), (n,), (m, n), (m,), (n,), (n,) (±inf for free entries).
        state (n,) int8, in/out: working set (0 free, -1 held at lb, +1 held at ub); read as the warm start.
        x (n,), nu (m,), z (n,): out — solution, equality multipliers, bound multipliers
            (stationarity H x + g + Aᵀ nu + z = 0; z ≤ 0 at a lower bound, z ≥ 0 at an upper bound, 0 when free).
        max_iter: working-set iterations allowed.
        primal_tol: bound violation (absolute) that makes a free variable be fixed.
        dual_tol: wrong-sign multiplier magnitude that makes a fixed variable be freed.
        rank_tol: relative pivot of the Schur complement below which the equalities count as dependent.
        free (n,) int64, L (n, n), Y (m, n), S (m, m), t (n,), rhs (m,): workspace.
        eq_residual (1,): out — max |A x − b| of the returned x.

    On success x lies inside [lb, ub] exactly (free entries within ``primal_tol`` of a bound are clipped onto it).

    Returns:
        iterations (≥ 1) on success, or a negative exit code.
    """
    n = H.shape[0]
    m = A.shape[0]
    _drop_infinite_active(state, lb, ub)
    for it in range(1, max_iter + 1):
        nf = _working_set_step(H, g, A, b, m, lb, ub, state, x, nu, rank_tol, free, L, Y, S, t, rhs)
        if nf < 0:
            return nf
        worst, worst_i, worst_side = _place_free(free, t, nf, x, lb, ub, primal_tol)
        if worst_i >= 0:
            state[worst_i] = worst_side
            continue
        # bound multipliers z = -(H x + g + Aᵀ nu) on the fixed set; the worst wrong sign is freed
        worst, worst_i = _bound_multipliers(H, g, A, m, nu, state, x, z, dual_tol)
        if worst_i < 0:
            eq_residual[0] = _clip_eq_residual(x, lb, ub, A, b, n, m)
            return it
        state[worst_i] = 0
    return ITERATION_CAP




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
    _drop_infinite_active(state, lb, ub)
    _drop_infinite_active(rstate, l, u)
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
    res = _clip_eq_residual(x, lb, ub, A, b, n, m)
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


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def _eliminate_base(A, b, er, nr, Eb, Tc):
    """Tc[:, :nr] = T = E_b⁻¹ E_j and Tc[:, nr] = c = E_b⁻¹ b_E for the 6 equality rows E = A[er:er + 6] (E_b their
    first 6 columns, the floating base; E_j the others): Gaussian elimination with partial pivoting. Returns False
    when E_b is singular (a pivot ≤ 1e-12 × its largest entry)."""
    scale = 0.0
    for i in range(6):
        for j in range(6):
            Eb[i, j] = A[er + i, j]
            if abs(Eb[i, j]) > scale:
                scale = abs(Eb[i, j])
        for j in range(nr):
            Tc[i, j] = A[er + i, 6 + j]
        Tc[i, nr] = b[er + i]
    for k in range(6):
        piv = k
        for i in range(k + 1, 6):
            if abs(Eb[i, k]) > abs(Eb[piv, k]):
                piv = i
        if not abs(Eb[piv, k]) > 1e-12 * scale:
            return False
        if piv != k:
            for j in range(6):
                Eb[k, j], Eb[piv, j] = Eb[piv, j], Eb[k, j]
            for j in range(nr + 1):
                Tc[k, j], Tc[piv, j] = Tc[piv, j], Tc[k, j]
        for i in range(k + 1, 6):
            f = Eb[i, k] / Eb[k, k]
            if f == 0.0:
                continue
            for j in range(k, 6):
                Eb[i, j] -= f * Eb[k, j]
            for j in range(nr + 1):
                Tc[i, j] -= f * Tc[k, j]
    for k in range(5, -1, -1):
        for i in range(k + 1, 6):
            f = Eb[k, i]
            if f != 0.0:
                for j in range(nr + 1):
                    Tc[k, j] -= f * Tc[i, j]
        d = Eb[k, k]
        for j in range(nr + 1):
            Tc[k, j] /= d
    return True


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def _reduce_row(src, n0, nr, Tc, out):
    """out[:nr] = src[n0:] − src[:n0] T (a row of the problem in the joint velocities after v_b = c − T v_j) and
    returns src[:n0] · c, the part of the row the base's constant c accounts for (n0 = 0: a copy, 0)."""
    for j in range(nr):
        out[j] = src[n0 + j]
    shift = 0.0
    for i in range(n0):
        a = src[i]
        if a != 0.0:
            shift += a * Tc[i, nr]
            for j in range(nr):
                out[j] -= a * Tc[i, j]
    return shift


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def _weighted_row(Js, es, rowp, k, row):
    """row ← √w_k J_k and returns √w_k v*_k, v*_k = ff_k − K_k e_k (rowp = (K, w, ff)): one stacked task row with
    its weight applied, the one formula of :func:`form_qp` and :func:`weighted_rows`."""
    sw = np.sqrt(rowp[1, k])
    Jk = Js[k]
    for j in range(row.shape[0]):
        row[j] = sw * Jk[j]
    return sw * (rowp[2, k] - rowp[0, k] * es[k])


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def weighted_rows(Js, es, rowp, out_J, out_r):
    """The stacked task rows with their weights applied, as a strict priority level of the kinematic QP takes them
    (:func:`wbc.hierarchy.solve_lexicographic`): out_J[k] = √w_k J_k, out_r[k] = √w_k v*_k with v*_k = ff_k − K_k e_k
    (compiled; the formula of :func:`form_qp`, whose cost is Σ_k ‖out_J[k] v − out_r[k]‖²).

    Args:
        Js (mt, nv), es (mt,), rowp (3, mt): as :func:`form_qp`. out_J (mt, nv), out_r (mt,): out.
    """
    for k in range(Js.shape[0]):
        out_r[k] = _weighted_row(Js, es, rowp, k, out_J[k])


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def form_qp(Js, es, rowp, diff, pw, prow, pgain, damping, H, g):
    """The cost of the kinematic QP (:mod:`wbc.formulations.velocity`) from its stacked task rows, written into H
    and g (compiled; the one cost formation of every kinematic route):

        H = ε I + Σ_k w_k J_kᵀ J_k + Σ_a d_a e_{i_a} e_{i_a}ᵀ,    g = −Σ_k w_k v*_k J_kᵀ − Σ_a d_a s_a e_{i_a}

    i.e. ½ vᵀHv + gᵀv = ½ Σ_k w_k (J_k v − v*_k)² + ½ Σ_a d_a (v_{i_a} − s_a)² + ½ ε ‖v‖² up to a constant, with
    v*_k = ff_k − K_k e_k and s_a = −K_p diff[i_a] (a posture task: a selection Jacobian, so its cost is diagonal).
    Each row enters as (√w_k J_k)ᵀ(√w_k J_k), whole rows of H at a time: H is exactly symmetric without a mirror.

    Args:
        Js (mt, nv), es (mt,): stacked task Jacobians and errors; rowp (3, mt): gain K (1/s), weight w ≥ 0 and
            feed-forward ė* of each row (a row with w = 0 is skipped).
        diff (nv,): q ⊖ q* of the posture task; pw (kp,): its weights d; prow (kp,) int64: its velocity indices
            i_a (kp = 0: no posture); pgain: its gain K_p (1/s).
        damping: ε > 0. H (nv, nv), g (nv,): out.

    Returns:
        trace(H) + Σ g: finite exactly when every number that entered H and g is (NaN and ±inf propagate into it).
    """
    n = H.shape[0]
    H[:, :] = 0.0
    g[:] = 0.0
    row = np.empty(n)
    for k in range(Js.shape[0]):
        if rowp[1, k] == 0.0:
            continue
        swr = _weighted_row(Js, es, rowp, k, row)
        for i in range(n):
            a = row[i]
            if a == 0.0:
                continue
            g[i] -= a * swr
            Hi = H[i]
            for j in range(n):
                Hi[j] += a * row[j]
    for a in range(prow.shape[0]):
        i = prow[a]
        H[i, i] += pw[a]
        g[i] -= pw[a] * (-pgain * diff[i])
    check = 0.0
    for i in range(n):
        H[i, i] += damping
        check += H[i, i] + g[i]
    return check


def kinematic_workspace(nv: int, n_eq: int, n_in: int, eliminate: bool) -> tuple[np.ndarray, np.ndarray]:
    """Float and integer workspaces of :func:`kinematic_solve` for nv velocities, ``n_eq`` equality and ``n_in``
    inequality rows, with or without the floating-base elimination. The float one starts with v·dt (nv,)."""
    nr = nv - 6 if eliminate else nv
    mr = n_eq - 6 if eliminate else n_eq
    size = (nv + 2 * nr * nr + 7 * nr + 6 * (nr + 1) + 36 + 6 * nr + 6 + n_in * nr + 3 * n_in + mr * nr + 2 * mr
            + mr * nr + mr * mr + mr + 1)
    return np.zeros(size), np.zeros(nr, np.int64)


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def _solve_views(ws, n, nr, mr, p):
    """Views of :func:`kinematic_solve`'s float workspace ``ws`` (layout of :func:`kinematic_workspace`) for n
    velocities, nr = n − 6 (elimination) or n reduced ones, mr reduced equality and p inequality rows."""
    o = n
    H = ws[o:o + nr * nr].reshape((nr, nr))
    o += nr * nr
    L = ws[o:o + nr * nr].reshape((nr, nr))
    o += nr * nr
    g = ws[o:o + nr]
    o += nr
    lbr = ws[o:o + nr]
    o += nr
    ubr = ws[o:o + nr]
    o += nr
    row = ws[o:o + nr]
    o += nr
    x = ws[o:o + nr]
    o += nr
    z = ws[o:o + nr]
    o += nr
    t = ws[o:o + nr]
    o += nr
    Tc = ws[o:o + 6 * (nr + 1)].reshape((6, nr + 1))
    o += 6 * (nr + 1)
    Eb = ws[o:o + 36].reshape((6, 6))
    o += 36
    V = ws[o:o + 6 * nr].reshape((6, nr))
    o += 6 * nr
    wb = ws[o:o + 6]
    o += 6
    Cr = ws[o:o + p * nr].reshape((p, nr))
    o += p * nr
    lr = ws[o:o + p]
    o += p
    ur = ws[o:o + p]
    o += p
    mu = ws[o:o + p]
    o += p
    Ar = ws[o:o + mr * nr].reshape((mr, nr))
    o += mr * nr
    br = ws[o:o + mr]
    o += mr
    nu = ws[o:o + mr]
    o += mr
    Y = ws[o:o + mr * nr].reshape((mr, nr))  # Y, S, rhs: solve_box_eq_ws (no rows of C)
    o += mr * nr
    S = ws[o:o + mr * mr].reshape((mr, mr))
    o += mr * mr
    rhs = ws[o:o + mr]
    o += mr
    eqres = ws[o:o + 1]
    return (H, L, g, lbr, ubr, row, x, z, t, Tc, Eb, V, wb, Cr, lr, ur, mu, Ar, br, nu, Y, S, rhs, eqres)


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def _reduce_cost(H, g, n0, nr, Tc, V, wb, Hr, gr):
    """Hr = Zᵀ H Z and gr = Zᵀ (g + H v₀) for v = Z v_j + v₀, Z = [−T; I], v₀ = [c; 0] (the base's v_b = c − T v_j):
    Hr = H_jj − H_jb T − Tᵀ V with V = H_bj − H_bb T, gr = (g_j + H_jb c) − Tᵀ (g_b + H_bb c); the lower triangle
    formed, mirrored (Hr exactly symmetric). n0 = 0: a copy."""
    if n0 == 0:
        for a in range(nr):
            gr[a] = g[a]
            for c in range(nr):
                Hr[a, c] = H[a, c]
        return
    for b in range(n0):
        Vb = V[b]
        Hb = H[b]
        s = g[b]
        for c in range(nr):
            Vb[c] = Hb[n0 + c]
        for b2 in range(n0):
            h = Hb[b2]
            s += h * Tc[b2, nr]
            if h != 0.0:
                T2 = Tc[b2]
                for c in range(nr):
                    Vb[c] -= h * T2[c]
        wb[b] = s
    for a in range(nr):
        Ha = H[n0 + a]
        Hra = Hr[a]
        s = g[n0 + a]
        for c in range(a + 1):
            Hra[c] = Ha[n0 + c]
        for b in range(n0):
            h = Ha[b]
            tb = Tc[b, a]
            s += h * Tc[b, nr] - tb * wb[b]
            Tb = Tc[b]
            Vb = V[b]
            for c in range(a + 1):
                Hra[c] -= h * Tb[c] + tb * Vb[c]
        gr[a] = s
    for a in range(nr):
        for c in range(a + 1, nr):
            Hr[a, c] = Hr[c, a]


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def kinematic_solve(H, g, A, b, C, l, u, lb, ub, er, dt, tolerance, max_iter, state, rstate, ws, iws, v):
    """The exact optimum of the assembled kinematic QP (:meth:`wbc.formulations.velocity.KinematicController.assemble`)

        min_v ½ vᵀHv + gᵀv   s.t.  A v = b,  l ≤ C v ≤ u,  lb ≤ v ≤ ub,

    with the floating base eliminated (compiled; the arguments are read, never written).

    Floating-base elimination (``er`` ≥ 0): the 6 equality rows E = A[er:er + 6] (a contact's LOCAL Jacobian, whose
    base block E_b is invertible) give v_b = c − T v_j (T = E_b⁻¹E_j, c = E_b⁻¹b_E), so the problem is solved exactly
    in the nv − 6 joint velocities with the remaining equality rows (a null-space / variable-elimination method;
    Nocedal & Wright, *Numerical Optimization*, 2nd ed., §15.3, eq. 15.14 with the basis columns the base's): H and
    g reduced by the substitution (:func:`_reduce_cost`), the other rows of A and C likewise. The base must be
    unbounded (else ``NOT_REDUCIBLE``). The reduced QP is solved by :func:`solve_box_eq_ws` (no inequality rows) or
    :func:`solve_qp_ws`, warm-started from ``state``/``rstate``; every KKT condition of the reduced problem holds at
    exit, and the residuals of all rows of the original one are checked against ``tolerance``.

    Args:
        H (nv, nv) symmetric positive definite, g (nv,), A (neq, nv), b (neq,), C (p, nv), l/u (p,), lb/ub (nv,):
            the assembled QP (a row of C with l = −inf and u = inf is unused).
        er: first row of the eliminating block, or −1 (no elimination). dt (s): the workspace receives v·dt.
        tolerance: largest residual accepted. max_iter: working-set iterations.
        state (nr,) int8, rstate (p,) int8: working sets (warm start, in/out). ws, iws: workspaces from
            :func:`kinematic_workspace`; on success ws[:nv] = v·dt. v (nv,): out.

    Returns:
        working-set iterations (≥ 1), or a negative exit code (the caller solves the tick by the general path).
    """
    n = H.shape[0]
    n0 = 6 if er >= 0 else 0
    nr = n - n0
    neq = A.shape[0]
    mr = neq - n0
    p = C.shape[0]
    (Hr, L, gr, lbr, ubr, row, x, z, t, Tc, Eb, V, wb, Cr, lr, ur, mu, Ar, br, nu, Y, S, rhs,
     eqres) = _solve_views(ws, n, nr, mr, p)
    for i in range(n0):
        if lb[i] > -np.inf or ub[i] < np.inf:
            return NOT_REDUCIBLE
    for j in range(nr):
        lbr[j] = lb[n0 + j]
        ubr[j] = ub[n0 + j]
    if n0 and not _eliminate_base(A, b, er, nr, Eb, Tc):
        return NOT_REDUCIBLE
    _reduce_cost(H, g, n0, nr, Tc, V, wb, Hr, gr)
    kk = 0
    for r in range(neq):
        if n0 and er <= r < er + 6:
            continue
        br[kk] = b[r] - _reduce_row(A[r], n0, nr, Tc, Ar[kk])
        kk += 1
    for r in range(p):
        if l[r] == -np.inf and u[r] == np.inf:  # an unused row (e.g. self-collision's beyond its close pairs)
            lr[r] = -np.inf
            ur[r] = np.inf
            continue
        shift = _reduce_row(C[r], n0, nr, Tc, Cr[r])
        lr[r] = l[r] - shift
        ur[r] = u[r] - shift
    if p == 0:
        it = solve_box_eq_ws(Hr, gr, Ar, br, lbr, ubr, state, x, nu, z, max_iter, 1e-12, 1e-12, 1e-24, iws, L, Y,
                             S, t, rhs, eqres)
    else:
        it = solve_qp_ws(Hr, gr, Ar, br, Cr, lr, ur, lbr, ubr, state, rstate, x, nu, mu, z, max_iter, 1e-12, 1e-12,
                         1e-24, eqres)
    if it < 1:
        state[:] = 0
        rstate[:] = 0
        return it
    if not _finish(A, b, C, l, u, Tc, x, n0, dt, tolerance, ws, v):
        state[:] = 0
        rstate[:] = 0
        return RESIDUAL
    return it


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def _finish(A, b, C, cl, cu, Tc, x, n0, dt, tolerance, ws, v):
    """v from the reduced solution x (joint velocities; the base's v_b = c − T v_j when n0 = 6), then the residuals
    of the original rows A v = b, cl ≤ C v ≤ cu: False when one exceeds ``tolerance``, else ws[:nv] = v·dt."""
    n = v.shape[0]
    nr = n - n0
    neq = A.shape[0]
    p = C.shape[0]
    for j in range(nr):
        v[n0 + j] = x[j]
    for i in range(n0):
        s = Tc[i, nr]
        for j in range(nr):
            s -= Tc[i, j] * x[j]
        v[i] = s
    # residuals of the original rows
    res = 0.0
    for r in range(neq):
        s = -b[r]
        for j in range(n):
            s += A[r, j] * v[j]
        if abs(s) > res:
            res = abs(s)
    for r in range(p):
        if cl[r] == -np.inf and cu[r] == np.inf:
            continue
        s = 0.0
        for j in range(n):
            s += C[r, j] * v[j]
        if cl[r] - s > res:
            res = cl[r] - s
        elif s - cu[r] > res:
            res = s - cu[r]
    if not res <= tolerance:
        return False
    for i in range(n):
        ws[i] = v[i] * dt
    return True


#: fields of the header of :func:`kinematic_solve_packed`'s integer array (offsets into its float array ``fb``)
_PACK_FIELDS = ("nv", "neq", "p", "er", "H", "g", "A", "b", "C", "l", "u", "lb", "ub", "ws", "iws")


def kinematic_pack(nv: int, n_eq: int, n_in: int, er: int) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    """The two arrays :func:`kinematic_solve_packed` reads (one float, one int64) for a kinematic QP of nv
    velocities, ``n_eq`` equality and ``n_in`` inequality rows, eliminating the floating base through the equality
    rows from ``er`` (−1: none), and named views of their parts: the QP's buffers ``H`` (nv, nv), ``g`` (nv,), ``A``
    (n_eq, nv), ``b``, ``C`` (n_in, nv), ``l``, ``u``, ``lb``, ``ub`` (nv,) — the arrays the controller assembles
    into, so that the compiled solver reads them where they were written — and ``vdt`` (nv,): v·dt after a solve."""
    ws, iws = kinematic_workspace(nv, n_eq, n_in, er >= 0)
    shapes = {"H": (nv, nv), "g": (nv,), "A": (n_eq, nv), "b": (n_eq,), "C": (n_in, nv), "l": (n_in,),
              "u": (n_in,), "lb": (nv,), "ub": (nv,), "ws": (ws.size,)}
    head = len(_PACK_FIELDS)
    offsets, o = {}, 0
    for name, shape in shapes.items():
        offsets[name] = o
        o += int(np.prod(shape))
    fb = np.zeros(o)
    ib = np.zeros(head + iws.size, np.int64)
    ib[:4] = (nv, n_eq, n_in, er)
    for i, name in enumerate(_PACK_FIELDS[4:-1], start=4):
        ib[i] = offsets[name]
    ib[head - 1] = head
    views = {name: fb[offsets[name]:offsets[name] + int(np.prod(shape))].reshape(shape)
             for name, shape in shapes.items()}
    views["vdt"] = views["ws"][:nv]
    return fb, ib, views


@nb.njit(cache=True, nogil=True)
def _unpack(fb, ib):
    """Views of the arrays :func:`kinematic_pack` packed into ``fb``/``ib``: (H, g, A, b, C, l, u, lb, ub, ws, iws,
    er)."""
    nv, neq, p, er = ib[0], ib[1], ib[2], ib[3]
    o = ib[4:]
    H = fb[o[0]:o[0] + nv * nv].reshape((nv, nv))
    g = fb[o[1]:o[1] + nv]
    A = fb[o[2]:o[2] + neq * nv].reshape((neq, nv))
    b = fb[o[3]:o[3] + neq]
    C = fb[o[4]:o[4] + p * nv].reshape((p, nv))
    l = fb[o[5]:o[5] + p]
    u = fb[o[6]:o[6] + p]
    lb = fb[o[7]:o[7] + nv]
    ub = fb[o[8]:o[8] + nv]
    ws = fb[o[9]:]
    iws = ib[o[10]:]
    return H, g, A, b, C, l, u, lb, ub, ws, iws, er


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def kinematic_solve_packed(fb, ib, state, rstate, v, dt, tolerance, max_iter):
    """:func:`kinematic_solve` on the QP packed into ``fb`` (float) and ``ib`` (int64) by :func:`kinematic_pack`:
    8 arguments instead of 18 (each array argument costs the call ≈ 50 ns to type and unbox). Same returns."""
    H, g, A, b, C, l, u, lb, ub, ws, iws, er = _unpack(fb, ib)
    return kinematic_solve(H, g, A, b, C, l, u, lb, ub, er, dt, tolerance, max_iter, state, rstate, ws, iws, v)


@nb.njit(cache=True, nogil=True)
def kinematic_reduced_packed(fb, ib):
    """The reduced QP formed by the last :func:`kinematic_solve_packed` call on these arrays (valid after any return
    but ``NOT_REDUCIBLE``), as views into ``fb``: (H (nr, nr), g (nr,), A (mr, nr), b (mr,), C (p, nr), l (p,),
    u (p,), lb (nr,), ub (nr,)) of min ½xᵀHx + gᵀx s.t. Ax = b, l ≤ Cx ≤ u, lb ≤ x ≤ ub in the joint velocities x
    (nr = nv − 6, mr = n_eq − 6 with the floating-base elimination; nv and n_eq without). Its solution x, given to
    :func:`kinematic_finish_packed`, completes the tick."""
    H, g, A, b, C, l, u, lb, ub, ws, iws, er = _unpack(fb, ib)
    n0 = 6 if er >= 0 else 0
    nr = A.shape[1] - n0
    (Hr, L, gr, lbr, ubr, row, x, z, t, Tc, Eb, V, wb, Cr, lr, ur, mu, Ar, br, nu, Y, S, rhs,
     eqres) = _solve_views(ws, A.shape[1], nr, A.shape[0] - n0, C.shape[0])
    return Hr, gr, Ar, br, Cr, lr, ur, lbr, ubr


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def kinematic_finish_packed(fb, ib, x, v, dt, tolerance):
    """Complete a :func:`kinematic_solve_packed` call whose kernel did not solve the reduced QP, from a solution x
    (nr,) of :func:`kinematic_reduced_packed` found by another solver: v (nv,) (out; base velocity recovered
    through the eliminating rows) and the check of every original row against ``tolerance`` (True: passed, and
    the float workspace then holds v·dt as after a successful solve)."""
    H, g, A, b, C, l, u, lb, ub, ws, iws, er = _unpack(fb, ib)
    n0 = 6 if er >= 0 else 0
    nr = A.shape[1] - n0
    Tc = _solve_views(ws, A.shape[1], nr, A.shape[0] - n0, C.shape[0])[9]
    return _finish(A, b, C, l, u, Tc, x, n0, dt, tolerance, ws, v)


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def _exp6_translation(xi, s, out):
    """out ← translation of exp(s ξ) for a 6-D twist ξ = (ν, ω) (Pinocchio's order): V(sω) sν with
    V(ω) = I + (1 − cos θ)/θ² [ω]× + (θ − sin θ)/θ³ [ω]×², θ = ‖ω‖ (Lynch & Park, Modern Robotics, eq. 3.88)."""
    nx, ny, nz = s * xi[0], s * xi[1], s * xi[2]
    wx, wy, wz = s * xi[3], s * xi[4], s * xi[5]
    t2 = wx * wx + wy * wy + wz * wz
    if t2 < 1e-12:  # series: 1/2 − θ²/24, 1/6 − θ²/120
        a, c = 0.5 - t2 / 24.0, 1.0 / 6.0 - t2 / 120.0
    else:
        t = np.sqrt(t2)
        a, c = (1.0 - np.cos(t)) / t2, (t - np.sin(t)) / (t2 * t)
    # w × n and w × (w × n)
    cx, cy, cz = wy * nz - wz * ny, wz * nx - wx * nz, wx * ny - wy * nx
    dx, dy, dz = wy * cz - wz * cy, wz * cx - wx * cz, wx * cy - wy * cx
    out[0] = nx + a * cx + c * dx
    out[1] = ny + a * cy + c * dy
    out[2] = nz + a * cz + c * dz


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def translation_gap(xa, sa, xb, sb):
    """‖t(exp(sa ξa)) − t(exp(sb ξb))‖ (m): the distance between the origins of two frames given by their twists
    ξa, ξb (6,) from one reference frame (e.g. a contact's placement)."""
    pa, pb = np.empty(3), np.empty(3)
    _exp6_translation(xa, sa, pa)
    _exp6_translation(xb, sb, pb)
    return np.sqrt((pa[0] - pb[0]) ** 2 + (pa[1] - pb[1]) ** 2 + (pa[2] - pb[2]) ** 2)


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def contact_drift(logs, b, starts, factors):
    """Largest distance (m) between where a contact frame ends and where its row sent it, over the contacts i:
    ‖t(exp(e⁺_i)) − t(exp(f_i b_i))‖ with e⁺_i = logs[i] (6,) its error at the next configuration (``pin.log6`` of
    placement⁻¹ oMf), b_i = b[starts[i]:starts[i] + 6] its rows' right-hand side −K e and f_i = dt − 1/K, so that
    f_i b_i = (1 − K dt) e_i (the row's target); t(exp(·)) the translation of the frame in the placement's frame."""
    worst = 0.0
    for i in range(logs.shape[0]):
        r0 = starts[i]
        d = translation_gap(logs[i], 1.0, b[r0:r0 + 6], factors[i])
        if d > worst:
            worst = d
    return worst


class FastBackend(DaqpBackend):
    """Compiled exact solver for bound- and equality-constrained QPs (module docstring); every other problem, and
    every kernel call that does not end in a KKT point, is solved by the :class:`~wbc.qp.DaqpBackend` it
    extends (so a controller's hierarchy levels and safe-command fallback, built as fresh DAQP backends of the same
    settings, take the general path).

    Args:
        tolerance: largest constraint violation accepted (constraint units), as for every backend.
        max_iter: working-set iterations before handing the problem to DAQP.
        kernel_rows: problems with inequality rows go to the kernel first (True) or to DAQP at once (False: the
            inverse-dynamics QP, whose compiled tick has its own kernel; this one's iterations refactor the working
            set, which costs more than DAQP on that QP: benchmarks/README.md, "Tick time bounded at both levels").
        **settings: DAQP settings for the fallback (:class:`~wbc.qp.DaqpBackend`).

    Attributes:
        last_kernel_iterations: working-set iterations of the last kernel call (negative: its exit code).
        kernel_solves / fallbacks: calls answered by the kernel / by DAQP.
        reduced_fallbacks: of the fallbacks, the kinematic controller's compiled ticks whose reduced QP DAQP
            solved after the kernel gave up (:meth:`wbc.formulations.velocity.KinematicController._fused_rescue`).
    """

    name = "fast"

    def __init__(self, tolerance: float = 1e-6, max_iter: int = 100, kernel_rows: bool = True, **settings):
        super().__init__(tolerance=tolerance, **settings)
        self.max_iter = int(max_iter)
        self.kernel_rows = bool(kernel_rows)
        self._n = -1
        self._m = -1
        self._p = -1
        self.last_kernel_iterations = 0
        self.kernel_solves = 0
        self.fallbacks = 0
        self.reduced_fallbacks = 0
        self._rows_failed = False
        ensure_compiled()  # compile / load the kernel here, once per process, not inside a controller's first tick

    def _prepare_kernel(self, n: int, m: int) -> None:
        if n != self._n:  # the working set concerns the bounds only: kept when the equality rows change
            self._state = np.zeros(n, np.int8)
            self._x = np.empty(n)
            self._z = np.zeros(n)
            self._ws_by_m: dict = {}  # workspaces per number of equality rows (a support switch goes back and
            #                           forth between a few shapes: no allocation after the first of each)
            self._p = -1
        self._n, self._m = n, m
        cached = self._ws_by_m.get(m)
        if cached is None:
            cached = self._ws_by_m[m] = (np.zeros(m), (
                np.empty(n, np.int64), np.empty((n, n)), np.empty((m, n)), np.empty((m, m)), np.empty(n),
                np.empty(m), np.empty(1)))
        self._nu, self._ws = cached

    def _kernel(self, H, g, A, b, lb, ub) -> bool:
        n, m = H.shape[0], A.shape[0]
        if n != self._n or m != self._m:
            self._prepare_kernel(n, m)
        it = solve_box_eq_ws(H, g, A, b, lb, ub, self._state, self._x, self._nu, self._z,
                             self.max_iter, 1e-12, 1e-12, 1e-24, *self._ws)
        self.last_kernel_iterations = it
        if it > 0 and self._ws[6][0] <= self.tolerance:
            self.kernel_solves += 1
            return True
        self._state[:] = 0
        return False

    def solve(self, H, g, A, b, C, l, u, lb, ub, *, confirm: bool = True) -> np.ndarray:
        """As :meth:`wbc.qp.QPBackend.solve` (``confirm`` likewise). A kernel solution is returned as is: it satisfies every KKT
        condition, lies inside the bounds by construction and its equality residual was checked in the kernel
        against ``tolerance``; anything else goes through DAQP and the general check.

        Raises:
            SolverError: the DAQP fallback failed (see :meth:`wbc.qp.QPBackend.solve`).
        """
        p = C.shape[0]
        if p and not self.kernel_rows:
            return super().solve(H, g, A, b, C, l, u, lb, ub, confirm=confirm)
        if p and self._rows_failed:
            # the kernel did not end in a KKT point on the previous call with rows: this one goes to DAQP at once
            # and the kernel is tried again on the next (degenerate rows, e.g. self-collision rows on joints held
            # at velocity bounds, defeat its pivoting for stretches of ticks: on the Talos hand-through-torso drive
            # 414 of 605 calls; a failed attempt cost about half a DAQP solve)
            self._rows_failed = False
        elif self._kernel(H, g, A, b, lb, ub) if p == 0 else self._kernel_rows(H, g, A, b, C, l, u, lb, ub):
            return self._x.copy()
        else:
            self._rows_failed = p > 0
        self.fallbacks += 1
        x = super().solve(H, g, A, b, C, l, u, lb, ub, confirm=confirm)
        if H.shape[0] == self._n:
            # warm start the kernel's next call from the bounds (and rows) DAQP found active
            self._state[:] = 0
            self._state[x <= lb + 1e-12] = -1
            self._state[x >= ub - 1e-12] = 1
            if p and self._p == p:
                cx = C @ x
                self._rstate[:] = 0
                self._rstate[cx <= l + 1e-12] = -1
                self._rstate[cx >= u - 1e-12] = 1
        return x

    def _kernel_rows(self, H, g, A, b, C, l, u, lb, ub) -> bool:
        n, m, p = H.shape[0], A.shape[0], C.shape[0]
        if n != self._n or m != self._m:
            self._prepare_kernel(n, m)
        if p != self._p:  # the rows' working set is kept when only the equality rows changed
            self._p = p
            self._rstate = np.zeros(p, np.int8)
            self._mu = np.zeros(p)
        it = solve_qp_ws(H, g, A, b, C, l, u, lb, ub, self._state, self._rstate, self._x, self._nu, self._mu,
                         self._z, self.max_iter, 1e-12, 1e-12, 1e-24, self._ws[6])
        self.last_kernel_iterations = it
        if it > 0 and self._ws[6][0] <= self.tolerance:
            self.kernel_solves += 1
            return True
        self._state[:] = 0
        self._rstate[:] = 0
        return False


@once_per_process
def ensure_compiled() -> float:
    """Run :func:`warm_up` once per process (later calls return None at once)."""
    return warm_up()


def warm_up() -> float:
    """Compile (or load from the on-disk cache) the kernel; returns the seconds taken."""
    t0 = time.perf_counter()
    H = np.eye(2)
    s = np.zeros(2, np.int8)
    solve_box_eq(H, np.ones(2), np.ones((1, 2)), np.ones(1), -np.ones(2), np.ones(2), s, np.empty(2),
                 np.empty(1), np.empty(2), 10, 1e-12, 1e-12, 1e-24)
    weighted_normal_equations(np.ones((1, 2)), np.ones(1), np.ones(1), 1e-6, np.empty((2, 2)), np.empty(2))
    clip_box_into(-np.ones(2), np.ones(2), 0, np.zeros(1), np.zeros(1))
    b = FastBackend()
    b.solve(H, np.ones(2), np.ones((1, 2)), np.ones(1), np.ones((1, 2)), -np.ones(1), np.ones(1), -np.ones(2),
            np.ones(2))
    # no inequality rows: the box/equality kernel's own entry point (else loaded inside a controller's first tick)
    b.solve(H, np.ones(2), np.ones((1, 2)), np.ones(1), np.zeros((0, 2)), np.zeros(0), np.zeros(0), -np.ones(2),
            np.ones(2))
    # the kinematic controller's cost formation and compiled solver (a 7-velocity QP whose base is eliminated
    # through 6 rows)
    fb, ib, views = kinematic_pack(7, 6, 0, 0)
    form_qp(np.eye(1, 7, 6), np.zeros(1), np.ones((3, 1)), np.zeros(7), np.zeros(0), np.zeros(0, np.int64), 0.0,
            1e-6, views["H"], views["g"])
    weighted_rows(np.eye(1, 7, 6), np.zeros(1), np.ones((3, 1)), np.empty((1, 7)), np.empty(1))
    views["A"][:, :6] = np.eye(6)
    views["lb"][:6], views["ub"][:6] = -np.inf, np.inf
    views["lb"][6], views["ub"][6] = -1.0, 1.0
    kinematic_solve_packed(fb, ib, np.zeros(1, np.int8), np.zeros(0, np.int8), np.empty(7), 0.002, 1e-6, 10)
    kinematic_reduced_packed(fb, ib)
    kinematic_finish_packed(fb, ib, np.zeros(1), np.empty(7), 0.002, 1e-6)
    contact_drift(np.zeros((1, 6)), np.zeros(6), np.zeros(1, np.int64), np.zeros(1))
    translation_gap(np.zeros(6), 1.0, np.zeros(6), 1.0)
    return time.perf_counter() - t0
