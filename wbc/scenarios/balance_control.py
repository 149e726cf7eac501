"""Building blocks of the balance behaviours: minimum-jerk references, the support polygon, a joint-trajectory
task and :class:`BalanceController` (the kinematic QP wired for standing balance).

See :mod:`wbc.scenarios.balance` for the runner, the run record and the summary.
"""

from __future__ import annotations

import numpy as np

from wbc.configuration import Configuration
from wbc.constants import SIDES
from wbc.constraints.zmp import DcmPolygonConstraint
from wbc.exceptions import InvalidInputError
from wbc.profiles import min_jerk_ramp
from wbc.solvers import DEFAULT_SOLVER
from wbc.robot import Robot
from wbc.scenarios.stance import DOUBLE, LEFT_STANCE, RIGHT_STANCE, StanceController
from wbc.tasks import PostureTask

__all__ = [
    "DOUBLE", "LEFT_STANCE", "RIGHT_STANCE", "BalanceController", "JointTrackingTask", "MinJerkPath",
    "min_jerk_ramp",
]



# -- reference profiles ---------------------------------------------------------------------------------------
class MinJerkPath:
    """Piecewise minimum-jerk path through waypoints, with holds.

    Args:
        start: (d,) initial value.
        segments: ``(move_s, hold_s, target (d,))`` in order: move from the previous value to ``target`` in
            ``move_s`` seconds, then hold it ``hold_s`` seconds.
        t0: start time (s).

    Raises:
        InvalidInputError: negative durations or mismatched shapes.
    """

    def __init__(self, start, segments, t0: float = 0.0):
        self.start = np.asarray(start, dtype=float).copy()
        self._segs = []
        t, prev = float(t0), self.start
        for move, hold, target in segments:
            target = np.asarray(target, dtype=float)
            if move < 0 or hold < 0 or target.shape != prev.shape:
                raise InvalidInputError(f"bad min-jerk segment (move {move}, hold {hold}, target {target.shape})")
            self._segs.append((t, float(move), prev, target))
            t += move + hold
            prev = target
        self.end_time = t
        self.end = prev

    def __call__(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(value (d,), rate (d,)) at time t (s)."""
        for t0, move, a, b in reversed(self._segs):
            if t >= t0:
                s, ds = min_jerk_ramp(t, t0, move)
                return a + s * (b - a), ds * (b - a)
        return self.start.copy(), np.zeros_like(self.start)


# -- controller wiring ------------------------------------------------------------------------------------------
class JointTrackingTask(PostureTask):
    """:class:`~wbc.tasks.PostureTask` on some joints with a joint-velocity feed-forward (rad/s), to track a
    joint trajectory: v*_j = q̇*_j − K (q_j − q*_j)."""

    def __init__(self, robot, *, joints, weight=1.0, gain: float = 50.0, name: str | None = None):
        super().__init__(robot, joints=joints, weight=weight, gain=gain, name=name)
        self._ff: np.ndarray | None = None

    def set_trajectory(self, q, dq) -> None:
        """Target configuration (nq,) and joint velocity (nv,) (only the tracked joints matter)."""
        self.set_target(q)
        self._ff = np.asarray(dq, dtype=float)[self.rows].copy()

    def feedforward(self) -> np.ndarray | None:
        return self._ff


class BalanceController(StanceController):
    """:class:`~wbc.scenarios.stance.StanceController` for standing balance, plus the CoM-in-support-polygon
    constraint, updated at every support switch.

    Args:
        robot: the robot.
        config: current configuration (contacts start at the current sole placements, torso target = current).
        solver: QP backend name.
        polygon_margin: margin (m) of the CoM polygon constraint.
        com_gain, foot_gain, torso_gain, posture_gain: task gains K (1/s).
        rank_rtol: numerical-rank tolerance of the equality rows (``KinematicController``). 1e-4 rather than
            the controller's 1e-3: reaching, humanoid15's sole-yaw rows become independent with
            σ_min/σ_max ≈ 9e-4 (hip roll ≈ 0.34 rad), and dropping such a row lets that sole yaw.
        joint_acceleration: a_max (rad/s²) of the joint acceleration and braking limits (relaxable, before the
            executed-ZMP constraint: :meth:`~wbc.scenarios.stance.StanceController.solve`; None: none, the
            default; the catalog runs with and without them are in ``benchmarks/README.md``).
    """

    def __init__(self, robot: Robot, config: Configuration, *, solver: str = DEFAULT_SOLVER,
                 polygon_margin: float = 0.01, com_gain: float = 100.0, foot_gain: float = 100.0,
                 torso_gain: float = 50.0, posture_gain: float = 2.0,
                 rank_rtol: float = 1e-4, joint_acceleration: float | None = None):
        self.com_polygon = DcmPolygonConstraint(robot, margin=polygon_margin)
        super().__init__(robot, config, solver=solver, com_gain=com_gain, foot_gain=foot_gain,
                         torso_gain=torso_gain, posture_gain=posture_gain, extra_constraints=(self.com_polygon,),
                         rank_rtol=rank_rtol, joint_acceleration=joint_acceleration)
        self.support_changed()

    def support_changed(self) -> None:
        """The CoM polygon follows the soles in contact."""
        self.com_polygon.set_support([self.contact[s].placement for s in SIDES if self.stance[s]])

    def has_task(self, task) -> bool:
        """True if ``task`` is currently in the controller's weighted level."""
        return any(t is task for t in self.controller.tasks)
