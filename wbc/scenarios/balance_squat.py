"""``squat`` behaviour: the CoM goes down ``depth`` (15 cm) and back up, ``repetitions`` (3) times.

Feet fixed, CoM ground projection and torso orientation held; the CoM height follows minimum-jerk moves (down,
hold, up, hold). The depth is measured on the **CoM** (as the issue states it: "CoM down 15 cm"): for each
repetition, the start CoM height minus the lowest CoM height reached during it. Acceptance: every repetition's
depth within ``tolerance`` of ``depth``, and the CoM back at its start height (within ``tolerance``) at the end.
"""

from __future__ import annotations

import numpy as np

from wbc.configuration import Configuration
from wbc.exceptions import InvalidInputError
from wbc.robot import Robot
from wbc.scenarios.framework import Criterion
from wbc.scenarios.balance import Behaviour, BalanceController, BalanceRun, MinJerkPath

__all__ = ["SquatBehaviour"]


class SquatBehaviour(Behaviour):
    """Squat ``repetitions`` times.

    Args:
        robot, config: see :class:`~wbc.scenarios.balance.Behaviour`.
        depth: CoM drop (m).
        repetitions: number of squats.
        move: duration (s) of each descent and ascent.
        hold: pause (s) at the bottom and at the top.
        tolerance: accepted |measured depth − depth| (m).

    Raises:
        InvalidInputError: non-positive depth, repetitions or durations.
    """

    name = "squat"

    def __init__(self, robot: Robot, config: Configuration, *, depth: float = 0.15, repetitions: int = 3,
                 move: float = 1.25, hold: float = 0.25, tolerance: float = 0.005):
        super().__init__(robot, config)
        if depth <= 0 or repetitions < 1 or move <= 0 or hold < 0:
            raise InvalidInputError("squat depth, repetitions and move time must be > 0, hold ≥ 0")
        self.depth, self.repetitions, self.tolerance = float(depth), int(repetitions), float(tolerance)
        low = self.com0 - np.array([0.0, 0.0, depth])
        segs = []
        for _ in range(self.repetitions):
            segs += [(move, hold, low), (move, hold, self.com0)]
        self.path = MinJerkPath(self.com0, segs)
        self.cycle = 2 * (move + hold)
        self.duration = self.path.end_time

    def update(self, ctrl: BalanceController, t: float, config: Configuration) -> None:
        com, vel = self.path(t)
        ctrl.com.set_target(com, vel)

    def summary(self, run: BalanceRun) -> dict:
        z0 = self.com0[2]
        depths = []
        for i in range(self.repetitions):
            sel = (run.t >= i * self.cycle) & (run.t < (i + 1) * self.cycle)
            depths.append(float(z0 - run.com[sel, 2].min()))
        return {
            "squat_depth_m": float(max(depths)),
            "squat_depths_m": depths,
            "final_height_error_m": float(abs(run.com[-1, 2] - z0)),
            "squat_depth_measured_on": "com",
        }

    def criteria(self):
        d, tol, n = self.depth, self.tolerance, self.repetitions
        return [
            Criterion(f"{n} squats (CoM)", "squat_depths_m", "==", n, reduce="len"),
            Criterion(f"each squat {d * 100:g} cm ± {tol * 1e3:g} mm deep (CoM)", "squat_depths_m", "<=", tol, minus=d,
                      reduce="max"),
            Criterion(f"CoM back up within {tol * 1e3:g} mm", "final_height_error_m", "<=", tol),
        ]
