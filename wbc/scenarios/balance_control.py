"""Building blocks of the balance behaviours: minimum-jerk references, the support polygon, a joint-trajectory
task and :class:`BalanceController` (the kinematic QP wired for standing balance).

See :mod:`wbc.scenarios.balance` for the runner, the run record and the summary.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from wbc.configuration import Configuration
from wbc.constraints import ComPolygonConstraint, ContactConstraint, JointPositionLimit, JointVelocityLimit
from wbc.controller import KinematicController, TickResult
from wbc.exceptions import InvalidInputError
from wbc.gait.support import convex_hull, sole_polygon
from wbc.qp import DEFAULT_SOLVER
from wbc.robot import Robot
from wbc.tasks import ComTask, FrameTask, OrientationTask, PostureTask

__all__ = [
    "DOUBLE", "LEFT_STANCE", "RIGHT_STANCE", "BalanceController", "JointTrackingTask", "MinJerkPath", "min_jerk",
    "support_polygon",
]

DOUBLE, LEFT_STANCE, RIGHT_STANCE = 0, 1, 2


# -- reference profiles ---------------------------------------------------------------------------------------
def min_jerk(t: float, t0: float, duration: float) -> tuple[float, float]:
    """Minimum-jerk ramp s(t) from 0 to 1 over [t0, t0 + duration] (Flash & Hogan 1985) and ds/dt (1/s).

    s = 10τ³ − 15τ⁴ + 6τ⁵ with τ = (t − t0)/duration clipped to [0, 1]: zero velocity and acceleration at both ends.
    """
    if duration <= 0:
        return (1.0 if t >= t0 else 0.0), 0.0
    tau = (t - t0) / duration
    if tau <= 0.0:
        return 0.0, 0.0
    if tau >= 1.0:
        return 1.0, 0.0
    t2 = tau * tau
    return t2 * tau * (10.0 - 15.0 * tau + 6.0 * t2), 30.0 * t2 * (1.0 - 2.0 * tau + t2) / duration


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
                s, ds = min_jerk(t, t0, move)
                return a + s * (b - a), ds * (b - a)
        return self.start.copy(), np.zeros_like(self.start)


# -- support polygon --------------------------------------------------------------------------------------------
def _yaw(pose) -> float:
    m = pose.homogeneous if isinstance(pose, pin.SE3) else np.asarray(pose)
    return math.atan2(m[1, 0], m[0, 0])


def support_polygon(robot: Robot, soles) -> np.ndarray:
    """(k, 2) CCW support polygon (m, world xy) of the given sole placements (pin.SE3 or (4, 4), world):
    the sole rectangle for one sole, the convex hull of the rectangles for several."""
    polys = []
    for pose in soles:
        m = pose.homogeneous if isinstance(pose, pin.SE3) else np.asarray(pose)
        polys.append(sole_polygon(m[0, 3], m[1, 3], _yaw(m), robot.sole_length, robot.sole_width))
    return polys[0] if len(polys) == 1 else convex_hull(np.vstack(polys))


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


class BalanceController:
    """The kinematic QP wired for standing balance: CoM, torso orientation and posture tasks; stance soles as
    hard contacts, swing soles as frame tasks; CoM-in-support-polygon, joint position and velocity limits.

    Args:
        robot: the robot.
        config: current configuration (contacts start at the current sole placements, torso target = current).
        solver: QP backend name.
        polygon_margin: margin (m) of the CoM polygon constraint.
        com_gain, foot_gain, torso_gain, posture_gain: task gains K (1/s).
        rank_rtol: numerical-rank tolerance of the equality rows (``KinematicController``). 1e-4 rather than
            the controller's 1e-3: reaching, humanoid15's sole-yaw rows become independent with
            σ_min/σ_max ≈ 9e-4 (hip roll ≈ 0.34 rad), and dropping such a row lets that sole yaw.
    """

    def __init__(self, robot: Robot, config: Configuration, *, solver: str = DEFAULT_SOLVER,
                 polygon_margin: float = 0.01, com_gain: float = 100.0, foot_gain: float = 100.0,
                 torso_gain: float = 50.0, posture_gain: float = 2.0,
                 rank_rtol: float = 1e-4):
        self.robot = robot
        self.com = ComTask(weight=10.0, gain=com_gain)
        self.com.set_target(config.com.copy())
        self.torso = OrientationTask(robot, robot.torso, weight=1.0, gain=torso_gain, name="torso")
        self.torso.set_target_from_configuration(config)
        self.posture = PostureTask(robot, weight=1e-2, gain=posture_gain)
        self.posture.set_target(config.q)
        self.swing = {
            side: FrameTask(robot, frame, position_weight=10.0, orientation_weight=10.0, gain=foot_gain,
                            name=f"swing:{side}")
            for side, frame in (("left", robot.left_sole), ("right", robot.right_sole))
        }
        self.contact = {
            side: ContactConstraint(robot, frame, gain=foot_gain)
            for side, frame in (("left", robot.left_sole), ("right", robot.right_sole))
        }
        for c in self.contact.values():
            c.set_placement_from_configuration(config)
        self.com_polygon = ComPolygonConstraint(robot, margin=polygon_margin)
        self.controller = KinematicController(
            robot, [self.com, self.torso, self.posture],
            [self.contact["left"], self.contact["right"], self.com_polygon, JointPositionLimit(robot),
             JointVelocityLimit(robot)],
            solver=solver, rank_rtol=rank_rtol,
        )
        self.stance = {"left": True, "right": True}
        self.support = DOUBLE
        self._update_polygon()

    def solve(self, config: Configuration, dt: float) -> TickResult:
        """One QP tick (``KinematicController.solve``)."""
        return self.controller.solve(config, dt)

    def _update_polygon(self) -> None:
        self.com_polygon.set_support([self.contact[s].placement for s in ("left", "right") if self.stance[s]])

    def set_support(self, support: int, config: Configuration) -> None:
        """Switch to a support phase (0 double, 1 left stance, 2 right stance). A sole that lifts off gets a swing
        task whose target is its current placement (zero velocity); one that touches down is held where it is."""
        if support == self.support:
            return
        wanted = {"left": support in (DOUBLE, LEFT_STANCE), "right": support in (DOUBLE, RIGHT_STANCE)}
        for side in ("left", "right"):
            if wanted[side] == self.stance[side]:
                continue
            if wanted[side]:  # touch-down
                self.controller.remove_task(self.swing[side])
                self.contact[side].set_placement_from_configuration(config)
                self.controller.add_constraint(self.contact[side])
            else:  # lift-off
                self.controller.remove_constraint(self.contact[side])
                self.swing[side].set_target_from_configuration(config)
                self.controller.add_task(self.swing[side])
            self.stance[side] = wanted[side]
        self.support = support
        self._update_polygon()

    def has_task(self, task) -> bool:
        return any(t is task for t in self.controller.tasks)
