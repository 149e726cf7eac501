"""Compiled assembly of the inverse-dynamics QP of :mod:`wbc.formulations.acceleration` (:func:`id_assemble`, the
one assembly of every backend), the torques of a solution (:func:`id_command`) and the output check
(:func:`output_violations`). :func:`id_assemble` writes the cost (:func:`task_cost`) and the state-dependent
constraint blocks with the compiled bodies of :mod:`wbc.constraints`, from the task rows and contact data gathered by
:mod:`wbc.formulations.id_rows`.
"""

from __future__ import annotations

from collections import namedtuple

import numba as nb
import numpy as np

from wbc.compiled import CHECK_TYPES, FASTMATH, once_per_process, specialise
from wbc.constraints.contact_acceleration import contact_acceleration_rows
from wbc.constraints.floating_base import contact_force_columns, floating_base_rows
from wbc.constraints.joint_acceleration_bounds import JointRange, joint_bounds_kernel
from wbc.constraints.torque_limits import torque_limit_rows
from wbc.formulations.reference import reference_rhs
from wbc.solvers.linalg import cholesky_lower, weighted_normal_equations

__all__ = ["contact_rows_well_conditioned", "inverse_diagonal", "id_assemble", "id_command", "load_id_kernels",
           "output_violations", "task_cost", "IDTaskRows", "IDDynamics", "IDContactData", "IDLimits", "IDArrays",
           "IDAssemblyWork", "IDOutputBuffers", "output_inputs", "IDOutputCheck"]

#: the arguments of :func:`id_assemble` (namedtuples, fields described there)
IDTaskRows = namedtuple("IDTaskRows", "Jt R pidx rt")
IDDynamics = namedtuple("IDDynamics", "M h q v dt")
IDContactData = namedtuple("IDContactData", "Jc Gc cdrift ckd active")
IDLimits = namedtuple("IDLimits", "idx lim par qmin qmax vmax brake")
IDArrays = namedtuple("IDArrays", "H g A b C l u lb ub JcT")
IDAssemblyWork = namedtuple("IDAssemblyWork", "Hw gw gram gram_y jlo jhi")
#: the buffers of :func:`output_violations`
IDOutputBuffers = namedtuple("IDOutputBuffers", "lbf ubf friction active out")


@nb.njit(cache=True, nogil=True, fastmath=FASTMATH)
def inverse_diagonal(M, L, y, out) -> bool:
    """out (n,) ← diag(M⁻¹) of a symmetric positive definite M (n, n): (M⁻¹)_ii = ‖L⁻¹ e_i‖² with M = L Lᵀ
    (Cholesky, from M's lower triangle). L (n, n) and y (n,) are workspace (L may be M, out may be y: overwritten).
    Returns False (out not written) when M is not positive definite."""
    n = M.shape[0]
    for i in range(n):
        for j in range(i + 1):
            L[i, j] = M[i, j]
    if not cholesky_lower(L, n):
        return False
    for i in range(n):  # column i of L⁻¹: zero above i, forward substitution from row i
        y[i] = 1.0 / L[i, i]
        s = y[i] * y[i]
        for r in range(i + 1, n):
            t = 0.0
            for p in range(i, r):
                t -= L[r, p] * y[p]
            y[r] = t / L[r, r]
            s += y[r] * y[r]
        out[i] = s  # (y[i] is not read again)
    return True


@nb.njit(cache=True, nogil=True, fastmath=FASTMATH)
def contact_rows_well_conditioned(Jc, active, ratio, G, y):
    """Certificate that the stacked rows J (m × nv) of the active contacts have every singular value
    σ ≥ ``ratio`` σ_max, so that :func:`wbc.constraints.contact_acceleration.independent_contact_rows` would keep
    every row and need not run. With G = J Jᵀ: λ_min ≥ 1 / tr(G⁻¹) (:func:`inverse_diagonal`) and λ_max ≤ tr(G), so
    1 / tr(G⁻¹) ≥ ratio² tr(G) implies λ_min ≥ ratio² λ_max. False when that bound does not hold or G is not
    positive definite.

    Args:
        Jc (nc, 6, nv): contact Jacobians; active (nc,) bool; ratio: σ / σ_max threshold; G (6 nc, 6 nc), y (6 nc,):
            workspace.
    """
    nc = Jc.shape[0]
    nv = Jc.shape[2]
    tr = 0.0
    m = 0  # rows of G written (6 per active contact)
    for c in range(nc):
        if not active[c]:
            continue
        for r in range(6):
            j = 0
            for c2 in range(c + 1):
                if not active[c2]:
                    continue
                for r2 in range(6):
                    if j > m:
                        break
                    acc = 0.0
                    for k in range(nv):
                        acc += Jc[c, r, k] * Jc[c2, r2, k]
                    G[m, j] = acc
                    j += 1
            tr += G[m, m]
            m += 1
    if m == 0:
        return True
    if not inverse_diagonal(G[:m, :m], G[:m, :m], y, y):
        return False
    tinv = 0.0
    for r in range(m):
        tinv += y[r]
    return 1.0 / tinv >= ratio * ratio * tr


