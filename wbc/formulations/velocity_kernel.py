"""Compiled (numba) kernels of the kinematic QP of :mod:`wbc.formulations.velocity`: its cost (:func:`form_qp`), its
exact solve with the floating base eliminated (:func:`kinematic_solve`), the compiled tick in one call on two pairs
of packed arrays (:func:`kinematic_tick_packed`: every array argument of a call from Python costs its unboxing) and
where a contact frame ends against where its row sent it (:func:`contact_drift`).
"""

from __future__ import annotations

from collections import namedtuple

import numba as nb
import numpy as np

from wbc.compiled import FASTMATH, NO_NRT, once_per_process
from wbc.constraints.limits import intersect_position_bounds
from wbc.lie import placement_log6_into, rotation_gap, translation_gap
from wbc.solvers.active_set import kinematic_settings, qp_ws_sizes, solve_qp_into
from wbc.solvers.linalg import carve, carve2, equality_residual, row_violation
from wbc.solvers.qp_data import QPData
from wbc.solvers.status import NOT_REDUCIBLE, RESIDUAL

__all__ = ["all_finite", "command_within", "contact_drift", "contact_pair_drift", "form_qp", "KernelBox",
           "kinematic_pack", "load_kinematic_kernels", "kinematic_solve", "kinematic_tick_packed", "kinematic_views",
           "load_kinematic_parts", "NO_KERNEL_BOX", "NONFINITE_RHS", "rows_pack", "task_rows", "TaskRows",
           "TickBuffers", "weighted_rows"]

#: the stacked task rows of the cost (:func:`form_qp`): J (mt, nv), e (mt,), rowp (3, mt) float64 (gain K (1/s),
#: weight w, feed-forward of each row), pw (kp,) float64 posture weights, prow (kp,) int64 their velocity indices and
#: row (nv,), the cost formation's scratch
TaskRows = namedtuple("TaskRows", "J e rowp pw prow row")

#: the box arguments of :func:`kinematic_tick_packed`: ``idx`` (2, k) int64 and ``limits`` (3, k) float64 of a
#: joint position limit (:meth:`wbc.constraints.JointPositionLimit.packed`) and ``const`` (2, nv) float64, the
#: constant bounds' intersection (lb, ub as rows); ``const`` (0, 0): the box is left as assembled
KernelBox = namedtuple("KernelBox", "idx limits const")

