"""Compiled tick of the inverse-dynamics QP: assembly of every block, the exact active-set solve and the torques
in one numba call (the ``fast`` solver of :class:`~wbc.formulations.acceleration.InverseDynamicsQP`).

The QP is the one of :mod:`wbc.formulations.acceleration`, written by the same compiled bodies: :func:`id_tick` is
:func:`id_assemble` — the cost by :func:`task_cost` and the state-dependent constraint blocks by the bodies of
:mod:`wbc.constraints` that the constraints' ``write`` call on the general path
(:meth:`~wbc.formulations.acceleration.InverseDynamicsQP.build`) —, then the solve and the torques. From Python
come the stacked task rows gathered for both paths: per row J (dense rows, stacked) or its v index (posture rows)
and the numbers e, ė_ff, J̇v, ä_ff, Kp, Kd, w of its reference (eq. 1 of :mod:`wbc.formulations.reference`); M, h;
the LOCAL sole Jacobians and the velocity-free part −J̇v − K_p e of eq. 5; the state (q, v). The assembly forms

    r = ä_ff − Kp e − Kd (J v − ė_ff) − J̇v,   H_vv = Σ_i J_iᵀ W_i J_i + diag(w_posture) + ε_a I,
    g_v = −Σ_i J_iᵀ W_i r_i,   J_cᵀ = [J_kᵀ G_k]_k,   A, b (eq. 4, 5),  C, l, u torque rows (eq. 6),
    lb, ub joint bounds (eq. 9),

into the formulation's preallocated arrays (the constant blocks — force regularisation ε_f I, friction rows (7),
force bounds (8) — are already there, written by their constraints), bitwise the arrays :meth:`build` writes at the
same state (``tests/formulations/test_formulations_acceleration.py``). The solver returns its exact optimum (KKT
conditions checked), and any call that does not end in one is handed back to the formulation's DAQP fallback by the
caller, on the same arrays.

Structure used before the general solve (:func:`_equality_step`): H = blockdiag(H_vv, ε_f I). The bounds held
at the previous tick's optimum (its working set: e.g. standing Talos holds a gripper joint on its acceleration
bound every tick) are held again, and the optimum of the equality-constrained QP over the other variables
(forces of inactive contacts are fixed by lb = ub = 0) is solved by the range-space method on the blocks (Nocedal
& Wright 2006, *Numerical Optimization*, §16.2, eq. 16.16), F the free accelerations, X the held variables:

    L Lᵀ = H_FF,  t = L⁻¹ (g_F + H_FX x_X),  Y = L⁻¹ A_Fᵀ,  S = Yᵀ Y + A_f D⁻¹ A_fᵀ  (D = ε_f I on the free forces),
    S ν = −(b − A_X x_X + A_f D⁻¹ g_f + Yᵀ t),   x_F = −L⁻ᵀ (t + Y ν),   x_f = −D⁻¹ (g_f + A_fᵀ ν),

a ≤ 38 × 38 Cholesky for Talos instead of a 62 × 62 one. If that x satisfies every bound and row (to 1e-12) and
every held bound's multiplier λ_i = −σ_i (H x + g + Aᵀν)_i is ≥ 0 (σ_i = −1 at lb, +1 at ub), every KKT
condition of the full QP holds and x is its (unique) optimum. When it fails on one bound — the most violated free
variable, else the held bound with the most negative multiplier — that bound enters (or leaves) the working set and
the step runs once more (a bound that alternates between ticks, as one joint's acceleration bound does while the
robot sways, costs two equality steps; the answer is checked as before). Otherwise the Goldfarb–Idnani dual active
set (:func:`~wbc.solvers.active_set.dual_active_set` on a :class:`~wbc.solvers.active_set.BlockSpace`,
warm-started from the previous tick's working set) takes over.

Accuracy (Talos/G1 ``wbc sim`` and perturbed states): the returned x matches quadprog (Goldfarb–Idnani,
dense) on the same QP to ≈ 1e-11 and DAQP's workspace solve likewise; DAQP's one-shot dual warm start (the
``daqp`` ID default) stops ≈ 3e-7 from that optimum. Where H_vv is ill-conditioned (a base or joint direction that no
task weighs, held by ε_a alone: condition number κ ~ 1e8) the Cholesky factor of H_FF loses as many digits, and v̇
parts from quadprog's by ~κ · 1e-16 relative along that direction. Closed-loop trajectories of two exact solvers still part
after a few hundred ticks: the loop amplifies a 1e-15 difference in v to 1e-6 within ~30 ticks (DAQP against
itself), so solvers are compared tick by tick at the same state (``tests/formulations/test_idkernel.py``).
"""

from __future__ import annotations

from collections import namedtuple

import numba as nb
import numpy as np

from wbc.compiled import FASTMATH, once_per_process
from wbc.constraints.contact_acceleration import contact_acceleration_rows
from wbc.constraints.floating_base import contact_force_columns, floating_base_rows
from wbc.constraints.joint_acceleration_bounds import joint_bounds_kernel
from wbc.constraints.torque_limits import torque_limit_rows
from wbc.formulations.reference import reference_rhs
from wbc.solvers.active_set import BlockSpace, dual_active_set
from wbc.solvers.box_eq import clip_eq_residual
from wbc.solvers.linalg import (backward_substitution, block_cost_gradient, carve, carve2, cholesky_lower,
                                forward_substitution, primal_from_multipliers, weighted_normal_equations)

