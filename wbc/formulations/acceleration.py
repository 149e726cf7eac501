"""Acceleration-level formulation: the inverse-dynamics QP for a floating-base robot in contact.

It assembles the shared task objects of :mod:`wbc.tasks` as (J_i, a*_i − J̇_i v) (their e, J and drift J̇v, with the
PD reference a*_i of :class:`~wbc.formulations.reference.AccelerationReference`) — the velocity-level formulation
(:mod:`wbc.formulations.velocity`) uses the same objects as (J_i, v*_i) — and named constraint objects
(:mod:`wbc.constraints`, plus any kinematic constraint of :mod:`wbc.constraints` with a barrier form,
under its own name: ``com_polygon``, ``self_collision``).

The problem, solved once per control tick of period dt (s), at the measured state (q, v):

Variables  x = [v̇ ; f] ∈ R^{nv + 12 n_c}: generalized accelerations v̇ (Pinocchio conventions: base spatial
acceleration in the base frame, then joints) and, per declared sole contact k, 4 corner forces f_k ∈ R^12 in
the sole frame (:mod:`wbc.constraints.sole_contact`).

Equations of motion (Featherstone 2008, "Rigid Body Dynamics Algorithms", eq. 3.6 with contacts)

    M(q) v̇ + h(q, v) = Sᵀ τ + Σ_k J_kᵀ G_k f_k,         S = [0_{(nv−6)×6}  I_{nv−6}]             (1)

with M, h = C v + g and the LOCAL sole Jacobians J_k from Pinocchio, G_k the constant corner-force →
sole-wrench map (sole frame). The actuated rows define the torques, which are therefore not variables:

    τ = M_a v̇ + h_a − Σ_k (J_kᵀ G_k)_a f_k          (a: rows 6..nv−1)                              (2)

    min_x   Σ_i ‖ diag(√w_i) (J_i v̇ − r_i) ‖²  +  ε_a ‖v̇‖²  +  ε_f ‖f‖²                           (3)
            r_i = a*_i − J̇_i v,  a*_i = ä_ff − Kp e_i − Kd (J_i v − ė_ff)       (wbc.formulations.reference)
    s.t.    M_u v̇ − Σ_k (J_kᵀ G_k)_u f_k = −h_u        (u: rows 0..5, unactuated floating base)          (4)
            J_k v̇ = −J̇_k v − Kd_c J_k v − Kp_c e_k    for each *active* contact k (sole does not accelerate)  (5)
                (with ≥ 2 active contacts, the stacked rows and right-hand side are replaced by their components along
                the rows' left singular vectors with σ ≥ 1e-2 σ_max: the nearly dependent directions are dropped,
                constraints.contact_acceleration.independent_contact_rows; the equality block then has fewer than
                6 n_c rows)
            −τ_max − h_a ≤ M_a v̇ − Σ_k (J_kᵀ G_k)_a f_k ≤ τ_max − h_a     (URDF effort limits, from (2))     (6)
            F_k f_k ≤ 0                                 (friction pyramids, μ/√2 per corner axis; active k)  (7)
            f_min ≤ f_z ≤ f_max per corner; f_k = 0 for an inactive contact   (unilaterality; CoP in sole)  (8)
            v̇_lo ≤ v̇_joints ≤ v̇_hi                      (joint position/velocity limits, below)             (9)
            G_j v̇ ≥ −Ġ_j v − 2γ_j G_j v − γ_j² h_j       for each added barrier j (h_j(q) ≥ 0, ḣ_j = G_j v:   (10)
                                                        CoM polygon, self-collision; :meth:`add_constraint`)

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

Every constraint (4)–(10) is a named object of :mod:`wbc.constraints` (``floating_base_dynamics``,
``contact:<c>``, ``torque_limits``, ``friction:<c>``, ``unilaterality:<c>``, ``joint_limits``, the barrier's own
name in (10); plus ``task:<t>`` for a task held as a hard equality, :meth:`InverseDynamicsQP.add_task` with ``hard=True``). The QP owns one
preallocated array per block (H, g, A, b, C, l, u, lb, ub); each constraint is given its rows once and writes
them in place every tick; the friction rows are constant and written once. The task and contact rows are gathered
once per tick into stacked buffers; the cost (:func:`~wbc.formulations.idkernel.task_cost`) and every
state-dependent block are written by compiled bodies that :meth:`InverseDynamicsQP.build` (through the constraints'
``write``) and the compiled tick (:func:`~wbc.formulations.idkernel.id_assemble`) share, so the ``fast`` solver and
any backend read the same arrays. When a DAQP backend finds no
solution to the full QP in one attempt, the QP is solved once more by quadprog with its pinned variables (lb = ub: a
released foot's forces) and its equality rows eliminated (:func:`wbc.solvers.independent.solve_pinned_reduced`; the
path then names ``quadprog``) before the failure stands (then the backend's own retries); the relaxed QP gets the same
quadprog solve when the backend's calls miss the minimiser of a relaxed set found not empty. Any other
:class:`~wbc.solvers.base.QPBackend` (e.g. ProxQP) that finds no solution to the full or the relaxed QP gets a second
opinion (:func:`wbc.solvers.independent.second_opinion`: the same quadprog solve, then one cold DAQP call) before its
failure stands. When the QP is infeasible, :meth:`InverseDynamicsQP.diagnose` names the conflicting constraints
(:mod:`wbc.solvers.diagnosis`).

Regularisation ε_a, ε_f > 0 make the Hessian positive definite. The solution gives τ by (2); the dynamics (1)
then hold to the solver's equality accuracy on rows 0..5 and exactly on the actuated rows.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from time import perf_counter, thread_time

import numpy as np

from wbc.constraints.barrier import AccelerationBarrier
from wbc.constraints.base import IDConstraint, IDContext, InequalityConstraint
from wbc.constraints.contact_acceleration import DEPENDENT_CONTACT_RATIO, ContactAcceleration, independent_contact_rows
from wbc.constraints.floating_base import FloatingBaseDynamics, contact_force_columns
from wbc.constraints.friction import FrictionPyramid
from wbc.constraints.hard_task import HardTask
from wbc.constraints.joint_acceleration_bounds import JointAccelerationLimits
from wbc.constraints.torque_limits import TorqueLimits
from wbc.constraints.unilaterality import Unilaterality
from wbc.constraints.sole_contact import SoleContact
from wbc.formulations.idkernel import (IDArrays, IDContactData, IDDynamics, IDLimits, IDTaskRows, IDTickBuffers,
                                       PAR_BRAKING, PAR_EPS_A, PAR_EXTRA_ROWS, PAR_JOINT_LIMITS, PAR_MAX_ITER,
                                       PAR_SPEED_HORIZON,
                                       PROJECT_CONTACT_RHS, R_ACC_FF, R_DRIFT, R_ERROR, R_ERROR_RATE_FF, R_KD, R_KP,
                                       R_WEIGHT, contact_rows_well_conditioned, ensure_compiled, id_command, id_tick,
                                       contact_views, id_tick_buffers, output_violations,
                                       task_cost, tick_outputs)
from wbc.state import DynamicsState
from wbc.formulations.reference import AccelerationReference
from wbc.exceptions import InvalidInputError, SolverError
from wbc.solvers import DaqpBackend, QPBackend, make_backend
from wbc.solvers.base import POLISH_RANGE
from wbc.solvers.daqp import DAQP_ITERATION_COST
from wbc.solvers.diagnosis import diagnose
from wbc.solvers.fallback import DAQP_SETTINGS, SCALED_EPS_PROX, FallbackChain
from wbc.solvers.qp_data import QPData
from wbc.solvers.status import SolverStatus
from wbc.tick import TickPath
from wbc.robot import Robot
from wbc.tasks.base import Task
from wbc.tasks.posture import PostureTask

__all__ = ["InverseDynamicsQP", "IDSolution", "KERNEL_ITERATION_COST", "KERNEL_ITERATIONS_AFTER_GIVE_UP",
           "OUTPUT_REFINE_RANGE", "kernel_iterations"]


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
        path: the route that produced it (:class:`wbc.tick.TickPath`): ``kernel`` (the compiled tick),
            ``general:<backend>`` (the backend on the assembled QP), ``relaxed:<backend>``
            (:meth:`InverseDynamicsQP.solve_relaxed`); None before a solve.
        reason: why a tick left the compiled route and which step of the fallback chain answered (e.g.
            ``kernel status ITERATION_CAP → daqp attempt``); '' on the compiled route.
    """

    dv: np.ndarray
    forces: np.ndarray
    tau: np.ndarray
    wrenches: dict[str, np.ndarray] = field(default_factory=dict)
    dynamics_residual: float = 0.0
    timings: dict[str, float] = field(default_factory=dict)
    path: TickPath | None = None
    reason: str = ""


