"""Compiled (numba) exact solver of the QP of :mod:`wbc.solvers.qp_data` (H positive definite; the first m rows of A
are the equalities): :func:`dual_active_set`, the dual active-set method of Goldfarb & Idnani ("A numerically stable
dual method for solving strictly convex quadratic programs", Math. Program. 27, 1983, §3; quadprog's and qpmad's),
warm-started from the previous call's working set, on a :class:`DenseSpace`: H = L Lᵀ once per call, the working
set's normals N kept through Y = L⁻¹Nᵀ and the Cholesky factor of S = Y Yᵀ. :func:`solve_qp_into` runs it for the
kinematic tick (``FastBackend``, :func:`kinematic_settings`) and the inverse-dynamics tick
(:class:`~wbc.solvers.compiled_id.CompiledIDSolver`), in the caller's workspaces.

A constraint linearly dependent on the working set only drops working constraints, which keeps the working set
independent — the degenerate case of nearly parallel self-collision rows or a sole corner at f_z = 0. Exit codes:
:mod:`wbc.solvers.status`.
"""

from __future__ import annotations

from collections import namedtuple

import numba as nb
import numpy as np

from wbc.compiled import FASTMATH, once_per_process
from wbc.solvers.linalg import (backward_substitution, carve, carve2, cholesky_lower, clip_eq_residual,
                                drop_infinite_active, forward_substitution, primal_from_multipliers, row_violation)
from wbc.solvers.status import (DEPENDENT_EQUALITIES, INFEASIBLE, ITERATION_CAP, NOT_POSITIVE_DEFINITE,
                                NOT_VERIFIED)

__all__ = ["ActiveSetArrays", "ActiveSetSettings", "DenseSpace", "QPWarmArrays", "carve_dense", "dual_active_set",
           "kinematic_settings", "load_active_set_kernels", "qp_ws_sizes", "solve_qp_into"]

#: workspace of the dense strategy: L (n, n) factor of H; Yw (K, n) = L⁻¹Nᵀ by working slot; Sm, Sf (K, K) Gram
#: matrix and its factor; t0 = L⁻¹g, y = L⁻¹a_p, w = ±y (n,); tmp, r, bw, nuw (K,); kind (0 equality, 1 row of C,
#: 2 bound), idx, side (K,) int64: the slots; sc (1,): wᵀw; rank_tol: the dependency pivot. K = n + m + 1.
DenseSpace = namedtuple("DenseSpace", "L Yw Sm Sf t0 y w tmp r bw nuw kind idx side sc rank_tol")
#: the arrays and settings of :func:`dual_active_set` (its Args)
ActiveSetArrays = namedtuple("ActiveSetArrays", "state rstate x nu mu lam_b lam_r z rb out")
ActiveSetSettings = namedtuple("ActiveSetSettings", "max_iter primal_tol dual_tol dep_tol block_tol hold_fixed "
                                                    "refresh start_cost verify_tol rank_tol")
