"""Compiled tick of the inverse-dynamics QP: assembly of every block, the exact working-set solve and the torques
in one numba call (the ``fast`` solver of :class:`~wbc.dynamics.formulation.InverseDynamicsQP`).

The QP is the one of :mod:`wbc.dynamics.formulation` (same rows, same named constraints); only its arithmetic
moves into compiled code. From Python come the task rows (J_i, w_i, r_i of eq. 3, stacked), the posture task's
diagonal rows, M, h, the LOCAL sole Jacobians and contact right-hand sides of eq. 5, the state (q, v) for the joint
bounds of eq. 9; the kernel writes

    H_vv = Σ_i J_iᵀ W_i J_i + diag(w_posture) + ε_a I,   g_v = −Σ_i J_iᵀ W_i r_i,   J_cᵀ = [J_kᵀ G_k]_k,
    A, b (eq. 4, 5),  C, l, u torque rows (eq. 6),  lb, ub joint bounds (eq. 9),

into the formulation's preallocated arrays (the constant blocks — force regularisation ε_f I, friction rows (7),
force bounds (8) — are already there), solves with :func:`wbc.fastqp.solve_qp_ws` (working set warm-started from
the previous tick) and computes τ by eq. 2. Sums are done in the kernel's order, so the QP equals the one of the
numpy assembly to rounding (not bit for bit); the solver returns its exact optimum (KKT conditions checked), and
any call that does not end in one is handed back to the formulation's DAQP fallback by the caller.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from wbc.dynamics.constraints import joint_bounds_kernel
from wbc.fastqp import solve_qp_ws

__all__ = ["id_tick"]


@nb.njit(cache=True, nogil=True)
def id_tick(Jt, wt, rt, pidx, pw, pr, reg_v, M, h, Jc, Gc, bc, active, t0, lim, joint_limits, q, v, iq, iv, qmin,
            qmax, vmax, a_brk, dt, jlo, jhi, H, g, A, b, C, l, u, lb, ub, JcT, state, rstate, x, nu, mu, z, max_iter, ws_Aw,
            ws_bw, ws_free, ws_L, ws_Y, ws_S, ws_t, ws_rhs, ws_nuw, residual, tau):
    """One ID tick (module docstring).

    Args:
        Jt (mt, nv), wt (mt,), rt (mt,): stacked weighted task rows (J, w, r = a* − J̇v).
        pidx (kp,) int64, pw (kp,), pr (kp,): posture rows (v indices), weights, targets.
        reg_v (nv,): ε_a. M (nv, nv), h (nv,). Jc (nc, 6, nv), Gc (nc, 6, 12): LOCAL sole Jacobians and corner
        maps; bc (nc, 6): eq. 5 right-hand sides; active (nc,) bool.
        t0, lim (nt,): first velocity index and limits (N·m) of the contiguous torque-limited joints.
        joint_limits: write the eq. 9 bounds. q, v, iq, iv, qmin, qmax, vmax, a_brk, dt: their data; jlo, jhi
            (k,): workspace.
        H, g, A, b, C, l, u, lb, ub, JcT: the formulation's arrays (written in place; A has room for every
        contact). state, rstate, x, nu, mu, z, max_iter, ws_*: :func:`wbc.fastqp.solve_qp_ws` arguments.
        residual (2,): out, largest constraint violation of x, then ‖M_u v̇ + h_u − (J_cᵀ)_u f‖_∞ (eq. 1's
            unactuated rows). tau (nv − 6,): out, eq. 2.

    Returns:
        (kernel iterations (negative: exit code of solve_qp_ws), number of equality rows m).
    """
    nv = M.shape[0]
    n = H.shape[0]
    nc = Jc.shape[0]
    # cost
    for i in range(nv):
        g[i] = 0.0
        for j in range(nv):
            H[i, j] = 0.0
    for r in range(Jt.shape[0]):
        w = wt[r]
        if w == 0.0:
            continue
        for i in range(nv):
            wji = w * Jt[r, i]
            if wji == 0.0:
                continue
            g[i] -= wji * rt[r]
            for j in range(nv):
                H[i, j] += wji * Jt[r, j]
    for k in range(pidx.size):
        i = pidx[k]
        H[i, i] += pw[k]
        g[i] -= pw[k] * pr[k]
    for i in range(nv):
        H[i, i] += reg_v[i]
    # J_cᵀ = [J_kᵀ G_k]
    for c in range(nc):
        for i in range(nv):
            for col in range(12):
                s = 0.0
                for k in range(6):
                    s += Jc[c, k, i] * Gc[c, k, col]
                JcT[i, 12 * c + col] = s
    # equalities: floating-base dynamics (4), active contacts (5)
    nf = n - nv
    for r in range(6):
        for j in range(nv):
            A[r, j] = M[r, j]
        for j in range(nf):
            A[r, nv + j] = -JcT[r, j]
        b[r] = -h[r]
    m = 6
    for c in range(nc):
        if not active[c]:
            continue
        for r in range(6):
            for j in range(nv):
                A[m, j] = Jc[c, r, j]
            for j in range(nf):
                A[m, nv + j] = 0.0
            b[m] = bc[c, r]
            m += 1
    # torque limits (6)
    for r in range(lim.size):
        vr = t0 + r
        for j in range(nv):
            C[r, j] = M[vr, j]
        for j in range(nf):
            C[r, nv + j] = -JcT[vr, j]
        l[r] = -lim[r] - h[vr]
        u[r] = lim[r] - h[vr]
    if joint_limits:
        joint_bounds_kernel(q, v, iq, iv, qmin, qmax, vmax, a_brk, dt, jlo, jhi)
        for j in range(iv.size):
            lb[iv[j]] = jlo[j]
            ub[iv[j]] = jhi[j]
    it = solve_qp_ws(H, g, A[:m], b[:m], C, l, u, lb, ub, state, rstate, x, nu[:m], mu, z, max_iter, 1e-12,
                     1e-12, 1e-24, ws_Aw, ws_bw, ws_free, ws_L, ws_Y, ws_S, ws_t, ws_rhs, ws_nuw, residual[:1])
    if it > 0:
        worst = 0.0
        for i in range(nv):
            s = h[i]
            for j in range(nv):
                s += M[i, j] * x[j]
            for j in range(nf):
                s -= JcT[i, j] * x[nv + j]
            if i >= 6:
                tau[i - 6] = s
            elif abs(s) > worst:
                worst = abs(s)
        residual[1] = worst
    return it, m