__all__ = ["contact_rows_well_conditioned", "id_assemble", "id_command", "id_tick", "id_workspace", "load_id_kernels",
           "id_tick_buffers", "output_violations", "tick_outputs", "contact_views", "task_cost", "PROJECT_CONTACT_RHS",
           "IDTaskRows", "IDDynamics", "IDContactData", "IDLimits", "IDArrays", "IDTickBuffers"]

#: the workspaces of :func:`id_tick`, one namedtuple per group of its arguments (numba takes them as tuples):
#: the stacked task rows of :func:`task_cost`
IDTaskRows = namedtuple("IDTaskRows", "Jt R pidx rt")
#: the state's dynamics, (q, v) and the control period dt (s)
IDDynamics = namedtuple("IDDynamics", "M h q v dt")
#: the contact data (:func:`contact_views`) and the activity of each contact
IDContactData = namedtuple("IDContactData", "cbuf active")
#: the limits' indices and numbers, and the settings vector ``par`` (``PAR_*``)
IDLimits = namedtuple("IDLimits", "idx lim par qmin qmax vmax")
#: the formulation's QP arrays, written in place
IDArrays = namedtuple("IDArrays", "H g A b C l u lb ub JcT")
#: the buffers of :func:`id_tick_buffers`
IDTickBuffers = namedtuple("IDTickBuffers", "ws_s ws_f ws_i ws_b out")


#: squared sine (in the H⁻¹ metric) between a constraint and the span of the working set below which it counts as
#: dependent on it (the ID tick's :func:`~wbc.solvers.active_set.dual_active_set`)
DEPENDENCE_TOL = 1e-10
#: violation (constraint units: m/s², N, N·m) beyond which a bound or row enters the working set (the same solve)
PRIMAL_TOL = 1e-11
#: largest constraint violation (m/s², N, N·m) of the solve's final KKT check (the same solve)
VERIFY_TOL = 1e-9


@nb.njit(cache=True, nogil=True, fastmath=FASTMATH)
def _equality_step(H, g, A, b, m, C, l, u, lb, ub, nv, state, rstate, x, L, Yt, S, t, nu, tol, dinv, fnz, vfree,
                   xv, bx):
    """The optimum of a working set of bounds (``state``; module docstring), written into x: the variables
    with ``state`` ≠ 0 (and the forces with lb = ub) held on their bound, the equality-constrained QP solved over
    the others. Returns (residual, i, side): residual the largest equality residual, or −1 — ``state`` untouched —
    when that x is not the optimum of the full QP or the step does not apply: a working inequality row
    (``rstate`` ≠ 0), a joint variable with lb = ub, H_FF or S not positive definite, a free variable or a row
    violated by more than ``tol``, or a held bound whose multiplier λ_i = −state_i (H x + g + Aᵀν)_i is negative.
    On a failure that one bound explains, (i, side) is the working-set change it points to: the most violated
    free variable (side −1: held at lb, +1: at ub) when no row is checked yet, else the held bound with the most
    negative multiplier (side 0: released); otherwise i = −1. dinv (n,), fnz (≥ m,) bool, vfree (nv,) int,
    xv (nv,), bx (≥ m,): workspace."""
    n = H.shape[0]
    for r in range(rstate.size):
        if rstate[r] != 0:
            return -1.0, -1, 0
    nfv = 0
    for i in range(nv):
        if lb[i] == ub[i]:
            return -1.0, -1, 0
        s = state[i]
        if s == 0:
            vfree[nfv] = i
            nfv += 1
        else:
            bound = lb[i] if s < 0 else ub[i]
            if not np.isfinite(bound):
                return -1.0, -1, 0
            x[i] = bound
    for f in range(nv, n):
        if lb[f] == ub[f] or state[f] != 0:
            bound = ub[f] if (state[f] > 0 and lb[f] != ub[f]) else lb[f]
            if not np.isfinite(bound):
                return -1.0, -1, 0
            x[f] = bound
            dinv[f] = 0.0
        else:
            dinv[f] = 1.0 / H[f, f]
    held = nfv < nv
    for a in range(nfv):
        i = vfree[a]
        s = g[i]
        if held:
            for j in range(nv):
                if state[j] != 0:
                    s += H[i, j] * x[j]
        t[a] = s
        for c in range(a + 1):
            L[a, c] = H[i, vfree[c]]
    if not cholesky_lower(L, nfv):
        return -1.0, -1, 0
    forward_substitution(L, nfv, t)
    for k in range(m):
        Ak = A[k]
        y = Yt[k]
        for a in range(nfv):
            y[a] = Ak[vfree[a]]
        acc = b[k]
        if held:
            for j in range(nv):
                if state[j] != 0:
                    acc -= Ak[j] * x[j]
        nz = False
        for f in range(nv, n):
            if dinv[f] == 0.0:
                acc -= Ak[f] * x[f]
            elif Ak[f] != 0.0:
                nz = True
                acc += Ak[f] * g[f] * dinv[f]
        fnz[k] = nz
        bx[k] = acc
    # Y = L⁻¹ A_Fᵀ: the m forward substitutions together, row i of L once for every k (measured 2× faster than
    # one substitution per row)
    for i in range(nfv):
        d = 1.0 / L[i, i]
        for k in range(m):
            acc = Yt[k, i]
            for p in range(i):
                acc -= L[i, p] * Yt[k, p]
            Yt[k, i] = acc * d
    for k in range(m):
        Ak = A[k]
        Yk = Yt[k]
        for c in range(k + 1):
            Yc = Yt[c]
            acc = 0.0
            for a in range(nfv):
                acc += Yk[a] * Yc[a]
            if fnz[k] and fnz[c]:
                Ac = A[c]
                for f in range(nv, n):
                    acc += Ak[f] * Ac[f] * dinv[f]
            S[k, c] = acc
        acc = bx[k]
        for a in range(nfv):
            acc += Yk[a] * t[a]
        nu[k] = -acc
    if not cholesky_lower(S, m):
        return -1.0, -1, 0
    forward_substitution(S, m, nu)
    backward_substitution(S, m, nu)
    primal_from_multipliers(L, nfv, t, Yt, nu, m, xv)
    for a in range(nfv):
        x[vfree[a]] = xv[a]
    for f in range(nv, n):
        if dinv[f] != 0.0:
            s = g[f]
            for k in range(m):
                if fnz[k]:
                    s += A[k, f] * nu[k]
            x[f] = -s * dinv[f]
    # primal feasibility of the free variables and of every row
    worst = tol
    wi = -1
    ws = 0
    for i in range(n):
        if state[i] == 0 and lb[i] != ub[i]:
            if lb[i] - x[i] > worst:
                worst, wi, ws = lb[i] - x[i], i, -1
            elif x[i] - ub[i] > worst:
                worst, wi, ws = x[i] - ub[i], i, 1
    if wi >= 0:
        return -1.0, wi, ws
    for r in range(C.shape[0]):
        acc = 0.0
        Cr = C[r]
        for j in range(n):
            acc += Cr[j] * x[j]
        if acc < l[r] - tol or acc > u[r] + tol:
            return -1.0, -1, 0
    # dual feasibility of the held bounds
    worst = 0.0
    wi = -1
    for i in range(n):
        if state[i] == 0 or lb[i] == ub[i]:
            continue
        s = block_cost_gradient(H, g, x, i, nv)
        for k in range(m):
            s += A[k, i] * nu[k]
        if -state[i] * s < worst:
            worst, wi = -state[i] * s, i
    if wi >= 0:
        return -1.0, wi, 0
    return clip_eq_residual(x, lb, ub, A, b, n, m), -1, 0