#: the arrays of :func:`solve_qp_into` (its Args); it takes plain tuples in the namedtuples' order as well (numba types
#: them faster than a namedtuple: the ``fast`` backend and the ID solver pass them)
QPWarmArrays = namedtuple("QPWarmArrays", "state rstate x nu mu z eq_residual")
#: negative working multiplier, relative to the largest (at least 1), that fails :func:`dual_active_set`'s KKT check
DUAL_CHECK_TOL = 1e-9
#: largest residual of a working row (its units) that the dense strategy's equality-constrained optimum keeps without
#: a step of iterative refinement (:func:`_dense_refine`): the kinematic kernels' primal tolerance
REFINE_TOL = 1e-12


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
def _ws_push(qp, sp, mw, kd, q, side):
    """Append constraint q of kind kd (0 equality row, 1 row of C, 2 bound) held at ``side`` as working slot mw: its
    image y = L⁻¹a (in sp.y) as row mw of Y = L⁻¹Nᵀ and its products to S = Y Yᵀ (unfactored). Returns mw + 1."""
    b, l, u, lb, ub = qp[3], qp[6], qp[7], qp[8], qp[9]
    Yw, Sm, y = sp.Yw, sp.Sm, sp.y
    n = y.shape[0]
    for j in range(n):
        Yw[mw, j] = y[j]
    for k in range(mw + 1):
        s = 0.0
        for j in range(n):
            s += Yw[k, j] * y[j]
        Sm[mw, k] = s
        Sm[k, mw] = s
    if kd == 0:
        bw = b[q]
    elif kd == 1:
        bw = l[q] if side < 0 else u[q]
    else:
        bw = lb[q] if side < 0 else ub[q]
    sp.kind[mw], sp.idx[mw], sp.side[mw], sp.bw[mw] = kd, q, side, bw
    return mw + 1


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
def _dense_prepare(qp, sp):
    """L Lᵀ = H, t0 = L⁻¹ g; 0, or NOT_POSITIVE_DEFINITE."""
    H, g = qp[0], qp[1]
    n = H.shape[0]
    L = sp.L
    for i in range(n):
        for j in range(i + 1):
            L[i, j] = H[i, j]
    if not cholesky_lower(L, n):
        return NOT_POSITIVE_DEFINITE
    for i in range(n):
        sp.t0[i] = g[i]
    forward_substitution(L, n, sp.t0)
    return 0


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def _dense_start(qp, sp, state, rstate):
    """The working set from ``state``/``rstate`` (slots: equality rows, held rows of C, held bounds) and its
    factor; its size, or DEPENDENT_EQUALITIES."""
    A, m, C = qp[2], qp[4], qp[5]
    n = qp[0].shape[0]
    p = C.shape[0]
    L, y = sp.L, sp.y
    K = sp.kind.shape[0]
    mw = 0
    for k in range(m):
        _normal_image(L, n, A, k, True, y)
        mw = _ws_push(qp, sp, mw, 0, k, 0)
    for q in range(p):
        if rstate[q] != 0:
            _normal_image(L, n, C, q, True, y)
            mw = _ws_push(qp, sp, mw, 1, q, rstate[q])
            if mw == K:
                break
    for i in range(n):
        if state[i] != 0 and mw < K:
            _normal_image(L, n, C, i, False, y)
            mw = _ws_push(qp, sp, mw, 2, i, state[i])
    if mw <= n and _ws_factor(sp.Sm, sp.Sf, mw, sp.rank_tol):
        return mw
    return DEPENDENT_EQUALITIES


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def _dense_refine(qp, sp, mw, x):
    """One step of iterative refinement of :func:`_dense_eqp`'s x and ν on the working set (Golub & Van Loan,
    *Matrix Computations*, 4th ed., §3.5.3; S = Y Yᵀ squares the conditioning of the working rows) when a working
    row's residual r = b_W − N x exceeds :data:`REFINE_TOL`: S w = r, ν ← ν − w and x ← x + L⁻ᵀ Yᵀ w, the
    least-H-norm step onto the rows (sp.tmp and sp.w as scratch)."""
    A, C = qp[2], qp[5]
    n = x.shape[0]
    Yw, r, e, kind, idx = sp.Yw, sp.tmp, sp.w, sp.kind, sp.idx
    big = 0.0
    for k in range(mw):
        s = sp.bw[k]
        if kind[k] == 2:
            s -= x[idx[k]]
        else:
            row = A[idx[k]] if kind[k] == 0 else C[idx[k]]
            for j in range(n):
                s -= row[j] * x[j]
        r[k] = s
        big = max(big, abs(s))
    if big <= REFINE_TOL:
        return
    forward_substitution(sp.Sf, mw, r)
    backward_substitution(sp.Sf, mw, r)
    for j in range(n):
        e[j] = 0.0
    for k in range(mw):
        wk = r[k]
        sp.nuw[k] -= wk
        yk = Yw[k]
        for j in range(n):
            e[j] += yk[j] * wk
    backward_substitution(sp.L, n, e)
    for j in range(n):
        x[j] += e[j]


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def _dense_eqp(qp, sp, mw, x, nu, lam_b, lam_r):
    """The equality-constrained optimum on the working set (range-space method, Nocedal & Wright 2006 eq. 16.16 with
    H = L Lᵀ, Y = L⁻¹Nᵀ): S ν = −(b_W + Y L⁻¹g), x = −L⁻ᵀ (L⁻¹g + Yᵀν) (Hx + g + Nᵀν = 0); ν of the equality rows
    in nu[:m], the oriented multipliers side·ν of the working rows and bounds in lam_r, lam_b."""
    n = x.shape[0]
    m = qp[4]
    Yw, t0, nuw, kind, idx, side = sp.Yw, sp.t0, sp.nuw, sp.kind, sp.idx, sp.side
    for k in range(mw):
        s = sp.bw[k]
        for j in range(n):
            s += Yw[k, j] * t0[j]
        nuw[k] = -s
    forward_substitution(sp.Sf, mw, nuw)
    backward_substitution(sp.Sf, mw, nuw)
    primal_from_multipliers(sp.L, n, t0, Yw, nuw, mw, x)
    if mw:
        _dense_refine(qp, sp, mw, x)
    for k in range(m):
        nu[k] = nuw[k]
    for k in range(m, mw):
        if kind[k] == 1:
            lam_r[idx[k]] = side[k] * nuw[k]
        else:
            lam_b[idx[k]] = side[k] * nuw[k]


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def _dense_target(qp, sp, pi, pside):
    """y = L⁻¹ a_p and w = −pside · y (the inward normal's image) of constraint ``pi`` (a bound < n, else the row
    pi − n), wᵀw in sc[0]."""
    C = qp[5]
    n = sp.y.shape[0]
    is_row = pi >= n
    _normal_image(sp.L, n, C, pi - n if is_row else pi, is_row, sp.y)
    s = -float(pside)
    ww = 0.0
    for j in range(n):
        sp.w[j] = s * sp.y[j]
        ww += sp.w[j] * sp.w[j]
    sp.sc[0] = ww


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def _dense_direction(qp, sp, mw, z, rb, rr):
    """r = S⁻¹ Y w, z = L⁻ᵀ (w − Yᵀ r) (the direction keeping W's constraints at their bounds, n_p = Nᵀr + Hz),
    the oriented r of the working rows in rr and of the bounds in rb; returns (n_p·z = wᵀw − (Yw)ᵀr, wᵀw)."""
    n = z.shape[0]
    m = qp[4]
    Yw, Sf, w, tmp, r, kind, idx, side = sp.Yw, sp.Sf, sp.w, sp.tmp, sp.r, sp.kind, sp.idx, sp.side
    ww = sp.sc[0]
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
        z[j] = w[j]
    for k in range(mw):
        rk = r[k]
        for j in range(n):
            z[j] -= Yw[k, j] * rk
    backward_substitution(sp.L, n, z)
    for k in range(m, mw):
        if kind[k] == 1:
            rr[idx[k]] = -side[k] * r[k]
        else:
            rb[idx[k]] = -side[k] * r[k]
    return nz, ww


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def _dense_update(qp, sp, mw, ci, pside):
    """Constraint ``ci`` (a bound < n, else the row ci − n) joins the working slots held at ``pside`` (its image y
    from :func:`_dense_target`), or leaves them (``pside`` 0; the last slot takes its place); refactor S. The new
    size, or DEPENDENT_EQUALITIES."""
    n = sp.y.shape[0]
    Yw, Sm, kind, idx, side, bw = sp.Yw, sp.Sm, sp.kind, sp.idx, sp.side, sp.bw
    kd, q = (1, ci - n) if ci >= n else (2, ci)
    if pside != 0:
        if mw == kind.shape[0]:
            return DEPENDENT_EQUALITIES
        mw = _ws_push(qp, sp, mw, kd, q, pside)
    else:
        for k in range(qp[4], mw):
            if kind[k] == kd and idx[k] == q:
                e = mw - 1
                if k != e:
                    for j in range(n):
                        Yw[k, j] = Yw[e, j]
                    for j in range(mw):
                        Sm[k, j] = Sm[e, j]
                    for j in range(mw):
                        Sm[j, k] = Sm[j, e]
                    Sm[k, k] = Sm[e, e]
                    kind[k], idx[k], side[k], bw[k] = kind[e], idx[e], side[e], bw[e]
                mw = e
                break
    if not _ws_factor(Sm, sp.Sf, mw, sp.rank_tol):
        return DEPENDENT_EQUALITIES
    return mw


