"""The block strategy of :func:`wbc.solvers.active_set.dual_active_set` (on a
:class:`~wbc.solvers.active_set.BlockSpace`; the operations of the dense strategy, same arguments) for
H = blockdiag(H_vv, D), D diagonal > 0 (the inverse-dynamics QP): held bounds eliminated, L Lᵀ = H_vv on the free
accelerations (kept while they do not change), D⁻¹ on the free forces, and the Schur complement of the working rows
(range-space method, Nocedal & Wright 2006, *Numerical Optimization*, §16.2), with two steps of iterative
refinement per equality-constrained optimum."""

from __future__ import annotations

import numba as nb

from wbc.compiled import FASTMATH
from wbc.solvers.linalg import backward_substitution, block_cost_gradient, cholesky_lower, forward_substitution
from wbc.solvers.status import DEPENDENT_EQUALITIES, NOT_POSITIVE_DEFINITE

__all__ = ["block_direction", "block_eqp", "block_prepare", "block_start", "block_target", "block_update"]


@nb.njit(cache=True, nogil=True, fastmath=FASTMATH)
def _row(A, C, m, rk):
    """Working row rk: A[rk] (an equality) when rk < m, else C[rk − m]."""
    return A[rk] if rk < m else C[rk - m]


@nb.njit(cache=True, nogil=True, fastmath=FASTMATH)
def _free_dot(acc, with_v, y, w, nfv, R, X, ffree, nff, H):
    """acc + (y·w over the nfv free accelerations, when ``with_v``) + Σ_f R[f] X[f] / H[f, f] over the free forces."""
    if with_v:
        for i in range(nfv):
            acc += y[i] * w[i]
    for i in range(nff):
        f = ffree[i]
        acc += R[f] * X[f] / H[f, f]
    return acc


@nb.njit(cache=True, nogil=True, fastmath=FASTMATH)
def _kkt(qp, sp, mw, a, c, y, rho):
    """With the factors of :func:`block_start` in ``sp`` (a :class:`~wbc.solvers.active_set.BlockSpace`, its tv
    the workspace): y_F, ρ solving H_FF y_F + R_Fᵀ ρ = a_F, R_F y_F = c (range space, Nocedal & Wright 2006
    eq. 16.16), y written on F only. Returns a_Fᵀ H_FF⁻¹ a_F."""
    H, A, m, C = qp[0], qp[2], qp[4], qp[5]
    rows, Yv, S, L, vfree, ffree, vrow, fac, tv = sp.rows, sp.Yv, sp.S, sp.L, sp.vfree, sp.ffree, sp.vrow, sp.fac, sp.tv
    nfv, nff = fac[0], fac[1]
    for i in range(nfv):
        tv[i] = a[vfree[i]]
    forward_substitution(L, nfv, tv)
    q = 0.0
    for i in range(nfv):
        q += tv[i] * tv[i]
    for i in range(nff):
        f = ffree[i]
        q += a[f] * a[f] / H[f, f]
    for k in range(mw):
        R = _row(A, C, m, rows[k])
        rho[k] = _free_dot(-c[k], vrow[k], Yv[k], tv, nfv, R, a, ffree, nff, H)
    forward_substitution(S, mw, rho)
    backward_substitution(S, mw, rho)
    for k in range(mw):
        if vrow[k]:
            yk = Yv[k]
            rk = rho[k]
            for i in range(nfv):
                tv[i] -= yk[i] * rk
    backward_substitution(L, nfv, tv)
    for i in range(nfv):
        y[vfree[i]] = tv[i]
    for i in range(nff):
        f = ffree[i]
        s = a[f]
        for k in range(mw):
            s -= _row(A, C, m, rows[k])[f] * rho[k]
        y[f] = s / H[f, f]
    return q