#: the buffers of :func:`kinematic_tick_packed`: ``fb``/``ib`` of :func:`kinematic_pack`, ``sfb``/``sib`` of
#: :func:`rows_pack` and ``states`` (nr + p,) int8, the working sets of the nr reduced variables and p inequality rows
TickBuffers = namedtuple("TickBuffers", "fb ib sfb sib states")


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def _eliminate_base(A, b, er, nr, Eb, Tc):
    """Tc[:, :nr] = T = E_b⁻¹ E_j and Tc[:, nr] = c = E_b⁻¹ b_E for the rows E = A[er:er + 6] (E_b: the base's
    columns) by Gaussian elimination with partial pivoting; False when a pivot ≤ 1e-12 × E_b's largest entry."""
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
    """out_J[k] = √w_k J_k, out_r[k] = √w_k v*_k (:func:`_weighted_row`) of each stacked task row, as a strict
    priority level takes them (:func:`wbc.solvers.hierarchy.solve_lexicographic`). Js (mt, nv), es (mt,), rowp (3, mt):
    as :func:`form_qp`; out_J (mt, nv), out_r (mt,): out."""
    for k in range(Js.shape[0]):
        out_r[k] = _weighted_row(Js, es, rowp, k, out_J[k])


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def form_qp(sfb, sib, diff, pgain, damping, H, g):
    """The cost of the kinematic QP (:mod:`wbc.formulations.velocity`) from its stacked task rows, written into H
    and g (compiled; the one cost formation of every kinematic route):

        H = ε I + Σ_k w_k J_kᵀ J_k + Σ_a d_a e_{i_a} e_{i_a}ᵀ,    g = −Σ_k w_k v*_k J_kᵀ − Σ_a d_a s_a e_{i_a}

    i.e. ½ vᵀHv + gᵀv = ½ Σ_k w_k (J_k v − v*_k)² + ½ Σ_a d_a (v_{i_a} − s_a)² + ½ ε ‖v‖² up to a constant, with
    v*_k = ff_k − K_k e_k and s_a = −K_p diff[i_a] (a posture task: a selection Jacobian, so its cost is diagonal).
    Each row enters as (√w_k J_k)ᵀ(√w_k J_k), whole rows of H at a time: H is exactly symmetric without a mirror.

    Args:
        sfb, sib: the arrays of :func:`rows_pack` (:class:`TaskRows`: J, e, rowp of each row — a row with w = 0 is
            skipped —, the posture's weights d and velocity indices i_a, kp = 0: no posture).
        diff (nv,): q ⊖ q* of the posture task; pgain: its gain K_p (1/s). damping: ε > 0. H (nv, nv), g (nv,): out.

    Returns:
        trace(H) + Σ g: finite exactly when every number that entered H and g is (NaN and ±inf propagate into it).
    """
    Js, es, rowp, pw, prow, row = task_rows(sfb, sib)
    n = H.shape[0]
    g[:] = 0.0
    first = True  # H not yet written: the first weighted row's products are added to 0.0 row by row (no memset)
    for k in range(Js.shape[0]):
        if rowp[1, k] == 0.0:
            continue
        swr = _weighted_row(Js, es, rowp, k, row)
        for i in range(n):
            a = row[i]
            Hi = H[i]
            if a == 0.0:
                if first:
                    for j in range(n):
                        Hi[j] = 0.0
                continue
            g[i] -= a * swr
            if first:
                for j in range(n):
                    Hi[j] = 0.0 + a * row[j]
            else:
                for j in range(n):
                    Hi[j] += a * row[j]
        first = False
    if first:
        H[:, :] = 0.0
    for a in range(prow.shape[0]):
        i = prow[a]
        H[i, i] += pw[a]
        g[i] -= pw[a] * (-pgain * diff[i])
    check = 0.0
    for i in range(n):
        H[i, i] += damping
        check += H[i, i] + g[i]
    return check


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def _solve_views(qp, er, ws):
    """Views of :func:`kinematic_solve`'s float workspace ``ws``: the reduced QP (a plain tuple in
    :class:`~wbc.solvers.qp_data.QPData`'s order), x, z, Tc, Eb, V, wb, mu, nu, eqres and the solver's workspace."""
    n0 = 6 if er >= 0 else 0
    n, mr, p = qp[0].shape[0], qp[2].shape[0] - n0, qp[4].shape[0]
    nr = n - n0
    H, o = carve2(ws, n, nr, nr)
    vec, o = carve2(ws, o, 5, nr)  # g, lbr, ubr, x, z
    Tc, o = carve2(ws, o, 6, nr + 1)
    Eb, o = carve2(ws, o, 6, 6)
    V, o = carve2(ws, o, 6, nr)
    wb, o = carve(ws, o, 6)
    Cr, o = carve2(ws, o, p, nr)
    rows, o = carve2(ws, o, 3, p)  # lr, ur, mu
    Ar, o = carve2(ws, o, mr, nr)
    eqs, o = carve2(ws, o, 2, mr)  # br, nu
    return ((H, vec[0], Ar, eqs[0], Cr, rows[0], rows[1], vec[1], vec[2]), vec[3], vec[4], Tc, Eb, V, wb,
            rows[2], eqs[1], ws[o:o + 1], ws[o + 1:])


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def _reduce_cost(H, g, n0, nr, Tc, V, wb, Hr, gr):
    """Hr = Zᵀ H Z and gr = Zᵀ (g + H v₀) for v = Z v_j + v₀, Z = [−T; I], v₀ = [c; 0] (the base's v_b = c − T v_j):
    Hr = H_jj − H_jb T − Tᵀ V with V = H_bj − H_bb T, gr = (g_j + H_jb c) − Tᵀ (g_b + H_bb c); the lower triangle
    formed, mirrored (Hr exactly symmetric). n0 = 0: a copy (H symmetric)."""
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
def kinematic_solve(qp, er, dt, tolerance, max_iter, state, rstate, ws, iws, v):
    """The exact optimum of the assembled kinematic QP (``qp``, read, never written) with the floating base
    eliminated: the 6 equality rows E = A[er:er + 6] (a contact's LOCAL Jacobian, E_b invertible) give
    v_b = c − T v_j (T = E_b⁻¹E_j, c = E_b⁻¹b_E), and the QP is solved exactly in the nv − 6 joint velocities with
    the other rows, H, g (:func:`_reduce_cost`), A and C substituted (variable elimination: Nocedal & Wright,
    *Numerical Optimization*, 2nd ed., §15.3, eq. 15.14). The base must be unbounded (else ``NOT_REDUCIBLE``). The
    reduced QP goes to :func:`~wbc.solvers.active_set.solve_qp_into`, warm-started from ``state``/``rstate``; the
    residuals of the original rows are then checked against ``tolerance``.

    Args:
        qp: a :class:`~wbc.solvers.qp_data.QPData`, H (nv, nv) symmetric positive definite, g (nv,), A (neq, nv),
            b (neq,), C (p, nv), l/u (p,), lb/ub (nv,): the assembled QP (a row of C with l = −inf and u = inf is
            unused).
        er: first row of the eliminating block, or −1 (no elimination). dt (s): the workspace receives v·dt.
        tolerance: largest residual accepted. max_iter: working-set iterations.
        state (nr,) int8, rstate (p,) int8: working sets (warm start, in/out). ws, iws: workspaces from
            :func:`kinematic_views`; on success ws[:nv] = v·dt. v (nv,): out.

    Returns:
        working-set iterations (≥ 1), or a negative exit code (the caller solves the tick by the general path).
    """
    H, g, A, b, C, l, u, lb, ub = qp
    n = H.shape[0]
    n0 = 6 if er >= 0 else 0
    nr = n - n0
    neq = A.shape[0]
    p = C.shape[0]
    red, x, z, Tc, Eb, V, wb, mu, nu, eqres, qpws = _solve_views(qp, er, ws)
    Hr, gr, Ar, br, Cr, lr, ur, lbr, ubr = red
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
    # plain tuples, the types of the fast backend's call: one compiled version of solve_qp_into
    it = solve_qp_into(red, (state, rstate, x, nu, mu, z, eqres), kinematic_settings(max_iter), qpws, iws)
    if it >= 1 and not _finish(qp, Tc, x, n0, dt, tolerance, ws, v):
        it = RESIDUAL
    if it < 1:
        state[:] = 0
        rstate[:] = 0
    return it


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def _finish(qp, Tc, x, n0, dt, tolerance, ws, v):
    """v from the reduced solution x (joint velocities; the base's v_b = c − T v_j when n0 = 6), then the residuals
    of the original rows of ``qp`` (:class:`~wbc.solvers.qp_data.QPData`) A v = b, l ≤ C v ≤ u: False when one
    exceeds ``tolerance``, else ws[:nv] = v·dt."""
    A, b, C = qp.A, qp.b, qp.C
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
    res = row_violation(C, qp.l, qp.u, v, n, p, equality_residual(A, b, v, n, neq))
    if not res <= tolerance:
        return False
    for i in range(n):
        ws[i] = v[i] * dt
    return True


