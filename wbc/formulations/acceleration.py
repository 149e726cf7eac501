"""Acceleration-level formulation: the inverse-dynamics QP of a floating-base robot in contact.

Variables x = [v̇; f] ∈ R^{nv + 12 n_c}: generalized accelerations v̇ (Pinocchio conventions) and, per declared sole
contact k, 4 corner forces f_k ∈ R^12 in the sole frame. With M, h and the LOCAL sole Jacobians J_k from Pinocchio and
G_k the corner-force → sole-wrench map, the torques are not variables (Featherstone 2008, eq. 3.6 with contacts):

    τ = M_a v̇ + h_a − Σ_k (J_kᵀ G_k)_a f_k                       (a: actuated rows 6..nv−1)                (2)

    min_x  Σ_i ‖diag(√w_i)(J_i v̇ − r_i)‖² + ε_a ‖v̇‖² + ε_f ‖f‖²,  r_i = a*_i − J̇_i v  (a*_i: reference.py)  (3)
    s.t.   M_u v̇ − Σ_k (J_kᵀ G_k)_u f_k = −h_u                    floating_base_dynamics   (u: rows 0..5)  (4)
           J_k v̇ = −J̇_k v − Kd_c J_k v − Kp_c e_k                  contact:<c>              (active k)     (5)
           −τ_max − h_a ≤ M_a v̇ − Σ_k (J_kᵀ G_k)_a f_k ≤ τ_max − h_a  torque_limits                            (6)
           F_k f_k ≤ 0                                              friction:<c>             (active k)     (7)
           f_min ≤ f_z ≤ f_max per corner; f_k = 0 if inactive      unilaterality:<c>                       (8)
           v̇_lo ≤ v̇_joints ≤ v̇_hi  (position, velocity, viability)  joint_limits  (del Prete 2018)          (9)
           G_j v̇ ≥ −Ġ_j v − 2γ_j G_j v − γ_j² h_j                   an added barrier's name                 (10)
           J_t v̇ = r_t                                               task:<t>                 (hard tasks)

With ≥ 2 active contacts the nearly dependent directions of (5) are dropped; ε_a, ε_f > 0 make the Hessian positive
definite. Every constraint is a named object of :mod:`wbc.constraints`. One assembly serves every backend
(:meth:`InverseDynamicsQP.build`): the per-tick rows gathered (:mod:`wbc.formulations.id_rows`), the cost and the
state-dependent blocks written by :func:`~wbc.formulations.idkernel.id_assemble`, the rows of hard tasks and added
constraints by their ``write``. A tick: assemble → :attr:`InverseDynamicsQP.chain`
(:class:`~wbc.solvers.fallback.FallbackChain`, :class:`~wbc.solvers.compiled_id.CompiledIDSolver` first with
``fast``) → decode (:meth:`InverseDynamicsQP.solution_from`). Derivations and the chain's rules:
docs/inverse-dynamics-controller.md.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from time import perf_counter, thread_time

import numpy as np

from wbc.compiled import CHECK_TYPES, specialise
from wbc.constraints.barrier import AccelerationBarrier
from wbc.constraints.base import IDConstraint, IDContext, InequalityConstraint
from wbc.constraints.contact_acceleration import DEPENDENT_CONTACT_RATIO, ContactAcceleration, independent_contact_rows
from wbc.constraints.floating_base import FloatingBaseDynamics
from wbc.constraints.friction import FrictionPyramid
from wbc.constraints.hard_task import HardTask
from wbc.constraints.joint_acceleration_bounds import JointAccelerationLimits
from wbc.constraints.torque_limits import TorqueLimits
from wbc.constraints.unilaterality import Unilaterality
from wbc.constraints.sole_contact import SoleContact
from wbc.formulations.id_rows import IDProblemRows
from wbc.formulations.idkernel import (IDArrays, IDAssemblyWork, IDDynamics, IDLimits, IDOutputCheck, PAR_BRAKING,
                                       PAR_EPS_A, PAR_JOINT_LIMITS, PAR_SPEED_HORIZON, id_assemble, id_command,
                                       load_id_kernels)
from wbc.state import DynamicsState
from wbc.formulations.reference import AccelerationReference
from wbc.exceptions import InvalidInputError, SolverError
from wbc.solvers import DaqpBackend, QPBackend, make_backend
from wbc.solvers.base import POLISH_RANGE
from wbc.solvers.compiled_id import CompiledIDSolver
from wbc.solvers.diagnosis import diagnose
from wbc.solvers.fallback import DAQP_SETTINGS, SCALED_EPS_PROX, FallbackChain
from wbc.solvers.qp_data import QPData
from wbc.tick import TickPath, TickResultBase
from wbc.robot import Robot
from wbc.tasks.base import Task

__all__ = ["IDCommand", "InverseDynamicsQP", "nonfinite_references"]


@dataclass
class IDCommand(TickResultBase):
    """A solution of the QP, and the output of a controller's tick (with the fields of
    :class:`wbc.tick.TickResultBase`: ``ok`` a QP, full or relaxed, was solved; ``message`` the failure reason;
    ``conflicts`` (name, violation), largest first; ``path`` the route: ``kernel``, ``general:<backend>``,
    ``relaxed:<backend>``, ``fallback:<kind>``; ``timings`` in s: 'assembly', 'solve', and of a tick 'pinocchio',
    'total', 'cpu' (thread CPU time, the budgeted quantity)).

    Attributes:
        tau: (nv − 6,) joint torques (N·m) from eq. (2), Pinocchio's actuated order.
        dv: (nv,) generalized acceleration v̇; forces: (12 n_c,) corner forces (N), sole frames, contact-major then
            corner-major (x, y, z); zeros on a gravity fallback.
        wrenches: contact name → (6,) wrench (N, N·m) at the sole origin, world axes.
        relaxed: the relaxed QP was used. dynamics_residual: ‖M_u v̇ + h_u − (J_cᵀ)_u f‖_∞ (N, N·m; nan on a held
            or gravity command).
        path_reason: why the tick left the compiled route and which step of the chain answered ('' on it;
            docs/inverse-dynamics-controller.md, "Routes and reasons").
    """

    tau: np.ndarray
    dv: np.ndarray
    forces: np.ndarray
    wrenches: dict[str, np.ndarray] = field(default_factory=dict)
    relaxed: bool = False
    dynamics_residual: float = 0.0
    path_reason: str = ""


_KERNEL_PATH = TickPath("kernel")  # the path of every compiled tick (frozen: shared by their solutions)

#: the ID QP's DAQP settings (benchmarks/README.md)
_ID_SETTINGS = {"daqp": DAQP_SETTINGS, "fast": {**DAQP_SETTINGS, "kernel_rows": False}}


class InverseDynamicsQP:
    """Builds and solves the QP of the module docstring from its named constraints.

    Args:
        robot: the robot.
        tasks: tasks with their PD references (:class:`~wbc.formulations.reference.AccelerationReference`),
            weighted (soft).
        contacts: sole contacts (all declared up front; (de)activate them to switch support).
        solver: the backend of :attr:`chain`: a name (``fast``, the default: the compiled tick, then DAQP's chain;
            ``daqp``: DAQP warm-started from the previous duals; any :func:`wbc.solvers.make_backend` name) or a
            :class:`~wbc.solvers.base.QPBackend`.
        acceleration_regularization: ε_a (weight of ‖v̇‖²).
        force_regularization: ε_f (weight of ‖f‖², 1/N² in task-cost units).
        torque_limit_scale: fraction of the URDF effort limit used in (6), in (0, 1].
        braking_acceleration: a_brk of the viability bound (rad/s²), > 0.
        joint_limits: apply the joint acceleration bounds (9).

    Attributes:
        constraints: every named constraint (:mod:`wbc.constraints`), in row order.
        torque_limits, joint_acceleration_limits, dynamics: the single-instance constraints.
        chain: the fallback ladder over the backend (:class:`~wbc.solvers.fallback.FallbackChain`).
        kernel_max_iterations: the compiled solver's iteration cap (set by the controller's budget).

    Raises:
        UnknownSolverError: unknown backend. InvalidInputError: bad numbers or objects.
    """

    def __init__(self, robot: Robot, tasks: list[AccelerationReference] = (), contacts: list[SoleContact] = (), *,
                 solver: str | QPBackend = "fast", acceleration_regularization: float = 1e-6,
                 force_regularization: float = 1e-7, torque_limit_scale: float = 1.0,
                 braking_acceleration: float = 50.0, joint_limits: bool = True):
        for value, what in ((acceleration_regularization, "acceleration_regularization"),
                            (force_regularization, "force_regularization")):
            if not (np.isfinite(value) and value > 0):
                raise InvalidInputError(f"{what} must be finite and > 0, got {value!r}")
        self.robot = robot
        self.nv = nv = robot.model.nv
        self.chain = FallbackChain(make_backend(solver, **_ID_SETTINGS.get(solver, {})) if isinstance(solver, str)
                                   else solver)
        self.eps_a = float(acceleration_regularization)
        self.joint_limits = bool(joint_limits)
        self.tasks: list[AccelerationReference] = []
        self.hard_tasks: list[HardTask] = []
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
        self.n = n = nv + 12 * nc
        self.dynamics = FloatingBaseDynamics()
        self.dynamics.rows = slice(0, 6)
        self.contact_accelerations = [ContactAcceleration(c) for c in self.contacts]
        self.torque_limits = TorqueLimits(robot, torque_limit_scale)
        self.friction = [FrictionPyramid(c, nv + 12 * k) for k, c in enumerate(self.contacts)]
        self.unilaterality = [Unilaterality(c, nv + 12 * k) for k, c in enumerate(self.contacts)]
        self.joint_acceleration_limits = JointAccelerationLimits(robot, braking_acceleration)
        self.joint_speed_limits = None  # optional JointSpeedBounds: with joint_limits, kept by solve_relaxed
        self.tau_max = self.torque_limits.tau_max
        r = 0
        for con in (self.torque_limits, *self.friction):
            con.rows = slice(r, r + con.dim)
            r += con.dim
        self._r0 = r  # inequality rows before the added constraints (add_constraint)
        self.extra_constraints: list[IDConstraint] = []
        self.extra_equalities: list[IDConstraint] = []
        self._H, self._g = np.zeros((n, n)), np.zeros(n)
        self._A, self._b = np.zeros((6 + 6 * nc, n)), np.zeros(6 + 6 * nc)  # grown by add_task(hard=True)
        self._C, self._l, self._u = np.zeros((r, n)), np.full(r, -np.inf), np.zeros(r)
        self._lb, self._ub = np.full(n, -np.inf), np.full(n, np.inf)
        self._JcT = np.zeros((nv, 12 * nc))
        load_id_kernels()
        self._rows = rows = IDProblemRows(self)  # the task rows laid out here (and at add/remove_task), not in a tick
        # the constraints' context: views of the gathered contact data (Jacobians, eq. 5's offsets) and of J_cᵀ
        self._ctx = IDContext(state=None, dt=0.0, nv=nv, JcT=self._JcT,
                              jacobians={c.name: rows.Jc[k] for k, c in enumerate(self.contacts)},
                              offsets={c.name: rows.cdrift[k] for k, c in enumerate(self.contacts)})
        self._force_slices = [slice(nv + 12 * k, nv + 12 * k + 12) for k in range(nc)]
        self._refresh_contact_rows()  # friction rows: constant while μ is (rewritten only when it changes)
        self._H[nv:, nv:] = np.diag(np.full(12 * nc, float(force_regularization)))  # constant force regularisation
        if isinstance(solver, str) and isinstance(self.backend, DaqpBackend):
            self.backend.scaled_settings = {"eps_prox": SCALED_EPS_PROX}
        self._fast = solver == "fast"  # the compiled solver is the chain's first rung
        self._new_buffers()
        self.output_check = IDOutputCheck(self.contacts, self.torque_limits, self._lb[nv:], self._ub[nv:])
        self._m = self._m_contacts = 6  # equality rows of the last build, and the row after its contact rows
        self.chain.hard_set_x = np.zeros(n)
        #: violations found by :meth:`verify` on the last solve ([] when it passed).
        self.last_violations: list[tuple[str, float]] = []
        self.kernel_max_iterations = 100
        self._id_command = None  # id_command specialised at the first decode (solution_from)

    @property
    def backend(self):
        """The QP backend asked first (:attr:`chain`'s; assignable)."""
        return self.chain.backend

    @backend.setter
    def backend(self, value) -> None:
        self.chain.backend = value

    @property
    def constraints(self) -> list[IDConstraint]:
        """Every named constraint: equalities (dynamics, active contacts, hard tasks), inequalities, bounds."""
        return [self.dynamics, *self.contact_accelerations, *self.hard_tasks, *self.extra_equalities,
                self.torque_limits, *self.friction, *self.extra_constraints, *self.unilaterality,
                self.joint_acceleration_limits]

    def add_constraint(self, constraint, *, gain: float = 10.0) -> IDConstraint:
        """Add a constraint under its name: an equality or inequality :class:`~wbc.constraints.base.IDConstraint`
        (rows in x = [v̇; f]; equality rows after the hard tasks'), or a kinematic constraint with a barrier form
        (``ComPolygonConstraint``, ``SelfCollisionConstraint``), held as
        :class:`~wbc.constraints.barrier.AccelerationBarrier` with γ = ``gain`` (1/s). Returns the ID constraint added
        (remove it with it, or with the kinematic constraint). Raises InvalidInputError: another kind of object, bad
        gain, or a name already in the QP."""
        if isinstance(constraint, InequalityConstraint):
            constraint = AccelerationBarrier(constraint, gain=gain)
        if not isinstance(constraint, IDConstraint) or constraint.kind not in ("equality", "inequality"):
            what = constraint.kind if isinstance(constraint, IDConstraint) else type(constraint).__name__
            raise InvalidInputError(f"add_constraint takes an equality or inequality IDConstraint (rows in [v̇; f]) "
                                    f"or a kinematic inequality constraint with a barrier form, got {what}")
        if not (isinstance(constraint.dim, (int, np.integer)) and constraint.dim >= 0):
            raise InvalidInputError(f"constraint {constraint.name!r}: dim must be an integer ≥ 0, got "
                                    f"{constraint.dim!r}")
        if any(c.name == constraint.name for c in self.constraints):
            raise InvalidInputError(f"a constraint named {constraint.name!r} is already in the QP")
        if constraint.kind == "equality":
            self.extra_equalities.append(constraint)
            self._grow_equalities()
        else:
            self.extra_constraints.append(constraint)
            self._layout_inequalities()
        return constraint

    def remove_constraint(self, constraint) -> None:
        """Remove a constraint added by :meth:`add_constraint` (the ID constraint or the kinematic one it holds).
        Raises ValueError when it is not in the QP."""
        for con in self.extra_constraints:
            if con is constraint or getattr(con, "constraint", None) is constraint:
                self.extra_constraints.remove(con)
                self._layout_inequalities()
                return
        if constraint in self.extra_equalities:
            self.extra_equalities.remove(constraint)
            return
        raise ValueError(f"{constraint!r} is not in the QP")

    def _new_buffers(self) -> None:
        """The arguments of :func:`~wbc.formulations.idkernel.id_assemble` over the current blocks, and (``fast``)
        the compiled solver of their sizes as :attr:`chain`'s first rung; both loaded for these buffers and a
        DynamicsState's types (M column-major) now, not inside the first tick (:func:`wbc.compiled.specialise`)."""
        tl, jl, nv, nc = self.torque_limits, self.joint_acceleration_limits, self.nv, len(self.contacts)
        self._par = np.array([self.eps_a, jl.braking_acceleration, float(self.joint_limits), DEPENDENT_CONTACT_RATIO,
                              jl.speed_horizon])
        self._par_written = None  # the values build last wrote into _par
        self._qp_views: dict[int, QPData] = {}  # build's QPData of these buffers by equality row count
        self._assembled = None  # (id(state), dt) of the QP held in the arrays by the last solve(), else None
        idx = np.concatenate([tl.velocity_indices, jl.iq, jl.iv]).astype(np.int64)
        qp = QPData(self._H, self._g, self._A, self._b, self._C, self._l, self._u, self._lb, self._ub)
        self._buffers = (IDLimits(idx, tl.limits.copy(), self._par, jl.qmin, jl.qmax, jl.vmax, jl.joint_braking),
                         IDArrays(*qp, self._JcT),
                         IDAssemblyWork(np.zeros((nv, nv)), np.zeros(nv), np.zeros((6 * nc, 6 * nc)), np.zeros(6 * nc),
                                        np.zeros(jl.dim), np.zeros(jl.dim)))
        self._id_assemble = None  # id_assemble specialised to these buffers and a DynamicsState's (first call)
        dynamics = IDDynamics(np.asfortranarray(np.eye(nv)), np.zeros(nv), self.robot.q_ref.copy(), np.zeros(nv), 0.0)
        specialise(id_assemble, self._rows.tasks, dynamics, self._rows.contacts, *self._buffers)
        if self._fast:
            self.chain.compiled = CompiledIDSolver(self.n, self._C.shape[0], self._A.shape[0])
            self.chain.compiled.load(qp)

    def _layout_inequalities(self) -> None:
        r = r0 = self._r0
        for con in self.extra_constraints:
            con.rows = slice(r, r + con.dim)
            r += con.dim
        C, l, u = np.zeros((r, self.n)), np.full(r, -np.inf), np.zeros(r)
        C[:r0], l[:r0], u[:r0] = self._C[:r0], self._l[:r0], self._u[:r0]  # torque (per tick) and friction rows
        self._C, self._l, self._u = C, l, u
        self._new_buffers()  # id_assemble's argument tuples hold the blocks: new blocks, new tuples

    def _refresh_contact_rows(self) -> None:
        """Rewrite the force bounds and friction rows whose contact parameters changed since they were written."""
        ctx = self._ctx
        for con, s in zip(self.unilaterality, self._force_slices):
            key = con.key()
            if key != con.written:  # force bounds change only when the contact is switched or re-bounded
                con.write(ctx, None, self._lb[s], self._ub[s])
                con.written = key
        for con in self.friction:
            key = con.key()
            if key != con.written:
                con.write(ctx, self._C[con.rows], self._l[con.rows], self._u[con.rows])
                con.written = key

    def add_task(self, task: AccelerationReference | Task, *, hard: bool = False, kp: float | None = None,
                 kd: float | None = None, weight=None) -> AccelerationReference:
        """Add a task, weighted or (``hard``) held as the equality ``task:<name>``
        (:class:`~wbc.constraints.hard_task.HardTask`): an :class:`~wbc.formulations.reference.AccelerationReference`,
        or a :class:`wbc.tasks.base.Task` with its gains ``kp`` (1/s², required), ``kd`` (1/s) and ``weight``. Returns
        the reference added. Raises InvalidInputError: neither; a Task without ``kp``; bad gains or weights."""
        if isinstance(task, Task):
            if kp is None:
                raise InvalidInputError(f"add_task({task.name}): a Task needs its reference gain kp (1/s²)")
            task = AccelerationReference(task, kp=kp, kd=kd, weight=weight)
        if not isinstance(task, AccelerationReference):
            raise InvalidInputError(f"expected an AccelerationReference or a Task, got {type(task).__name__}")
        if hard:
            self.hard_tasks.append(HardTask(task))
            self._grow_equalities()
        else:
            self.tasks.append(task)
            if hasattr(self, "_rows"):
                self._rows.relayout(self)
        return task

    def remove_task(self, task: AccelerationReference) -> None:
        """Remove an acceleration task (weighted or hard) added to the QP. Raises ValueError when it is not in it."""
        for h in self.hard_tasks:
            if h.task is task:
                self.hard_tasks.remove(h)
                return
        self.tasks.remove(task)
        self._rows.relayout(self)

    def _grow_equalities(self) -> None:
        rows = 6 + 6 * len(self.contacts) + sum(h.dim for h in (*self.hard_tasks, *self.extra_equalities))
        if rows > self._A.shape[0]:
            self._A = np.zeros((rows, self.n))
            self._b = np.zeros(rows)
            self._new_buffers()  # id_assemble's argument tuples hold the blocks: new blocks, new tuples

    def contact(self, name: str) -> SoleContact:
        """The contact called ``name``. Raises InvalidInputError (listing the names) when there is none."""
        for c in self.contacts:
            if c.name == name:
                return c
        raise InvalidInputError(f"no contact {name!r}; contacts: {[c.name for c in self.contacts]}")

    def assembled_qp(self) -> tuple | None:
        """Copies of (H, g, A, b, C, l, u, lb, ub) as the last :meth:`solve` assembled them; None when none did."""
        if self._assembled is None:
            return None
        return tuple(a.copy() for a in self._qp_views[self._m])  # (build made the views of its row count)

    def _relax(self, l, u, lb, ub, state: DynamicsState | None = None, dt: float = 0.0):
        """Copies of (l, u, lb, ub) without the relaxable rows; with ``state``, the relaxed QP's (solve_relaxed)."""
        l, u, lb, ub = l.copy(), u.copy(), lb.copy(), ub.copy()
        for con in self.constraints:
            if con.relaxable and con.kind == "inequality":
                l[con.rows], u[con.rows] = -np.inf, np.inf
            elif con.relaxable and con.kind == "bounds":
                lb[con.indices], ub[con.indices] = -np.inf, np.inf
        if state is not None and self.joint_limits and (sb := self.joint_speed_limits) is not None:  # the full QP's h
            jl, floor = self.joint_acceleration_limits, sb.braking  # and ≤ its a_brk: a relaxation (joint_velocity)
            sb.intersect(state.v, dt, lb, ub, horizon=jl.speed_horizon, braking=jl.braking_at(sb.indices, floor))
        return l, u, lb, ub

    def solve_relaxed(self, state: DynamicsState, dt: float, *, reuse_assembly: bool = False) -> IDCommand:
        """Solve the QP without the relaxable constraints — joint acceleration bounds (9) and torque limits (6) —
        the :attr:`joint_speed_limits` bounds kept (when the full QP has (9): :attr:`joint_limits`). Same returns and
        raises as :meth:`solve`. ``reuse_assembly``: reuse the arrays of this tick's failed full QP at ``state``."""
        t0 = perf_counter()
        same_tick = reuse_assembly and self._assembled == (id(state), dt)
        H, g, A, b, C, l, u, lb, ub = self._qp_views[self._m] if same_tick else self.build(state, dt)
        # this tick's failed full QP formed the relaxed bounds for its check of the relaxed hard set
        reuse = same_tick and self.chain.relaxed_bounds is not None
        l, u, lb, ub = self.chain.relaxed_bounds if reuse else self._relax(l, u, lb, ub, state, dt)
        t1 = perf_counter()
        x, solver, step = self.chain.solve_relaxed(QPData(H, g, A, b, C, l, u, lb, ub), same_tick=same_tick,
                                                   formed=not reuse)
        t2 = perf_counter()
        sol = self.solution_from(state, x, {"assembly": t1 - t0, "solve": t2 - t1}, TickPath("relaxed", solver),
                                 f"full QP failed → relaxed QP, {step}")
        self.last_violations = viol = self.verify(state, sol, relaxed=True)
        if viol:
            raise _output_check_error(sol, viol)
        return sol

    def solve(self, state: DynamicsState, dt: float) -> IDCommand:
        """Assemble the QP at ``state`` for control period ``dt`` (s), solve it by :attr:`chain` and decode the
        answer into an :class:`IDCommand` that passes the output check (:meth:`verify`; an answer of the ladder failing
        it by at most :data:`~wbc.solvers.base.POLISH_RANGE` is refined first,
        :meth:`~wbc.solvers.fallback.FallbackChain.refine`, before the chain's ``retry_deadline``).

        Raises:
            InvalidInputError: dt not finite and > 0.
            SolverError: no step of the chain found a solution, or none passes the output check.
        """
        if not (np.isfinite(dt) and dt > 0):
            raise InvalidInputError(f"dt must be finite and > 0 (s), got {dt!r}")
        self.last_violations = []
        self._assembled = None
        self.chain.begin_tick()
        t0 = perf_counter()
        qp = self.build(state, dt)
        self._assembled = (id(state), dt)  # solve_relaxed(reuse_assembly=True) may reuse these arrays
        t1 = perf_counter()
        checked = []

        def check(x):  # the compiled solver's answer stands when it passes the output check
            checked.append(self.solution_from(state, x, {"assembly": t1 - t0}, _KERNEL_PATH))
            self.last_violations = viol = self.verify(state, checked[-1])
            return f"kernel answer fails the output check ({viol[0][0]})" if viol else ""

        x, solver, step = self.chain.solve(qp, lambda l, u, lb, ub: self._relax(l, u, lb, ub, state, dt),
                                           check, self._skip)
        if solver == CompiledIDSolver.name:
            sol = checked[-1]
            sol.timings["solve"] = perf_counter() - t1
            return sol
        why = self.chain.compiled_reason
        sol = self.solution_from(state, x, {"assembly": t1 - t0, "solve": perf_counter() - t1},
                                 TickPath("general", solver), f"{why} → {solver} {step}" if why else "")
        viol = self.verify(state, sol)
        if (viol and viol[0][0] != "non_finite_command" and not self.verify(state, sol, tol=POLISH_RANGE)
                and thread_time() < self.chain.retry_deadline):
            def candidate(x, solver):  # a refined answer's command (solver None: polished) if it passes, else None
                path = sol.path if solver is None else TickPath("general", solver)
                reason = f"{sol.path_reason or 'output check'} → {'polished' if solver is None else solver}"
                cand = self.solution_from(state, x, sol.timings, path, reason)
                return None if self.verify(state, cand) else cand

            refined = self.chain.refine(np.concatenate((sol.dv, sol.forces)), qp, candidate, sol.path.solver)
            if refined is not None:
                self.last_violations = []
                return refined
        self.last_violations = viol
        if viol:
            raise _output_check_error(sol, viol)
        return sol

    def build(self, state: DynamicsState, dt: float) -> QPData:
        """The QP at ``state`` for control period ``dt`` (s) (module docstring: the one assembly), as every backend
        gets it: views of the preallocated arrays, written in place (constant blocks are not rewritten)."""
        rows = self._rows
        rows.gather(self, state)
        self._refresh_contact_rows()
        par = self._par
        jl = self.joint_acceleration_limits
        values = (self.eps_a, jl.braking_acceleration, self.joint_limits, jl.speed_horizon)
        if values != self._par_written:  # attributes assignable between ticks: written when one changed
            par[PAR_EPS_A], par[PAR_BRAKING], par[PAR_JOINT_LIMITS], par[PAR_SPEED_HORIZON] = values
            self._par_written = values
        args = (rows.tasks, IDDynamics(state.M, state.h, state.q, state.v, dt), rows.contacts, *self._buffers)
        if self._id_assemble is None:  # the buffers' and state's types are fixed (CHECK_TYPES: the dispatcher)
            self._id_assemble = id_assemble if CHECK_TYPES else specialise(id_assemble, *args)
        m = self._id_assemble(*args)
        self._skip = ""  # why the compiled solver is not asked ('' when it is)
        if m < 0:  # ≥ 2 active contacts not certified well conditioned: the nearly dependent directions dropped
            m = 6 + independent_contact_rows(self._A[6:-m], self._b[6:-m])  # (rows 6 .. −m: the contacts')
            self._skip = "kernel: dependent contact rows"
        self._m_contacts = m
        if self.hard_tasks or self.extra_equalities or self.extra_constraints:  # rows no compiled body writes
            ctx = self._ctx
            ctx.state, ctx.dt = state, dt
            for con in (*self.hard_tasks, *self.extra_equalities):  # after the contacts' rows
                if con.enabled:
                    con.rows = slice(m, m + con.dim)
                    con.write(ctx, self._A[m:m + con.dim], self._b[m:m + con.dim], None)
                    m += con.dim
            for con in self.extra_constraints:
                con.write(ctx, self._C[con.rows], self._l[con.rows], self._u[con.rows])
        self._m = m
        if self._fast:
            self.chain.compiled.max_iterations = self.kernel_max_iterations
        qp = self._qp_views.get(m)
        if qp is None:  # views of the buffers, one per equality row count (the buffers live until _new_buffers)
            qp = self._qp_views[m] = QPData(self._H, self._g, self._A[:m], self._b[:m], self._C, self._l, self._u,
                                            self._lb, self._ub)
        return qp

    def nonfinite_inputs(self) -> list[tuple[str, float]]:
        """:func:`nonfinite_references` of the QP's weighted and hard tasks."""
        return nonfinite_references((*self.tasks, *(h.task for h in self.hard_tasks)))

    def verify(self, state: DynamicsState, sol: IDCommand, *, relaxed: bool = False,
               tol: float | None = None) -> list[tuple[str, float]]:
        """The output check of ``sol`` at ``state`` (:class:`~wbc.formulations.idkernel.IDOutputCheck`) at
        relative tolerance ``tol`` (default the backend's), without the torque limits when ``relaxed``. Returns
        [(constraint name, violation in its units)], largest scaled first, [] when it passes;
        ``[("non_finite_command", nan), *nonfinite_inputs()]`` for a non-finite solution."""
        found = self.output_check.violations(state.h, sol, self.backend.tolerance if tol is None else float(tol),
                                             relaxed)
        return [("non_finite_command", float("nan")), *self.nonfinite_inputs()] if found is None else found

    def diagnose(self, state: DynamicsState, dt: float, *, include_relaxable: bool = True,
                 tol: float = 1e-6) -> list[tuple[str, float]]:
        """Names of the hard constraints that conflict at ``state`` with their violation (constraint units, at least
        ``tol``), largest first (:func:`wbc.solvers.diagnosis.diagnose`); empty when the hard set is feasible.
        ``include_relaxable`` False: the set without torque and joint limits (the relaxed QP)."""
        H, g, A, b, C, l, u, lb, ub = self.build(state, dt)
        if not include_relaxable:
            l, u, lb, ub = self._relax(l, u, lb, ub)
        eq, ineq, box = [], [], []
        i, end = 6, self._m_contacts
        for con in self.contact_accelerations:  # (rows rotated when dependent ones were dropped: the blocks' labels)
            if con.enabled:
                con.rows = slice(min(i, end), min(i + 6, end))
                i += 6
        for con in self.constraints:
            if not con.enabled or (con.relaxable and not include_relaxable):
                continue
            if con.kind in ("equality", "inequality"):
                (eq if con.kind == "equality" else ineq).append((con.name, con.rows.start, con.rows.stop))
            elif con.kind == "bounds" and (con is not self.joint_acceleration_limits or self.joint_limits):
                box.append((con.name, con.indices, lb[con.indices], ub[con.indices]))
        conflicts, _ = diagnose(A, b, C, l, u, lb, ub, eq, ineq, box, tol=tol)
        return conflicts

    def solution_from(self, state: DynamicsState, x: np.ndarray, timings: dict | None = None,
                      path: TickPath | None = None, reason: str = "") -> IDCommand:
        """:class:`IDCommand` of a QP solution x (n,) at ``state`` (:func:`~wbc.formulations.idkernel.id_command`),
        from the matrices and contact data of the last assembly at this state, with ``path`` and ``path_reason`` =
        ``reason``."""
        nv = self.nv
        x = np.array(x, dtype=float)  # a fresh contiguous copy: dv and forces are views of it
        rows = self._rows
        tau = np.empty(nv - 6)
        wrench = np.empty((len(self.contacts), 6))
        args = (state.M, state.h, self._JcT, rows.Gc, rows.Rc, rows.active, x, tau, wrench)
        if self._id_command is None:  # fixed types, as id_assemble's
            self._id_command = id_command if CHECK_TYPES else specialise(id_command, *args)
        residual = self._id_command(*args)
        wrenches = {c.name: wrench[k] for k, c in enumerate(self.contacts)}
        return IDCommand(dv=x[:nv], forces=x[nv:], tau=tau, wrenches=wrenches, dynamics_residual=float(residual),
                         timings=timings or {}, path=path, path_reason=reason)

    @property
    def contact_jacobian_transpose(self) -> np.ndarray:
        """(nv, 12 n_c) J_cᵀ = [J_kᵀ G_k]_k of the last build (maps corner forces to generalized forces)."""
        return self._JcT


def _output_check_error(sol: IDCommand, viol: list[tuple[str, float]]) -> SolverError:
    """The SolverError of a solution that fails the output check (:meth:`InverseDynamicsQP.verify`'s ``viol``)."""
    return SolverError(f"{sol.path} returned a command that fails the output check: "
                       + ", ".join(f"{n} ({v:.3g})" for n, v in viol))


def nonfinite_references(references) -> list[tuple[str, float]]:
    """``(task:<name>, nan)`` for every acceleration reference whose error (at the last assembly), weights or
    acceleration feed-forward are not finite — e.g. a target or weight array written in place with a NaN."""
    out = []
    for ref in references:
        ff = ref.feedforward_acceleration
        if not (np.isfinite(ref.last_error).all() and np.isfinite(ref.weight).all()
                and (ff is None or np.isfinite(ff).all())):
            out.append((f"task:{ref.name}", float("nan")))
    return out