@nb.njit(cache=True, nogil=True, fastmath=FASTMATH)
def block_eqp(qp, sp, mw, state, rstate, x, nu, lam_b, lam_r):
    """x = optimum of the working set's equality-constrained QP (held variables on their bound), ν of the equality
    rows in nu[:m], and the multipliers of its inequalities (≥ 0 expected, normals oriented into the feasible side):
    λ_i = σ_i (H x + g + R_wᵀ ρ)_i in lam_b (σ = 1 at lb, −1 at ub), λ_r = s_r ρ_r in lam_r (s = −1 at l, +1 at u)."""
    H, g, A, b, m, C, l, u, lb, ub = qp
    nv, rows, a, c, ra, rc, dx, drho, nuw = sp.nv, sp.rows, sp.a, sp.c, sp.ra, sp.rc, sp.dx, sp.drho, sp.nuw
    n = H.shape[0]
    for i in range(n):
        if state[i] < 0:
            x[i] = lb[i]
        elif state[i] > 0:
            x[i] = ub[i]
    for i in range(n):
        if state[i] != 0:
            a[i] = 0.0
            continue
        s = -g[i]
        if i < nv:
            for j in range(nv):
                if state[j] != 0:
                    s -= H[i, j] * x[j]
        a[i] = s
    for k in range(mw):
        rk = rows[k]
        R = _row(A, C, m, rk)
        if rk < m:
            s = b[rk]
        else:
            s = l[rk - m] if rstate[rk - m] < 0 else u[rk - m]
        for j in range(n):
            if state[j] != 0:
                s -= R[j] * x[j]
        c[k] = s
    _kkt(qp, sp, mw, a, c, x, nuw)
    # iterative refinement (the Schur complement carries D⁻¹ = 1/ε_f: one correction step restores the digits)
    for _ in range(2):
        for i in range(n):
            if state[i] != 0:
                dx[i] = 0.0
                continue
            s = a[i]
            if i < nv:
                for j in range(nv):
                    if state[j] == 0:
                        s -= H[i, j] * x[j]
            else:
                s -= H[i, i] * x[i]
            ra[i] = s
        for i in range(n):
            if state[i] == 0:
                for k in range(mw):
                    ra[i] -= _row(A, C, m, rows[k])[i] * nuw[k]
            else:
                ra[i] = 0.0
        for k in range(mw):
            R = _row(A, C, m, rows[k])
            s = c[k]
            for j in range(n):
                if state[j] == 0:
                    s -= R[j] * x[j]
            rc[k] = s
        _kkt(qp, sp, mw, ra, rc, dx, drho)
        for i in range(n):
            if state[i] == 0:
                x[i] += dx[i]
        for k in range(mw):
            nuw[k] += drho[k]
    for k in range(m):
        nu[k] = nuw[k]
    for k in range(m, mw):
        r = rows[k] - m
        lam_r[r] = rstate[r] * nuw[k]
    for i in range(n):
        if state[i] == 0:
            continue
        s = block_cost_gradient(H, g, x, i, nv)
        for k in range(mw):
            s += _row(A, C, m, rows[k])[i] * nuw[k]
        lam_b[i] = -state[i] * s


@nb.njit(cache=True, nogil=True, fastmath=FASTMATH)
def block_prepare(qp, sp):
    """A new QP: the factor of H_vv kept by :func:`block_start` is stale."""
    sp.fac[0] = -1
    return 0