#: a full-QP answer that fails the output check (:meth:`InverseDynamicsQP.verify`) is refined (polished, else
#: quadprog's solve: :meth:`InverseDynamicsQP.solve`) only when it passes the check at this relative tolerance: off by
#: the solver's precision, the backends' own polish range (:data:`wbc.solvers.base.POLISH_RANGE`)
OUTPUT_REFINE_RANGE = POLISH_RANGE

_KERNEL_PATH = TickPath("kernel")  # the path of every compiled tick (frozen: shared by their solutions)

#: Solver settings of the ID QP: the floating-base dynamics rows are equalities (exact in an active-set solve);
#: DAQP's primal tolerance 1e-6 (1e-9 reported "no solution" on feasible walking problems, FIELD_NOTES); the dual
#: warm start faster than DAQP's persistent workspace on this inequality-heavy QP (benchmarks/README.md).
_ID_SETTINGS = {"daqp": DAQP_SETTINGS, "fast": {**DAQP_SETTINGS, "kernel_rows": False}}
_STATUS_CODES = {int(code) for code in SolverStatus}

#: CPU time (s) of one working-set iteration of the compiled ID tick (:func:`~wbc.solvers.active_set.dual_active_set`
#: refactors its working set every iteration), with its share of the call's set-up, on the slow ticks of the ID fuzz
#: (benchmarks/README.md, "ID kernel cap from its measured iteration cost"). A tick budget becomes an iteration cap
#: of ⌊budget / (4 · KERNEL_ITERATION_COST)⌋ (:func:`kernel_iterations`).
KERNEL_ITERATION_COST = 1.2e-4

#: iteration cap of the compiled ID tick on the tick after one whose compiled call gave up (DAQP answered it): the
#: call starts from DAQP's working set, so a tick one working-set change away from the last answer stays in the
#: compiled tick; one that needs more is as hard as the last and goes to DAQP after this short attempt.
KERNEL_ITERATIONS_AFTER_GIVE_UP = 2


def kernel_iterations(budget: float) -> int:
    """Iteration cap of the compiled ID tick for a tick budget of ``budget`` seconds of CPU time: a quarter of the
    budget at :data:`KERNEL_ITERATION_COST` per iteration, between 4 and 100 (100: an unbounded budget). A count,
    not a clock: the tick's answer stays a function of its inputs; a capped call is answered by DAQP on the same
    assembly, and a failed full QP's checks and relaxed QP come after it, in the rest of the budget."""
    if not np.isfinite(budget):
        return 100
    return int(min(100, max(4, budget / (4.0 * KERNEL_ITERATION_COST))))


_ID_TICK_LOADED = False


