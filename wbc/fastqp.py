"""Compiled (numba) exact solver for the common QP of the kinematic tick, with DAQP as fallback.

Solves

    min_x ½ xᵀ H x + gᵀ x   s.t.   A x = b,   l ≤ C x ≤ u,   lb ≤ x ≤ ub

(H symmetric positive definite, A full row rank) by an active set on the bounds and the rows of C
(:func:`solve_qp_ws`; :func:`solve_box_eq_ws` when C has no rows), warm-started from the previous
call's active set. For a fixed working set W (variables held at a bound) the free part F solves the
equality-constrained QP through its KKT system, eliminated with a Cholesky factor L Lᵀ = H_FF and the Schur
complement S = A_F H_FF⁻¹ A_Fᵀ (Nocedal & Wright, *Numerical Optimization*, 2nd ed., §16.2, eq. 16.16 "range-space
method"). The working set is then corrected: the free variable furthest outside its bounds is fixed at the
violated bound; otherwise the fixed variable whose bound multiplier has the wrong sign (most negative) is freed (single-pivot
principal pivoting, Júdice & Pires, Comput. Oper. Res. 21(5), 1994). The loop ends
only when every KKT condition holds (stationarity by construction, primal feasibility, dual sign, complementarity
since free variables and inactive rows carry no multiplier), so the returned x is the exact optimum; when it does not
end within the iteration cap, when H_FF is not positive definite or when S is singular (dependent equalities or
active rows, more active constraints than free variables), the call is handed to :class:`wbc.qp.DaqpBackend`.

:func:`kinematic_tick` is the kinematic controller's whole QP tick in one compiled call (assembly from stacked task
rows, posture diagonal, damping and position limits; floating-base elimination through a contact's 6 rows; the
working set above on the reduced problem; residuals of the original rows checked), with its persistent arrays
packed into two by :func:`kinematic_pack` for :func:`kinematic_tick_packed`.

The kernels are compiled on first use and cached on disk (``cache=True``); :func:`warm_up` compiles (or loads)
them eagerly and returns the seconds it took.
"""

from __future__ import annotations

import time

import numba as nb
import numpy as np

from wbc.compiled import once_per_process
from wbc.qp import DaqpBackend

__all__ = ["FastBackend", "backward_substitution", "cholesky_lower", "clip_box_into", "contact_drift",
           "ensure_compiled", "forward_substitution", "kinematic_pack", "kinematic_tick", "kinematic_tick_packed",
           "kinematic_workspace",
           "primal_from_multipliers", "solve_box_eq", "solve_box_eq_ws", "solve_qp_ws", "warm_up",
           "weighted_normal_equations"]

#: exit codes of :func:`solve_box_eq` (≥ 0: number of working-set iterations)
NOT_POSITIVE_DEFINITE = -1
DEPENDENT_EQUALITIES = -2
ITERATION_CAP = -3
#: exit codes of :func:`kinematic_tick`: the floating base cannot be eliminated (a bound on a base velocity, a
#: singular eliminating block); the solution's equality or inequality residual is above the tolerance
NOT_REDUCIBLE = -4
RESIDUAL = -5

#: LLVM fast-math flags: reassociation (vectorised dot products) and fused multiply-add only — no
#: "no-inf/no-nan" assumptions, since ±inf bounds are legitimate input.
_FM = {"reassoc", "contract"}


@nb.njit(cache=True, fastmath=_FM, nogil=True)
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


@nb.njit(cache=True, fastmath=_FM, nogil=True)
def forward_substitution(L, k, v):
    """v ← L⁻¹ v in place, L lower triangular (leading k × k block), forward substitution (compiled)."""
    for i in range(k):
        t = v[i]
        for p in range(i):
            t -= L[i, p] * v[p]
        v[i] = t / L[i, i]


@nb.njit(cache=True, fastmath=_FM, nogil=True)
def backward_substitution(L, k, v):
    """v ← L⁻ᵀ v in place, L lower triangular (leading k × k block), backward substitution (compiled), by rows of L
    (x_i = v_i / L_ii, then v[:i] −= x_i L[i, :i]: contiguous, where the column form reads L with a stride)."""
    for i in range(k - 1, -1, -1):
        xi = v[i] / L[i, i]
        v[i] = xi
        Li = L[i]
        for p in range(i):
            v[p] -= xi * Li[p]