@nb.njit(cache=True, nogil=True, fastmath=FASTMATH)
def block_start(qp, sp, state, rstate):
    """Factor the working set: L Lᵀ = H_vv[F_v, F_v] on the free accelerations (kept while F_v is unchanged,
    ``fac[0]``), the working rows (A[:m], then the active rows of C) in ``rows``, Yv_k = L⁻¹ (R_k)_{F_v} and the
    Cholesky factor of S = R_F H_FF⁻¹ R_Fᵀ. Returns the number of working rows, NOT_POSITIVE_DEFINITE, or
    DEPENDENT_EQUALITIES (a row's squared sine to the ones before it below ``sp.dep_tol``)."""
    H, A, m, C = qp[0], qp[2], qp[4], qp[5]
    nv, rows, Yv, S, L, vfree, ffree, vrow, fac = sp.nv, sp.rows, sp.Yv, sp.S, sp.L, sp.vfree, sp.ffree, sp.vrow, sp.fac
    n = H.shape[0]
    p = C.shape[0]
    nfv = 0
    same = fac[0] >= 0
    for i in range(nv):
        if state[i] == 0:
            if same and (nfv >= fac[0] or vfree[nfv] != i):
                same = False
            vfree[nfv] = i
            nfv += 1
    if nfv != fac[0]:
        same = False
    nff = 0
    for i in range(nv, n):
        if state[i] == 0:
            ffree[nff] = i
            nff += 1
    fac[1] = nff
    if not same:
        for a in range(nfv):
            i = vfree[a]
            for c in range(a + 1):
                L[a, c] = H[i, vfree[c]]
        if not cholesky_lower(L, nfv):
            fac[0] = -1
            return NOT_POSITIVE_DEFINITE
        fac[0] = nfv
    mw = 0
    for k in range(m):
        rows[mw] = k
        mw += 1
    for r in range(p):
        if rstate[r] != 0:
            rows[mw] = m + r
            mw += 1
    if mw > nfv + nff:
        return DEPENDENT_EQUALITIES
    for k in range(mw):
        R = _row(A, C, m, rows[k])
        y = Yv[k]
        nz = False
        for a in range(nfv):
            y[a] = R[vfree[a]]
            if y[a] != 0.0:
                nz = True
        vrow[k] = nz
        if nz:
            forward_substitution(L, nfv, y)
        for c in range(k + 1):
            S[k, c] = _free_dot(0.0, nz and vrow[c], y, Yv[c], nfv, R, _row(A, C, m, rows[c]), ffree, nff, H)
    if not cholesky_lower(S, mw, sp.dep_tol):
        return DEPENDENT_EQUALITIES
    fac[2] = mw
    return mw


@nb.njit(cache=True, nogil=True, fastmath=FASTMATH)
def block_update(qp, sp, mw, state, rstate, ci, pside):
    """Refactor after constraint ``ci`` joined (``pside`` ≠ 0) or left ``state``/``rstate``."""
    return block_start(qp, sp, state, rstate)


@nb.njit(cache=True, nogil=True, fastmath=FASTMATH)
def block_target(qp, sp, pi, pside):
    """npv = the inward normal −pside · a_p of constraint ``pi`` (a bound < n, else the row pi − n)."""
    C = qp[5]
    npv = sp.npv
    n = npv.shape[0]
    for i in range(n):
        npv[i] = 0.0
    if pi < n:
        npv[pi] = -pside
    else:
        Cr = C[pi - n]
        for j in range(n):
            npv[j] = -pside * Cr[j]


@nb.njit(cache=True, nogil=True, fastmath=FASTMATH)
def block_direction(qp, sp, mw, state, rstate, pi, z, rb, rr):
    """The step (z, ρ) solving H_FF z_F + R_Fᵀ ρ = (n_p)_F, R_F z_F = 0 (:func:`_kkt`; z = 0 on the held
    variables), the oriented r of the working rows (−s ρ) in rr and of the held bounds (σ (n_p − H z − R_wᵀ ρ)_i)
    in rb. Returns (n_p·z, (n_p)_Fᵀ H_FF⁻¹ (n_p)_F)."""
    H, g, A, b, m, C, l, u, lb, ub = qp
    nv, rows, npv, a, c, nuw = sp.nv, sp.rows, sp.npv, sp.a, sp.c, sp.nuw
    n = z.shape[0]
    for i in range(n):
        a[i] = npv[i] if state[i] == 0 else 0.0
        z[i] = 0.0
    for k in range(mw):
        c[k] = 0.0
    q = _kkt(qp, sp, mw, a, c, z, nuw)
    nz = 0.0
    for i in range(n):
        nz += a[i] * z[i]
    for k in range(m, mw):
        r = rows[k] - m
        rr[r] = -rstate[r] * nuw[k]
    for i in range(n):
        if state[i] == 0:
            continue
        s = npv[i]
        if i < nv:
            for j in range(nv):
                s -= H[i, j] * z[j]
        for k in range(mw):
            s -= _row(A, C, m, rows[k])[i] * nuw[k]
        rb[i] = -state[i] * s
    return nz, q