@nb.njit(cache=True, nogil=True, fastmath=FASTMATH)
def contact_rows_well_conditioned(Jc, active, ratio, G, y):
    """Certificate that the stacked rows J (m × nv) of the active contacts have every singular value
    σ ≥ ``ratio`` σ_max, so that :func:`wbc.constraints.contact_acceleration.independent_contact_rows` would keep every row
    and need not run (its eigen-decomposition is the tick's largest numpy call). With G = J Jᵀ
    (eigenvalues λ = σ²): λ_min ≥ 1 / tr(G⁻¹) and λ_max ≤ tr(G), so 1 / tr(G⁻¹) ≥ ratio² tr(G) implies
    λ_min ≥ ratio² λ_max. tr(G⁻¹) = ‖L⁻¹‖_F² from the Cholesky factor L of G. False (no certificate) when that
    bound does not hold or G is not positive definite.

    Args:
        Jc (nc, 6, nv): contact Jacobians; active (nc,) bool; ratio: σ / σ_max threshold; G (6 nc, 6 nc), y (6 nc,):
            workspace.
    """
    nc = Jc.shape[0]
    nv = Jc.shape[2]
    m = 0
    for c in range(nc):
        if active[c]:
            m += 6
    if m == 0:
        return True
    tr = 0.0
    i = 0
    for c in range(nc):
        if not active[c]:
            continue
        for r in range(6):
            j = 0
            for c2 in range(c + 1):
                if not active[c2]:
                    continue
                for r2 in range(6):
                    if j > i:
                        break
                    acc = 0.0
                    for k in range(nv):
                        acc += Jc[c, r, k] * Jc[c2, r2, k]
                    G[i, j] = acc
                    j += 1
            tr += G[i, i]
            i += 1
    if not cholesky_lower(G, m):
        return False
    tinv = 0.0
    for col in range(m):  # column col of L⁻¹: forward substitution of e_col (zero above col)
        for r in range(col, m):
            t = 1.0 if r == col else 0.0
            for p in range(col, r):
                t -= G[r, p] * y[p]
            y[r] = t / G[r, r]
            tinv += y[r] * y[r]
    return 1.0 / tinv >= ratio * ratio * tr