@nb.njit(cache=True, nogil=True, fastmath=FASTMATH)
def _violation(C, l, u, lb, ub, x, state, rstate, tol):
    """The constraint outside the working set violated most beyond ``tol`` (bounds first, then rows; the first of
    equal ones): (index — variable i or row n + r —, side −1 lower / +1 upper); index −1 when none."""
    n = x.shape[0]
    worst = -tol
    wi = -1
    side = 0
    for i in range(n):
        if state[i] != 0:
            continue
        if x[i] - lb[i] < worst:
            worst, wi, side = x[i] - lb[i], i, -1
        elif ub[i] - x[i] < worst:
            worst, wi, side = ub[i] - x[i], i, 1
    for r in range(C.shape[0]):
        if rstate[r] != 0 or (l[r] == -np.inf and u[r] == np.inf):
            continue
        s = 0.0
        Cr = C[r]
        for j in range(n):
            s += Cr[j] * x[j]
        if s - l[r] < worst:
            worst, wi, side = s - l[r], n + r, -1
        elif u[r] - s < worst:
            worst, wi, side = u[r] - s, n + r, 1
    return wi, side


@nb.njit(cache=True, nogil=True, fastmath=FASTMATH)
def dual_active_set(qp, space, arrays, settings):
    """Exact solution of the QP (module docstring) by the dual active-set method of Goldfarb & Idnani (1983, §3).

    Start: the equality-constrained optimum on the warm start (a dependent one emptied; lb = ub variables kept when
    ``hold_fixed``), whose inequality with the most negative multiplier leaves until none is below −``dual_tol``.
    Then, while a constraint is violated by more than ``primal_tol``, the most violated, p, is approached along the
    step keeping the working set W at its bounds: the full step (p joins W), or the first working multiplier to
    reach 0 among those with r_j > ``block_tol``·max|r| (it leaves). When n_p is dependent on W (n_p·z ≤ ``dep_tol``
    · n_pᵀH⁻¹n_p) only the second exists; when none does, INFEASIBLE. With ``refresh`` x and the multipliers are
    recomputed on W after each full step, else once no constraint is violated (the method then goes on if a
    multiplier or a constraint is wrong). At the end the held bounds are set exactly, x clipped into [lb, ub], and
    the KKT check: working multipliers ≥ −:data:`DUAL_CHECK_TOL` (relative), rows satisfied to ``verify_tol``.

    Args:
        qp: (H (n, n), g (n,), A (≥ m, n), b (≥ m,), m, C (p, n), l, u (p,), lb, ub (n,)), ±inf for absent sides.
        space: a :class:`DenseSpace`.
        arrays: an :data:`ActiveSetArrays`:

            state (n,) int8, rstate (p,) int8, in/out: working set (0 out, −1 held at the lower, +1 at the upper
            side); read as the warm start. x (n,), nu (≥ m,): out — solution, multipliers of the equality rows.
            mu (p,): out, row multipliers (H x + g + Aᵀν + Cᵀμ + z_b = 0 convention: μ ≤ 0 at l, ≥ 0 at u, 0 off
            W); workspace until the end. lam_b (n,), lam_r (p,): out, oriented multipliers (≥ 0) of the held
            bounds and rows (valid where held). z (n,), rb (n,): workspace (the step, the bounds' r). out (3,):
            out — largest residual of x (equality rows, rows), steps, working-set size; (inf, 0, 0) after an exit
            code other than NOT_VERIFIED (no checked point: every entry is written on every call).
        settings: an :data:`ActiveSetSettings`:

            max_iter: steps allowed (drops and GI steps, plus ``start_cost`` per factorisation of a warm or cold
            start). primal_tol: violation that makes a constraint enter. dual_tol: negative multiplier that makes
            one leave at a start. dep_tol: dependency test. block_tol: relative r below which a working constraint
            does not block. hold_fixed: variables with lb = ub are held from the start and never leave.
            refresh: see above. verify_tol: largest residual of the final check (inf: not checked). rank_tol: not
            read here (the ``space``'s dependency pivot, :func:`carve_dense`).

    Returns:
        steps (≥ 1), or NOT_POSITIVE_DEFINITE / DEPENDENT_EQUALITIES (a dependent working set) / ITERATION_CAP /
        INFEASIBLE / NOT_VERIFIED (:mod:`wbc.solvers.status`).
    """
    H, g, A, b, m, C, l, u, lb, ub = qp
    state, rstate, x, nu, mu, lam_b, lam_r, z, rb, out = arrays
    max_iter, primal_tol, dual_tol, dep_tol, block_tol, hold_fixed, refresh, start_cost, verify_tol, _ = settings
    n = H.shape[0]
    p = C.shape[0]
    out[0] = np.inf  # an exit before the final check reports no residual, not the workspace's last one
    out[1] = 0.0
    out[2] = 0.0
    for i in range(n):
        if hold_fixed and lb[i] == ub[i]:
            state[i] = -1
    drop_infinite_active(state, lb, ub)
    drop_infinite_active(rstate, l, u)
    code = _dense_prepare(qp, space)
    if code < 0:
        return code
    steps = start_cost
    if steps > max_iter:
        return ITERATION_CAP
    mw = _dense_start(qp, space, state, rstate)
    started = False  # a constraint has been approached: a failed factorisation ends the call
    need_eqp = True
    exact = False
    while True:
        if need_eqp:
            if mw < 0:
                if mw == NOT_POSITIVE_DEFINITE or started:
                    return mw
                # a dependent warm start: from the equality-constrained optimum (fixed variables held) instead
                cleared = False
                for i in range(n):
                    if state[i] != 0 and not (hold_fixed and lb[i] == ub[i]):
                        state[i] = 0
                        cleared = True
                for r in range(p):
                    if rstate[r] != 0:
                        rstate[r] = 0
                        cleared = True
                if not cleared:
                    return mw
                steps += start_cost
                if steps > max_iter:
                    return ITERATION_CAP
                mw = _dense_start(qp, space, state, rstate)
                continue
            # x, multipliers on W; the inequality with the most negative multiplier leaves until none is
            _dense_eqp(qp, space, mw, x, nu, lam_b, lam_r)
            worst = -dual_tol
            kw = -1
            for r in range(p):
                if rstate[r] != 0 and lam_r[r] < worst:
                    worst, kw = lam_r[r], n + r
            for i in range(n):
                if state[i] != 0 and lam_b[i] < worst and not (hold_fixed and lb[i] == ub[i]):
                    worst, kw = lam_b[i], i
            if kw >= 0:
                steps += 1
                if steps > max_iter:
                    return ITERATION_CAP
                if kw < n:
                    state[kw] = 0
                else:
                    rstate[kw - n] = 0
                mw = _dense_update(qp, space, mw, kw, 0)
                continue
            need_eqp = False
            exact = True
        pi, pside = _violation(C, l, u, lb, ub, x, state, rstate, primal_tol)
        if pi < 0:
            if exact:
                break  # x and the multipliers are those of the equality-constrained optimum on W
            need_eqp = True  # after steps: recomputed on the final W and checked again
            continue
        started = True
        for r in range(p):
            if rstate[r] != 0 and lam_r[r] < 0.0:
                lam_r[r] = 0.0
        for i in range(n):
            if state[i] != 0 and lam_b[i] < 0.0:
                lam_b[i] = 0.0
        _dense_target(qp, space, pi, pside)
        lam_p = 0.0
        exact = False
        while True:
            steps += 1
            if steps > max_iter:
                return ITERATION_CAP
            nz, q = _dense_direction(qp, space, mw, z, rb, mu)
            thr = 0.0
            if block_tol > 0.0:
                for r in range(p):
                    if rstate[r] != 0 and abs(mu[r]) > thr:
                        thr = abs(mu[r])
                for i in range(n):
                    if state[i] != 0 and abs(rb[i]) > thr:
                        thr = abs(rb[i])
                thr *= block_tol
            # the first working multiplier to reach 0
            t2 = np.inf
            blk = -1
            for r in range(p):
                if rstate[r] != 0 and mu[r] > thr and lam_r[r] / mu[r] < t2:
                    t2, blk = lam_r[r] / mu[r], n + r
            for i in range(n):
                if state[i] != 0 and rb[i] > thr and lam_b[i] / rb[i] < t2 and not (hold_fixed and lb[i] == ub[i]):
                    t2, blk = lam_b[i] / rb[i], i
            full = False
            if not nz > dep_tol * q:
                if blk < 0:
                    return INFEASIBLE
                t = t2
            else:
                if pi < n:
                    s = x[pi]
                    t1 = ((lb[pi] - s) if pside < 0 else (s - ub[pi])) / nz
                else:
                    s = 0.0
                    Cr = C[pi - n]
                    for j in range(n):
                        s += Cr[j] * x[j]
                    t1 = ((l[pi - n] - s) if pside < 0 else (s - u[pi - n])) / nz
                full = t1 <= t2
                t = t1 if full else t2
                for j in range(n):
                    x[j] += t * z[j]
            for r in range(p):
                if rstate[r] != 0:
                    lam_r[r] -= t * mu[r]
                    if lam_r[r] < 0.0:
                        lam_r[r] = 0.0
            for i in range(n):
                if state[i] != 0:
                    lam_b[i] -= t * rb[i]
                    if lam_b[i] < 0.0:
                        lam_b[i] = 0.0
            lam_p += t
            if full:  # p joins the working set
                if pi < n:
                    state[pi] = pside
                    lam_b[pi] = lam_p
                    x[pi] = lb[pi] if pside < 0 else ub[pi]
                else:
                    rstate[pi - n] = pside
                    lam_r[pi - n] = lam_p
                mw = _dense_update(qp, space, mw, pi, pside)
                if mw < 0:
                    return mw
                if refresh:
                    _dense_eqp(qp, space, mw, x, nu, lam_b, lam_r)
                    exact = True
                break
            # partial step: the blocking constraint leaves
            if blk < n:
                state[blk] = 0
                lam_b[blk] = 0.0
            else:
                rstate[blk - n] = 0
                lam_r[blk - n] = 0.0
            mw = _dense_update(qp, space, mw, blk, 0)
            if mw < 0:
                return mw
    # outputs: the held bounds exactly, x clipped into the bounds, residuals, multipliers, the KKT check
    for i in range(n):
        if state[i] < 0:
            x[i] = lb[i]
        elif state[i] > 0:
            x[i] = ub[i]
    res = row_violation(C, l, u, x, n, p, clip_eq_residual(x, lb, ub, A, b, n, m))
    worst = 0.0
    big = 1.0
    for i in range(n):
        if state[i] != 0 and not (hold_fixed and lb[i] == ub[i]):
            big = max(big, abs(lam_b[i]))
            worst = min(worst, lam_b[i])
    for r in range(p):
        mu[r] = 0.0
        if rstate[r] != 0:
            big = max(big, abs(lam_r[r]))
            worst = min(worst, lam_r[r])
            mu[r] = rstate[r] * lam_r[r]
    out[0] = res
    out[1] = steps
    out[2] = mw
    if worst < -DUAL_CHECK_TOL * big or res > verify_tol:
        return NOT_VERIFIED
    return max(steps, 1)


