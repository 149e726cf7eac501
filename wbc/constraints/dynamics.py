"""Named constraints of the inverse-dynamics QP (:mod:`wbc.formulations.acceleration`).

Each constraint is an object with a ``name`` (used in infeasibility reports, :mod:`wbc.solvers.diagnosis`), a ``kind``
(``"equality"`` rows of ``A x = b``, ``"inequality"`` rows of ``l ≤ C x ≤ u``, ``"bounds"`` on entries of x) and a
fixed number of rows. The decision variable is x = [v̇ ; f] (nv + 12 n_c). The formulation gives each constraint its
place once (row block or variable indices, :attr:`IDConstraint.rows` / :attr:`IDConstraint.indices`); per tick
:meth:`IDConstraint.write` writes the constraint's numbers **in place** into the formulation's preallocated
arrays, so no matrix is rebuilt and a constant block (the friction pyramids) is written only once.

The per-tick quantities that several constraints share (M, h, the contact Jacobians J_k and J_cᵀ = [J_kᵀ G_k]_k)
are computed once by the formulation and handed over in an :class:`IDContext`.

The rows that depend on the state are written by one compiled (numba) body each — :func:`floating_base_rows`,
:func:`contact_acceleration_rows`, :func:`torque_limit_rows`, :func:`joint_bounds_kernel`, and
:func:`contact_force_columns` for J_cᵀ —, called by the constraint's :meth:`IDConstraint.write` (the general
assembly, :meth:`~wbc.formulations.acceleration.InverseDynamicsQP.build`) and by the compiled tick
(:func:`wbc.formulations.idkernel.id_assemble`) alike: both paths solve one problem, written by one formula.

============================  ==========  ===============================================================  ===========
name                          kind        rows                                                             relaxable
============================  ==========  ===============================================================  ===========
``floating_base_dynamics``    equality    M_u v̇ − (J_cᵀ)_u f = −h_u (eq. 4)                                no
``contact:<c>``               equality    J_k v̇ = −J̇_k v − K_d J_k v − K_p e_k, active contacts (eq. 5)     no
``task:<t>``                  equality    a hard acceleration task J v̇ = a* − J̇ v                          no
``torque_limits``             inequality  −τ_max − h_a ≤ M_a v̇ − (J_cᵀ)_a f ≤ τ_max − h_a (eq. 6)           yes
``friction:<c>``              inequality  friction pyramid F_k f_k ≤ 0 (eq. 7) while active, else free      no
``unilaterality:<c>``         bounds      min(f_min, f_max) ≤ f_z ≤ f_max per corner (CoP inside the       no
                                          sole), or f_k = 0 when the contact is inactive (eq. 8)
``joint_limits``              bounds      joint position / velocity / viability bounds on v̇ (eq. 9)        yes
``<name of the kinematic      inequality  second-order barrier G v̇ ≥ −Ġv − 2γ G v − γ² h of a kinematic      as the
constraint>``                             constraint's h(q) ≥ 0 (:class:`AccelerationBarrier`: ``com_polygon``,  kinematic
                                          ``self_collision``)                                                 one
============================  ==========  ===============================================================  ===========

The barrier rows make the kinematic constraint objects of :mod:`wbc.constraints` (the same object, the same name)
constraints of the acceleration level: with h(q) ≥ 0 the constrained function, ḣ = G v and ḧ = G v̇ + Ġv (from the
constraint's :meth:`~wbc.constraints.base.InequalityConstraint.barrier`), asking ḧ + 2γ ḣ + γ² h ≥ 0 makes
h(t) ≥ (h₀ + (ḣ₀ + γ h₀) t) e^{−γt} ≥ 0 whenever h₀ ≥ 0 and ḣ₀ ≥ −γ h₀ (comparison with the critically damped
solution; exponential control barrier function of relative degree 2, Nguyen & Sreenath, "Exponential control
barrier functions for enforcing high relative-degree safety-critical constraints", ACC 2016). A row with h = +inf
(unused) is −inf ≤ C x.

*Relaxable* constraints are the ones the controller drops when the full QP is infeasible
(:meth:`~wbc.formulations.acceleration.InverseDynamicsQP.solve_relaxed`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numba as nb
import numpy as np

from wbc.constraints.base import InequalityConstraint
from wbc.constraints.sole_contact import SoleContact
from wbc.state import DynamicsState
from wbc.compiled import FASTMATH, once_per_process
from wbc.exceptions import InvalidInputError
from wbc.robot import Robot

__all__ = [
    "IDContext", "IDConstraint", "FloatingBaseDynamics", "ContactAcceleration", "HardTask", "AccelerationBarrier",
    "TorqueLimits",
    "FrictionPyramid", "Unilaterality", "JointAccelerationLimits", "joint_acceleration_bounds", "joint_bounds_kernel",
    "DEPENDENT_CONTACT_RATIO", "consistent_contact_rhs", "independent_contact_rows", "contact_force_columns",
    "floating_base_rows", "contact_acceleration_rows", "torque_limit_rows",
]


@dataclass
class IDContext:
    """Per-tick quantities shared by the constraints (written by the formulation before they are).

    Attributes:
        state: the dynamic state. dt: control period (s). nv: velocity dimension.
        JcT: (nv, 12 n_c) J_cᵀ = [J_kᵀ G_k]_k (LOCAL sole Jacobians; inactive contacts included).
        jacobians: contact name → (6, nv) LOCAL sole Jacobian of this tick.
        offsets: contact name → (6,) velocity-free part −J̇v − K_p e of its eq. 5 right-hand side
            (:meth:`~wbc.constraints.sole_contact.SoleContact.acceleration_offset`) of this tick; a contact missing
            here has it computed by its constraint.
    """

    state: DynamicsState
    dt: float
    nv: int
    JcT: np.ndarray
    jacobians: dict
    offsets: dict = field(default_factory=dict)


class IDConstraint:
    """Base of the named ID constraints (module docstring).

    Attributes:
        name: label in reports. kind: ``equality``, ``inequality`` or ``bounds``. dim: rows (or bounded entries).
        relaxable: dropped by the relaxed solve. constant: written once (rows do not depend on the state).
        rows: slice of the constraint's rows in A (equality) or C (inequality), set by the formulation.
        indices: (dim,) indices of x bounded by a ``bounds`` constraint.
    """

    name: str = "constraint"
    kind: str = "equality"
    dim: int = 0
    relaxable: bool = False
    constant: bool = False
    rows: slice = slice(0, 0)
    indices: np.ndarray | None = None

    @property
    def enabled(self) -> bool:
        """False while the constraint has no rows in the QP (an inactive contact's acceleration rows)."""
        return True

    def write(self, ctx: IDContext, M_rows: np.ndarray, rhs_lo: np.ndarray, rhs_hi: np.ndarray | None) -> None:
        """Write this tick's numbers in place: for ``equality`` M_rows = A[rows], rhs_lo = b[rows] (rhs_hi None);
        for ``inequality`` C[rows], l[rows], u[rows]; for ``bounds`` (M_rows None) lb[indices], ub[indices] —
        given as the views ``rhs_lo``/``rhs_hi`` of length dim."""
        raise NotImplementedError


class FloatingBaseDynamics(IDConstraint):
    """Unactuated rows of the equations of motion (eq. 4): M_u v̇ − (J_cᵀ)_u f = −h_u (N, N·m)."""

    name = "floating_base_dynamics"
    kind = "equality"
    dim = 6

    def write(self, ctx, A, b, _):
        floating_base_rows(ctx.state.M, ctx.state.h, ctx.JcT, A, b, 0)


class ContactAcceleration(IDConstraint):
    """The sole of an active contact does not accelerate (eq. 5; m/s², rad/s², LOCAL). No rows while inactive."""

    kind = "equality"
    dim = 6

    def __init__(self, contact: SoleContact):
        self.contact = contact
        self.name = f"contact:{contact.name}"

    @property
    def enabled(self) -> bool:
        return self.contact.active

    def write(self, ctx, A, b, _):
        c = self.contact
        J = ctx.jacobians[c.name]
        offset = ctx.offsets.get(c.name)
        if offset is None:
            offset = c.acceleration_offset(ctx.state)
        contact_acceleration_rows(J, offset, float(c.kd), ctx.state.v, A, b, 0)


@nb.njit(cache=True, nogil=True, fastmath=FASTMATH, inline="always")
def contact_force_columns(J, G, JcT, col):
    """Write one contact's columns of J_cᵀ: JcT[:, col:col + 12] = Jᵀ G (G = [I; [c_i]×] per corner, the
    corner-force → sole-wrench map: its zero entries are skipped).

    Args:
        J (6, nv): LOCAL sole Jacobian. G (6, 12): corner map. JcT (nv, ≥ col + 12): out. col: first column.
    """
    nv = J.shape[1]
    for i in range(nv):
        for j in range(12):
            JcT[i, col + j] = 0.0
    for k in range(6):
        Jk = J[k]
        for j in range(12):
            gk = G[k, j]
            if gk == 0.0:
                continue
            for i in range(nv):
                JcT[i, col + j] += Jk[i] * gk


@nb.njit(cache=True, nogil=True, fastmath=FASTMATH, inline="always")
def floating_base_rows(M, h, JcT, A, b, row):
    """Rows ``row .. row + 5`` of A x = b: eq. 4, M_u v̇ − (J_cᵀ)_u f = −h_u (N, N·m).

    Args:
        M (nv, nv), h (nv,): mass matrix and nonlinear effects. JcT (nv, n − nv): J_cᵀ. A (≥ row + 6, n),
        b (≥ row + 6,): out.
    """
    nv = M.shape[0]
    nf = A.shape[1] - nv
    for r in range(6):
        for j in range(nv):
            A[row + r, j] = M[r, j]
        for j in range(nf):
            A[row + r, nv + j] = -JcT[r, j]
        b[row + r] = -h[r]


@nb.njit(cache=True, nogil=True, fastmath=FASTMATH, inline="always")
def contact_acceleration_rows(J, offset, kd, v, A, b, row):
    """Rows ``row .. row + 5`` of A x = b: eq. 5 of an active contact, J v̇ = offset − K_d J v (force columns zero;
    offset = −J̇v − K_p e, m/s², rad/s², LOCAL).

    Args:
        J (6, nv): LOCAL sole Jacobian. offset (6,). kd: K_d (1/s). v (nv,). A (≥ row + 6, n), b: out.
    """
    nv = J.shape[1]
    n = A.shape[1]
    for r in range(6):
        s = 0.0
        for j in range(nv):
            s += J[r, j] * v[j]
        for j in range(nv):
            A[row + r, j] = J[r, j]
        for j in range(nv, n):
            A[row + r, j] = 0.0
        b[row + r] = offset[r] - kd * s


@nb.njit(cache=True, nogil=True, fastmath=FASTMATH, inline="always")
def torque_limit_rows(M, h, JcT, vrows, limits, C, l, u, row):
    """Rows ``row ..`` of l ≤ C x ≤ u: eq. 6, −τ_max − h_a ≤ M_a v̇ − (J_cᵀ)_a f ≤ τ_max − h_a (N·m) for the
    joints with velocity indices ``vrows`` (k,) int64 and limits ``limits`` (k,)."""
    nv = M.shape[0]
    nf = C.shape[1] - nv
    for r in range(vrows.size):
        vr = vrows[r]
        for j in range(nv):
            C[row + r, j] = M[vr, j]
        for j in range(nf):
            C[row + r, nv + j] = -JcT[vr, j]
        l[row + r] = -limits[r] - h[vr]
        u[row + r] = limits[r] - h[vr]


#: σ/σ_max below which a direction of the stacked rows of the active contacts counts as dependent
#: (:func:`consistent_contact_rhs`): it lies between the double support of 6-DoF legs (well conditioned) and that of
#: legs without hip yaw, whose relative foot yaw is rank deficient (the ratios per robot: ``benchmarks/README.md``).
DEPENDENT_CONTACT_RATIO = 1e-2


def consistent_contact_rhs(J: np.ndarray, b: np.ndarray, ratio: float = DEPENDENT_CONTACT_RATIO) -> int:
    """Make the stacked contact equalities ``J v̇ = b`` (eq. 5 of every active contact) consistent, in place.

    Two flat soles of a robot whose legs cannot yaw the foot (humanoid15: 5-DoF legs) fix the relative yaw of the
    feet twice: the 12 rows of the two soles have rank 11 at a flat stance (σ_min / σ_max = 8e-19) and stay
    nearly dependent while walking (≤ 5e-3). The component of ``b`` along such a direction u (−uᵀJ̇v − K_d uᵀJv:
    a relative foot yaw the legs can only produce through second-order roll–pitch coupling, non-zero after a
    touch-down with some foot velocity) either makes the equalities infeasible (exact dependence: the controller
    fell back to the relaxed QP with kN forces and the robot fell) or demands an acceleration of order |uᵀb|/σ.
    Here ``b`` is replaced by its projection onto the span of the left singular vectors of ``J`` whose singular
    value is ≥ ``ratio`` σ_max, the least-squares consistent right-hand side of the well-conditioned rows; the rows
    themselves are kept. An exactly dependent row with a consistent right-hand side is then satisfied by the
    solution of the others; a nearly dependent one (σ > 0) is not: it still forbids the motion along its right
    singular vector, which is why the ID QP drops such directions instead (:func:`independent_contact_rows`).
    Singular vectors from the eigen-decomposition of the (m, m) Gram matrix J Jᵀ (σ² = λ).

    Args:
        J: (m, nv) stacked contact rows. b: (m,) right-hand side, modified in place.
        ratio: relative singular-value threshold (dimensionless, in [0, 1)).

    Returns:
        The number of directions projected out (0: ``b`` unchanged).
    """
    lam, U = np.linalg.eigh(J @ J.T)  # ascending
    keep = lam >= (ratio * ratio) * lam[-1]
    n_out = int(J.shape[0] - np.count_nonzero(keep))
    if n_out:
        Uk = U[:, keep]
        b[:] = Uk @ (Uk.T @ b)
    return n_out


def independent_contact_rows(A: np.ndarray, b: np.ndarray, ratio: float = DEPENDENT_CONTACT_RATIO) -> int:
    """Replace the stacked contact equalities ``A x = b`` (eq. 5 of every active contact) by their well-conditioned
    directions, in place: the rows of ``A`` and ``b`` are rotated onto the left singular vectors u_i of ``A`` with
    σ_i ≥ ``ratio`` σ_max, ``u_iᵀ A x = u_iᵀ b``, written in the first r rows; the other m − r rows (the dependent
    directions) are dropped by the caller.

    Keeping a nearly dependent row with a consistent right-hand side (:func:`consistent_contact_rhs`) still forbids
    the motion along its right singular vector v: the row reads σ vᵀv̇ = 0, a hard constraint whatever σ is. For
    two flat soles on 5-DoF legs (humanoid15, no hip yaw) that motion is a pitch and roll of the pelvis over the
    fixed feet (σ / σ_max 1e-4–5e-3 in double support: the second-order relative foot yaw it produces), so the
    QP could not command any pelvis orientation correction while standing, and a disturbance the plant followed
    (soft contacts, model errors) tipped the pelvis past 30°. Dropping the direction leaves the pelvis free along
    v, at the cost of a relative foot yaw acceleration ≤ ``ratio`` σ_max |vᵀv̇| that the contact friction resists.
    Directions from the eigen-decomposition of the (m, m) Gram matrix A Aᵀ (σ² = λ), as in
    :func:`consistent_contact_rhs`.

    Args:
        A: (m, n) stacked contact rows (columns beyond the accelerations, e.g. zero force columns, allowed),
            modified in place. b: (m,) right-hand side, modified in place.
        ratio: relative singular-value threshold (dimensionless, in [0, 1)).

    Returns:
        r, the number of rows kept (m: ``A`` and ``b`` unchanged).
    """
    lam, U = np.linalg.eigh(A @ A.T)  # ascending
    keep = lam >= (ratio * ratio) * lam[-1]
    r = int(np.count_nonzero(keep))
    if r < A.shape[0]:
        Uk = U[:, keep]
        rows, rhs = Uk.T @ A, Uk.T @ b
        A[:r], b[:r] = rows, rhs
    return r


class HardTask(IDConstraint):
    """A task held as a hard equality J v̇ = a* − J̇ v (task units /s²); its weights play no role.

    Args:
        task: an :class:`~wbc.formulations.reference.AccelerationReference` (anything with ``name``, ``dim`` and
            ``compute(state) -> (J, r)``; the formulation checks the type).
    """

    kind = "equality"

    def __init__(self, task):
        self.task = task
        self.name = f"task:{task.name}"
        self.dim = task.dim

    def write(self, ctx, A, b, _):
        J, r = self.task.compute(ctx.state)
        A[:, :ctx.nv] = J
        A[:, ctx.nv:] = 0.0
        b[:] = r


class AccelerationBarrier(IDConstraint):
    """A kinematic inequality constraint with a :meth:`~wbc.constraints.base.InequalityConstraint.barrier` held at
    the acceleration level by the second-order barrier of the module docstring, under the same name.

    Args:
        constraint: e.g. :class:`~wbc.constraints.ComPolygonConstraint`, :class:`~wbc.constraints.SelfCollisionConstraint`.
        gain: γ (1/s, > 0) of ḧ + 2γ ḣ + γ² h ≥ 0.

    Raises:
        InvalidInputError: a constraint without a barrier form, or a bad gain.
    """

    kind = "inequality"

    def __init__(self, constraint, *, gain: float = 10.0):
        if type(constraint).barrier is InequalityConstraint.barrier or not isinstance(constraint,
                                                                                       InequalityConstraint):
            raise InvalidInputError(f"{type(constraint).__name__} has no acceleration-level (barrier) form")
        if not (np.isfinite(gain) and gain > 0):
            raise InvalidInputError(f"barrier gain must be finite and > 0 (1/s), got {gain!r}")
        self.constraint = constraint
        self.name = constraint.name
        self.dim = constraint.dim
        self.relaxable = constraint.relaxable
        self.gain = float(gain)

    def write(self, ctx, C, l, u):
        h, G, drift = self.constraint.barrier(ctx.state, ctx.dt)
        nv, g = ctx.nv, self.gain
        C[:, :nv] = G
        C[:, nv:] = 0.0
        with np.errstate(invalid="ignore"):
            l[:] = -drift - 2.0 * g * (G @ ctx.state.v) - g * g * h
        l[~np.isfinite(h)] = -np.inf
        u[:] = np.inf


class TorqueLimits(IDConstraint):
    """URDF effort limits on the torques of eq. 2 (eq. 6, N·m), joints with a finite positive limit only.

    Args:
        robot: the robot. scale: fraction of the URDF effort limit, in (0, 1].

    Attributes:
        tau_max: (nv − 6,) scaled effort limits (all joints). joints: indices (into τ) of the limited joints.
        limits: (dim,) the limits of those joints. velocity_indices: (dim,) int64 their indices in v;
        velocity_rows: the same, a slice when contiguous.
    """

    name = "torque_limits"
    kind = "inequality"
    relaxable = True

    def __init__(self, robot: Robot, scale: float = 1.0):
        if not (0 < scale <= 1):
            raise InvalidInputError(f"torque_limit_scale must be in (0, 1], got {scale!r}")
        effort = np.asarray(robot.model.effortLimit[6:], dtype=float) * float(scale)
        self.tau_max = effort
        self.joints = np.flatnonzero(np.isfinite(effort) & (effort > 0))
        self.dim = int(self.joints.size)
        self.velocity_indices = (6 + self.joints).astype(np.int64)
        self.velocity_rows = self.velocity_indices
        if self.dim and np.array_equal(self.joints, np.arange(self.joints[0], self.joints[0] + self.dim)):
            self.velocity_rows = slice(6 + int(self.joints[0]), 6 + int(self.joints[-1]) + 1)  # views, no gather
        self.limits = effort[self.joints]

    def write(self, ctx, C, l, u):
        if not self.dim:
            return
        torque_limit_rows(ctx.state.M, ctx.state.h, ctx.JcT, self.velocity_indices, self.limits, C, l, u, 0)


class FrictionPyramid(IDConstraint):
    """Inscribed friction pyramid of a sole's 4 corner forces (eq. 7; N): ``friction_matrix @ f_k ≤ 0`` while the
    contact is active; free rows (−inf ≤ · ≤ inf) while it is inactive, where its bounds already hold f_k = 0 (the
    16 rows 0 ≤ 0 would be always active and dependent on those bounds: a degenerate set on which DAQP's dual
    active-set method reported feasible single-support problems infeasible). Constant between changes of the
    contact's μ or activity: the formulation rewrites it when :meth:`key` changes. ``offset`` is the first force
    variable of the contact in x."""

    kind = "inequality"
    dim = 16
    constant = True

    def __init__(self, contact: SoleContact, offset: int):
        self.contact = contact
        self.name = f"friction:{contact.name}"
        self.offset = int(offset)
        #: :meth:`key` of the rows last written by the formulation (None: never).
        self.written: tuple | None = None

    def key(self) -> tuple:
        """What the rows depend on: the contact's (μ, active)."""
        return (self.contact.mu, self.contact.active)

    def write(self, ctx, C, l, u):
        C[:] = 0.0
        C[:, self.offset:self.offset + 12] = self.contact.friction_matrix
        l[:] = -np.inf
        u[:] = 0.0 if self.contact.active else np.inf


class Unilaterality(IDConstraint):
    """Bounds on a sole's 12 corner forces (eq. 8; N): f_min ≤ f_z ≤ f_max and tangential free while active —
    the unilateral contact, which keeps the CoP inside the sole rectangle (:mod:`wbc.constraints.sole_contact`) —, all
    zero while inactive."""

    kind = "bounds"
    dim = 12

    def __init__(self, contact: SoleContact, offset: int):
        self.contact = contact
        self.name = f"unilaterality:{contact.name}"
        self.indices = np.arange(offset, offset + 12)
        #: :meth:`key` of the bounds last written by the formulation (None: never).
        self.written: tuple | None = None

    def key(self) -> tuple:
        """What the bounds depend on: (active, f_min, f_max) — rewritten only when it changes."""
        c = self.contact
        return (c.active, c.f_min, c.f_max)

    def write(self, ctx, _, lb, ub):
        c = self.contact
        if c.active:
            lb.fill(-np.inf)
            ub.fill(np.inf)
            lb[2::3], ub[2::3] = c.normal_force_bounds  # min(f_min, f_max) ≤ f_z ≤ f_max: never crossed
        else:
            lb.fill(0.0)
            ub.fill(0.0)


@nb.njit(cache=True, nogil=True)
def joint_bounds_kernel(q, v, iq, iv, qmin, qmax, vmax, a, dt, lo_out, hi_out, horizon):
    """Compiled :func:`joint_acceleration_bounds` (the numbers of eq. 9, joint by joint), written into lo_out,
    hi_out (k,); the velocity term approaches ±vmax over ``horizon`` ticks."""
    dt2 = dt * dt
    dth = dt * horizon
    for j in range(iq.size):
        qj = q[iq[j]]
        vj = v[iv[j]]
        q1 = qj + vj * dt
        d_hi = qmax[j] - q1
        d_lo = q1 - qmin[j]
        hi = min((vmax[j] - vj) / dth, 2.0 * d_hi / dt2)
        lo = max((-vmax[j] - vj) / dth, -2.0 * d_lo / dt2)
        # viability: larger root of dt² x² + B x + (w² − 2 a d) = 0, mirrored for the lower limit
        w = vj
        B = 2.0 * w * dt + a * dt2
        disc = max(B * B - 4.0 * dt2 * (w * w - 2.0 * a * d_hi), 0.0)
        hi = min(hi, (-B + np.sqrt(disc)) / (2.0 * dt2))
        w = -vj
        B = 2.0 * w * dt + a * dt2
        disc = max(B * B - 4.0 * dt2 * (w * w - 2.0 * a * d_lo), 0.0)
        lo = max(lo, -((-B + np.sqrt(disc)) / (2.0 * dt2)))
        hi = max(hi, -a)
        lo = min(lo, a)
        lo_out[j] = min(lo, hi)
        hi_out[j] = hi


def joint_acceleration_bounds(q, v, iq, iv, qmin, qmax, vmax, braking_acceleration: float, dt: float,
                              lo: np.ndarray | None = None, hi: np.ndarray | None = None, speed_horizon: float = 1.0):
    """(lo, hi) joint acceleration bounds (rad/s²) of eq. 9 (position, velocity and viability with braking
    acceleration a_brk; del Prete 2018, IEEE RA-L 3(1):281–288, §III–IV) for the 1-DoF joints with configuration
    indices ``iq`` and velocity indices ``iv`` (limits qmin, qmax (rad), vmax (rad/s, inf when unlimited)).
    The velocity term is (±vmax − v) / (h dt), h = ``speed_horizon`` (ticks, ≥ 1; 1: eq. 9's one-tick bound; see
    :class:`~wbc.constraints.joint_velocity.JointSpeedBounds` for h > 1). Written into ``lo``/``hi`` when given."""
    k = len(iq)
    lo = np.empty(k) if lo is None else lo
    hi = np.empty(k) if hi is None else hi
    joint_bounds_kernel(q, v, iq, iv, qmin, qmax, vmax, float(braking_acceleration), float(dt), lo, hi,
                        float(speed_horizon))
    return lo, hi


@once_per_process
def _warm_up() -> None:
    """Load the compiled row bodies (on-disk cache) once per process, at construction of
    :class:`JointAccelerationLimits`, not inside a controller's first tick: on arrays of the types of a real call (M
    column-major as a :class:`~wbc.state.DynamicsState`'s, the rest C-contiguous)."""
    z, i = np.zeros(1), np.zeros(1, dtype=np.int64)
    joint_bounds_kernel(z, z, i, i, -np.ones(1), np.ones(1), np.ones(1), 1.0, 1e-3, np.empty(1), np.empty(1), 1.0)
    nv = 7
    M, h, v = np.asfortranarray(np.eye(nv)), np.zeros(nv), np.zeros(nv)
    JcT, A, b = np.zeros((nv, 12)), np.zeros((12, nv + 12)), np.zeros(12)
    contact_force_columns(np.zeros((6, nv)), np.zeros((6, 12)), JcT, 0)
    floating_base_rows(M, h, JcT, A, b, 0)
    contact_acceleration_rows(np.zeros((6, nv)), np.zeros(6), 1.0, v, A, b, 6)
    torque_limit_rows(M, h, JcT, np.full(1, 6, dtype=np.int64), np.ones(1), A, b, b.copy(), 0)


class JointAccelerationLimits(IDConstraint):
    """Joint position / velocity / viability bounds on the 1-DoF joint accelerations (eq. 9; rad/s²).

    Args:
        robot: the robot. braking_acceleration: a_brk (rad/s²), > 0.
    """

    name = "joint_limits"
    kind = "bounds"
    relaxable = True

    def __init__(self, robot: Robot, braking_acceleration: float = 50.0):
        if not (np.isfinite(braking_acceleration) and braking_acceleration > 0):
            raise InvalidInputError(f"braking_acceleration must be finite and > 0, got {braking_acceleration!r}")
        model = robot.model
        iq, iv = [], []
        for j in range(2, model.njoints):
            jm = model.joints[j]
            if jm.nq == 1 and jm.nv == 1:
                iq.append(jm.idx_q)
                iv.append(jm.idx_v)
        self.iq, self.iv = np.array(iq, dtype=np.int64), np.array(iv, dtype=np.int64)
        self.indices = self.iv
        self.dim = int(self.iv.size)
        self.qmin = np.asarray(model.lowerPositionLimit, dtype=float)[self.iq].copy()
        self.qmax = np.asarray(model.upperPositionLimit, dtype=float)[self.iq].copy()
        vmax = np.asarray(model.velocityLimit, dtype=float)[self.iv]
        self.vmax = np.where(vmax > 0, vmax, np.inf)
        self.braking_acceleration = float(braking_acceleration)
        #: ticks h over which the velocity term lets a joint reach ±vmax (≥ 1; see joint_acceleration_bounds)
        self.speed_horizon = 1.0
        self._lo = np.empty(self.dim)
        self._hi = np.empty(self.dim)
        _warm_up()

    def bounds(self, state: DynamicsState, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """(lo, hi) (dim,) at ``state`` (arrays reused across calls)."""
        return joint_acceleration_bounds(state.q, state.v, self.iq, self.iv, self.qmin, self.qmax, self.vmax,
                                         self.braking_acceleration, dt, self._lo, self._hi, self.speed_horizon)

    def write(self, ctx, _, lb, ub):
        lo, hi = self.bounds(ctx.state, ctx.dt)
        lb[:] = lo
        ub[:] = hi
