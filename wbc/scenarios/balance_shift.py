"""``shift`` behaviour: CoM over the left sole centre, then over the right one, then back to the start.

Feet fixed (double support throughout). The CoM ground projection follows minimum-jerk moves between the sole
centres (its height and the torso orientation are held), each followed by a hold. Acceptance: the CoM is within
``tolerance`` (m) of each target at the end of its hold.
"""

from __future__ import annotations

import numpy as np

from wbc.configuration import Configuration
from wbc.robot import Robot
from wbc.scenarios.framework import Criterion
from wbc.scenarios.balance import Behaviour, BalanceController, BalanceRun, MinJerkPath

__all__ = ["ShiftBehaviour"]


class ShiftBehaviour(Behaviour):
    """CoM xy: start → left sole centre → right sole centre → start.

    Args:
        robot, config: see :class:`~wbc.scenarios.balance.Behaviour`.
        move: duration (s) of a move between neighbouring targets (start ↔ sole); left → right takes 1.5×.
        hold: hold time (s) at each target.
        tolerance: largest accepted CoM xy distance (m) to a target at the end of its hold.
    """

    name = "shift"

    def __init__(self, robot: Robot, config: Configuration, *, move: float = 1.5, hold: float = 1.0,
                 tolerance: float = 0.005):
        super().__init__(robot, config)
        z = self.com0[2]
        self.targets = {
            "left": np.r_[self.left0.translation[:2], z],
            "right": np.r_[self.right0.translation[:2], z],
            "centre": self.com0.copy(),
        }
        segs = [(move, hold, self.targets["left"]), (1.5 * move, hold, self.targets["right"]),
                (move, hold, self.targets["centre"])]
        self.path = MinJerkPath(self.com0, segs)
        self.check_times = {}  # target name -> time (s) at the end of its hold
        t = 0.0
        for (m, h, _), name in zip(segs, ("left", "right", "centre")):
            t += m + h
            self.check_times[name] = t
        self.duration = self.path.end_time
        self.tolerance = tolerance

    def update(self, ctrl: BalanceController, t: float, config: Configuration) -> None:
        com, vel = self.path(t)
        ctrl.com.set_target(com, vel)

    def summary(self, run: BalanceRun) -> dict:
        errs = {}
        for name, tc in self.check_times.items():
            k = min(int(round(tc / run.dt)), len(run.t) - 1)
            errs[name] = float(np.linalg.norm(run.com[k, :2] - self.targets[name][:2]))
        return {"shift_target_error_m": errs,
                "shift_amplitude_m": float(np.max(np.abs(run.com[:, 1] - self.com0[1])))}

    def criteria(self):
        tol = self.tolerance
        return [Criterion(f"CoM over each target (≤ {tol * 1e3:g} mm) at the end of its hold", "shift_target_error_m",
                          "<=", tol, reduce="max")]