#: :func:`kinematic_tick_packed`'s code when the equality right-hand side is not finite (nothing solved); below every
#: exit code of :mod:`wbc.solvers.status`
NONFINITE_RHS = -1000

#: the ``box`` of :func:`kinematic_tick_packed` when it leaves the box as assembled
NO_KERNEL_BOX = KernelBox(np.zeros((2, 0), np.int64), np.zeros((3, 0)), np.zeros((0, 0)))

def kinematic_pack(nv: int, n_eq: int, n_in: int, er: int) -> tuple[np.ndarray, np.ndarray]:
    """The float and int64 arrays that the compiled tick reads (their parts: :func:`kinematic_views`) for a
    kinematic QP of nv velocities, ``n_eq`` equality and ``n_in`` inequality rows, eliminating the floating base
    through the equality rows from ``er`` (−1: none): the QP's buffers and :func:`kinematic_solve`'s workspaces."""
    nr, mr = (nv - 6, n_eq - 6) if er >= 0 else (nv, n_eq)
    fsize, isize = qp_ws_sizes(nr, mr, n_in)
    # the float workspace that _solve_views lays out
    views = nv + nr * nr + 5 * nr + 6 * (nr + 1) + 36 + 6 * nr + 6 + n_in * nr + 3 * n_in + mr * nr + 2 * mr + 1
    fb = np.zeros(nv * (nv + n_eq + n_in + 3) + n_eq + 2 * n_in + views + fsize)
    ib = np.zeros(4 + isize, np.int64)
    ib[:4] = (nv, n_eq, n_in, er)
    return fb, ib


