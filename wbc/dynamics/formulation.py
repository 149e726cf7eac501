"""Inverse-dynamics QP for a floating-base robot in contact.

The problem, solved once per control tick of period dt (s), at the measured state (q, v):

Variables  x = [v̇ ; f] ∈ R^{nv + 12 n_c}: generalized accelerations v̇ (Pinocchio conventions: base spatial
acceleration in the base frame, then joints) and, per declared sole contact k, 4 corner forces f_k ∈ R^12 in
the sole frame (:mod:`wbc.dynamics.contacts`).

Equations of motion (Featherstone 2008, "Rigid Body Dynamics Algorithms", eq. 3.6 with contacts)

    M(q) v̇ + h(q, v) = Sᵀ τ + Σ_k J_kᵀ G_k f_k,         S = [0_{(nv−6)×6}  I_{nv−6}]             (1)

with M, h = C v + g and the LOCAL sole Jacobians J_k from Pinocchio, G_k the constant corner-force →
sole-wrench map (sole frame). The actuated rows define the torques, which are therefore not variables:

    τ = M_a v̇ + h_a − Σ_k (J_kᵀ G_k)_a f_k          (a: rows 6..nv−1)                              (2)

    min_x   Σ_i ‖ diag(√w_i) (J_i v̇ − r_i) ‖²  +  ε_a ‖v̇‖²  +  ε_f ‖f‖²                           (3)
            r_i = a*_i − J̇_i v,  a*_i = ä_ff − Kp e_i − Kd (J_i v − ė_ff)       (tasks, wbc.dynamics.tasks)
    s.t.    M_u v̇ − Σ_k (J_kᵀ G_k)_u f_k = −h_u        (u: rows 0..5, unactuated floating base)          (4)
            J_k v̇ = −J̇_k v − Kd_c J_k v − Kp_c e_k    for each *active* contact k (sole does not accelerate)  (5)
            −τ_max − h_a ≤ M_a v̇ − Σ_k (J_kᵀ G_k)_a f_k ≤ τ_max − h_a     (URDF effort limits, from (2))     (6)
            F_k f_k ≤ 0                                 (friction pyramids, μ/√2 per corner axis)            (7)
            f_min ≤ f_z ≤ f_max per corner; f_k = 0 for an inactive contact   (unilaterality; CoP in sole)  (8)
            v̇_lo ≤ v̇_joints ≤ v̇_hi                      (joint position/velocity limits, below)             (9)

Joint acceleration bounds (9), per 1-DoF joint with limits [q_min, q_max], |v| ≤ v_max (URDF), and a braking
acceleration a_brk (``braking_acceleration``, rad/s²):

    velocity      (−v_max − v)/dt ≤ v̇ ≤ (v_max − v)/dt                       (v reached after one tick)
    position      v̇ ≤ 2 (q_max − q − v dt)/dt²,   v̇ ≥ 2 (q_min − q − v dt)/dt²      (q after one tick)
    viability     v⁺ ≤ √(2 a_brk (q_max − q⁺)) with v⁺ = v + v̇ dt, q⁺ = q + v dt + ½ v̇ dt² (and symmetrically
                  at q_min): the state after one tick can still stop before the limit by decelerating at a_brk.
                  Squaring gives dt² v̇² + (2 v dt + a_brk dt²) v̇ + v² − 2 a_brk (q_max − q − v dt) ≤ 0, whose
                  larger root is the bound.

(del Prete 2018, "Joint position and velocity bounds in discrete-time acceleration/torque control of robot
manipulators", IEEE RA-L 3(1):281–288, sections III–IV: the position bound alone is not viable; the braking
bound makes it so under the assumption that a_brk is always available.) When a state is already outside these
sets (a joint faster than its viable velocity, e.g. after an impact, or MuJoCo's soft joint limit let q pass
q_max), the bounds would demand an arbitrarily large braking acceleration in one tick, which the torque limits
cannot deliver: the demanded braking is then capped at a_brk (v̇ ≤ max(hi, −a_brk), v̇ ≥ min(lo, a_brk)), the
best the viability assumption allows, and the lower bound is lowered to the upper one if they cross.

Regularisation ε_a, ε_f > 0 make the Hessian positive definite. The solution gives τ by (2); the dynamics (1)
then hold to the solver's equality accuracy on rows 0..5 and exactly on the actuated rows.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from time import perf_counter

import numpy as np

from wbc.dynamics.contacts import SoleContact
from wbc.dynamics.state import DynamicsState
from wbc.backends import make_backend
from wbc.dynamics.tasks import AccelerationTask, PostureAccelerationTask
from wbc.exceptions import InvalidInputError
from wbc.qp import QPBackend
from wbc.robot import Robot

__all__ = ["InverseDynamicsQP", "IDSolution"]


@dataclass
class IDSolution:
    """Solution of one inverse-dynamics QP.

    Attributes:
        dv: (nv,) generalized acceleration v̇.
        forces: (12 n_c,) corner forces (N), sole frames, contact-major then corner-major (x, y, z).
        tau: (nv − 6,) joint torques (N·m) from eq. (2).
        wrenches: contact name → (6,) wrench (N, N·m) at the sole origin, world axes.
        dynamics_residual: ‖M v̇ + h − Sᵀτ − J_cᵀ f‖_∞ (N, N·m).
        timings: seconds spent in 'assembly' and 'solve'.
    """

    dv: np.ndarray
    forces: np.ndarray
    tau: np.ndarray
    wrenches: dict[str, np.ndarray] = field(default_factory=dict)
    dynamics_residual: float = 0.0
    timings: dict[str, float] = field(default_factory=dict)


#: Solver settings of the ID QP: the floating-base dynamics rows are equalities (exact in an active-set solve);
#: a tight primal tolerance keeps the inequalities (friction, torque limits) to 1e-9 as well; the dual warm
#: start measured faster than DAQP's persistent workspace on this inequality-heavy QP (159 vs 191 µs median).
_ID_SETTINGS = {"daqp": {"primal_tol": 1e-6, "warm_start": "dual"}}

class InverseDynamicsQP:
    """Builds and solves the QP of the module docstring.

    Args:
        robot: the robot.
        tasks: acceleration tasks (:mod:`wbc.dynamics.tasks`).
        contacts: sole contacts (all declared up front; (de)activate them to switch support).
        solver: QP backend name (``daqp``: warm-started from the previous duals, ``primal_tol`` 1e-9;
            ``proxqp`` warm-started; any other qpsolvers backend — :func:`wbc.backends.make_backend`) or a
            :class:`~wbc.qp.QPBackend`.
        acceleration_regularization: ε_a (weight of ‖v̇‖²).
        force_regularization: ε_f (weight of ‖f‖², 1/N² in task-cost units).
        torque_limit_scale: fraction of the URDF effort limit used in (6), in (0, 1].
        braking_acceleration: a_brk of the viability bound (rad/s²), > 0.
        joint_limits: apply the joint acceleration bounds (9).

    Raises:
        UnknownSolverError: unknown backend. InvalidInputError: bad numbers or objects.
    """

    def __init__(self, robot: Robot, tasks: list[AccelerationTask] = (), contacts: list[SoleContact] = (), *,
                 solver: str | QPBackend = "daqp", acceleration_regularization: float = 1e-6,
                 force_regularization: float = 1e-7, torque_limit_scale: float = 1.0,
                 braking_acceleration: float = 50.0, joint_limits: bool = True):
        for value, what in ((acceleration_regularization, "acceleration_regularization"),
                            (force_regularization, "force_regularization"),
                            (braking_acceleration, "braking_acceleration")):
            if not (np.isfinite(value) and value > 0):
                raise InvalidInputError(f"{what} must be finite and > 0, got {value!r}")
        if not (0 < torque_limit_scale <= 1):
            raise InvalidInputError(f"torque_limit_scale must be in (0, 1], got {torque_limit_scale!r}")
        self.robot = robot
        model = robot.model
        self.nv = nv = model.nv
        self.backend = (make_backend(solver, **_ID_SETTINGS.get(solver, {})) if isinstance(solver, str) else solver)
        self.eps_a = float(acceleration_regularization)
        self.eps_f = float(force_regularization)
        self.braking_acceleration = float(braking_acceleration)
        self.joint_limits = bool(joint_limits)
        self.tasks: list[AccelerationTask] = []
        for t in tasks:
            self.add_task(t)
        self.contacts: list[SoleContact] = []
        for c in contacts:
            if not isinstance(c, SoleContact):
                raise InvalidInputError(f"expected a SoleContact, got {type(c).__name__}")
            if any(c.name == other.name for other in self.contacts):
                raise InvalidInputError(f"two contacts named {c.name!r}")
            self.contacts.append(c)
        nc = len(self.contacts)
        self.n = nv + 12 * nc
        # Torque limits (6).
        effort = np.asarray(model.effortLimit[6:], dtype=float) * float(torque_limit_scale)
        self.tau_rows = np.flatnonzero(np.isfinite(effort) & (effort > 0))
        self.tau_max = effort
        self._tau_v_rows = 6 + self.tau_rows
        self._tau_lim = effort[self.tau_rows]
        # Joint limit indices (9): 1-DoF joints.
        iq, iv = [], []
        for j in range(2, model.njoints):
            jm = model.joints[j]
            if jm.nq == 1 and jm.nv == 1:
                iq.append(jm.idx_q)
                iv.append(jm.idx_v)
        self._iq, self._iv = np.array(iq, dtype=int), np.array(iv, dtype=int)
        self._qmin = np.asarray(model.lowerPositionLimit)[self._iq]
        self._qmax = np.asarray(model.upperPositionLimit)[self._iq]
        vmax = np.asarray(model.velocityLimit)[self._iv]
        self._vmax = np.where(vmax > 0, vmax, np.inf)
        # Preallocated matrices.
        self._H = np.zeros((self.n, self.n))
        self._g = np.zeros(self.n)
        n_tau = self.tau_rows.size
        self._C = np.zeros((n_tau + 16 * nc, self.n))
        self._l = np.full(n_tau + 16 * nc, -np.inf)
        self._u = np.zeros(n_tau + 16 * nc)
        for k, c in enumerate(self.contacts):
            r0 = n_tau + 16 * k
            self._C[r0:r0 + 16, nv + 12 * k:nv + 12 * k + 12] = c.friction_matrix
        self._JcT = np.zeros((nv, 12 * nc))
        self._lb = np.full(self.n, -np.inf)
        self._ub = np.full(self.n, np.inf)
        self._reg = np.concatenate([np.full(nv, self.eps_a), np.full(12 * nc, self.eps_f)])
        self._diag = np.arange(self.n)

    # -- problem definition ----------------------------------------------------------------------------------
    def add_task(self, task: AccelerationTask) -> AccelerationTask:
        """Add an acceleration task. Raises InvalidInputError for another object."""
        if not isinstance(task, AccelerationTask):
            raise InvalidInputError(f"expected an AccelerationTask, got {type(task).__name__}")
        self.tasks.append(task)
        return task

    def remove_task(self, task: AccelerationTask) -> None:
        """Remove an acceleration task added to the QP.

        Raises:
            ValueError: the task is not in the QP.
        """
        self.tasks.remove(task)

    def contact(self, name: str) -> SoleContact:
        """The contact called ``name``. Raises InvalidInputError (listing the names) when there is none."""
        for c in self.contacts:
            if c.name == name:
                return c
        raise InvalidInputError(f"no contact {name!r}; contacts: {[c.name for c in self.contacts]}")

    # -- assembly --------------------------------------------------------------------------------------------
    def joint_acceleration_bounds(self, state: DynamicsState, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """(lo, hi) bounds (9) on the 1-DoF joint accelerations (rad/s²), in the order of ``self._iv``."""
        q = state.q[self._iq]
        v = state.v[self._iv]
        q1 = q + v * dt
        d_hi = self._qmax - q1
        d_lo = q1 - self._qmin
        a = self.braking_acceleration
        dt2 = dt * dt
        hi = np.minimum((self._vmax - v) / dt, 2.0 * d_hi / dt2)
        lo = np.maximum((-self._vmax - v) / dt, -2.0 * d_lo / dt2)
        # Viability (larger root of the quadratic of the module docstring), mirrored for the lower limit.
        for sign, d, out in ((1.0, d_hi, "hi"), (-1.0, d_lo, "lo")):
            w = sign * v
            B = 2.0 * w * dt + a * dt2
            disc = np.maximum(B * B - 4.0 * dt2 * (w * w - 2.0 * a * d), 0.0)
            root = (-B + np.sqrt(disc)) / (2.0 * dt2)
            if out == "hi":
                hi = np.minimum(hi, root)
            else:
                lo = np.maximum(lo, -root)
        hi = np.maximum(hi, -a)
        lo = np.minimum(lo, a)
        return np.minimum(lo, hi), hi

    def build(self, state: DynamicsState, dt: float):
        """(H, g, A, b, C, l, u, lb, ub) of the QP at ``state`` (module docstring). Arrays are reused."""
        nv, n = self.nv, self.n
        H, g = self._H, self._g
        H.fill(0.0)
        g.fill(0.0)
        Hvv = H[:nv, :nv]
        gv = g[:nv]
        for task in self.tasks:
            J, r = task.compute(state)
            if isinstance(task, PostureAccelerationTask):  # J is a row selection: diagonal update
                idx = task.task.rows
                H[idx, idx] += task.weight
                gv[idx] -= task.weight * r
                continue
            wJ = J * task.weight[:, None]
            Hvv += J.T @ wJ
            gv -= wJ.T @ r
        H[self._diag, self._diag] += self._reg
        M, h = state.M, state.h
        JcT = self._JcT
        n_act = sum(c.active for c in self.contacts)
        A = np.zeros((6 + 6 * n_act, n))
        b = np.empty(6 + 6 * n_act)
        lb, ub = self._lb, self._ub
        i = 6
        for k, c in enumerate(self.contacts):
            J = c.jacobian(state)
            cols = slice(nv + 12 * k, nv + 12 * k + 12)
            np.matmul(J.T, c._G, out=JcT[:, 12 * k:12 * k + 12])
            if c.active:
                lb[cols] = -np.inf
                ub[cols] = np.inf
                lb[nv + 12 * k + 2:nv + 12 * k + 12:3] = c.f_min
                ub[nv + 12 * k + 2:nv + 12 * k + 12:3] = c.f_max
                A[i:i + 6, :nv] = J
                b[i:i + 6] = c.acceleration_target(state, J)
                i += 6
            else:
                lb[cols] = 0.0
                ub[cols] = 0.0
        A[:6, :nv] = M[:6]
        A[:6, nv:] = -JcT[:6]
        np.negative(h[:6], out=b[:6])
        C, l, u = self._C, self._l, self._u
        rows = self._tau_v_rows
        nt = rows.size
        if nt:
            C[:nt, :nv] = M[rows]
            C[:nt, nv:] = -JcT[rows]
            hr = h[rows]
            np.subtract(-self._tau_lim, hr, out=l[:nt])
            np.subtract(self._tau_lim, hr, out=u[:nt])
        if self.joint_limits:
            lo, hi = self.joint_acceleration_bounds(state, dt)
            lb[self._iv], ub[self._iv] = lo, hi
        return H, g, A, b, C, l, u, lb, ub

    def solve_relaxed(self, state: DynamicsState, dt: float) -> IDSolution:
        """Solve the QP without the joint acceleration bounds (9) and torque limits (6) — a fallback when the
        full QP is infeasible (MuJoCo still enforces joint limits and clamps torques). Same returns/raises as
        :meth:`solve`."""
        t0 = perf_counter()
        H, g, A, b, C, l, u, lb, ub = self.build(state, dt)
        nt = self.tau_rows.size
        l, u = l.copy(), u.copy()
        l[:nt], u[:nt] = -np.inf, np.inf
        lb, ub = lb.copy(), ub.copy()
        lb[:self.nv], ub[:self.nv] = -np.inf, np.inf
        t1 = perf_counter()
        x = self.backend.solve(H, g, A, b, C, l, u, lb, ub)
        t2 = perf_counter()
        return self.solution_from(state, x, timings={"assembly": t1 - t0, "solve": t2 - t1})

    def solve(self, state: DynamicsState, dt: float) -> IDSolution:
        """Build and solve the QP at ``state`` for control period ``dt`` (s).

        Returns:
            :class:`IDSolution`.

        Raises:
            InvalidInputError: dt not finite and > 0.
            SolverError: the backend failed or returned a solution violating a constraint by more than its
                tolerance (1e-6 in constraint units for the default backends).
        """
        if not (np.isfinite(dt) and dt > 0):
            raise InvalidInputError(f"dt must be finite and > 0 (s), got {dt!r}")
        t0 = perf_counter()
        H, g, A, b, C, l, u, lb, ub = self.build(state, dt)
        t1 = perf_counter()
        x = self.backend.solve(H, g, A, b, C, l, u, lb, ub)
        t2 = perf_counter()
        return self.solution_from(state, x, timings={"assembly": t1 - t0, "solve": t2 - t1})

    def solution_from(self, state: DynamicsState, x: np.ndarray, timings: dict | None = None) -> IDSolution:
        """:class:`IDSolution` of a QP solution x (n,) at ``state`` (τ by eq. 2, residual of eq. 1).

        Uses the matrices of the last :meth:`build` at this state.
        """
        nv = self.nv
        dv, f = x[:nv], x[nv:]
        gen = state.M @ dv + state.h - self._JcT @ f
        tau = gen[6:].copy()
        residual = float(np.max(np.abs(gen[:6])))
        wrenches = {}
        for k, c in enumerate(self.contacts):
            wrenches[c.name] = c.world_wrench(state, f[12 * k:12 * k + 12]) if c.active else np.zeros(6)
        return IDSolution(dv=dv.copy(), forces=f.copy(), tau=tau, wrenches=wrenches, dynamics_residual=residual,
                          timings=timings or {})

    @property
    def contact_jacobian_transpose(self) -> np.ndarray:
        """(nv, 12 n_c) J_cᵀ = [J_kᵀ G_k]_k of the last build (maps corner forces to generalized forces)."""
        return self._JcT

    def check_solution(self, state: DynamicsState, sol: IDSolution) -> dict[str, float]:
        """Margins of a solution (≥ 0 when satisfied, in constraint units) — used by tests and logs.

        Returns:
            ``friction`` (N, min over corners of μ/√2 f_z − |f_t|), ``normal`` (N, min f_z − f_min over active
            corners), ``torque`` (N·m, min τ_max − |τ| over limited joints), ``cop`` (m, min distance of each
            loaded foot's CoP to the sole edges).
        """
        out = {"friction": np.inf, "normal": np.inf, "torque": np.inf, "cop": np.inf}
        for k, c in enumerate(self.contacts):
            if not c.active:
                continue
            f = sol.forces[12 * k:12 * k + 12].reshape(4, 3)
            mu_in = c.mu / np.sqrt(2.0)
            out["friction"] = min(out["friction"], float(np.min(mu_in * f[:, 2:3] - np.abs(f[:, :2]))))
            out["normal"] = min(out["normal"], float(np.min(f[:, 2] - c.f_min)))
            cop = c.cop(sol.forces[12 * k:12 * k + 12])
            if cop is not None:
                a, bw = c.corners[0, 0], c.corners[0, 1]
                out["cop"] = min(out["cop"], float(min(a - abs(cop[0]), bw - abs(cop[1]))))
        if self.tau_rows.size:
            out["torque"] = float(np.min(self.tau_max[self.tau_rows] - np.abs(sol.tau[self.tau_rows])))
        return out
