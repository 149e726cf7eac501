"""Compiled tick of the inverse-dynamics QP: assembly of every block, the exact working-set solve and the torques
in one numba call (the ``fast`` solver of :class:`~wbc.formulations.acceleration.InverseDynamicsQP`).

The QP is the one of :mod:`wbc.formulations.acceleration` (same rows, same named constraints); only its arithmetic
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

Structure used before the general solve (:func:`_equality_step`): H = blockdiag(H_vv, ε_f I) and, while no bound
or inequality row is active (standing, walking without saturation), the optimum is that of the equality-constrained
QP over the free variables (forces of inactive contacts are fixed by lb = ub = 0). Its KKT system is solved by the
range-space method on the blocks (Nocedal & Wright 2006, *Numerical Optimization*, §16.2, eq. 16.16):

    L Lᵀ = H_vv,  Y = L⁻¹ A_vᵀ,  S = Yᵀ Y + A_f D⁻¹ A_fᵀ  (D = ε_f I on the free forces),
    S ν = −(b − A_f,fixed x_fixed + Yᵀ L⁻¹ g_v),   x_v = −L⁻ᵀ (L⁻¹ g_v + Y ν),   x_f = −D⁻¹ A_fᵀ ν,

a 38 × 38 Cholesky for Talos instead of a 62 × 62 one. If that x satisfies every bound and row (to 1e-12; the
inequality multipliers are then zero, so every KKT condition holds and x is the optimum of the full QP), it is
returned; otherwise the working-set solver takes over.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from wbc.constraints.dynamics import joint_bounds_kernel
from wbc.fastqp import (
    backward_substitution,
    cholesky_lower,
    forward_substitution,
    solve_qp_ws,
    weighted_normal_equations,
)

__all__ = ["id_tick"]

#: LLVM fast-math flags: reassociation (vectorised dot products) and fused multiply-add only; ±inf bounds stay
#: legitimate input (no "no-inf/no-nan" assumption).
_FM = {"reassoc", "contract"}


@nb.njit(cache=True, nogil=True, fastmath=_FM)
def _equality_step(H, g, A, b, m, C, l, u, lb, ub, nv, x, L, Yt, S, t, nu, tol):
    """The equality-constrained optimum with no active bound or row (module docstring), written into x. Returns
    the largest equality residual, or −1 when H_vv or S is not positive definite, a joint variable is fixed, or x
    violates a bound or row by more than ``tol``."""
    n = H.shape[0]
    for i in range(nv):
        if lb[i] == ub[i]:
            return -1.0
        for j in range(i + 1):
            L[i, j] = H[i, j]
    if not cholesky_lower(L, nv):
        return -1.0
    for i in range(nv):
        t[i] = g[i]
    forward_substitution(L, nv, t)
    for k in range(m):
        for i in range(nv):
            Yt[k, i] = A[k, i]
        forward_substitution(L, nv, Yt[k])
    for k in range(m):
        for c in range(k + 1):
            acc = 0.0
            for i in range(nv):
                acc += Yt[k, i] * Yt[c, i]
            for f in range(nv, n):
                if lb[f] < ub[f]:
                    acc += A[k, f] * A[c, f] / H[f, f]
            S[k, c] = acc
        acc = b[k]
        for f in range(nv, n):
            if lb[f] == ub[f]:
                acc -= A[k, f] * lb[f]
        for i in range(nv):
            acc += Yt[k, i] * t[i]
        nu[k] = -acc
    if not cholesky_lower(S, m):
        return -1.0
    forward_substitution(S, m, nu)
    backward_substitution(S, m, nu)
    for i in range(nv):
        acc = t[i]
        for k in range(m):
            acc += Yt[k, i] * nu[k]
        x[i] = -acc
    backward_substitution(L, nv, x[:nv])
    for f in range(nv, n):
        if lb[f] == ub[f]:
            x[f] = lb[f]
        else:
            acc = 0.0
            for k in range(m):
                acc += A[k, f] * nu[k]
            x[f] = -acc / H[f, f]
    for i in range(n):
        if x[i] < lb[i] - tol or x[i] > ub[i] + tol:
            return -1.0
    for r in range(C.shape[0]):
        acc = 0.0
        for j in range(n):
            acc += C[r, j] * x[j]
        if acc < l[r] - tol or acc > u[r] + tol:
            return -1.0
    for i in range(n):
        x[i] = min(max(x[i], lb[i]), ub[i])
    res = 0.0
    for k in range(m):
        acc = -b[k]
        for j in range(n):
            acc += A[k, j] * x[j]
        res = max(res, abs(acc))
    return res


@nb.njit(cache=True, nogil=True, fastmath=_FM)
def id_tick(Jt, wt, rt, pidx, pw, pr, eps_a, M, h, Jc, Gc, Rc, bc, active, t0, lim, joint_limits, q, v, iq, iv, qmin,
            qmax, vmax, a_brk, dt, jlo, jhi, H, g, A, b, C, l, u, lb, ub, JcT, state, rstate, x, nu, mu, z, max_iter, ws_Aw,
            ws_bw, ws_free, ws_L, ws_Y, ws_S, ws_t, ws_rhs, ws_nuw, residual, tau, wrench):
    """One ID tick (module docstring).

    Args:
        Jt (mt, nv), wt (mt,), rt (mt,): stacked weighted task rows (J, w, r = a* − J̇v).
        pidx (kp,) int64, pw (kp,), pr (kp,): posture rows (v indices), weights, targets.
        eps_a: ε_a (weight of ‖v̇‖²). M (nv, nv), h (nv,). Jc (nc, 6, nv), Gc (nc, 6, 12): LOCAL sole Jacobians and corner
        maps; Rc (nc, 3, 3): sole rotations (world ← sole); bc (nc, 6): eq. 5 right-hand sides; active (nc,)
        bool.
        t0, lim (nt,): first velocity index and limits (N·m) of the contiguous torque-limited joints.
        joint_limits: write the eq. 9 bounds. q, v, iq, iv, qmin, qmax, vmax, a_brk, dt: their data; jlo, jhi
            (k,): workspace.
        H, g, A, b, C, l, u, lb, ub, JcT: the formulation's arrays (written in place; A has room for every
        contact). state, rstate, x, nu, mu, z, max_iter, ws_*: :func:`wbc.fastqp.solve_qp_ws` arguments.
        residual (2,): out, largest constraint violation of x, then ‖M_u v̇ + h_u − (J_cᵀ)_u f‖_∞ (eq. 1's
            unactuated rows). tau (nv − 6,): out, eq. 2. wrench (nc, 6): out, each sole's wrench G_k f_k at its
            origin in world axes (N, N·m), zero for an inactive contact.

    Returns:
        (kernel iterations (negative: exit code of solve_qp_ws), number of equality rows m).
    """
    nv = M.shape[0]
    n = H.shape[0]
    nc = Jc.shape[0]
    # cost: H_vv = ε_a I + Jᵀ W J (+ the posture diagonal), g_v = −Jᵀ W r (+ posture); H_ff = ε_f I stays as written
    weighted_normal_equations(Jt, wt, rt, eps_a, H[:nv, :nv], g[:nv])
    for k in range(pidx.size):
        i = pidx[k]
        H[i, i] += pw[k]
        g[i] -= pw[k] * pr[k]
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
    res = _equality_step(H, g, A, b, m, C, l, u, lb, ub, nv, x, ws_L, ws_Aw, ws_S, ws_t, nu, 1e-12)
    if res >= 0.0:
        it = 1
        residual[0] = res
        for i in range(n):
            state[i] = -1 if (i >= nv and lb[i] == ub[i]) else 0
        for r in range(rstate.size):
            rstate[r] = 0
    else:
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
        for c in range(nc):
            for k in range(6):
                wrench[c, k] = 0.0
            if not active[c]:
                continue
            for k in range(6):
                s = 0.0
                for col in range(12):
                    s += Gc[c, k, col] * x[nv + 12 * c + col]
                for r in range(3):
                    wrench[c, 3 * (k // 3) + r] += Rc[c, r, k % 3] * s
    return it, m