@nb.njit(cache=True, nogil=True)
def kinematic_views(fb, ib):
    """Views of the arrays of :func:`kinematic_pack`: (the QP (:class:`~wbc.solvers.qp_data.QPData`), box (2, nv) =
    its lb and ub as the rows of one array, the float workspace ws (ws[:nv] = v·dt after a solve), the int workspace
    iws, er).
    From Python, ``kinematic_views.py_func`` gives them as numpy views (no numba allocation)."""
    nv, neq, p = ib[0], ib[1], ib[2]
    M, o = carve2(fb, 0, nv + neq + p + 2, nv)  # H, A, C, lb, ub: one view (each reshape costs a call)
    g, o = carve(fb, o, nv)
    b, o = carve(fb, o, neq)
    l, o = carve(fb, o, p)
    u, o = carve(fb, o, p)
    e = nv + neq + p
    box = M[e:]
    return QPData(M[:nv], g, M[nv:nv + neq], b, M[nv + neq:e], l, u, box[0], box[1]), box, fb[o:], ib[4:], ib[3]


def rows_pack(mt: int, nv: int, prow: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The float and int64 arrays of mt stacked task rows of nv velocities that the compiled tick reads (their
    parts: :func:`task_rows`), zeroed but for ``prow`` (kp,), the velocity indices of a posture diagonal."""
    prow = np.asarray(prow, np.int64)
    return np.zeros(mt * nv + 4 * mt + prow.size + nv), np.concatenate((np.array([mt, nv, prow.size], np.int64), prow))


@nb.njit(cache=True, nogil=True)
def task_rows(sfb, sib):
    """Views of the arrays of :func:`rows_pack`: a :class:`TaskRows`."""
    mt, nv, kp = sib[0], sib[1], sib[2]
    o = mt * nv
    return TaskRows(sfb[:o].reshape((mt, nv)), sfb[o:o + mt], sfb[o + mt:o + 4 * mt].reshape((3, mt)),
                    sfb[o + 4 * mt:o + 4 * mt + kp], sib[3:3 + kp], sfb[o + 4 * mt + kp:o + 4 * mt + kp + nv])


@nb.njit(cache=True, fastmath=FASTMATH, **NO_NRT)  # GIL kept: releasing it costs more per call than a thread could gain
def kinematic_tick_packed(bufs, diff, pgain, damping, v, dt, tolerance, max_iter, q, box):
    """The compiled tick in one call on ``bufs`` (:class:`TickBuffers`), the same numbers as these calls one after
    the other: when ``box`` (:class:`KernelBox`) has ``const`` (2, nv), lb, ub ← its rows, then
    :func:`wbc.constraints.limits.intersect_position_bounds` (q (nq,), ``box.idx``, ``box.limits``, dt) (``const``
    (0, 0): lb, ub as assembled); :func:`form_qp` into H, g (``diff`` … ``damping`` as there); its check and
    :func:`all_finite` on b; :func:`kinematic_solve` (working sets ``bufs.states`` = state (nr,) then rstate (p,));
    :func:`command_within` on v.

    Returns:
        (code, guard): code = ``NONFINITE_RHS`` (a number of the cost or of b is NaN or inf: nothing solved,
        ``states`` untouched), else the return of :func:`kinematic_solve`; guard = True when code ≥ 1 and v passed
        both screens.
    """
    qp, _, ws, iws, er = kinematic_views(bufs.fb, bufs.ib)
    H, g, A, b, C, l, u, lb, ub = qp
    const_box = box.const
    if const_box.shape[0] == 2:
        for i in range(lb.shape[0]):
            lb[i] = const_box[0, i]
            ub[i] = const_box[1, i]
        intersect_position_bounds(q, box.idx, box.limits, dt, lb, ub)
    check = form_qp(bufs.sfb, bufs.sib, diff, pgain, damping, H, g)
    if not (np.isfinite(check) and all_finite(b)):
        return NONFINITE_RHS, False
    nr = H.shape[0] - (6 if er >= 0 else 0)
    states = bufs.states
    it = kinematic_solve(qp, er, dt, tolerance, max_iter, states[:nr], states[nr:], ws, iws, v)
    if it < 1:
        return it, False
    return it, command_within(v, lb, ub, C, l, u, tolerance)


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True, **NO_NRT)
def contact_drift(logs, b, starts, factors, lever):
    """(largest distance (m), largest drift (m)) of a contact frame from where its row sent it, over the contacts
    i: the distance ‖t(exp(e⁺_i)) − t(exp(f_i b_i))‖ and the drift, the larger of that distance and ``lever``
    (m) times the angle between the two frames (:func:`rotation_gap`; ``lever`` 0: the distance), with e⁺_i = logs[i]
    (6,) its error at the next configuration (``pin.log6`` of placement⁻¹ oMf), b_i = b[starts[i]:starts[i] + 6]
    its rows' right-hand side −K e and f_i = dt − 1/K, so that f_i b_i = (1 − K dt) e_i (the row's target);
    t(exp(·)) the translation of the frame in the placement's frame."""
    far = 0.0
    worst = 0.0
    for i in range(logs.shape[0]):
        r0 = starts[i]
        far, worst = _contact_gaps(logs[i], b[r0:r0 + 6], factors[i], lever, far, worst)
    return far, worst


