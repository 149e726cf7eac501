"""``reach``: one hand reaches for a point 0.6 m in front of the chest, as far as balance and joint limits allow.

Target: the torso frame origin (``robot.torso``; the chest) + ``distance`` along the robot's forward axis (the
mean heading of the two soles, horizontal), at the torso origin's height. The hand (``robot.right_hand`` or
``left_hand``) position target moves there from the hand's start position by minimum jerk in ``move`` seconds and
stays there ``hold`` seconds.

Feet are fixed; there is no CoM task: the hand task (weight ``hand_weight``) pulls the whole body forward, and
only the hard constraints stop it — the CoM ground projection inside the support polygon shrunk by
``polygon_margin`` ("as far as balance allows") and the joint limits. The torso orientation task is weak
(``torso_weight``) so the robot can bend; posture stays as the low-weight regulariser.

Summary: ``reach_residual_m`` (hand-to-target distance at the end), ``reach_initial_distance_m``,
``reach_limited_by`` (which hard limits are active at the end: "balance" when the CoM margin is within 1 mm of
the constraint's margin, "joint_limits: …" for joints within 1e-3 rad of a limit; empty when the hand is on
target). Acceptance: the hand reaches the target (residual ≤ 5 mm) or is stopped by an active hard limit, and
it got closer than it started.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from wbc.configuration import Configuration
from wbc.exceptions import InvalidInputError
from wbc.robot import Robot
from wbc.scenarios.framework import Criterion
from wbc.scenarios.balance import Behaviour, BalanceController, BalanceRun, MinJerkPath, side_option
from wbc.tasks import PositionTask

__all__ = ["ReachBehaviour"]


class ReachBehaviour(Behaviour):
    """Reach forward with one hand.

    Args:
        robot, config: see :class:`~wbc.scenarios.balance.Behaviour`.
        hand: "right" or "left".
        distance: target distance (m) in front of the torso origin.
        move, hold: durations (s) of the target's motion and of the final hold.
        hand_weight, torso_weight: task weights.
        polygon_margin: margin (m) of the CoM polygon constraint.
        tolerance: residual (m) below which the hand counts as on target.

    Raises:
        InvalidInputError: bad hand, the robot has no such hand frame, or non-positive durations.
    """

    name = "reach"

    def __init__(self, robot: Robot, config: Configuration, *, hand: str = "right", distance: float = 0.6,
                 move: float = 3.0, hold: float = 2.0, hand_weight: float = 10.0, torso_weight: float = 0.1,
                 polygon_margin: float = 0.01, tolerance: float = 0.005):
        super().__init__(robot, config)
        side_option(hand, "hand")
        frame = robot.right_hand if hand == "right" else robot.left_hand
        if frame is None:
            raise InvalidInputError(f"robot {robot.name!r} has no {hand} hand frame")
        if move <= 0 or hold < 0:
            raise InvalidInputError("reach move time must be > 0 and hold ≥ 0")
        self.hand, self.frame = hand, frame
        self.hand_weight, self.torso_weight = hand_weight, torso_weight
        self.polygon_margin, self.tolerance = float(polygon_margin), float(tolerance)
        yaw_l = math.atan2(self.left0.rotation[1, 0], self.left0.rotation[0, 0])
        yaw_r = math.atan2(self.right0.rotation[1, 0], self.right0.rotation[0, 0])
        yaw = math.atan2(math.sin(yaw_l) + math.sin(yaw_r), math.cos(yaw_l) + math.cos(yaw_r))
        self.forward = np.array([math.cos(yaw), math.sin(yaw), 0.0])
        chest = config.data.oMf[robot.frame_id(robot.torso)].translation
        self.target = chest + distance * self.forward
        self.hand0 = config.data.oMf[robot.frame_id(frame)].translation.copy()
        self.path = MinJerkPath(self.hand0, [(move, hold, self.target)])
        self.duration = self.path.end_time
        self.task: PositionTask | None = None
        self._vel = np.zeros(6)

    def setup(self, ctrl: BalanceController) -> None:
        self.task = PositionTask(self.robot, self.frame, weight=self.hand_weight, gain=50.0, name=f"hand:{self.hand}")
        ctrl.controller.remove_task(ctrl.com)
        ctrl.torso.weight = self.torso_weight
        ctrl.controller.add_task(self.task)

    def update(self, ctrl: BalanceController, t: float, config: Configuration) -> None:
        p, dp = self.path(t)
        self._vel[:3] = dp
        self.task.set_target(pin.SE3(np.eye(3), p), self._vel)

    def summary(self, run: BalanceRun) -> dict:
        model = self.robot.model
        data = model.createData()
        pin.framesForwardKinematics(model, data, run.q[-1])
        hand = data.oMf[self.robot.frame_id(self.frame)].translation
        at_limit = []  # joints that ended within 1e-3 rad of a limit they did not start on (Talos's grippers do)
        for jid in range(2, model.njoints):
            j = model.joints[jid]
            if j.nq != 1:
                continue
            lo, hi = model.lowerPositionLimit[j.idx_q], model.upperPositionLimit[j.idx_q]
            q0, q1 = run.q[0, j.idx_q], run.q[-1, j.idx_q]
            if min(q1 - lo, hi - q1) <= 1e-3 < min(q0 - lo, hi - q0):
                at_limit.append(model.names[jid])
        residual = float(np.linalg.norm(hand - self.target))
        limited = []
        if run.com_margin[-1] <= self.polygon_margin + 1e-3:
            limited.append("balance")
        if at_limit:
            limited.append("joint_limits: " + ", ".join(at_limit))
        return {
            "hand": self.hand,
            "reach_target_m": self.target.tolist(),
            "reach_initial_distance_m": float(np.linalg.norm(self.hand0 - self.target)),
            "reach_residual_m": residual,
            "reach_forward_m": float((hand - self.hand0) @ self.forward),
            "final_com_margin_m": float(run.com_margin[-1]),
            "reach_limited_by": limited,
        }

    def overlays(self, run: BalanceRun) -> dict[str, np.ndarray]:
        return {"target": np.tile(self.target, (len(run.t), 1))}

    def criteria(self):
        tol = self.tolerance
        return [
            Criterion("hand on target, or stopped by balance / joint limits", "reach_residual_m", "<=", tol,
                      either=(Criterion("stopped by balance / joint limits", "reach_limited_by", ">", 0,
                                        reduce="len"),)),
            Criterion("hand closer to the target than at the start", "reach_residual_m", "<", 1.0,
                      scale_by="reach_initial_distance_m"),
        ]