@nb.njit(cache=True, nogil=True)
def qp_ws_sizes(n, m, p):
    """Lengths of the float and int64 workspaces of :func:`solve_qp_into` for n variables, m equality, p other rows."""
    K = n + m + 1
    return n * n + K * n + 2 * K * K + 6 * n + 4 * K + p + 4, 3 * K


@nb.njit(cache=True, nogil=True)
def carve_dense(fw, iw, n, m, p, rank_tol):
    """Disjoint views of the float64 and int64 workspaces ``fw``, ``iw`` (at least :func:`qp_ws_sizes` (n, m, p)
    long) for :func:`dual_active_set` on a QP of n variables, m equality rows, p rows of C: (a :class:`DenseSpace`
    of dependency pivot ``rank_tol``, lam_b (n,), lam_r (p,), z (n,), rb (n,), out (3,))."""
    K = n + m + 1  # a working set of independent constraints has at most n members
    # two 2-D views in all (each reshape costs a call): L, Yw, then t0, y, w, z, lam_b, rb by n columns; Sm, Sf,
    # then tmp, r, bw, nuw by K columns
    vn, o = carve2(fw, 0, n + K + 6, n)
    vk, o = carve2(fw, o, 2 * K + 4, K)
    lam_r, o = carve(fw, o, p)
    sc, o = carve(fw, o, 1)
    out, o = carve(fw, o, 3)
    e, f = n + K, 2 * K
    space = DenseSpace(vn[:n], vn[n:e], vk[:K], vk[K:f], vn[e], vn[e + 1], vn[e + 2], vk[f], vk[f + 1], vk[f + 2],
                       vk[f + 3], iw[:K], iw[K:2 * K], iw[2 * K:3 * K], sc, rank_tol)
    return space, vn[e + 4], lam_r, vn[e + 3], vn[e + 5], out