@nb.njit(cache=True, fastmath=_FM, nogil=True)
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


@nb.njit(cache=True, fastmath=_FM, nogil=True)
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


@nb.njit(cache=True, fastmath=_FM, nogil=True)
def solve_box_eq(H, g, A, b, lb, ub, state, x, nu, z, max_iter, primal_tol, dual_tol, rank_tol):
    """Allocating form of :func:`solve_box_eq_ws` (same arguments, no workspace)."""
    n, m = H.shape[0], A.shape[0]
    return solve_box_eq_ws(H, g, A, b, lb, ub, state, x, nu, z, max_iter, primal_tol, dual_tol, rank_tol,
                           np.empty(n, np.int64), np.empty((n, n)), np.empty((m, n)), np.empty((m, m)),
                           np.empty(n), np.empty(m), np.empty(1))


@nb.njit(cache=True, fastmath=_FM, nogil=True)
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


@nb.njit(cache=True, fastmath=_FM, nogil=True)
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


@nb.njit(cache=True, fastmath=_FM, nogil=True)
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


@nb.njit(cache=True, fastmath=_FM, nogil=True)
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


@nb.njit(cache=True, fastmath=_FM, nogil=True)
def solve_box_eq_ws(H, g, A, b, lb, ub, state, x, nu, z, max_iter, primal_tol, dual_tol, rank_tol,
                    free, L, Y, S, t, rhs, eq_residual):
    """Exact solution of min ½xᵀHx + gᵀx s.t. Ax = b, lb ≤ x ≤ ub (module docstring).

    Args:
        H (n, n), g (n,), A (m, n), b (m,), lb/ub (n,) (±inf for free entries).
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




@nb.njit(cache=True, fastmath=_FM, nogil=True)
def solve_qp_ws(H, g, A, b, C, l, u, lb, ub, state, rstate, x, nu, mu, z, max_iter, primal_tol, dual_tol,
                rank_tol, Aw, bw, free, L, Y, S, t, rhs, nuw, eq_residual):
    """Exact solution of min ½xᵀHx + gᵀx s.t. Ax = b, l ≤ Cx ≤ u, lb ≤ x ≤ ub: the working set of
    :func:`solve_box_eq_ws` extended to the rows of C (an active row is held as an equality at the bound it
    touches, with the same fix-worst-violation / free-worst-wrong-sign rule).

    Args (beyond :func:`solve_box_eq_ws`):
        C (p, n), l/u (p,): inequality rows (±inf for one-sided rows).
        rstate (p,) int8, in/out: row working set (0 inactive, -1 held at l, +1 held at u).
        mu (p,): out — row multipliers (H x + g + Aᵀnu + Cᵀmu + z = 0; mu ≤ 0 at l, ≥ 0 at u, 0 inactive).
        Aw (m + p, n), bw (m + p,), nuw (m + p,): workspace; Y (m + p, n), S (m + p, m + p), rhs (m + p,).

    Returns:
        iterations (≥ 1) on success, or a negative exit code.
    """
    n = H.shape[0]
    m = A.shape[0]
    p = C.shape[0]
    _drop_infinite_active(state, lb, ub)
    _drop_infinite_active(rstate, l, u)
    for it in range(1, max_iter + 1):
        # working equality rows: A, then the active rows of C
        mw = m
        for k in range(m):
            Aw[k, :] = A[k, :]
            bw[k] = b[k]
        for r in range(p):
            if rstate[r] != 0:
                Aw[mw, :] = C[r, :]
                bw[mw] = l[r] if rstate[r] < 0 else u[r]
                mw += 1
        nf = _working_set_step(H, g, Aw, bw, mw, lb, ub, state, x, nuw, rank_tol, free, L, Y, S, t, rhs)
        if nf < 0:
            return nf
        # primal: the worst violated bound or inactive row is added to the working set
        worst, worst_i, worst_side = _place_free(free, t, nf, x, lb, ub, primal_tol)
        worst_row = False
        for r in range(p):
            if rstate[r] != 0:
                continue
            s = 0.0
            for j in range(n):
                s += C[r, j] * x[j]
            if l[r] - s > worst:
                worst, worst_i, worst_side, worst_row = l[r] - s, r, -1, True
            elif s - u[r] > worst:
                worst, worst_i, worst_side, worst_row = s - u[r], r, 1, True
        if worst_i >= 0:
            if worst_row:
                rstate[worst_i] = worst_side
            else:
                state[worst_i] = worst_side
            continue
        # dual: row multipliers, then bound multipliers; the worst wrong sign leaves the working set
        for k in range(m):
            nu[k] = nuw[k]
        k = m
        worst = dual_tol
        worst_i = -1
        worst_row = False
        for r in range(p):
            if rstate[r] == 0:
                mu[r] = 0.0
                continue
            mu[r] = nuw[k]
            k += 1
            wrong = mu[r] if rstate[r] < 0 else -mu[r]
            if wrong > worst:
                worst, worst_i, worst_row = wrong, r, True
        worst_b, worst_bi = _bound_multipliers(H, g, Aw, mw, nuw, state, x, z, worst)
        if worst_bi >= 0:
            worst, worst_i, worst_row = worst_b, worst_bi, False
        if worst_i >= 0:
            if worst_row:
                rstate[worst_i] = 0
            else:
                state[worst_i] = 0
            continue
        res = _clip_eq_residual(x, lb, ub, A, b, n, m)
        for r in range(p):
            s = 0.0
            for j in range(n):
                s += C[r, j] * x[j]
            if l[r] - s > res:
                res = l[r] - s
            elif s - u[r] > res:
                res = s - u[r]
        eq_residual[0] = res
        return it
    return ITERATION_CAP


@nb.njit(cache=True, fastmath=_FM, nogil=True)
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


@nb.njit(cache=True, fastmath=_FM, nogil=True)
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


@nb.njit(cache=True, fastmath=_FM, nogil=True)
def _add_row(H, g, row, w, r, nr):
    """H += w row rowᵀ and g −= w r row: one weighted least-squares row w (row·x − r)²/2 (whole rows of H: the
    loops vectorise, where the triangle's ragged ones do not)."""
    wr = w * r
    for i in range(nr):
        a = row[i]
        if a == 0.0:
            continue
        g[i] -= a * wr
        wa = w * a
        Hi = H[i]
        for j in range(nr):
            Hi[j] += wa * row[j]


def kinematic_workspace(nv: int, n_eq: int, n_in: int, eliminate: bool) -> tuple[np.ndarray, np.ndarray]:
    """Float and integer workspaces of :func:`kinematic_tick` for nv velocities, ``n_eq`` equality and ``n_in``
    inequality rows, with or without the floating-base elimination. The float one starts with v·dt (nv,)."""
    nr = nv - 6 if eliminate else nv
    mr = n_eq - 6 if eliminate else n_eq
    k = mr + n_in
    size = (3 * nv + 2 * nr * nr + 7 * nr + 6 * (nr + 1) + 36 + n_in * nr + 3 * n_in + mr * nr + 2 * mr
            + 2 * k * nr + k * k + 3 * k + 1)
    return np.zeros(size), np.zeros(nr, np.int64)


@nb.njit(cache=True, fastmath=_FM, nogil=True)
def kinematic_tick(Js, es, rowp, diff, pw, prow, pgain, A, b, lb, ub, q, plim, pidx, C, cl, cu, dt, damping,
                   tolerance, er, max_iter, state, rstate, ws, iws, v):
    """One kinematic QP tick (:class:`wbc.formulations.velocity.KinematicController`), assembled and solved in one
    compiled call: the exact optimum of

        min_v ½ Σ_k w_k (J_k v − v*_k)² + ½ Σ_i d_i (v_i − s_i)² + ½ ε ‖v‖²
        s.t.  A v = b,  cl ≤ C v ≤ cu,  lb ≤ v ≤ ub  (∩ the joint position limits over dt)

    with v*_k = ff_k − K_k e_k (dense task rows), d the posture weights on their velocity indices and
    s = −K_p (q ⊖ q*) there.

    Floating-base elimination (``er`` ≥ 0): the 6 equality rows E = A[er:er + 6] (a contact's LOCAL Jacobian, whose
    base block E_b is invertible) give v_b = c − T v_j (T = E_b⁻¹E_j, c = E_b⁻¹b_E), so the problem is solved exactly
    in the nv − 6 joint velocities with the remaining equality rows (a null-space / variable-elimination method;
    Nocedal & Wright, *Numerical Optimization*, 2nd ed., §15.3, eq. 15.14 with the basis columns the base's). The
    base must be unbounded (else ``NOT_REDUCIBLE``). The reduced QP is solved by :func:`solve_box_eq_ws` (no
    inequality rows) or :func:`solve_qp_ws`, warm-started from ``state``/``rstate``; every KKT condition of the
    reduced problem holds at exit, and the residuals of all rows of the original one are checked against
    ``tolerance``.

    Args:
        Js (mt, nv), es (mt,): stacked task Jacobians and errors; rowp (3, mt): gain K, weight w, feed-forward ė*.
        diff (nv,): q ⊖ q* of the posture task (``pin.difference``); pw (kp,), prow (kp,) int64: its weights and
            velocity indices (kp = 0: no posture); pgain: its gain (1/s).
        A (neq, nv), b (neq,): equality rows. lb/ub (nv,): bounds before the position limits.
        q (nq,), plim (4, kl): q_min, q_max, v_max, −v_max of the position-limited joints, pidx (2, kl) int64: their
            q and v indices; their bounds min((q_min − q)/dt, v_max) ≤ v ≤ max((q_max − q)/dt, −v_max) are
            clipped into [lb, ub] (``JointPositionLimit``; kl = 0: none).
        C (p, nv), cl/cu (p,): inequality rows. dt (s), damping ε, tolerance: largest residual accepted.
        er: first row of the eliminating block, or −1 (no elimination). max_iter: working-set iterations.
        state (nr,) int8, rstate (p,) int8: working sets (warm start, in/out). ws, iws: workspaces from
            :func:`kinematic_workspace`; on success ws[:nv] = v·dt.
        v (nv,): out.

    Returns:
        working-set iterations (≥ 1), or a negative exit code (the caller solves the tick by the general path).
    """
    n = Js.shape[1]
    mt = Js.shape[0]
    n0 = 6 if er >= 0 else 0
    nr = n - n0
    neq = A.shape[0]
    mr = neq - n0
    p = C.shape[0]
    k = mr + p
    o = n
    pd = ws[o:o + n]
    o += n
    ps = ws[o:o + n]
    o += n
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
    Aw = ws[o:o + k * nr].reshape((k, nr))
    o += k * nr
    Y = ws[o:o + k * nr].reshape((k, nr))
    o += k * nr
    S = ws[o:o + k * k].reshape((k, k))
    o += k * k
    bw = ws[o:o + k]
    o += k
    rhs = ws[o:o + k]
    o += k
    nuw = ws[o:o + k]
    o += k
    eqres = ws[o:o + 1]
    # bounds: [lb, ub] on the joint velocities, the position limits clipped into them
    for i in range(n0):
        if lb[i] > -np.inf or ub[i] < np.inf:
            return NOT_REDUCIBLE
    for j in range(nr):
        lbr[j] = lb[n0 + j]
        ubr[j] = ub[n0 + j]
    for a in range(pidx.shape[1]):
        j = pidx[1, a] - n0
        if j < 0:
            return NOT_REDUCIBLE
        qa = q[pidx[0, a]]
        lo = min((plim[0, a] - qa) / dt, plim[2, a])
        hi = max((plim[1, a] - qa) / dt, plim[3, a])
        cur_lo, cur_hi = lbr[j], ubr[j]
        lbr[j] = min(max(lo, cur_lo), cur_hi)
        ubr[j] = max(min(hi, cur_hi), cur_lo)
    if n0 and not _eliminate_base(A, b, er, nr, Eb, Tc):
        return NOT_REDUCIBLE
    # cost: dense task rows, posture (diagonal), damping
    for i in range(n):
        pd[i] = 0.0
        ps[i] = 0.0
    for a in range(prow.shape[0]):
        i = prow[a]
        pd[i] += pw[a]
        ps[i] = -pgain * diff[i]
    for i in range(nr):
        g[i] = 0.0
        for j in range(nr):
            H[i, j] = 0.0
    for r in range(mt):
        w = rowp[1, r]
        if w == 0.0:
            continue
        target = rowp[2, r] - rowp[0, r] * es[r]
        target -= _reduce_row(Js[r], n0, nr, Tc, row)
        _add_row(H, g, row, w, target, nr)
    for i in range(n0):  # the base's posture and damping terms, through v_b = c − T v_j
        wd = pd[i] + damping
        s = pd[i] * ps[i] - wd * Tc[i, nr]
        Ti = Tc[i]
        for a in range(nr):
            ta = Ti[a]
            if ta == 0.0:
                continue
            g[a] += ta * s
            wta = wd * ta
            Ha = H[a]
            for c in range(nr):
                Ha[c] += wta * Ti[c]
    for j in range(nr):
        i = n0 + j
        H[j, j] += damping + pd[i]
        g[j] -= pd[i] * ps[i]
    # constraint rows in the joint velocities
    kk = 0
    for r in range(neq):
        if n0 and er <= r < er + 6:
            continue
        br[kk] = b[r] - _reduce_row(A[r], n0, nr, Tc, Ar[kk])
        kk += 1
    for r in range(p):
        shift = _reduce_row(C[r], n0, nr, Tc, Cr[r])
        lr[r] = cl[r] - shift
        ur[r] = cu[r] - shift
    if p == 0:
        it = solve_box_eq_ws(H, g, Ar, br, lbr, ubr, state, x, nu, z, max_iter, 1e-12, 1e-12, 1e-24, iws, L, Y, S,
                             t, rhs, eqres)
    else:
        it = solve_qp_ws(H, g, Ar, br, Cr, lr, ur, lbr, ubr, state, rstate, x, nu, mu, z, max_iter, 1e-12, 1e-12,
                         1e-24, Aw, bw, iws, L, Y, S, t, rhs, nuw, eqres)
    if it < 1:
        state[:] = 0
        rstate[:] = 0
        return it
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
        s = 0.0
        for j in range(n):
            s += C[r, j] * v[j]
        if cl[r] - s > res:
            res = cl[r] - s
        elif s - cu[r] > res:
            res = s - cu[r]
    if not res <= tolerance:
        state[:] = 0
        rstate[:] = 0
        return RESIDUAL
    for i in range(n):
        ws[i] = v[i] * dt
    return it


#: fields of the header of :func:`kinematic_tick_packed`'s integer array (offsets into its float array ``fb``)
_PACK_FIELDS = ("nv", "mt", "neq", "p", "kl", "kp", "er", "Js", "es", "rowp", "A", "b", "C", "cl", "cu", "lb", "ub",
                "plim", "pw", "ws", "pidx", "prow", "iws")


def kinematic_pack(nv: int, mt: int, n_eq: int, n_in: int, n_limits: int, n_posture: int, er: int
                   ) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    """The two arrays :func:`kinematic_tick_packed` reads (one float, one int64) for nv velocities, ``mt`` dense task
    rows, ``n_eq`` equality and ``n_in`` inequality rows, ``n_limits`` position-limited joints and ``n_posture``
    posture rows, eliminating the floating base through the equality rows from ``er`` (−1: none), and named views
    of their parts, the arguments of :func:`kinematic_tick`: ``Js`` (mt, nv), ``es`` (mt,), ``rowp`` (3, mt), ``A``
    (n_eq, nv), ``b``, ``C`` (n_in, nv), ``cl``, ``cu``, ``lb``, ``ub`` (nv,), ``plim`` (4, n_limits), ``pw``
    (n_posture,), ``pidx`` (2, n_limits) and ``prow`` (n_posture,) int64, and ``vdt`` (nv,): v·dt after a solve."""
    ws, iws = kinematic_workspace(nv, n_eq, n_in, er >= 0)
    shapes = {"Js": (mt, nv), "es": (mt,), "rowp": (3, mt), "A": (n_eq, nv), "b": (n_eq,), "C": (n_in, nv),
              "cl": (n_in,), "cu": (n_in,), "lb": (nv,), "ub": (nv,), "plim": (4, n_limits), "pw": (n_posture,),
              "ws": (ws.size,)}
    ishapes = {"pidx": (2, n_limits), "prow": (n_posture,), "iws": (iws.size,)}
    head = len(_PACK_FIELDS)
    offsets, o = {}, 0
    for name, shape in shapes.items():
        offsets[name] = o
        o += int(np.prod(shape))
    fb = np.zeros(o)
    io = head
    for name, shape in ishapes.items():
        offsets[name] = io
        io += int(np.prod(shape))
    ib = np.zeros(io, np.int64)
    ib[:7] = (nv, mt, n_eq, n_in, n_limits, n_posture, er)
    for i, name in enumerate(_PACK_FIELDS[7:], start=7):
        ib[i] = offsets[name]
    views = {name: fb[offsets[name]:offsets[name] + int(np.prod(shape))].reshape(shape)
             for name, shape in shapes.items()}
    views.update({name: ib[offsets[name]:offsets[name] + int(np.prod(shape))].reshape(shape)
                  for name, shape in ishapes.items()})
    views["vdt"] = views["ws"][:nv]
    return fb, ib, views


@nb.njit(cache=True, fastmath=_FM, nogil=True)
def kinematic_tick_packed(fb, ib, state, rstate, diff, q, v, pgain, dt, damping, tolerance, max_iter):
    """:func:`kinematic_tick` with its persistent arrays packed into ``fb`` (float) and ``ib`` (int64) by
    :func:`kinematic_pack`: 12 arguments instead of 27 (each array argument costs the call ≈ 50 ns to type and
    unbox). Same returns."""
    nv, mt, neq, p, kl, kp, er = ib[0], ib[1], ib[2], ib[3], ib[4], ib[5], ib[6]
    o = ib[7:]
    Js = fb[o[0]:o[0] + mt * nv].reshape((mt, nv))
    es = fb[o[1]:o[1] + mt]
    rowp = fb[o[2]:o[2] + 3 * mt].reshape((3, mt))
    A = fb[o[3]:o[3] + neq * nv].reshape((neq, nv))
    b = fb[o[4]:o[4] + neq]
    C = fb[o[5]:o[5] + p * nv].reshape((p, nv))
    cl = fb[o[6]:o[6] + p]
    cu = fb[o[7]:o[7] + p]
    lb = fb[o[8]:o[8] + nv]
    ub = fb[o[9]:o[9] + nv]
    plim = fb[o[10]:o[10] + 4 * kl].reshape((4, kl))
    pw = fb[o[11]:o[11] + kp]
    ws = fb[o[12]:]
    pidx = ib[o[13]:o[13] + 2 * kl].reshape((2, kl))
    prow = ib[o[14]:o[14] + kp]
    iws = ib[o[15]:]
    return kinematic_tick(Js, es, rowp, diff, pw, prow, pgain, A, b, lb, ub, q, plim, pidx, C, cl, cu, dt, damping,
                          tolerance, er, max_iter, state, rstate, ws, iws, v)


@nb.njit(cache=True, fastmath=_FM, nogil=True)
def contact_drift(logs, b, starts, factors):
    """Largest ‖t(e⁺_i − f_i b_i)‖ over the contacts i: e⁺_i = logs[i] (6,) their errors at the next configuration
    (``pin.log6``), b_i = b[starts[i]:starts[i] + 6] their rows' right-hand sides −K e and f_i = dt − 1/K, so that
    f_i b_i = (1 − K dt) e_i; t(·) the translation part (m)."""
    worst = 0.0
    for i in range(logs.shape[0]):
        s = 0.0
        r0 = starts[i]
        for a in range(3):
            d = logs[i, a] - factors[i] * b[r0 + a]
            s += d * d
        if s > worst:
            worst = s
    return np.sqrt(worst)


class FastBackend(DaqpBackend):
    """Compiled exact solver for bound- and equality-constrained QPs (module docstring); every other problem, and
    every kernel call that does not end in a KKT point, is solved by the :class:`~wbc.qp.DaqpBackend` it
    extends (so a controller's hierarchy levels and safe-command fallback, built as fresh DAQP backends of the same
    settings, take the general path).

    Args:
        tolerance: largest constraint violation accepted (constraint units), as for every backend.
        max_iter: working-set iterations before handing the problem to DAQP.
        **settings: DAQP settings for the fallback (:class:`~wbc.qp.DaqpBackend`).

    Attributes:
        last_kernel_iterations: working-set iterations of the last kernel call (negative: its exit code).
        kernel_solves / fallbacks: calls answered by the kernel / by DAQP.
    """

    name = "fast"

    def __init__(self, tolerance: float = 1e-6, max_iter: int = 100, **settings):
        super().__init__(tolerance=tolerance, **settings)
        self.max_iter = int(max_iter)
        self._n = -1
        self._m = -1
        self._p = -1
        self._pm = -1
        self.last_kernel_iterations = 0
        self.kernel_solves = 0
        self.fallbacks = 0
        self._rows_failed = False
        ensure_compiled()  # compile / load the kernel here, once per process, not inside a controller's first tick

    def _prepare_kernel(self, n: int, m: int) -> None:
        if n != self._n:  # the working set concerns the bounds only: kept when the equality rows change
            self._state = np.zeros(n, np.int8)
            self._x = np.empty(n)
            self._z = np.zeros(n)
            self._ws_by_m: dict = {}   # workspaces per number of equality rows (a support switch goes back and
            self._ws_by_mp: dict = {}  # forth between a few shapes: no allocation after the first of each)
            self._rstate_p = -1
        self._n, self._m = n, m
        cached = self._ws_by_m.get(m)
        if cached is None:
            cached = self._ws_by_m[m] = (np.zeros(m), (
                np.empty(n, np.int64), np.empty((n, n)), np.empty((m, n)), np.empty((m, m)), np.empty(n),
                np.empty(m), np.empty(1)))
        self._nu, self._ws = cached
        self._p = -1  # row workspace shares these buffers: rebuilt with them

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

    def solve(self, H, g, A, b, C, l, u, lb, ub) -> np.ndarray:
        """As :meth:`wbc.qp.QPBackend.solve`. A kernel solution is returned as is: it satisfies every KKT
        condition, lies inside the bounds by construction and its equality residual was checked in the kernel
        against ``tolerance``; anything else goes through DAQP and the general check.

        Raises:
            SolverError: the DAQP fallback failed (see :meth:`wbc.qp.QPBackend.solve`).
        """
        p = C.shape[0]
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
        x = super().solve(H, g, A, b, C, l, u, lb, ub)
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
        if p != self._p or m != self._pm:
            self._p, self._pm = p, m
            if p != self._rstate_p:  # the rows' working set is kept when only the equality rows changed
                self._rstate_p = p
                self._rstate = np.zeros(p, np.int8)
                self._mu = np.zeros(p)
            ws = self._ws_by_mp.get((m, p))
            if ws is None:
                ws = self._ws_by_mp[(m, p)] = (
                    np.empty((m + p, n)), np.empty(m + p), self._ws[0], self._ws[1], np.empty((m + p, n)),
                    np.empty((m + p, m + p)), self._ws[4], np.empty(m + p), np.empty(m + p), self._ws[6])
            self._ws_rows = ws
        it = solve_qp_ws(H, g, A, b, C, l, u, lb, ub, self._state, self._rstate, self._x, self._nu, self._mu,
                         self._z, self.max_iter, 1e-12, 1e-12, 1e-24, *self._ws_rows)
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
    # the kinematic controller's compiled tick (a 7-velocity problem whose base is eliminated through 6 rows)
    fb, ib, views = kinematic_pack(7, 1, 6, 0, 0, 0, 0)
    views["A"][:, :6] = np.eye(6)
    views["rowp"][1] = 1.0
    views["Js"][0, 6] = 1.0
    views["lb"][6], views["ub"][6] = -1.0, 1.0
    q = np.zeros(7)
    kinematic_tick_packed(fb, ib, np.zeros(1, np.int8), np.zeros(0, np.int8), q, q, np.empty(7), 0.0, 0.002, 1e-6,
                          1e-6, 10)
    contact_drift(np.zeros((1, 6)), np.zeros(6), np.zeros(1, np.int64), np.zeros(1))
    return time.perf_counter() - t0