def id_workspace(n: int, nv: int, p: int, w: int) -> tuple:
    """Workspace of the ID tick's :func:`~wbc.solvers.active_set.dual_active_set` on a
    :class:`~wbc.solvers.active_set.BlockSpace` (and of the block equality step) for n variables, nv accelerations, p
    inequality rows and up to w working rows: (rows, Yv, S, L, tv, c, nuw, vrow, vfree, ffree, fac, a, z, npv, rb,
    lam_b, lam_r, ra, rc, dx, drho, out), the ``ws_*`` arguments of :func:`id_tick` in order."""
    return (np.empty(w, np.int64), np.zeros((w, nv)), np.empty((w, w)), np.empty((nv, nv)), np.empty(nv),
            np.zeros(w), np.zeros(w), np.zeros(w, np.bool_), np.empty(nv, np.int64), np.empty(max(n - nv, 1), np.int64),
            np.zeros(3, np.int64), np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(p),
            np.zeros(n), np.zeros(w), np.zeros(n), np.zeros(w), np.zeros(3))


def id_tick_buffers(n: int, nv: int, p: int, nc: int, k: int, me: int | None = None) -> tuple[np.ndarray, ...]:
    """The solver state, outputs and workspace of :func:`id_tick` for n variables, nv accelerations, p inequality
    rows, nc contacts, k joint-bounded joints and up to ``me`` equality rows (default 6 + 6 nc; more with the
    formulation's gathered equality rows, ``par[PAR_EXTRA_ROWS]``), as five zeroed flat buffers (:func:`_carve_tick`,
    a handful of arguments to unbox per call instead of thirty):

    * ``ws_s`` int8 (n + p,): the working set, ``state`` (n,) then ``rstate`` (p,);
    * ``ws_f`` float64: the arrays of :func:`id_workspace` (w = me + p working rows) that are float, then
      jlo, jhi (k,), nu (me,), mu (p,), gram (6 nc, 6 nc), gram_y (6 nc,);
    * ``ws_i`` int64 and ``ws_b`` bool (w,): the integer and boolean arrays of :func:`id_workspace`;
    * ``out`` float64: residual (2,), tau (nv − 6,), wrench (nc, 6), x (n,) — the outputs the caller reads.
    """
    me = 6 + 6 * nc if me is None else me
    w = me + p
    nf = w * nv + w * w + nv * nv + nv + 4 * w + 7 * n + p + 3
    nf += 2 * k + me + p + 36 * nc * nc + 6 * nc
    return (np.zeros(n + p, np.int8), np.zeros(nf), np.zeros(w + nv + max(n - nv, 1) + 3, np.int64),
            np.zeros(w, np.bool_), np.zeros(2 + nv - 6 + 6 * nc + n))