@nb.njit(cache=True, nogil=True)
def kinematic_settings(max_iter):
    """The kinematic tick's :data:`ActiveSetSettings`, a plain tuple: ``max_iter`` (drops and GI steps), primal and
    dual tolerance 1e-12, dependency test 1e-10, blocking r above 1e-9 of the largest, no held bounds, no refresh, no
    final check, dependency pivot of S² 1e-24."""
    return (max_iter, 1e-12, 1e-12, 1e-10, 1e-9, False, False, 0, np.inf, 1e-24)


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def solve_qp_into(qp, arrays, settings, fw, iw):
    """:func:`dual_active_set` on a :class:`DenseSpace` in the caller's workspaces: no allocation (a kernel compiled
    without numba's runtime may call it).

    Args:
        qp: a :class:`~wbc.solvers.qp_data.QPData` (n variables, m equality rows, p rows of C).
        arrays: a :data:`QPWarmArrays`: state (n,), rstate (p,) int8, in/out: working set (0 out, −1 lower, +1 upper
            side), read as the warm start; out: x (n,), nu (≥ m,), mu (p,), z (n,) (H x + g + Aᵀnu + Cᵀmu + z = 0;
            mu, z ≤ 0 at a lower side, ≥ 0 at an upper one), eq_residual (1,): largest row residual (inf after an
            exit code other than NOT_VERIFIED).
        settings: an :data:`ActiveSetSettings` (:func:`kinematic_settings`, or the ID tick's of
            :class:`~wbc.solvers.compiled_id.CompiledIDSolver`).
        fw, iw: float64 and int64 workspaces, at least :func:`qp_ws_sizes` (n, m, p) long.

    Returns:
        steps (≥ 1) on success, x inside [lb, ub] exactly; or a negative exit code.
    """
    H, g, A, b, C, l, u, lb, ub = qp
    state, rstate, x, nu, mu, z, eq_residual = arrays
    n, m, p = H.shape[0], A.shape[0], C.shape[0]
    space, lam_b, lam_r, zd, rb, out = carve_dense(fw, iw, n, m, p, settings[9])
    it = dual_active_set((H, g, A, b, m, C, l, u, lb, ub), space,
                         ActiveSetArrays(state, rstate, x, nu, mu, lam_b, lam_r, zd, rb, out), settings)
    eq_residual[0] = out[0]
    for i in range(n):
        z[i] = state[i] * lam_b[i] if state[i] != 0 else 0.0
    return it


@once_per_process
def load_active_set_kernels() -> None:
    """Compile (or load), once per process, :func:`solve_qp_into` for its callers' argument types (plain tuples):
    the ``fast`` backend's and the kinematic tick's loaders run after this one and link this version."""
    n, m, p = 2, 1, 1
    fsize, isize = qp_ws_sizes(n, m, p)
    solve_qp_into((np.eye(n), np.ones(n), np.ones((m, n)), np.ones(m), np.ones((p, n)), -np.ones(p), np.ones(p),
                   -np.ones(n), np.ones(n)),
                  (np.zeros(n, np.int8), np.zeros(p, np.int8), np.empty(n), np.empty(m), np.empty(p), np.empty(n),
                   np.empty(1)),
                  kinematic_settings(10), np.empty(fsize), np.empty(isize, np.int64))
