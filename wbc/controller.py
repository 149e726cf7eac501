"""Kinematic (velocity-level) QP whole-body controller.

The optimisation problem, solved once per control tick of period dt (s), with v ∈ R^nv the generalized
velocity (floating base included):

    min_v   Σ_i ‖ diag(√w_i) (J_i v − v*_i) ‖²  +  ε ‖v‖²                     (weighted tasks)
    s.t.    A_k v = b_k                       for each equality constraint k  (e.g. stance feet: J_c v = −K_c e_c)
            l_k ≤ C_k v ≤ u_k                 for each inequality constraint k
            lb ≤ v ≤ ub                       (intersection of all bound constraints: joint position and velocity
                                               limits over dt)

Equality rows that are (numerically) linearly dependent on others are dropped before the solve and their
residual is checked after it (≤ ``dependent_row_tolerance``). Example: a leg whose hip-roll → hip-pitch →
knee → ankle-pitch → ankle-roll chain is in gimbal lock when the sole is flat cannot change the foot's yaw
relative to the pelvis, so two flat stance feet fix the base yaw twice. The independent set is chosen by QR
with column pivoting of Aᵀ (numerical rank: |R_ii| > ``rank_rtol`` · |R_00|), once per change of the
constraint set, and again after a failed tick.

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
import scipy.linalg

from wbc.configuration import Configuration
from wbc.constraints.base import BoxConstraint, Constraint, EqualityConstraint, InequalityConstraint
from wbc.exceptions import InvalidInputError, SolverError
from wbc.qp import DEFAULT_SOLVER, QPBackend, make_backend
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
        solver: QP backend name (default ``wbc.qp.DEFAULT_SOLVER``, DAQP: an active-set method, so bounds hold
            exactly) or a :class:`~wbc.qp.QPBackend`.
        damping: ε, weight of ‖v‖² (s²·task units), > 0.
        rank_rtol: relative tolerance of the numerical rank of the equality rows.
        dependent_row_tolerance: largest residual accepted on a dropped equality row (its units: m/s, rad/s).

    Raises:
        UnknownSolverError: unknown backend name.
        InvalidInputError: damping ≤ 0, or an object that is not a Task/Constraint.
    """

    def __init__(self, robot: Robot, tasks: list[Task] = (), constraints: list[Constraint] = (), *,
                 solver: str | QPBackend = DEFAULT_SOLVER, damping: float = 1e-6, rank_rtol: float = 1e-3,
                 dependent_row_tolerance: float = 1e-3):
        if not (np.isfinite(damping) and damping > 0):
            raise InvalidInputError(f"damping must be finite and > 0, got {damping!r}")
        self.robot = robot
        self.nv = robot.model.nv
        self.damping = float(damping)
        self.rank_rtol = float(rank_rtol)
        self.dependent_row_tolerance = float(dependent_row_tolerance)
        self.backend = make_backend(solver) if isinstance(solver, str) else solver
        self.tasks: list[Task] = []
        self.constraints: list[Constraint] = []
        self._layout_ok = False
        self._eq_rows: np.ndarray | None = None
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
        self._eq_rows = None
        self._layout_ok = False
        return constraint

    def remove_constraint(self, constraint: Constraint) -> None:
        self.constraints.remove(constraint)
        self._eq_rows = None
        self._layout_ok = False

    @staticmethod
    def independent_rows(A: np.ndarray, rtol: float = 1e-3) -> np.ndarray:
        """Indices of a maximal linearly independent subset of the rows of A (QR with pivoting of Aᵀ)."""
        if A.shape[0] == 0:
            return np.zeros(0, dtype=int)
        _, R, piv = scipy.linalg.qr(A.T, mode="economic", pivoting=True)
        diag = np.abs(np.diag(R))
        rank = int(np.sum(diag > rtol * max(diag[0], 1.0)))
        return np.sort(piv[:rank])

    # -- assembly -------------------------------------------------------------------------------------------
    def _build_layout(self) -> None:
        """Row layout of the equality and inequality blocks and their buffers (redone when constraints change)."""
        eq = [c for c in self.constraints if isinstance(c, EqualityConstraint)]
        ineq = [c for c in self.constraints if isinstance(c, InequalityConstraint)]
        self._box = [c for c in self.constraints if isinstance(c, BoxConstraint)]
        self._eq_blocks, self._in_blocks = [], []
        row = 0
        for c in eq:
            self._eq_blocks.append((c, row, row + c.dim))
            row += c.dim
        self._A = np.zeros((row, self.nv))
        self._b = np.zeros(row)
        row = 0
        for c in ineq:
            self._in_blocks.append((c, row, row + c.dim))
            row += c.dim
        self._C = np.zeros((row, self.nv))
        self._l = np.zeros(row)
        self._u = np.zeros(row)
        self._lb = np.empty(self.nv)
        self._ub = np.empty(self.nv)
        self._layout_ok = True

    def assemble(self, config: Configuration, dt: float):
        """Build (H, g, A, b, C, l, u, lb, ub) of the QP at ``config`` (module docstring).

        The arrays are buffers owned by the controller, overwritten at the next call.
        """
        if not self._layout_ok:
            self._build_layout()
        H, g = self._H, self._g
        np.copyto(H, self._eye)
        g.fill(0.0)
        for task in self.tasks:
            task.add_cost(config, H, g)
        A, b = self._A, self._b
        for c, r0, r1 in self._eq_blocks:
            A[r0:r1], b[r0:r1] = c.compute(config, dt)
        C, l, u = self._C, self._l, self._u
        for c, r0, r1 in self._in_blocks:
            C[r0:r1], l[r0:r1], u[r0:r1] = c.compute(config, dt)
        lb, ub = self._lb, self._ub
        lb.fill(-np.inf)
        ub.fill(np.inf)
        for c in self._box:
            lo, hi = c.compute(config, dt)
            idx = c.indices
            lb[idx] = np.maximum(lb[idx], lo)
            ub[idx] = np.minimum(ub[idx], hi)
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
        H, g, A, b, C, l, u, lb, ub = self.assemble(config, dt)
        if self._eq_rows is None:
            self._eq_rows = self.independent_rows(A, self.rank_rtol)
        full_rank = self._eq_rows.size == A.shape[0]
        A_kept, b_kept = (A, b) if full_rank else (A[self._eq_rows], b[self._eq_rows])
        t1 = perf_counter()
        try:
            v = self.backend.solve(H, g, A_kept, b_kept, C, l, u, lb, ub)
            if not full_rank:
                residual = float(np.max(np.abs(A @ v - b)))
                if residual > self.dependent_row_tolerance:
                    raise SolverError(f"dependent equality rows violated by {residual:.3g} after the solve")
            result = TickResult(v)
        except SolverError as exc:
            self._eq_rows = None  # the rank may have changed: recompute next tick
            result = TickResult(np.zeros(self.nv), ok=False, message=str(exc))
        t2 = perf_counter()
        result.timings = {"assembly": t1 - t0, "solve": t2 - t1}
        self.last_result = result
        return result