def tick_outputs(out: np.ndarray, nv: int, nc: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(residual (2,), tau (nv − 6,), wrench (nc, 6), x) views of :func:`id_tick_buffers`' ``out`` buffer."""
    return out[:2], out[2:nv - 4], out[nv - 4:nv - 4 + 6 * nc].reshape(nc, 6), out[nv - 4 + 6 * nc:]


@nb.njit(cache=True, nogil=True, inline="always")
def contact_views(cbuf, nc, nv):
    """(Jc (nc, 6, nv), Gc (nc, 6, 12), Rc (nc, 3, 3), cdrift (nc, 6), ckd (nc,)): the contact data of :func:`id_tick`
    as C-ordered disjoint views of one float64 buffer cbuf (nc (6 nv + 88),), in that order. Compiled (inlined in
    :func:`id_tick`) and callable from Python alike."""
    o = 6 * nv * nc
    Jc = cbuf[0:o].reshape((nc, 6, nv))
    Gc = cbuf[o:o + 72 * nc].reshape((nc, 6, 12))
    o += 72 * nc
    Rc = cbuf[o:o + 9 * nc].reshape((nc, 3, 3))
    o += 9 * nc
    cdrift = cbuf[o:o + 6 * nc].reshape((nc, 6))
    o += 6 * nc
    ckd = cbuf[o:o + nc]
    return Jc, Gc, Rc, cdrift, ckd


@nb.njit(cache=True, nogil=True, inline="always")
def _carve_tick(ws_s, wf, wi, wb, out, n, nv, p, nc, k):
    """The arrays of :func:`id_tick_buffers` (same shapes, C order, disjoint views): (state, rstate, residual, tau,
    wrench, x, jlo, jhi, nu, mu, gram, gram_y, the arrays of :func:`id_workspace` in its order)."""
    w = wb.shape[0]
    state = ws_s[0:n]
    rstate = ws_s[n:n + p]
    residual = out[0:2]
    tau = out[2:nv - 4]
    wrench = out[nv - 4:nv - 4 + 6 * nc].reshape((nc, 6))
    x = out[nv - 4 + 6 * nc:nv - 4 + 6 * nc + n]
    Yv, o = carve2(wf, 0, w, nv)
    S, o = carve2(wf, o, w, w)
    L, o = carve2(wf, o, nv, nv)
    tv, o = carve(wf, o, nv)
    rows_w, o = carve2(wf, o, 2, w)  # c, nuw
    c, nuw = rows_w[0], rows_w[1]
    rows_n, o = carve2(wf, o, 5, n)  # a, z, npv, rb, lam_b
    a, z, npv, rb, lam_b = rows_n[0], rows_n[1], rows_n[2], rows_n[3], rows_n[4]
    lam_r, o = carve(wf, o, p)
    ra, o = carve(wf, o, n)
    rc, o = carve(wf, o, w)
    dx, o = carve(wf, o, n)
    drho, o = carve(wf, o, w)
    wout, o = carve(wf, o, 3)
    bounds, o = carve2(wf, o, 2, k)  # jlo, jhi
    jlo, jhi = bounds[0], bounds[1]
    nu, o = carve(wf, o, w - p)  # the equality rows' multipliers
    mu, o = carve(wf, o, p)
    gram, o = carve2(wf, o, 6 * nc, 6 * nc)
    gram_y = wf[o:o + 6 * nc]
    nff = wi.shape[0] - w - nv - 3
    rows = wi[0:w]
    vfree = wi[w:w + nv]
    ffree = wi[w + nv:w + nv + nff]
    fac = wi[w + nv + nff:w + nv + nff + 3]
    return (state, rstate, residual, tau, wrench, x, jlo, jhi, nu, mu, gram, gram_y,
            (rows, Yv, S, L, tv, c, nuw, wb, vfree, ffree, fac, a, z, npv, rb, lam_b, lam_r, ra, rc, dx, drho, wout))


#: :func:`id_assemble` / :func:`id_tick` exit code: two or more active contacts whose stacked rows are not certified
#: well conditioned (:func:`contact_rows_well_conditioned`); the caller assembles the tick on its general path, which
#: drops the dependent directions (:func:`wbc.constraints.contact_acceleration.independent_contact_rows`).
PROJECT_CONTACT_RHS = -10

#: entries of :func:`id_tick`'s ``par`` vector
PAR_EPS_A, PAR_BRAKING, PAR_JOINT_LIMITS, PAR_MAX_ITER, PAR_CONTACT_RATIO, PAR_SPEED_HORIZON, PAR_EXTRA_ROWS = range(7)
#: rows of the ``R`` array of :func:`task_cost` (one column per task row)
R_ERROR, R_ERROR_RATE_FF, R_DRIFT, R_ACC_FF, R_KP, R_KD, R_WEIGHT = range(7)


@nb.njit(cache=True, nogil=True, fastmath=FASTMATH, inline="always")
def task_cost(Jt, R, pidx, rt, v, eps_a, Hw, gw, H, g):
    """The cost (3) of the ID QP from the stacked task rows, written into H[:nv, :nv] and g[:nv] (the force block
    H_ff = ε_f I is constant and left as it is):

        r = ä_ff − Kp e − Kd (J v − ė_ff) − J̇v   (:mod:`wbc.formulations.reference`, eq. 1),
        H_vv = Σ_i J_iᵀ W_i J_i + diag(w_posture) + ε_a I,   g_v = −Σ_i J_iᵀ W_i r_i.

    Args:
        Jt (mt, nv): stacked Jacobians of the dense task rows. R (7, mt + kp): per task row (dense rows, then the
            posture rows) its e, ė_ff, J̇v, ä_ff, Kp, Kd and weight (rows ``R_*``). pidx (kp,) int64: the v index
            of each posture row (J = e_i). rt (mt + kp,): out, r. v (nv,): velocity (rad/s, m/s). eps_a: ε_a.
        Hw (nv, nv), gw (nv,): contiguous workspace (the sums are formed there, vectorised, then copied).
        H (n, n), g (n,): out.
    """
    nv = Hw.shape[0]
    mt = Jt.shape[0]
    for k in range(R.shape[1]):
        if k < mt:
            jv = 0.0
            for j in range(nv):
                jv += Jt[k, j] * v[j]
        else:
            jv = v[pidx[k - mt]]
        rt[k] = reference_rhs(R[R_ACC_FF, k], R[R_KP, k], R[R_ERROR, k], R[R_KD, k], jv, R[R_ERROR_RATE_FF, k],
                              R[R_DRIFT, k])
    weighted_normal_equations(Jt, R[R_WEIGHT, :mt], rt[:mt], eps_a, Hw, gw)
    for k in range(pidx.size):
        i = pidx[k]
        w = R[R_WEIGHT, mt + k]
        Hw[i, i] += w
        gw[i] -= w * rt[mt + k]
    for i in range(nv):
        g[i] = gw[i]
        for j in range(nv):
            H[i, j] = Hw[i, j]


@nb.njit(cache=True, nogil=True, fastmath=FASTMATH, inline="always")
def id_command(M, h, JcT, Gc, Rc, active, x, tau, wrench):
    """The command of a QP solution x = [v̇; f] (n,): the torques τ = M_a v̇ + h_a − (J_cᵀ)_a f (eq. 2) into tau
    (nv − 6,), and each active sole's wrench G_k f_k at its origin in world axes (N, N·m; Rc (nc, 3, 3) world ←
    sole) into wrench (nc, 6), zero for an inactive contact. Used by the compiled tick and by
    :meth:`~wbc.formulations.acceleration.InverseDynamicsQP.solution_from` alike.

    Returns:
        ‖M_u v̇ + h_u − (J_cᵀ)_u f‖_∞ (N, N·m), the residual of eq. 1's unactuated rows.
    """
    nv = M.shape[0]
    nf = x.shape[0] - nv
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
    for c in range(Gc.shape[0]):
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
    return worst


@nb.njit(cache=True, nogil=True, fastmath=FASTMATH, inline="always")
def id_assemble(tasks, contacts, dynamics, limits, qp, work):
    """Write the state-dependent blocks of the ID QP into the formulation's arrays with the compiled bodies that
    :meth:`~wbc.formulations.acceleration.InverseDynamicsQP.build` calls through the constraints' ``write``: the
    cost (:func:`task_cost`), J_cᵀ (:func:`~wbc.constraints.floating_base.contact_force_columns`), eq. 4
    (:func:`~wbc.constraints.floating_base.floating_base_rows`), eq. 5 of each active contact
    (:func:`~wbc.constraints.contact_acceleration.contact_acceleration_rows`), eq. 6
    (:func:`~wbc.constraints.torque_limits.torque_limit_rows`) and eq. 9
    (:func:`~wbc.constraints.joint_acceleration_bounds.joint_bounds_kernel`, when ``par[PAR_JOINT_LIMITS]`` ≠ 0). The constant
    blocks (ε_f I, friction rows, force bounds) are the formulation's, written by their constraints; so are the
    gathered rows of its other constraints (hard tasks and added equalities: ``par[PAR_EXTRA_ROWS]`` rows of A after
    the active contacts'; added inequalities: their rows of C), written before the call. Inlined into
    :func:`id_tick` (its arguments grouped in tuples: numba inlines no call with that many arguments).

    Args (the arrays of :func:`id_tick`, grouped):
        tasks: (Jt, R, pidx, rt). contacts: (Jc, Gc, cdrift, ckd, active). dynamics: (M, h, q, v, dt).
        limits: (vrows, lim, par, iq, iv, qmin, qmax, vmax). qp: (H, g, A, b, C, l, u, lb, ub, JcT), out.
        work: (Hw (nv, nv), gw (nv,): :func:`task_cost`; gram, gram_y: :func:`contact_rows_well_conditioned`;
        jlo, jhi (k,): joint bounds).

    Returns:
        m, the number of equality rows (6 + 6 per active contact + ``par[PAR_EXTRA_ROWS]``), or PROJECT_CONTACT_RHS
        when two or more
        active contacts are not certified well conditioned (:func:`contact_rows_well_conditioned`; the torque rows
        and bounds are then not written).
    """
    Jt, R, pidx, rt = tasks
    Jc, Gc, cdrift, ckd, active = contacts
    M, h, q, v, dt = dynamics
    vrows, lim, par, iq, iv, qmin, qmax, vmax = limits
    H, g, A, b, C, l, u, lb, ub, JcT = qp
    Hw, gw, gram, gram_y, jlo, jhi = work
    nv = M.shape[0]
    nc = Jc.shape[0]
    task_cost(Jt, R, pidx, rt, v, par[PAR_EPS_A], Hw, gw, H, g)
    for c in range(nc):
        contact_force_columns(Jc[c], Gc[c], JcT, 12 * c)
    floating_base_rows(M, h, JcT, A, b, 0)
    m = 6
    for c in range(nc):
        if active[c]:
            contact_acceleration_rows(Jc[c], cdrift[c], ckd[c], v, A, b, m)
            m += 6
    if m > 12 and not contact_rows_well_conditioned(Jc, active, par[PAR_CONTACT_RATIO], gram, gram_y):
        return PROJECT_CONTACT_RHS
    torque_limit_rows(M, h, JcT, vrows, lim, C, l, u, 0)
    if par[PAR_JOINT_LIMITS] != 0.0:
        joint_bounds_kernel(q, v, iq, iv, qmin, qmax, vmax, par[PAR_BRAKING], dt, jlo, jhi, par[PAR_SPEED_HORIZON])
        for j in range(iv.size):
            lb[iv[j]] = jlo[j]
            ub[iv[j]] = jhi[j]
    return m + int(par[PAR_EXTRA_ROWS])


@nb.njit(cache=True, nogil=True, fastmath=FASTMATH)
def id_tick(tasks, dynamics, contacts, limits, qp, buffers):
    """One ID tick (module docstring): :func:`id_assemble`, then the solve (:func:`_equality_step`, else
    :func:`~wbc.solvers.active_set.dual_active_set` on a :class:`~wbc.solvers.active_set.BlockSpace`), the
    torques and the wrenches.

    Args (namedtuples, the fields below):
        tasks (:data:`IDTaskRows`): Jt (mt, nv), R (7, mt + kp), pidx (kp,), rt (mt + kp,): the stacked task rows
            of :func:`task_cost`.
        dynamics (:data:`IDDynamics`): M (nv, nv), h (nv,), q (nq,), v (nv,): the state's dynamics and (q, v); dt:
            control period (s).
        contacts (:data:`IDContactData`): cbuf: the contact data (:func:`contact_views`): Jc (nc, 6, nv), Gc (nc, 6, 12), LOCAL sole Jacobians and
            corner maps; Rc (nc, 3, 3): sole rotations (world ← sole); cdrift (nc, 6), ckd (nc,): eq. 5 right-hand
            side cdrift − K_d J v (cdrift = −J̇v − K_p e). active (nc,) bool.
        limits (:data:`IDLimits`): idx int64: [vrows (nt,) | iq (k,) | iv (k,)], the v indices of the torque-limited joints, then the q and v
            indices of the joint-bounded ones; lim (nt,): their torque limits (N·m). par (7,): ε_a, a_brk, joint
            limits on (≠ 0), iteration cap, contact conditioning ratio, speed horizon in ticks, gathered equality rows
            written after the active contacts' (``PAR_*``). qmin,
            qmax, vmax (k,): joint-limit data (eq. 9).
        qp (:data:`IDArrays`): H, g, A, b, C, l, u, lb, ub, JcT: the formulation's arrays (written in place; A has room for every
            contact).
        buffers (:data:`IDTickBuffers`): ws_s, ws_f, ws_i, ws_b, out: the buffers of :func:`id_tick_buffers`: the working set (state, rstate; read
            as the warm start, written), the solve's workspace (the arrays of :func:`id_workspace` — its L and tv
            are also the workspace of :func:`task_cost`, warm in cache for the solve that reuses them —, the joint
            bounds jlo, jhi, the equality step's multipliers nu, the workspace gram, gram_y of
            :func:`contact_rows_well_conditioned`), and the outputs (:func:`tick_outputs`): residual (2,), the
            largest constraint violation of x, then ‖M_u v̇ + h_u − (J_cᵀ)_u f‖_∞ (eq. 1's unactuated rows); tau
            (nv − 6,), eq. 2; wrench (nc, 6), each sole's wrench G_k f_k at its origin in world axes (N, N·m), zero
            for an inactive contact; x (n,), the solution.

    Returns:
        (kernel iterations — 1: the equality step; 2: the step after one working-set change, when the cap
        ``par[PAR_MAX_ITER]`` is ≥ 2; else the dual active set's steps; negative: exit code of the solve, or
        PROJECT_CONTACT_RHS —, number of equality rows m).
    """
    Jt, R, pidx, rt = tasks
    M, h, q, v, dt = dynamics
    cbuf, active = contacts
    idx, lim, par, qmin, qmax, vmax = limits
    H, g, A, b, C, l, u, lb, ub, JcT = qp
    ws_s, ws_f, ws_i, ws_b, out = buffers
    nv = M.shape[0]
    Jc, Gc, Rc, cdrift, ckd = contact_views(cbuf, active.shape[0], nv)
    nt = lim.shape[0]
    k = qmin.shape[0]
    vrows = idx[0:nt]
    iq = idx[nt:nt + k]
    iv = idx[nt + k:nt + 2 * k]
    (state, rstate, residual, tau, wrench, x, jlo, jhi, nu, mu, gram, gram_y, ws) = _carve_tick(
        ws_s, ws_f, ws_i, ws_b, out, H.shape[0], nv, C.shape[0], Jc.shape[0], k)
    (ws_rows, ws_Yv, ws_S, ws_L, ws_tv, ws_c, ws_nuw, ws_vrow, ws_vfree, ws_ffree, ws_fac, ws_a, ws_z, ws_npv, ws_rb,
     ws_lam_b, ws_lam_r, ws_ra, ws_rc, ws_dx, ws_drho, ws_out) = ws
    m = id_assemble((Jt, R, pidx, rt), (Jc, Gc, cdrift, ckd, active), (M, h, q, v, dt),
                    (vrows, lim, par, iq, iv, qmin, qmax, vmax), (H, g, A, b, C, l, u, lb, ub, JcT),
                    (ws_L, ws_tv, gram, gram_y, jlo, jhi))
    if m < 0:
        return m, 0
    res, i, side = _equality_step(H, g, A, b, m, C, l, u, lb, ub, nv, state, rstate, x, ws_L, ws_Yv, ws_S, ws_tv,
                                  nu, 1e-12, ws_rb, ws_vrow, ws_vfree, ws_dx, ws_rc)
    it = 1
    if res < 0.0 and i >= 0 and int(par[PAR_MAX_ITER]) >= 2:
        # one working-set change (a bound entering or leaving), the step again: a bound that alternates between
        # ticks costs a second equality step instead of the general solve
        held = state[i]
        state[i] = side
        res = _equality_step(H, g, A, b, m, C, l, u, lb, ub, nv, state, rstate, x, ws_L, ws_Yv, ws_S, ws_tv, nu,
                             1e-12, ws_rb, ws_vrow, ws_vfree, ws_dx, ws_rc)[0]
        it = 2
        if res < 0.0:
            state[i] = held  # the general solve starts from the previous tick's working set
    if res >= 0.0:
        residual[0] = res
    else:
        space = BlockSpace(nv, ws_rows, ws_Yv, ws_S, ws_L, ws_vfree, ws_ffree, ws_vrow, ws_fac, ws_a, ws_c, ws_tv,
                           ws_ra, ws_rc, ws_dx, ws_drho, ws_npv, ws_nuw, DEPENDENCE_TOL)
        it = dual_active_set((H, g, A, b, m, C, l, u, lb, ub), space, state, rstate, x, nu, mu, ws_lam_b, ws_lam_r,
                             ws_z, ws_rb, int(par[PAR_MAX_ITER]), PRIMAL_TOL, 0.0, DEPENDENCE_TOL, 0.0, True, True, 1,
                             VERIFY_TOL, ws_out)
        residual[0] = ws_out[0]
    if it > 0:
        residual[1] = id_command(M, h, JcT, Gc, Rc, active, x, tau, wrench)
    return it, m


@nb.njit(cache=True, nogil=True)
def output_violations(dv, f, tau, lbf, ubf, friction, active, joints, limits, residual, h, tol, out):
    """The output check of a command (:meth:`~wbc.formulations.acceleration.InverseDynamicsQP.verify`) in one call:
    dv (nv,), corner forces f (12 n_c,) with their bounds lbf, ubf (12 n_c,), torques tau (nv − 6,), the contacts'
    (n_c, 16, 12) friction rows and (n_c,) activity, the limited joints (k,) int64 (into τ) and their limits (k,)
    (k = 0: no torque check), the dynamics residual (N, N·m) and h (nv,). Writes (scaled violation, violation in
    the constraint's units) into out (2 n_c + 2, 2): row 2i the force bounds of contact i, row 2i + 1 its friction
    rows (−inf when inactive), row 2 n_c the torque limits (−inf without a check), the last the floating-base rows.

    Returns:
        -1 when an entry of dv, f or tau is not finite (out not written), 1 when a scaled violation exceeds tol, else 0.
    """
    for a in (dv, f, tau):
        for i in range(a.shape[0]):
            if not np.isfinite(a[i]):
                return -1
    nc = active.shape[0]
    status = 0
    for k in range(nc):
        worst = 0.0
        viol = 0.0
        for i in range(12 * k, 12 * k + 12):
            lo, hi, fi = lbf[i], ubf[i], f[i]
            below, above = lo - fi, fi - hi
            ex = below if below > above else above
            ref = max(1.0, abs(lo) if below > above else abs(hi))
            if not ex > 0:
                ex = 0.0
            worst = max(worst, ex / ref)
            viol = max(viol, ex)
        out[2 * k, 0] = worst
        out[2 * k, 1] = viol
        if worst > tol:
            status = 1
        if active[k]:
            F = friction[k]
            worst = -np.inf
            viol = -np.inf
            for r in range(F.shape[0]):
                fr = 0.0
                size = 0.0
                for j in range(12):
                    fr += F[r, j] * f[12 * k + j]
                    size += abs(F[r, j]) * abs(f[12 * k + j])
                worst = max(worst, fr / max(1.0, size))
                viol = max(viol, fr)
            if worst > tol:
                status = 1
        else:
            worst = viol = -np.inf
        out[2 * k + 1, 0] = worst
        out[2 * k + 1, 1] = viol
    worst = viol = -np.inf
    for r in range(joints.shape[0]):
        ex = abs(tau[joints[r]]) - limits[r]
        worst = max(worst, ex / max(1.0, limits[r]))
        viol = max(viol, ex)
    if worst > tol:
        status = 1
    out[2 * nc, 0] = worst
    out[2 * nc, 1] = viol
    scale = 1.0
    for i in range(6):
        scale = max(scale, abs(h[i]))
    out[2 * nc + 1, 0] = residual / scale
    out[2 * nc + 1, 1] = residual
    if residual / scale > tol:
        status = 1
    return status


@once_per_process
def load_id_kernels() -> None:
    """Load (on-disk cache) or compile, once per process, the kernels the general path calls from Python —
    :func:`task_cost`, :func:`id_command`, :func:`contact_rows_well_conditioned` — on arrays of the types of a real
    call (M column-major as a :class:`~wbc.state.DynamicsState`'s), at construction of an
    :class:`~wbc.formulations.acceleration.InverseDynamicsQP`, not inside its first tick."""
    nv = 7
    Jt, R, pidx = np.zeros((1, nv)), np.zeros((7, 2)), np.zeros(1, np.int64)
    task_cost(Jt, R, pidx, np.zeros(2), np.zeros(nv), 1e-6, np.empty((nv, nv)), np.empty(nv),
              np.zeros((nv + 12, nv + 12)), np.zeros(nv + 12))
    active = np.ones(1, np.bool_)
    id_command(np.asfortranarray(np.eye(nv)), np.zeros(nv), np.zeros((nv, 12)), np.zeros((1, 6, 12)),
               np.zeros((1, 3, 3)), active, np.zeros(nv + 12), np.empty(nv - 6), np.empty((1, 6)))
    contact_rows_well_conditioned(np.ones((1, 6, nv)), active, 1e-2, np.zeros((6, 6)), np.zeros(6))
    output_violations(np.zeros(nv), np.zeros(12), np.zeros(nv - 6), np.zeros(12), np.zeros(12), np.zeros((1, 16, 12)),
                      active, np.zeros(1, np.int64), np.ones(1), 0.0, np.zeros(nv), 1e-6, np.zeros((4, 2)))
