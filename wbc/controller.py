"""Kinematic (velocity-level) QP whole-body controller.

The optimisation problem, solved once per control tick of period dt (s), with v ∈ R^nv the generalized
velocity (floating base included):

    min_v   Σ_i ‖ diag(√w_i) (J_i v − v*_i) ‖²  +  ε ‖v‖²                     (weighted tasks)
    s.t.    A_k v = b_k                       for each equality constraint k  (e.g. stance feet: J_c v = −K_c e_c)
            l_k ≤ C_k v ≤ u_k                 for each inequality constraint k
            lb ≤ v ≤ ub                       (intersection of all bound constraints: joint position and velocity
                                               limits over dt)

with, for each task i: error e_i(q), Jacobian J_i = ∂e_i/∂q, gain K_i (1/s), feed-forward ė*_i, and
v*_i = ė*_i − K_i e_i. ε (``damping``) keeps H positive definite. The next configuration is
q⁺ = pin.integrate(q, v dt).

When the QP cannot be solved, the tick does not raise: the command falls back to v = 0 (hold the current
posture), ``last_result.ok`` is False and the reason is recorded.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from time import perf_counter

import numpy as np

from wbc.configuration import Configuration
from wbc.constraints.base import BoxConstraint, Constraint, EqualityConstraint, InequalityConstraint
from wbc.exceptions import InvalidInputError, SolverError
from wbc.qp import QPBackend, make_backend
from wbc.robot import Robot
from wbc.tasks.base import Task

__all__ = ["KinematicController", "TickResult"]


@dataclass
class TickResult:
    """Outcome of one control tick.

    Attributes:
        v: (nv,) commanded generalized velocity (zero when the solve failed).
        ok: the QP was solved.
        message: failure reason ('' when ok).
        timings: seconds spent in 'assembly' (tasks + constraints) and 'solve'.
    """

    v: np.ndarray
    ok: bool = True
    message: str = ""
    timings: dict[str, float] = field(default_factory=dict)


class KinematicController:
    """Velocity-level whole-body QP (see module docstring).

    Args:
        robot: the robot.
        tasks: weighted tasks (order irrelevant).
        constraints: equality, inequality and bound constraints.
        solver: QP backend name (``proxqp`` default: warm-started, holds bounds to 1e-9) or a
            :class:`~wbc.qp.QPBackend`.
        damping: ε, weight of ‖v‖² (s²·task units), > 0.

    Raises:
        UnknownSolverError: unknown backend name.
        InvalidInputError: damping ≤ 0, or an object that is not a Task/Constraint.
    """

    def __init__(self, robot: Robot, tasks: list[Task] = (), constraints: list[Constraint] = (), *,
                 solver: str | QPBackend = "proxqp", damping: float = 1e-6):
        if not (np.isfinite(damping) and damping > 0):
            raise InvalidInputError(f"damping must be finite and > 0, got {damping!r}")
        self.robot = robot
        self.nv = robot.model.nv
        self.damping = float(damping)
        self.backend = make_backend(solver) if isinstance(solver, str) else solver
        self.tasks: list[Task] = []
        self.constraints: list[Constraint] = []
        for t in tasks:
            self.add_task(t)
        for c in constraints:
            self.add_constraint(c)
        self.last_result = TickResult(np.zeros(self.nv))
        self._H = np.empty((self.nv, self.nv))
        self._g = np.empty(self.nv)
        self._eye = np.eye(self.nv) * self.damping

    # -- problem definition -------------------------------------------------------------------------------
    def add_task(self, task: Task) -> Task:
        if not isinstance(task, Task):
            raise InvalidInputError(f"expected a wbc Task, got {type(task).__name__}")
        self.tasks.append(task)
        return task

    def remove_task(self, task: Task) -> None:
        self.tasks.remove(task)

    def add_constraint(self, constraint: Constraint) -> Constraint:
        if not isinstance(constraint, (EqualityConstraint, InequalityConstraint, BoxConstraint)):
            raise InvalidInputError(f"expected a wbc Constraint, got {type(constraint).__name__}")
        self.constraints.append(constraint)
        return constraint

    def remove_constraint(self, constraint: Constraint) -> None:
        self.constraints.remove(constraint)

    # -- assembly -------------------------------------------------------------------------------------------
    def assemble(self, config: Configuration, dt: float):
        """Build (H, g, A, b, C, l, u, lb, ub) of the QP at ``config`` (module docstring)."""
        H, g = self._H, self._g
        np.copyto(H, self._eye)
        g.fill(0.0)
        for task in self.tasks:
            error, jac = task.compute(config)
            target = task.velocity_target(error)
            wj = jac * task.weight[:, None]
            H += jac.T @ wj
            g -= wj.T @ target
        eq_A, eq_b, in_C, in_l, in_u = [], [], [], [], []
        lb = np.full(self.nv, -np.inf)
        ub = np.full(self.nv, np.inf)
        for c in self.constraints:
            if isinstance(c, EqualityConstraint):
                A, b = c.compute(config, dt)
                eq_A.append(A)
                eq_b.append(b)
            elif isinstance(c, InequalityConstraint):
                C, l, u = c.compute(config, dt)
                in_C.append(C)
                in_l.append(l)
                in_u.append(u)
            else:
                lo, hi = c.compute(config, dt)
                idx = c.indices
                lb[idx] = np.maximum(lb[idx], lo)
                ub[idx] = np.minimum(ub[idx], hi)
        A = np.vstack(eq_A) if eq_A else np.zeros((0, self.nv))
        b = np.concatenate(eq_b) if eq_b else np.zeros(0)
        C = np.vstack(in_C) if in_C else np.zeros((0, self.nv))
        l = np.concatenate(in_l) if in_l else np.zeros(0)
        u = np.concatenate(in_u) if in_u else np.zeros(0)
        return H, g, A, b, C, l, u, lb, ub

    # -- one tick -------------------------------------------------------------------------------------------
    def solve(self, config: Configuration, dt: float) -> TickResult:
        """Solve one tick at ``config`` with control period ``dt`` (s).

        Returns:
            :class:`TickResult`; on failure ``v`` is zero (hold posture) and ``ok`` is False.

        Raises:
            InvalidInputError: dt not finite and > 0.
        """
        if not (np.isfinite(dt) and dt > 0):
            raise InvalidInputError(f"dt must be finite and > 0 (s), got {dt!r}")
        t0 = perf_counter()
        problem = self.assemble(config, dt)
        t1 = perf_counter()
        try:
            v = self.backend.solve(*problem)
            result = TickResult(v)
        except SolverError as exc:
            result = TickResult(np.zeros(self.nv), ok=False, message=str(exc))
        t2 = perf_counter()
        result.timings = {"assembly": t1 - t0, "solve": t2 - t1}
        self.last_result = result
        return result