class InverseDynamicsQP:
    """Builds and solves the QP of the module docstring from its named constraints.

    Args:
        robot: the robot.
        tasks: tasks with their PD references (:class:`~wbc.formulations.reference.AccelerationReference`),
            weighted (soft).
        contacts: sole contacts (all declared up front; (de)activate them to switch support).
        solver: QP backend name (``fast``, the default: the compiled tick of :mod:`wbc.formulations.idkernel` —
            assembly, Goldfarb–Idnani dual active-set solve (:func:`~wbc.solvers.active_set.dual_active_set`) and
            torques in one call — with DAQP as fallback (the general path while the torque-limited joints are
            not contiguous in v); ``daqp``: the general path, warm-started from the
            previous duals, ``primal_tol`` 1e-6 (DAQP's one-shot dual warm start stops ≈ 3e-7 from the optimum on
            this QP; the compiled tick matches quadprog to ≈ 1e-11); any other qpsolvers backend —
            :func:`wbc.solvers.make_backend`) or a :class:`~wbc.solvers.base.QPBackend`.
        acceleration_regularization: ε_a (weight of ‖v̇‖²).
        force_regularization: ε_f (weight of ‖f‖², 1/N² in task-cost units).
        torque_limit_scale: fraction of the URDF effort limit used in (6), in (0, 1].
        braking_acceleration: a_brk of the viability bound (rad/s²), > 0.
        joint_limits: apply the joint acceleration bounds (9).

    Attributes:
        constraints: every named constraint (:mod:`wbc.constraints`), in row order.
        torque_limits, joint_acceleration_limits, dynamics: the single-instance constraints.

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
        model = robot.model
        self.nv = nv = model.nv
        #: the fallback ladder over the backend (:class:`~wbc.solvers.fallback.FallbackChain`): its budget, steps
        #: and counters
        self.chain = FallbackChain(make_backend(solver, **_ID_SETTINGS.get(solver, {})) if isinstance(solver, str)
                                   else solver)
        self.eps_a = float(acceleration_regularization)
        self.eps_f = float(force_regularization)
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
        # Named constraints (wbc.constraints), each with its place in the preallocated blocks.
        self.dynamics = FloatingBaseDynamics()
        self.dynamics.rows = slice(0, 6)
        self.contact_accelerations = [ContactAcceleration(c) for c in self.contacts]
        self.torque_limits = TorqueLimits(robot, torque_limit_scale)
        self.friction = [FrictionPyramid(c, nv + 12 * k) for k, c in enumerate(self.contacts)]
        self.unilaterality = [Unilaterality(c, nv + 12 * k) for k, c in enumerate(self.contacts)]
        self.joint_acceleration_limits = JointAccelerationLimits(robot, braking_acceleration)
        #: optional non-relaxable joint speed bounds kept by :meth:`solve_relaxed`
        #: (:class:`wbc.constraints.joint_velocity.JointSpeedBounds`); None: none
        self.joint_speed_limits = None
        self.tau_max = self.torque_limits.tau_max
        self.tau_rows = self.torque_limits.joints
        r = 0
        for con in (self.torque_limits, *self.friction):
            con.rows = slice(r, r + con.dim)
            r += con.dim
        self._r0 = r  # inequality rows before the added constraints (add_constraint)
        self.extra_constraints: list[IDConstraint] = []
        #: equality constraints added by :meth:`add_constraint` (rows after the hard tasks')
        self.extra_equalities: list[IDConstraint] = []
        # Preallocated blocks.
        self._H = np.zeros((n, n))
        self._g = np.zeros(n)
        self._A = np.zeros((6 + 6 * nc, n))  # grown by add_task(hard=True)
        self._b = np.zeros(6 + 6 * nc)
        self._C = np.zeros((r, n))
        self._l = np.full(r, -np.inf)
        self._u = np.zeros(r)
        self._lb = np.full(n, -np.inf)
        self._ub = np.full(n, np.inf)
        self._JcT = np.zeros((nv, 12 * nc))
        self._ctx = IDContext(state=None, dt=0.0, nv=nv, JcT=self._JcT, jacobians={})
        for con in self.friction:  # constant while μ is: rewritten only when it changes (_refresh_contact_rows)
            con.write(self._ctx, self._C[con.rows], self._l[con.rows], self._u[con.rows])
            con.written = con.key()
        self._H[nv:, nv:] = np.diag(np.full(12 * nc, self.eps_f))  # constant force regularisation
        ensure_compiled()
        self._rows = _ProblemRows(self)
        self._rows.relayout(self)  # the task rows laid out here (and at add_task/remove_task), not in the first tick
        if isinstance(solver, str) and isinstance(self.backend, DaqpBackend):
            self.backend.scaled_settings = {"eps_prox": SCALED_EPS_PROX}
        self._kernel = None
        if solver == "fast" and (self.torque_limits.dim == 0 or isinstance(self.torque_limits.velocity_rows, slice)):
            self._kernel = self._new_kernel()
        # why a tick of this QP is not on the compiled route ('' for a backend chosen by name or object)
        self._general_reason = ("no compiled tick: torque-limited joints not contiguous in v"
                                if solver == "fast" and self._kernel is None else "")
        self._force_slices = [slice(nv + 12 * k, nv + 12 * k + 12) for k in range(nc)]
        # verify's inputs to output_violations: friction rows, activity, results; no limited joint (relaxed)
        self._verify_buffers = (np.zeros((nc, 16, 12)), np.zeros(nc, np.bool_), np.zeros((2 * nc + 2, 2)))
        self._no_joints = np.zeros(0, np.int64)
        self._m = 6  # equality rows of the last build
        #: directions of the stacked active contact rows dropped at the last build
        #: (:func:`wbc.constraints.contact_acceleration.independent_contact_rows`; 0 for legs that can yaw the foot)
        self.dependent_contact_rows = 0
        self.chain.hard_set_x = np.zeros(n)
        #: violations found by :meth:`verify` on the last solve ([] when it passed).
        self.last_violations: list[tuple[str, float]] = []
        #: working-set iterations the compiled tick may take before DAQP answers the tick (``solver="fast"``);
        #: :class:`~wbc.controllers.inverse_dynamics.InverseDynamicsController` sets it from its budget
        #: (:func:`kernel_iterations`). A tick whose compiled call gave up is answered by DAQP, whose working set
        #: warm-starts the next tick's compiled call, capped at :data:`KERNEL_ITERATIONS_AFTER_GIVE_UP`.
        self.kernel_max_iterations = 100
        self._assembled = None  # (id(state), dt) of the QP held in the arrays by the last solve(), else None
        jl = self.joint_acceleration_limits
        self._jl_slice = (slice(int(jl.iv[0]), int(jl.iv[-1]) + 1)
                          if jl.dim and np.array_equal(jl.iv, np.arange(jl.iv[0], jl.iv[0] + jl.dim)) else None)

    @property
    def backend(self):
        """The QP backend asked first (:attr:`chain`'s; assignable)."""
        return self.chain.backend

    @backend.setter
    def backend(self, value) -> None:
        self.chain.backend = value

    @property
    def braking_acceleration(self) -> float:
        """a_brk of the joint viability bounds (rad/s²)."""
        return self.joint_acceleration_limits.braking_acceleration

    @property
    def constraints(self) -> list[IDConstraint]:
        """Every named constraint: equalities (dynamics, active contacts, hard tasks), inequalities, bounds."""
        return [self.dynamics, *self.contact_accelerations, *self.hard_tasks, *self.extra_equalities,
                self.torque_limits, *self.friction, *self.extra_constraints, *self.unilaterality,
                self.joint_acceleration_limits]

    def add_constraint(self, constraint, *, gain: float = 10.0) -> IDConstraint:
        """Add a constraint under its name: an equality or inequality :class:`~wbc.constraints.base.IDConstraint`
        (rows in x = [v̇; f], written by its ``write``; equality rows go after the hard tasks' in A x = b), or a
        kinematic constraint of :mod:`wbc.constraints` with a barrier form (``ComPolygonConstraint``,
        ``SelfCollisionConstraint``), held as :class:`~wbc.constraints.barrier.AccelerationBarrier` with γ =
        ``gain`` (1/s). Its rows are a gathered entry of the assembly (:meth:`_write_gathered`): the compiled tick
        solves the QP with them as the general path does.

        Returns:
            the ID constraint added (remove it with it, or with the kinematic constraint).

        Raises:
            InvalidInputError: another kind of object (a ``bounds`` constraint, a kinematic constraint without a
                barrier form), bad gain, or a name already in the QP.
        """
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

        Raises:
            ValueError: not in the QP.
        """
        for con in self.extra_constraints:
            if con is constraint or getattr(con, "constraint", None) is constraint:
                self.extra_constraints.remove(con)
                self._layout_inequalities()
                return
        if constraint in self.extra_equalities:
            self.extra_equalities.remove(constraint)
            return
        raise ValueError(f"{constraint!r} is not in the QP")

    def _new_kernel(self) -> _KernelBuffers:
        """The compiled tick's buffers (:class:`_KernelBuffers`) over this QP's gathered rows and current blocks."""
        return _KernelBuffers(self, self._rows, (self._H, self._g, self._A, self._b, self._C, self._l, self._u,
                                                 self._lb, self._ub, self._JcT))

    def _layout_inequalities(self) -> None:
        r = self._r0
        for con in self.extra_constraints:
            con.rows = slice(r, r + con.dim)
            r += con.dim
        C, l, u = np.zeros((r, self.n)), np.full(r, -np.inf), np.zeros(r)
        r0 = self._r0
        C[:r0], l[:r0], u[:r0] = self._C[:r0], self._l[:r0], self._u[:r0]  # torque (per tick) and friction rows
        self._C, self._l, self._u = C, l, u
        if self._kernel is not None:  # its argument tuples hold the blocks: new blocks, new buffers
            self._kernel = self._new_kernel()

    def _refresh_contact_rows(self) -> None:
        """Rewrite the contact blocks whose parameters were assigned since they were written: the force bounds
        (active, f_min, f_max) and the friction rows (μ); both paths read them from the preallocated blocks."""
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

    # -- problem definition ----------------------------------------------------------------------------------
    def add_task(self, task: AccelerationReference | Task, *, hard: bool = False, kp: float | None = None,
                 kd: float | None = None, weight=None) -> AccelerationReference:
        """Add a task: weighted (default) or, with ``hard=True``, held as the equality constraint ``task:<name>``
        (:class:`~wbc.constraints.hard_task.HardTask`). ``task`` is an
        :class:`~wbc.formulations.reference.AccelerationReference`, or a :class:`wbc.tasks.base.Task` given with
        its reference gains ``kp`` (1/s², required), ``kd`` (1/s) and ``weight`` (then wrapped in one).

        Returns:
            the :class:`~wbc.formulations.reference.AccelerationReference` added (remove it with it).

        Raises:
            InvalidInputError: neither; a Task without ``kp``; bad gains or weights.
        """
        if isinstance(task, Task):
            if kp is None:
                raise InvalidInputError(f"add_task({task.name}): a Task needs its reference gain kp (1/s²)")
            task = AccelerationReference(task, kp=kp, kd=kd, weight=weight)
        if not isinstance(task, AccelerationReference):
            raise InvalidInputError(f"expected an AccelerationReference or a Task, got {type(task).__name__}")
        if hard:
            self.hard_tasks.append(HardTask(task))
            if hasattr(self, "_A"):
                self._grow_equalities()
        else:
            self.tasks.append(task)
            if hasattr(self, "_rows"):
                self._rows.relayout(self)
        return task

    def remove_task(self, task: AccelerationReference) -> None:
        """Remove an acceleration task (weighted or hard) added to the QP.

        Raises:
            ValueError: the task is not in the QP.
        """
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
            if self._kernel is not None:  # its argument tuples hold the blocks: new blocks, new buffers
                self._kernel = self._new_kernel()

    def contact(self, name: str) -> SoleContact:
        """The contact called ``name``. Raises InvalidInputError (listing the names) when there is none."""
        for c in self.contacts:
            if c.name == name:
                return c
        raise InvalidInputError(f"no contact {name!r}; contacts: {[c.name for c in self.contacts]}")

    # -- assembly --------------------------------------------------------------------------------------------
    def joint_acceleration_bounds(self, state: DynamicsState, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """(lo, hi) bounds (9) on the 1-DoF joint accelerations (rad/s²), in the order of
        ``joint_acceleration_limits.iv`` (copies)."""
        lo, hi = self.joint_acceleration_limits.bounds(state, dt)
        return lo.copy(), hi.copy()

    def build(self, state: DynamicsState, dt: float):
        """(H, g, A, b, C, l, u, lb, ub) of the QP at ``state`` (module docstring). Arrays are reused: the cost is
        formed from the gathered task rows by :func:`~wbc.formulations.idkernel.task_cost` and every constraint
        writes its block in place (the compiled bodies of the compiled tick: the same numbers bit for bit); the
        constant blocks (force regularisation, friction rows, force bounds whose contact did not change) are not
        rewritten. With ≥ 2 active contacts whose rows are not certified well conditioned
        (:func:`~wbc.formulations.idkernel.contact_rows_well_conditioned`) the dependent directions are dropped
        (:func:`~wbc.constraints.contact_acceleration.independent_contact_rows`)."""
        return self._build(state, dt)

    def _build(self, state: DynamicsState, dt: float, gathered: bool = False):
        """:meth:`build`; ``gathered``: this tick's task rows and contact data are already in the buffers (gathered at
        this ``state`` by the compiled tick that handed the QP over), not gathered again."""
        rows = self._rows
        if not gathered:
            rows.gather(self, state)
        task_cost(*rows.tasks, state.v, self.eps_a, rows.Hw, rows.gw, self._H, self._g)
        ctx = self._context(state, dt)
        A, b = self._A, self._b
        self.dynamics.write(ctx, A[0:6], b[0:6], None)
        i = 6
        for con in self.contact_accelerations:
            if con.enabled:
                con.rows = slice(i, i + con.dim)
                con.write(ctx, A[i:i + con.dim], b[i:i + con.dim], None)
                i += con.dim
        # ≥ 2 active contacts: (nearly) dependent directions of the stacked contact rows dropped (none when the
        # rows are certified well conditioned, the compiled tick's test)
        self.dependent_contact_rows = 0
        if i > 12 and not contact_rows_well_conditioned(rows.Jc, rows.active, DEPENDENT_CONTACT_RATIO, rows.gram,
                                                        rows.gram_y):
            kept = independent_contact_rows(A[6:i], b[6:i])
            self.dependent_contact_rows = i - 6 - kept
            if kept < i - 6:
                i = 6 + kept
                for con in self.contact_accelerations:  # (rows rotated: the labels are those of the blocks)
                    if con.enabled:
                        con.rows = slice(min(con.rows.start, i), min(con.rows.stop, i))
        i = self._write_gathered(ctx, i)
        self._m = i
        C, l, u = self._C, self._l, self._u
        tl = self.torque_limits
        tl.write(ctx, C[tl.rows], l[tl.rows], u[tl.rows])
        lb, ub = self._lb, self._ub
        self._refresh_contact_rows()
        if self.joint_limits:
            jl = self.joint_acceleration_limits
            if self._jl_slice is not None:
                jl.write(ctx, None, lb[self._jl_slice], ub[self._jl_slice])
            else:
                lo, hi = jl.bounds(state, dt)
                lb[jl.iv], ub[jl.iv] = lo, hi
        return self._H, self._g, A[:i], b[:i], C, l, u, lb, ub

    def _context(self, state: DynamicsState, dt: float) -> IDContext:
        """The constraints' context of this tick from the gathered contact data: J_cᵀ, the sole Jacobians and the
        velocity-free parts of eq. 5."""
        rows = self._rows
        ctx = self._ctx
        ctx.state, ctx.dt = state, dt
        JcT, jac, offsets = self._JcT, ctx.jacobians, ctx.offsets
        for k, c in enumerate(self.contacts):
            contact_force_columns(rows.Jc[k], rows.Gc[k], JcT, 12 * k)
            jac[c.name] = rows.Jc[k]
            offsets[c.name] = rows.cdrift[k]
        return ctx

    @property
    def _gathers_rows(self) -> bool:
        """The QP has gathered constraint entries (:meth:`_write_gathered`)."""
        return bool(self.hard_tasks or self.extra_equalities or self.extra_constraints)

    def _write_gathered(self, ctx: IDContext, i: int) -> int:
        """Write the gathered constraint entries — the rows that no compiled body of the tick writes: the hard tasks'
        and added equalities' rows of A from row ``i`` on, the added inequalities' rows of C — by their constraints'
        ``write``. The one driver of these rows for both assemblies: :meth:`build` calls it after the contact rows,
        the compiled tick before its call (:func:`~wbc.formulations.idkernel.id_tick` counts the equality rows,
        ``PAR_EXTRA_ROWS``, and solves with every row). An added constraint is one more entry here.

        Returns:
            the row after the last equality row written.
        """
        A, b = self._A, self._b
        for con in (*self.hard_tasks, *self.extra_equalities):
            if con.enabled:
                con.rows = slice(i, i + con.dim)
                con.write(ctx, A[i:i + con.dim], b[i:i + con.dim], None)
                i += con.dim
        C, l, u = self._C, self._l, self._u
        for con in self.extra_constraints:
            con.write(ctx, C[con.rows], l[con.rows], u[con.rows])
        return i

    def assembled_qp(self) -> tuple | None:
        """Copies of (H, g, A, b, C, l, u, lb, ub) as the last :meth:`solve` assembled them (by :meth:`build` or by
        the compiled tick, :func:`~wbc.formulations.idkernel.id_tick`), the QP its solver received; None when no
        :meth:`solve` assembled one since."""
        if self._assembled is None:
            return None
        m = self._m
        return tuple(a.copy() for a in (self._H, self._g, self._A[:m], self._b[:m], self._C, self._l, self._u,
                                         self._lb, self._ub))

    def _relaxed_set(self, state: DynamicsState, dt: float, l, u, lb, ub):
        """Copies of (l, u, lb, ub) of the relaxed QP (:meth:`solve_relaxed`): without the relaxable constraints,
        with the :attr:`joint_speed_limits` bounds at ``state``."""
        l, u, lb, ub = self._relax(l, u, lb, ub)
        if self.joint_speed_limits is not None:  # not relaxable: |v + v̇ dt| ≤ v_max also here
            self.joint_speed_limits.intersect(state.v, dt, lb, ub)
        return l, u, lb, ub

    def _relax(self, l, u, lb, ub):
        """Copies of (l, u, lb, ub) without the relaxable constraints (torque limits, joint limits)."""
        l, u, lb, ub = l.copy(), u.copy(), lb.copy(), ub.copy()
        for con in self.constraints:
            if not con.relaxable:
                continue
            if con.kind == "inequality":
                l[con.rows], u[con.rows] = -np.inf, np.inf
            elif con.kind == "bounds":
                lb[con.indices], ub[con.indices] = -np.inf, np.inf
        return l, u, lb, ub

    def solve_relaxed(self, state: DynamicsState, dt: float, *, reuse_assembly: bool = False) -> IDSolution:
        """Solve the QP without the relaxable constraints — joint acceleration bounds (9) and torque limits (6) —
        a fallback when the full QP is infeasible (MuJoCo still enforces joint limits and clamps torques); the
        :attr:`joint_speed_limits` bounds, when set, are kept. Same returns/raises as :meth:`solve`.

        ``reuse_assembly``: when the last :meth:`solve` assembled the QP at this same ``state`` object and ``dt``
        (the failed full QP of the same tick, nothing edited since), its arrays are used instead of assembling
        again; otherwise (or False) the QP is assembled here. With ``reuse_assembly``, a relaxed hard set that this
        tick's failed full QP proved empty (:attr:`relaxed_set_feasible` False) raises SolverError at once."""
        t0 = perf_counter()
        if reuse_assembly and self._assembled == (id(state), dt):
            m = self._m
            H, g, A, b, C, l, u, lb, ub = (self._H, self._g, self._A[:m], self._b[:m], self._C, self._l, self._u,
                                           self._lb, self._ub)
        else:
            H, g, A, b, C, l, u, lb, ub = self.build(state, dt)
        same_tick = reuse_assembly and self._assembled == (id(state), dt)
        reused = self.chain.relaxed_bounds
        if same_tick and reused is not None:
            l, u, lb, ub = reused  # this tick's failed full QP formed them for its check of the relaxed hard set
        else:
            l, u, lb, ub = self._relaxed_set(state, dt, l, u, lb, ub)
        t1 = perf_counter()
        x, solver, step = self.chain.solve_relaxed(QPData(H, g, A, b, C, l, u, lb, ub), same_tick=same_tick,
                                                   formed=not (same_tick and reused is not None))
        t2 = perf_counter()
        sol = self.solution_from(state, x, timings={"assembly": t1 - t0, "solve": t2 - t1})
        sol.path = TickPath("relaxed", solver)
        sol.reason = f"full QP failed → relaxed QP, {step}"
        self._guard(state, sol, relaxed=True)
        return sol

    def solve(self, state: DynamicsState, dt: float) -> IDSolution:
        """Build and solve the QP at ``state`` for control period ``dt`` (s). The solution passes the output check
        (:meth:`verify`); a backend's answer that fails it by at most :data:`OUTPUT_REFINE_RANGE` (relative) is first
        polished on its active set, else replaced by quadprog's solve of the same QP (path ``general:quadprog``), and
        the first that passes is returned.

        Returns:
            :class:`IDSolution`.

        Raises:
            InvalidInputError: dt not finite and > 0.
            SolverError: the backend failed, or no answer passes the output check (each row and bound to the backend's
                tolerance, 1e-6 for the default backends, times max(1, |bound|); :meth:`verify`).
        """
        if not (np.isfinite(dt) and dt > 0):
            raise InvalidInputError(f"dt must be finite and > 0 (s), got {dt!r}")
        self.last_violations = []
        self._assembled = None
        self.chain.begin_tick()
        if self._kernel is not None:
            return self._solve_kernel(state, dt)
        t0 = perf_counter()
        qp = QPData(*self.build(state, dt))
        self._assembled = (id(state), dt)  # solve_relaxed(reuse_assembly=True) may reuse these arrays
        return self._solve_general(state, dt, qp, t0, self._general_reason)

    def _solve_general(self, state: DynamicsState, dt: float, qp: QPData, t0: float, why: str,
                       answered=None) -> IDSolution:
        """The assembled full QP ``qp`` through :attr:`chain` (route ``general``), its answer checked by
        :meth:`_guard_full`; ``why`` the tick is not on the compiled route (its ``reason``, with the chain's step);
        ``answered(x, solver)`` is called with the chain's answer before the check."""
        t1 = perf_counter()
        x, solver, step = self.chain.solve(qp, lambda l, u, lb, ub: self._relaxed_set(state, dt, l, u, lb, ub))
        if answered is not None:
            answered(x, solver)
        sol = self.solution_from(state, x, timings={"assembly": t1 - t0, "solve": perf_counter() - t1})
        sol.path = TickPath("general", solver)
        sol.reason = f"{why} → {solver} {step}" if why else ""
        return self._guard_full(state, sol, qp)

    def nonfinite_inputs(self) -> list[tuple[str, float]]:
        """``(task:<name>, nan)`` for every task whose error (at the last assembly), weights or acceleration
        feed-forward are not finite — e.g. a target or weight array written in place with a NaN."""
        out = []
        for ref in (*self.tasks, *(h.task for h in self.hard_tasks)):
            ff = ref.feedforward_acceleration
            if not (np.isfinite(ref.last_error).all() and np.isfinite(ref.weight).all()
                    and (ff is None or np.isfinite(ff).all())):
                out.append((f"task:{ref.name}", float("nan")))
        return out

    def _guard(self, state: DynamicsState, sol: IDSolution, *, relaxed: bool = False) -> None:
        """Raise SolverError (naming the constraints, :attr:`last_violations`) when :meth:`verify` finds any."""
        self.last_violations = viol = self.verify(state, sol, relaxed=relaxed)
        if viol:
            raise _output_check_error(sol, viol)

    def _guard_full(self, state: DynamicsState, sol: IDSolution, qp: tuple) -> IDSolution:
        """:meth:`_guard` of a full-QP answer of the backend (route ``general``), given the QP it solved
        ``qp`` = (H, g, A, b, C, l, u, lb, ub): an answer that fails the output check is first refined — polished on
        its active set (:meth:`wbc.solvers.base.QPBackend.polish`: the bounds and rows it meets or crosses held
        exactly, the smallest correction of the other entries), then, failing that, replaced by quadprog's solve
        (pinned variables eliminated, :func:`wbc.solvers.independent.solve_pinned_reduced`; the next route) — and the
        first candidate that passes :meth:`verify` is returned. The backend's check measures a row against the size
        of its terms (:meth:`wbc.solvers.base.QPBackend.scaled_violation`), the output check a bound against
        max(1, |bound|): a torque row whose terms are large against its limit (an ill-conditioned cost's error in the
        solver's answer) can pass the first and fail the second. Only an answer within :data:`OUTPUT_REFINE_RANGE`
        of the output check (every violation at most that times its scale) is refined: one further off is not an
        error of the solver's precision (a solver's bug), and its tick fails. With a clock guard (:attr:`tick_clock`)
        the refinement starts only before :attr:`retry_deadline`, quadprog only when it is expected to end by
        ``QUADPROG_END`` budgets; without one, quadprog only when its count (:func:`quadprog_work`) fits below
        ``QUADPROG_WORK`` budgets of :attr:`tick_work`, as in the failure path.

        Returns:
            ``sol``, or the refined solution (path ``general:<backend>`` polished, ``general:quadprog``).

        Raises:
            SolverError: no candidate passes the output check (the message and :attr:`last_violations` are those
                of ``sol``).
        """
        viol = self.verify(state, sol)
        if (viol and viol[0][0] != "non_finite_command" and not self.verify(state, sol, tol=OUTPUT_REFINE_RANGE)
                and thread_time() < self.chain.retry_deadline):
            refined = self.chain.refine(np.concatenate((sol.dv, sol.forces)), qp,
                                        lambda x, solver: self._candidate(state, sol, x, solver), sol.path.solver)
            if refined is not None:
                self.last_violations = []
                return refined
        self.last_violations = viol
        if viol:
            raise _output_check_error(sol, viol)
        return sol

    def _candidate(self, state: DynamicsState, sol: IDSolution, x: np.ndarray, solver: str | None):
        """The solution of a refined candidate ``x`` of ``sol`` (``solver``: the one that gave it, None: ``sol``'s
        polished) when it passes :meth:`verify`, else None."""
        cand = self.solution_from(state, x, timings=sol.timings)
        cand.path = sol.path if solver is None else TickPath("general", solver)
        cand.reason = f"{sol.reason or 'output check'} → {'polished' if solver is None else solver}"
        return None if self.verify(state, cand) else cand

    def verify(self, state: DynamicsState, sol: IDSolution, *, relaxed: bool = False,
               tol: float | None = None) -> list[tuple[str, float]]:
        """Output check of a solution against the hard constraints of the last assembly at ``state``, independent
        of the solver that produced it: every entry finite; corner normal forces within their bounds
        (``unilaterality:<c>``, N); the friction pyramids (``friction:<c>``, N); the torque limits
        (``torque_limits``, N·m; skipped when ``relaxed``: the controller clips the relaxed torques); the
        floating-base rows of the equations of motion (``floating_base_dynamics``, N, N·m). Each violation is
        measured in the constraint's units and compared with ``tol`` times the row's scale (max(1, |bound|) for a
        bound; for a friction row max(1, |f_t| + μ/√2 |f_z|), the size of its terms; the largest |h_u| entry), the
        scaling of :meth:`wbc.solvers.base.QPBackend.scaled_violation` (a solution the solver accepted is not
        rejected for a tolerance measured on another scale).

        Args:
            state: the state the solution was computed at. sol: the solution. relaxed: the torque limits were
                dropped. tol: relative tolerance (default the backend's ``tolerance``).

        Returns:
            [(constraint name, violation in its units)], largest scaled first; empty when the solution passes.
            A non-finite solution gives ``("non_finite_command", nan)`` followed by every task whose error is
            not finite (``task:<name>``, nan), e.g. a target written in place with a NaN.
        """
        tol = self.backend.tolerance if tol is None else float(tol)
        contacts = self.contacts
        friction, active, out = self._verify_buffers
        for k, c in enumerate(contacts):  # copies: a contact's friction rows are rewritten in place when μ is set
            friction[k] = c.friction_matrix
            active[k] = c.active
        nv = self.nv
        tl = self.torque_limits
        joints = self._no_joints if relaxed or not self.tau_rows.size else tl.joints
        status = output_violations(sol.dv, sol.forces, sol.tau, self._lb[nv:], self._ub[nv:], friction, active,
                                   joints, tl.limits, float(sol.dynamics_residual), state.h, tol, out)
        if status < 0:
            return [("non_finite_command", float("nan")), *self.nonfinite_inputs()]
        if status == 0:
            return []
        found = []  # (scaled, name, violation)
        for k, c in enumerate(contacts):
            if out[2 * k, 0] > tol:
                found.append((float(out[2 * k, 0]), f"unilaterality:{c.name}", float(out[2 * k, 1])))
            if out[2 * k + 1, 0] > tol:
                found.append((float(out[2 * k + 1, 0]), f"friction:{c.name}", float(out[2 * k + 1, 1])))
        nc = len(contacts)
        if out[2 * nc, 0] > tol:
            found.append((float(out[2 * nc, 0]), "torque_limits", float(out[2 * nc, 1])))
        if out[2 * nc + 1, 0] > tol:
            found.append((float(out[2 * nc + 1, 0]), "floating_base_dynamics", float(out[2 * nc + 1, 1])))
        found.sort(key=lambda item: -item[0])
        return [(name, v) for _, name, v in found]

    def _solve_kernel(self, state: DynamicsState, dt: float) -> IDSolution:
        """:meth:`solve` through :func:`wbc.formulations.idkernel.id_tick` (same QP, compiled assembly and solve);
        a kernel call that does not end in a KKT point within tolerance goes to the backend (DAQP)."""
        t0 = perf_counter()
        kb = self._kernel
        rows = self._rows
        rows.gather(self, state)
        self._refresh_contact_rows()
        par = kb.par  # settings read every tick, as the general path does
        par[PAR_EPS_A] = self.eps_a
        par[PAR_BRAKING] = self.joint_acceleration_limits.braking_acceleration
        par[PAR_JOINT_LIMITS] = self.joint_limits
        par[PAR_SPEED_HORIZON] = self.joint_acceleration_limits.speed_horizon
        if self._gathers_rows:  # their rows written here, after the active contacts' equality rows
            m0 = 6 + 6 * int(np.count_nonzero(rows.active))
            par[PAR_EXTRA_ROWS] = self._write_gathered(self._context(state, dt), m0) - m0
        else:
            par[PAR_EXTRA_ROWS] = 0.0
        # after a give-up the call starts from DAQP's working set, one answer away: a short attempt
        cap = self.kernel_max_iterations
        par[PAR_MAX_ITER] = min(cap, KERNEL_ITERATIONS_AFTER_GIVE_UP) if kb.gave_up else cap
        kb.gave_up = False
        ta = perf_counter()
        it, m = id_tick(rows.tasks, IDDynamics(state.M, state.h, state.q, state.v, dt), rows.contacts, *kb.tail)
        self.dependent_contact_rows = 0
        if it == PROJECT_CONTACT_RHS:  # dependent contact rows: the backend solves the QP of build, which drops them
            kb.state[:] = 0
            kb.rstate[:] = 0
            qp = QPData(*self._build(state, dt, gathered=True))  # the rows gathered above
            self._assembled = (id(state), dt)
            return self._solve_general(state, dt, qp, t0, "kernel: dependent contact rows")
        self._m = m
        self._assembled = (id(state), dt)  # the kernel wrote the whole QP into the arrays (as build does)
        t1 = perf_counter()
        if it > 0 and kb.residual[0] <= self.backend.tolerance:
            x = kb.x.copy()  # fresh arrays every tick (callers keep them): one copy, views of it
            nv = self.nv
            wrench = kb.wrench.copy()
            sol = IDSolution(dv=x[:nv], forces=x[nv:], tau=kb.tau.copy(),
                             wrenches={name: wrench[k] for k, name in enumerate(rows.names)},
                             dynamics_residual=float(kb.residual[1]),
                             timings={"assembly": ta - t0, "solve": t1 - ta}, path=_KERNEL_PATH)
            self.last_violations = self.verify(state, sol)
            if not self.last_violations:
                kb.solves += 1
                return sol
            kb.rejected += 1  # the kernel's answer fails the output check: the backend solves the same QP
            why = f"kernel answer fails the output check ({self.last_violations[0][0]})"
        elif it > 0:
            why = f"kernel residual {kb.residual[0]:.1e} above the tolerance"
        else:
            why = f"kernel status {SolverStatus(it).name if it in _STATUS_CODES else it}"
        kb.fallbacks += 1
        kb.gave_up = True
        # the compiled call's work: its iteration cap at its per-iteration cost, in DAQP iterations
        self.chain.tick_work += par[PAR_MAX_ITER] * KERNEL_ITERATION_COST / DAQP_ITERATION_COST
        kb.state[:] = 0
        kb.rstate[:] = 0
        qp = QPData(self._H, self._g, self._A[:m], self._b[:m], self._C, self._l, self._u, self._lb, self._ub)
        return self._solve_general(state, dt, qp, t0, why, lambda x, solver: self._warm_kernel(x, solver, m))

    def _warm_kernel(self, x: np.ndarray, solver: str, m: int) -> None:
        """Warm start of the compiled tick's next call from the chain's answer ``x`` to a QP with ``m`` equality rows:
        the backend's multipliers (bounds, equality rows, inequality rows; > 0 at an upper bound, < 0 at a lower
        one), else the active bounds of ``x``."""
        kb = self._kernel
        lam = getattr(self.backend, "last_multipliers", None) if solver == self.backend.name else None
        n, p = self.n, self._C.shape[0]
        if lam is not None and len(lam) == n + m + p:
            lam = np.asarray(lam)
            kb.state[:] = np.sign(lam[:n])
            kb.rstate[:] = np.sign(lam[n + m:])
        else:
            lb, ub = self._lb, self._ub
            lo, hi = np.isfinite(lb), np.isfinite(ub)  # an infinite bound is never active
            kb.state[lo & (x <= np.where(lo, lb, 0.0) + 1e-9 * np.maximum(1.0, np.abs(np.where(lo, lb, 0.0))))] = -1
            kb.state[hi & (x >= np.where(hi, ub, 0.0) - 1e-9 * np.maximum(1.0, np.abs(np.where(hi, ub, 0.0))))] = 1

    def diagnose(self, state: DynamicsState, dt: float, *, include_relaxable: bool = True,
                 tol: float = 1e-6) -> list[tuple[str, float]]:
        """Names of the hard constraints that conflict at ``state``, with their violation (constraint units),
        largest first (:func:`wbc.solvers.diagnosis.diagnose`: slack-relaxed least-squares solve of the hard set).
        Empty when the hard set is feasible.

        Args:
            include_relaxable: False: diagnose the set without torque and joint limits (the relaxed QP).
            tol: smallest violation reported.
        """
        H, g, A, b, C, l, u, lb, ub = self.build(state, dt)
        if not include_relaxable:
            l, u, lb, ub = self._relax(l, u, lb, ub)
        eq, ineq, box = [], [], []
        for con in self.constraints:
            if not con.enabled or (con.relaxable and not include_relaxable):
                continue
            if con.kind == "equality":
                eq.append((con.name, con.rows.start, con.rows.stop))
            elif con.kind == "inequality":
                ineq.append((con.name, con.rows.start, con.rows.stop))
            elif con.kind == "bounds" and (con is not self.joint_acceleration_limits or self.joint_limits):
                box.append((con.name, con.indices, lb[con.indices], ub[con.indices]))
        conflicts, _ = diagnose(A, b, C, l, u, lb, ub, eq, ineq, box, tol=tol)
        return conflicts

    def solution_from(self, state: DynamicsState, x: np.ndarray, timings: dict | None = None) -> IDSolution:
        """:class:`IDSolution` of a QP solution x (n,) at ``state`` (τ by eq. 2, residual of eq. 1, sole wrenches:
        :func:`~wbc.formulations.idkernel.id_command`, the compiled tick's).

        Uses the matrices and contact data of the last assembly (:meth:`build`, or a :meth:`solve`) at this state.
        """
        nv = self.nv
        x = np.array(x, dtype=float)  # a fresh contiguous copy: dv and forces are views of it
        rows = self._rows
        tau = np.empty(nv - 6)
        wrench = np.empty((len(self.contacts), 6))
        residual = id_command(state.M, state.h, self._JcT, rows.Gc, rows.Rc, rows.active, x, tau, wrench)
        wrenches = {c.name: wrench[k] for k, c in enumerate(self.contacts)}
        return IDSolution(dv=x[:nv], forces=x[nv:], tau=tau, wrenches=wrenches, dynamics_residual=float(residual),
                          timings=timings or {})

    @property
    def contact_jacobian_transpose(self) -> np.ndarray:
        """(nv, 12 n_c) J_cᵀ = [J_kᵀ G_k]_k of the last build (maps corner forces to generalized forces)."""
        return self._JcT

    def check_solution(self, state: DynamicsState, sol: IDSolution) -> dict[str, float]:
        """Margins of a solution (≥ 0 when satisfied, in constraint units) — used by tests and logs.

        Returns:
            ``friction`` (N, min over corners of μ/√2 f_z − |f_t|), ``normal`` (N, min f_z − min(f_min, f_max)
            over active corners), ``torque`` (N·m, min τ_max − |τ| over limited joints), ``cop`` (m, min distance of each
            loaded foot's CoP to the sole edges).
        """
        out = {"friction": np.inf, "normal": np.inf, "torque": np.inf, "cop": np.inf}
        for k, c in enumerate(self.contacts):
            if not c.active:
                continue
            f = sol.forces[12 * k:12 * k + 12].reshape(4, 3)
            mu_in = c.mu / np.sqrt(2.0)
            out["friction"] = min(out["friction"], float(np.min(mu_in * f[:, 2:3] - np.abs(f[:, :2]))))
            out["normal"] = min(out["normal"], float(np.min(f[:, 2] - c.normal_force_bounds[0])))
            cop = c.cop(sol.forces[12 * k:12 * k + 12])
            if cop is not None:
                x0, x1, y0, y1 = c.support
                out["cop"] = min(out["cop"], float(min(cop[0] - x0, x1 - cop[0], cop[1] - y0, y1 - cop[1])))
        if self.tau_rows.size:
            out["torque"] = float(np.min(self.tau_max[self.tau_rows] - np.abs(sol.tau[self.tau_rows])))
        return out