@nb.njit(cache=True, nogil=True)
def _contact_gaps(log, b_rows, factor, lever, far, worst):
    """One contact's term of :func:`contact_drift`: (far, worst) raised to its distance and its drift."""
    d = translation_gap(log, 1.0, b_rows, factor)
    if d > far:
        far = d
    if lever > 0.0:
        d = max(d, lever * rotation_gap(log, 1.0, b_rows, factor))
    if d > worst:
        worst = d
    return far, worst


@nb.njit(cache=True, **NO_NRT)  # GIL kept: releasing it costs more than this call's work
def contact_pair_drift(frame_a, frame_b, logs, b, start_a, start_b, factor_a, factor_b, lever):
    """Two contacts' errors and :func:`contact_drift` in one compiled call: logs[0], logs[1] ← the errors of
    :func:`wbc.lie.placement_log6_into` (``frame_*`` = (placement (4, 3) = [R_P; p_Pᵀ], frame rotation (3, 3),
    frame position (3,)), world: :meth:`wbc.constraints.ContactConstraint.log_operands`; every angle, a half turn
    included), then :func:`contact_drift` (logs (2, 6), b, starts (``start_a``, ``start_b``), factors
    (``factor_a``, ``factor_b``), ``lever`` (m)) — the same numbers as those calls made one after the other.

    Returns:
        :func:`contact_drift`'s (distance (m), drift (m)), both ≥ 0 (or NaN).
    """
    placement_log6_into(frame_a[0], frame_a[1], frame_a[2], logs[0])
    placement_log6_into(frame_b[0], frame_b[1], frame_b[2], logs[1])
    far, worst = _contact_gaps(logs[0], b[start_a:start_a + 6], factor_a, lever, 0.0, 0.0)
    return _contact_gaps(logs[1], b[start_b:start_b + 6], factor_b, lever, far, worst)


@nb.njit(cache=True, nogil=True)
def all_finite(x):
    """True when every entry of the vector x is finite (no NaN, no ±inf)."""
    for i in range(x.shape[0]):
        if not np.isfinite(x[i]):
            return False
    return True