#: entries of :func:`id_assemble`'s ``par`` vector
PAR_EPS_A, PAR_BRAKING, PAR_JOINT_LIMITS, PAR_CONTACT_RATIO, PAR_SPEED_HORIZON = range(5)
#: rows of the ``R`` array of :func:`task_cost` (one column per task row)
R_ERROR, R_ERROR_RATE_FF, R_DRIFT, R_ACC_FF, R_KP, R_KD, R_WEIGHT = range(7)


@nb.njit(cache=True, nogil=True, fastmath=FASTMATH, inline="always")
def task_cost(Jt, R, pidx, rt, v, eps_a, Hw, gw, H, g):
    """The cost (3) of the ID QP from the stacked task rows, written into H[:nv, :nv] and g[:nv] (H_ff = ε_f I is
    left as it is): r by eq. 1 of :mod:`wbc.formulations.reference`, H_vv = Σ_i J_iᵀ W_i J_i + diag(w_posture) + ε_a I,
    g_v = −Σ_i J_iᵀ W_i r_i.

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
    """The command of a QP solution x = [v̇; f] (n,): the torques of eq. 2 into tau (nv − 6,), and each active
    sole's wrench G_k f_k at its origin in world axes (N, N·m; Rc (nc, 3, 3) world ← sole) into wrench (nc, 6), zero
    for an inactive contact. Returns ‖M_u v̇ + h_u − (J_cᵀ)_u f‖_∞ (N, N·m), the residual of the unactuated rows."""
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


@nb.njit(cache=True, nogil=True, fastmath=FASTMATH)
def id_assemble(tasks, dynamics, contacts, limits, qp, work):
    """Write the state-dependent blocks of the ID QP (module docstring) into the formulation's arrays: the cost, J_cᵀ
    and eqs. 4, 5 (active contacts), 6 and 9 (when ``par[PAR_JOINT_LIMITS]`` ≠ 0). The constant blocks (ε_f I,
    friction rows, force bounds) and the rows of hard tasks and added constraints are the formulation's.

    Args (namedtuples):
        tasks (:data:`IDTaskRows`): the stacked task rows of :func:`task_cost`.
        dynamics (:data:`IDDynamics`): M (nv, nv), h (nv,), q (nq,), v (nv,) of the state; dt: control period (s).
        contacts (:data:`IDContactData`): Jc (nc, 6, nv) the LOCAL sole Jacobians, Gc (nc, 6, 12) the corner maps,
            eq. 5's cdrift = −J̇v − K_p e (nc, 6) and K_d (nc,), active (nc,) bool.
        limits (:data:`IDLimits`): idx int64 [vrows (nt,) | iq (k,) | iv (k,)], the v indices of the torque-limited
            joints, then the q and v indices of the joint-bounded ones; lim (nt,) their torque limits (N·m); par (5,)
            the settings ``PAR_*``; qmin, qmax, vmax (k,) joint-limit data (eq. 9).
        qp (:data:`IDArrays`): H, g, A, b, C, l, u, lb, ub, JcT, written in place (A has room for every contact).
        work (:data:`IDAssemblyWork`): Hw (nv, nv), gw (nv,), gram (6 nc, 6 nc), gram_y (6 nc,), jlo, jhi (k,).

    Returns:
        m, the number of equality rows written (6 + 6 per active contact); −m when two or more active contacts are
        not certified well conditioned (:func:`contact_rows_well_conditioned`: the caller drops the dependent
        directions of rows 6 .. m).
    """
    Jt, R, pidx, rt = tasks
    M, h, q, v, dt = dynamics
    Jc, Gc, cdrift, ckd, active = contacts
    idx, lim, par, qmin, qmax, vmax, brake = limits
    nt = lim.shape[0]
    k = qmin.shape[0]
    vrows, iq, iv = idx[0:nt], idx[nt:nt + k], idx[nt + k:nt + 2 * k]
    H, g, A, b, C, l, u, lb, ub, JcT = qp
    Hw, gw, gram, gram_y, jlo, jhi = work
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
    torque_limit_rows(M, h, JcT, vrows, lim, C, l, u, 0)
    if par[PAR_JOINT_LIMITS] != 0.0:
        joint_bounds_kernel(q, v, JointRange(iq, iv, qmin, qmax, vmax, brake), par[PAR_BRAKING], dt,
                            par[PAR_SPEED_HORIZON], jlo, jhi)
        for j in range(iv.size):
            lb[iv[j]] = jlo[j]
            ub[iv[j]] = jhi[j]
    if m > 12 and not contact_rows_well_conditioned(Jc, active, par[PAR_CONTACT_RATIO], gram, gram_y):
        return -m
    return m


@nb.njit(cache=True, nogil=True)
def output_violations(dv, f, tau, residual, h, joints, limits, tol, buffers):
    """The output check of a command (:class:`IDOutputCheck`) in one call:
    dv (nv,), corner forces f (12 n_c,), torques tau (nv − 6,), the dynamics residual (N, N·m) and h (nv,), the
    limited joints (k,) int64 (into τ) and their limits (k,) (k = 0: no torque check); of ``buffers``
    (:data:`IDOutputBuffers`) the forces' bounds lbf, ubf (12 n_c,), the contacts' (n_c, 16, 12) friction rows and
    (n_c,) activity. Writes (scaled violation, violation) into ``buffers.out`` (2 n_c + 2, 2): rows 2i, 2i + 1 the
    force bounds and friction rows of contact i (−inf inactive), then the torque limits (−inf: none), the base rows.

    Returns:
        -1 when an entry of dv, f or tau is not finite (out not written), 1 when a scaled violation exceeds tol, else 0.
    """
    lbf, ubf, friction, active, out = buffers
    for a in (dv, f, tau):
        for i in range(a.shape[0]):
            if not np.isfinite(a[i]):
                return -1
    nc = active.shape[0]
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
        worst = viol = -np.inf
        if active[k]:
            F = friction[k]
            for r in range(F.shape[0]):
                fr = 0.0
                size = 0.0
                for j in range(12):
                    fr += F[r, j] * f[12 * k + j]
                    size += abs(F[r, j]) * abs(f[12 * k + j])
                worst = max(worst, fr / max(1.0, size))
                viol = max(viol, fr)
        out[2 * k + 1, 0] = worst
        out[2 * k + 1, 1] = viol
    worst = viol = -np.inf
    for r in range(joints.shape[0]):
        ex = abs(tau[joints[r]]) - limits[r]
        worst = max(worst, ex / max(1.0, limits[r]))
        viol = max(viol, ex)
    out[2 * nc, 0] = worst
    out[2 * nc, 1] = viol
    scale = 1.0
    for i in range(6):
        scale = max(scale, abs(h[i]))
    out[2 * nc + 1, 0] = residual / scale
    out[2 * nc + 1, 1] = residual
    for r in range(2 * nc + 2):
        if out[r, 0] > tol:
            return 1
    return 0


@once_per_process
def load_id_kernels() -> None:
    """Load, once per process, the kernels called from Python on arrays of a real call's types (M column-major), at
    construction of an :class:`~wbc.formulations.acceleration.InverseDynamicsQP`, not inside its first tick."""
    nv = 8
    active = np.ones(1, np.bool_)
    id_command(np.asfortranarray(np.eye(nv)), np.zeros(nv), np.zeros((nv, 12)), np.zeros((1, 6, 12)),
               np.zeros((1, 3, 3)), active, np.zeros(nv + 12), np.empty(nv - 6), np.empty((1, 6)))
    buffers = IDOutputBuffers(np.zeros(12), np.zeros(12), np.zeros((1, 16, 12)), active, np.zeros((4, 2)))
    for dv, f, tau, h in (output_inputs(nv, 1), output_inputs(nv, 1, strided=True)):
        output_violations(dv, f, tau, 0.0, h, np.zeros(1, np.int64), np.ones(1), 1e-6, buffers)


def output_inputs(nv: int, nc: int, strided: bool = False) -> tuple:
    """Zeros of the types of :func:`output_violations`' dv (nv,), f (12 nc,), tau (nv − 6,), h (nv,): contiguous, or
    strided (numba layout 'A', the version called on arrays of any strides; nv ≥ 8, as numpy flags a strided array
    of one entry contiguous)."""
    k = 2 if strided else 1
    return tuple(np.zeros(k * n)[::k] for n in (nv, 12 * nc, nv - 6, nv))


class IDOutputCheck:
    """The output check of the solutions of one QP (:func:`output_violations` on preallocated buffers), independent
    of the solver: every entry finite; corner normal forces within their bounds (``unilaterality:<c>``, N); the
    friction pyramids (``friction:<c>``, N); the torque limits (``torque_limits``, N·m); the floating-base rows
    (``floating_base_dynamics``, N, N·m). Each violation is compared with a relative tolerance times the row's scale
    — max(1, |bound|) for a bound, max(1, |f_t| + μ/√2 |f_z|) for a friction row, the largest |h_u| entry for the
    base rows — as :meth:`wbc.solvers.base.QPBackend.scaled_violation` scales them.

    Args:
        contacts: the QP's sole contacts. torque_limits: its :class:`~wbc.constraints.torque_limits.TorqueLimits`.
        force_lb, force_ub: (12 n_c,) views of the QP's bounds on the corner forces (written by the constraints).
    """

    def __init__(self, contacts, torque_limits, force_lb: np.ndarray, force_ub: np.ndarray):
        nc = len(contacts)
        self.contacts = contacts
        self.torque_limits = torque_limits
        self._buffers = IDOutputBuffers(force_lb, force_ub, np.zeros((nc, 16, 12)), np.zeros(nc, np.bool_),
                                        np.zeros((2 * nc + 2, 2)))
        self._friction_rows = list(self._buffers.friction)  # (16, 12) views, one per contact
        self._names = [f"{kind}:{c.name}" for c in contacts for kind in ("unilaterality", "friction")] + [
            "torque_limits", "floating_base_dynamics"]  # the rows of out
        self._no_joints = np.zeros(0, np.int64)
        self._kernel = None  # violations' compiled call, specialised at its first call

    def violations(self, h: np.ndarray, sol, tol: float, relaxed: bool) -> list[tuple[str, float]] | None:
        """[(constraint name, violation in its units)] of the solution ``sol`` (an
        :class:`~wbc.formulations.acceleration.IDCommand`) at a state of nonlinear effects ``h`` (nv,), largest
        scaled first, at relative tolerance ``tol``; the torque limits skipped when ``relaxed``. [] when it passes;
        None when an entry of the solution is not finite."""
        active, out = self._buffers.active, self._buffers.out
        for k, c in enumerate(self.contacts):  # copies: a contact's friction rows are rewritten in place when μ is set
            self._friction_rows[k][...] = c.friction_matrix
            active[k] = c.active
        tl = self.torque_limits
        joints = self._no_joints if relaxed or not tl.joints.size else tl.joints
        args = (sol.dv, sol.forces, sol.tau, float(sol.dynamics_residual), h, joints, tl.limits, tol, self._buffers)
        kernel = self._kernel
        if kernel is None:  # for a solution and h of any strides (with kernel type checks on, the dispatcher)
            dv, f, tau, h_any = output_inputs(8, 1, strided=True)  # (types only: any sizes)
            kernel = self._kernel = output_violations if CHECK_TYPES else specialise(
                output_violations, dv, f, tau, args[3], h_any, *args[5:])
        status = kernel(*args)
        if status <= 0:
            return None if status < 0 else []
        found = sorted((r for r in range(len(self._names)) if out[r, 0] > tol), key=lambda r: -out[r, 0])
        return [(self._names[r], float(out[r, 1])) for r in found]