def _output_check_error(sol: IDSolution, viol: list[tuple[str, float]]) -> SolverError:
    """The SolverError of a solution that fails the output check (:meth:`InverseDynamicsQP.verify`'s ``viol``)."""
    return SolverError(f"{sol.path} returned a command that fails the output check: "
                       + ", ".join(f"{n} ({v:.3g})" for n, v in viol))


def _write_feedforward(row: np.ndarray, ff: np.ndarray | None) -> bool:
    """Write a feed-forward term (ė_ff or ä_ff, (m,)) into its row of R: ``ff``, or zeros if None. Returns whether
    the row now holds zeros."""
    if ff is None:
        row.fill(0.0)
        return True
    row[:] = ff
    return False


class _ProblemRows:
    """The per-tick inputs of the QP's state-dependent blocks, gathered once per tick into stacked buffers that both
    assemblies read (:meth:`InverseDynamicsQP.build` through the constraints' ``write`` and the compiled tick
    :func:`~wbc.formulations.idkernel.id_tick`): the task rows of
    :func:`~wbc.formulations.idkernel.task_cost` (J, e, ė_ff, J̇v, ä_ff, Kp, Kd, w; re-laid out only when the task
    list changes) and the contact data (LOCAL sole Jacobians, corner maps, −J̇v − K_p e, K_d, activity, sole
    rotations)."""

    def __init__(self, qp: InverseDynamicsQP):
        nv, nc = qp.nv, len(qp.contacts)
        self.names = [c.name for c in qp.contacts]
        # Jc, Gc, Rc, cdrift, ckd: views of one buffer, the compiled tick's one argument for them (contact_views)
        self.cbuf = np.zeros(nc * (6 * nv + 72 + 9 + 6 + 1))
        self.Jc, self.Gc, self.Rc, self.cdrift, self.ckd = contact_views(self.cbuf, nc, nv)
        self.Gc[:] = np.array([c.force_map() for c in qp.contacts]).reshape(nc, 6, 12)
        self.active = np.zeros(nc, dtype=np.bool_)
        self.contacts = IDContactData(self.cbuf, self.active)
        self.Hw = np.zeros((nv, nv))  # task_cost workspace
        self.gw = np.zeros(nv)
        self.gram = np.zeros((6 * nc, 6 * nc))  # contact_rows_well_conditioned workspace
        self.gram_y = np.zeros(6 * nc)
        self.layout: tuple | None = None  # none yet: InverseDynamicsQP lays the task rows out at construction
        self.entries: list = []
        self.tasks: tuple = ()
        self._rotations: tuple = (None, [])

    def relayout(self, qp: InverseDynamicsQP) -> None:
        """Lay the task rows out for ``qp.tasks`` (dense rows first, then the posture rows)."""
        dense = [t for t in qp.tasks if not isinstance(t.task, PostureTask)]
        posture = [t for t in qp.tasks if isinstance(t.task, PostureTask)]
        mt = sum(t.dim for t in dense)
        mp = sum(t.dim for t in posture)
        self.Jt = np.zeros((mt, qp.nv))
        self.R = np.zeros((7, mt + mp))
        pidx = [t.task.rows for t in posture]
        self.pidx = np.concatenate(pidx).astype(np.int64) if pidx else np.zeros(0, np.int64)
        self.entries = []
        k = 0
        for ref in dense + posture:
            s = slice(k, k + ref.dim)
            # reference, its task, dense rows?, views of its J rows, e, ė_ff, J̇v, ä_ff, weights; its columns of R;
            # the (Kp, Kd) last written there; whether its ė_ff and ä_ff columns hold zeros
            self.entries.append([ref, ref.task, k < mt, self.Jt[s], self.R[R_ERROR, s], self.R[R_ERROR_RATE_FF, s],
                                 self.R[R_DRIFT, s], self.R[R_ACC_FF, s], self.R[R_WEIGHT, s], s, None, True, True])
            ref.last_error = self.R[R_ERROR, s]  # a view, rewritten every tick
            k += ref.dim
        self.tasks = IDTaskRows(self.Jt, self.R, self.pidx, np.zeros(mt + mp))
        self.layout = tuple(map(id, qp.tasks))

    def gather(self, qp: InverseDynamicsQP, state: DynamicsState) -> None:
        """Task rows and contact data of this tick into the buffers (no validation: the tasks and contacts
        validated their targets when they were set)."""
        if tuple(map(id, qp.tasks)) != self.layout:
            self.relayout(qp)
        R = self.R
        for ent in self.entries:
            ref, task, dense, J, e, eff, drift, aff, w, s, gains, eff_zero, aff_zero = ent
            if dense:
                task.compute_with_drift_into(state, e, J, drift)
            else:
                e[:] = task.compute(state)[0]
                drift[:] = task.drift(state)
            ff = task.feedforward()  # ė_ff, then ä_ff, into their rows (None: zeros, written once)
            if ff is not None or not eff_zero:
                ent[11] = _write_feedforward(eff, ff)
            ff = ref.feedforward_acceleration
            if ff is not None or not aff_zero:
                ent[12] = _write_feedforward(aff, ff)
            w[:] = ref.weight
            kp, kd = ref.kp, ref.kd
            if gains is None or gains[0] != kp or gains[1] != kd:
                R[R_KP, s] = kp
                R[R_KD, s] = kd
                ent[10] = (kp, kd)
        data = state.kinematics_data  # each contact's frame placed by its jacobian below, before its rotation is read
        if self._rotations[0] is not data:  # views of Data's frame rotations (updated in place by Pinocchio)
            self._rotations = (data, [data.oMf[c.frame_id].rotation for c in qp.contacts])
        rotations = self._rotations[1]
        for i, c in enumerate(qp.contacts):
            self.Jc[i] = c.jacobian(state)
            self.Gc[i] = c.force_map()  # a partial foothold (SoleContact.set_support) moves its corners
            a = c.active
            self.active[i] = a
            if a:
                self.cdrift[i] = c.acceleration_offset(state)
                self.ckd[i] = c.kd
                self.Rc[i] = rotations[i]