@nb.njit(cache=True, nogil=True)
def command_within(v, lb, ub, C, l, u, tolerance):
    """The compiled screens of the kinematic controller's output guard: True when every v_i is finite with
    |v_i| < 1e100 (so that v·v is finite) and lb_i − v_i ≤ tolerance, v_i − ub_i ≤ tolerance (its unscaled box test,
    the same elementwise numbers), and every row holds with a rounding margin: max(l_i − c_i, c_i − u_i) / d_i +
    1e-12 ≤ tolerance, c_i = C_i v summed here, d_i = max(1, |C_i| |v|, |l_i|, |u_i|) (finite bounds only; its scaled
    row test, whose sums, in another order, differ from these by far less than the margin). False otherwise,
    including NaN or inf anywhere (the guard then runs its full test).

    Args:
        v (n,): command (rad/s, m/s). lb, ub (n,): box. C (p, n), l, u (p,): rows. Bounds may be ±inf.
        tolerance: largest excess (box) and scaled excess (rows) accepted.
    """
    for i in range(v.shape[0]):
        x = v[i]
        if not abs(x) < 1e100:
            return False
        if not (lb[i] - x <= tolerance and x - ub[i] <= tolerance):
            return False
    for i in range(C.shape[0]):
        c = 0.0
        s = 0.0
        for j in range(C.shape[1]):
            t = C[i, j] * v[j]
            c += t
            s += abs(t)
        d = max(1.0, s)
        lo, hi = l[i], u[i]
        if abs(lo) < np.inf:
            d = max(d, abs(lo))
        if abs(hi) < np.inf:
            d = max(d, abs(hi))
        over = max(lo - c, c - hi)
        if not (over / d + 1e-12 <= tolerance):
            return False
    return True


@once_per_process
def load_kinematic_parts() -> None:
    """Compile (or load), once per process, the kinematic kernels that link no solver kernel (``wbc compile`` runs it
    beside the solvers': :data:`wbc.cli.kernels.PARTS`)."""
    fb, ib = kinematic_pack(7, 6, 0, 0)
    qp = kinematic_views.py_func(fb, ib)[0]
    form_qp(*rows_pack(1, 7, np.zeros(0, np.int64)), np.zeros(7), 0.0, 1e-6, qp.H, qp.g)
    weighted_rows(np.eye(1, 7, 6), np.zeros(1), np.ones((3, 1)), np.empty((1, 7)), np.empty(1))
    # kinematic_solve's base elimination, with the argument types it gives (views of the packed workspace)
    _eliminate_base(np.zeros((6, 7)), np.zeros(6), 0, 1, np.zeros((6, 6)), np.zeros((6, 2)))
    _reduce_cost(np.eye(7), np.zeros(7), 6, 1, np.zeros((6, 2)), np.zeros((6, 1)), np.zeros(6), np.zeros((1, 1)),
                 np.zeros(1))
    contact_drift(np.zeros((1, 6)), np.zeros(6), np.zeros(1, np.int64), np.zeros(1), 0.1)
    frame = (np.eye(4, 3), np.asfortranarray(np.eye(3)), np.zeros(3))  # Pinocchio's F-ordered rotation
    contact_pair_drift(frame, frame, np.zeros((2, 6)), np.zeros(12), 0, 6, 0.0, 0.0, 0.1)
    all_finite(qp.b)
    command_within(np.zeros(7), qp.lb, qp.ub, np.zeros((1, 7)), -np.ones(1), np.ones(1), 1e-6)
    translation_gap(np.zeros(6), 1.0, np.zeros(6), 1.0)
    rotation_gap(np.zeros(6), 1.0, np.zeros(6), 1.0)


@once_per_process
def load_kinematic_kernels() -> None:
    """:func:`load_kinematic_parts`, then the compiled tick :func:`kinematic_tick_packed`, once per process."""
    load_kinematic_parts()
    # the kinematic controller's compiled tick (a 7-velocity QP whose base is eliminated through 6 rows)
    fb, ib = kinematic_pack(7, 6, 0, 0)
    qp = kinematic_views.py_func(fb, ib)[0]
    qp.A[:, :6] = np.eye(6)
    qp.lb[:6], qp.ub[:6] = -np.inf, np.inf
    qp.lb[6], qp.ub[6] = -1.0, 1.0
    sfb, sib = rows_pack(1, 7, np.zeros(0, np.int64))
    rows = task_rows.py_func(sfb, sib)
    rows.J[0, 6], rows.rowp[:] = 1.0, 1.0
    kinematic_tick_packed(TickBuffers(fb, ib, sfb, sib, np.zeros(1, np.int8)), np.zeros(7), 0.0, 1e-6, np.empty(7),
                          0.002, 1e-6, 10, np.zeros(0), NO_KERNEL_BOX)