class _KernelBuffers:
    """Preallocated solver state, outputs and workspace of :func:`wbc.formulations.idkernel.id_tick` for one QP, and
    its argument tuple after the gathered rows (:class:`_ProblemRows`): ``rows`` the QP's gathered rows, ``blocks``
    its (H, g, A, b, C, l, u, lb, ub, JcT) arrays (:meth:`InverseDynamicsQP._new_kernel`)."""

    def __init__(self, qp: InverseDynamicsQP, rows: _ProblemRows, blocks: tuple[np.ndarray, ...]):
        nv, n, nc = qp.nv, qp.n, len(qp.contacts)
        tl = qp.torque_limits
        jl = qp.joint_acceleration_limits
        self.par = np.array([qp.eps_a, jl.braking_acceleration, float(qp.joint_limits), 100.0,
                             DEPENDENT_CONTACT_RATIO, jl.speed_horizon, 0.0])
        p = blocks[4].shape[0]  # C (p, n): the inequality rows
        buffers = id_tick_buffers(n, nv, p, nc, jl.dim, blocks[2].shape[0])  # A (me, n): room for every equality row
        self.state, self.rstate = buffers[0][:n], buffers[0][n:]  # the working set, views of the kernel's buffer
        self.residual, self.tau, self.wrench, self.x = tick_outputs(buffers[-1], nv, nc)
        idx = np.concatenate([tl.velocity_indices, jl.iq, jl.iv]).astype(np.int64)
        # id_tick's arguments after the tick's rows and dynamics: (IDLimits, IDArrays, IDTickBuffers)
        self.tail = (IDLimits(idx, tl.limits.copy(), self.par, jl.qmin, jl.qmax, jl.vmax), IDArrays(*blocks),
                     IDTickBuffers(*buffers))
        self.solves = 0
        self.fallbacks = 0
        self.rejected = 0
        #: the last call did not end in a solution: the next one is capped at KERNEL_ITERATIONS_AFTER_GIVE_UP
        self.gave_up = False
        self._load_kernel(qp, rows)

    def _load_kernel(self, qp: InverseDynamicsQP, rows: _ProblemRows) -> None:
        """Load :func:`~wbc.formulations.idkernel.id_tick` here, at construction, not inside the first tick: once per
        process, one call on these buffers at a neutral state (M = I in the column-major order of a
        :class:`~wbc.state.DynamicsState`'s M, h = 0, v = 0, no contact active), every buffer it writes
        restored afterwards (the first tick starts exactly as without this call)."""
        global _ID_TICK_LOADED
        if _ID_TICK_LOADED:
            return
        if rows.layout is None:
            rows.relayout(qp)
        nv = qp.nv
        arrays = [a for a in (*rows.tasks, *rows.contacts, *(x for t in self.tail for x in t))
                  if isinstance(a, np.ndarray)]
        saved = [a.copy() for a in arrays]
        try:
            id_tick(rows.tasks, IDDynamics(np.asfortranarray(np.eye(nv)), np.zeros(nv), qp.robot.q_ref.copy(),
                                           np.zeros(nv), 0.002), rows.contacts, *self.tail)
            _ID_TICK_LOADED = True
        finally:
            for a, a0 in zip(arrays, saved):
                np.copyto(a, a0)
