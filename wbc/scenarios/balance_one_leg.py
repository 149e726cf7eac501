"""``one-leg`` behaviour: CoM over one sole, lift the other 10 cm, hold, put it back, CoM back to the centre.

Timeline (s): CoM ground projection moves (minimum jerk) to the stance sole centre (``shift``), settles
(``settle``); the swing sole lifts off and rises vertically by ``height`` (``lift``, minimum jerk, orientation
held), holds (``hold``), comes down on its lift-off placement (``lift``) and touches down; after ``settle`` the
CoM moves back to its start (``shift``) and holds (``settle``).

During single support the CoM polygon constraint uses the stance sole alone with a margin of
``stance_margin`` (m, default 12.5 mm): the issue's "≥ 0.01 m over the stance sole" then holds by construction
with 2.5 mm for the linearisation over one tick and tracking; the planned CoM sits on the sole centre anyway
(G1's sole is 5 cm wide, so it must stay within ±15 mm laterally).

CoM height over the stance sole: the start height is planned, but whatever height the robot reached at lift-off
(both soles down, CoM over the stance sole) is held in single support. The outer leg of a robot with wide-apart
feet can be fully stretched before the CoM reaches the stance sole at the start height (the shift then ends
lower); holding the start height in single support would leave the swing sole short of the floor at touch-down.

When the lift or its hold fails, the summary's ``swing_joints_at_limit`` names the swing leg's joints within
1e-3 rad of a position limit at the highest point of the lift (the measured reason a sole held level cannot rise
further, e.g. an ankle pitch range of −30°).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from wbc.configuration import Configuration
from wbc.exceptions import InvalidInputError
from wbc.robot import Robot
from wbc.scenarios.framework import Criterion
from wbc.scenarios.balance import (
    DOUBLE, LEFT_STANCE, RIGHT_STANCE, Behaviour, BalanceController, BalanceRun, MinJerkPath, side_option,
)
from wbc.geometry import signed_distance, support_polygon

__all__ = ["OneLegBehaviour"]


class OneLegBehaviour(Behaviour):
    """Stand on one leg.

    Args:
        robot, config: see :class:`~wbc.scenarios.balance.Behaviour`.
        stance: "left" or "right": the sole that stays on the ground.
        height: lift of the swing sole (m).
        hold: time (s) the swing sole is held up.
        shift, lift, settle: durations (s) of the CoM moves, of the swing sole's rise / descent, of the pauses.
        stance_margin: margin (m) of the CoM polygon constraint (whole run), ≥ the required 0.01 m.
        height_tolerance: accepted |lift height − height| (m).

    Raises:
        InvalidInputError: bad ``stance`` or non-positive height/durations.
    """

    name = "one-leg"

    def __init__(self, robot: Robot, config: Configuration, *, stance: str = "left", height: float = 0.10,
                 hold: float = 3.0, shift: float = 2.0, lift: float = 1.0, settle: float = 0.5,
                 stance_margin: float = 0.0125, height_tolerance: float = 0.005):
        side_option(stance, "stance")
        super().__init__(robot, config)
        if min(height, hold, shift, lift, settle) <= 0:
            raise InvalidInputError("one-leg height and durations must be > 0")
        self.stance, self.swing = stance, ("right" if stance == "left" else "left")
        self.stance_code = LEFT_STANCE if stance == "left" else RIGHT_STANCE
        self.stance0 = self.left0 if stance == "left" else self.right0
        self.swing0 = self.right0 if stance == "left" else self.left0
        self.height, self.height_tolerance = float(height), float(height_tolerance)
        self.hold = float(hold)
        self.polygon_margin = float(stance_margin)
        over = np.r_[self.stance0.translation[:2], self.com0[2]]
        self.t_over = shift                      # CoM over the stance sole
        self.t_lift = shift + settle             # lift-off
        self.t_touch = self.t_lift + 2 * lift + hold  # touch-down
        self.com_path = MinJerkPath(self.com0, [(shift, self.t_touch - shift + settle, over),
                                                (shift, settle, self.com0)])
        self.lift_path = MinJerkPath([0.0], [(lift, hold, [height]), (lift, 0.0, [0.0])], t0=self.t_lift)
        self.duration = self.com_path.end_time
        self._vel = np.zeros(6)
        self._single_height_set = False

    def _hold_lift_off_height(self, com_z: float) -> None:
        """Re-plan the CoM path from lift-off on at the measured CoM height ``com_z`` (m, world)."""
        over = np.r_[self.stance0.translation[:2], com_z]
        settle = self.t_lift - self.t_over
        self.com_path = MinJerkPath(over, [(self.t_over, settle, self.com0)], t0=self.t_touch + settle)

    def update(self, ctrl: BalanceController, t: float, config: Configuration) -> None:
        single = self.t_lift <= t < self.t_touch
        if single and not self._single_height_set:
            self._hold_lift_off_height(float(config.com[2]))
            self._single_height_set = True
        ctrl.set_support(self.stance_code if single else DOUBLE, config)
        com, vel = self.com_path(t)
        ctrl.com.set_target(com, vel)
        if single:
            dz, vz = self.lift_path(t)
            pose = pin.SE3(self.swing0.rotation, self.swing0.translation + np.array([0.0, 0.0, dz[0]]))
            self._vel[2] = vz[0]
            ctrl.swing[self.swing].set_target(pose, self._vel)

    def summary(self, run: BalanceRun) -> dict:
        swing = run.right_sole if self.swing == "right" else run.left_sole
        stance = run.left_sole if self.stance == "left" else run.right_sole
        rise = swing[:, 2, 3] - self.swing0.translation[2]
        window = (run.t >= self.t_over) & (run.t <= self.t_touch)
        poly = support_polygon([self.stance0], self.robot.sole_length, self.robot.sole_width)
        stance_margin = signed_distance(run.com[window, :2], poly)
        up = rise >= self.height - self.height_tolerance
        peak = int(np.argmax(rise))
        return {
            "stance": self.stance,
            "lift_height_m": float(rise.max()),
            "lift_hold_s": float(np.sum(up) * run.dt),
            "min_stance_margin_m": float(np.min(stance_margin)),
            "touchdown_error_m": float(np.linalg.norm(swing[-1, :3, 3] - self.swing0.translation)),
            "max_stance_slip_single_m": float(np.max(np.linalg.norm(
                stance[:, :3, 3] - self.stance0.translation, axis=1))),
            "swing_joints_at_limit": self._joints_at_limit(run.q[peak]),
        }

    def _joints_at_limit(self, q: np.ndarray) -> str:
        """Swing-leg joints within 1e-3 rad of a position limit in configuration ``q`` (nq,), e.g.
        ``"RAnklePitch at its lower limit -0.5236 rad"``, "; "-separated, or ``"none"``."""
        model = self.robot.model
        frame = self.robot.right_sole if self.swing == "right" else self.robot.left_sole
        out = []
        for j in model.supports[model.frames[self.robot.frame_id(frame)].parentJoint]:
            if j == 0 or model.joints[j].nq != 1:
                continue
            i = model.joints[j].idx_q
            lo, hi = model.lowerPositionLimit[i], model.upperPositionLimit[i]
            if q[i] - lo < 1e-3:
                out.append(f"{model.names[j]} at its lower limit {lo:.4g} rad")
            elif hi - q[i] < 1e-3:
                out.append(f"{model.names[j]} at its upper limit {hi:.4g} rad")
        return "; ".join(out) or "none"

    def criteria(self):
        h, tol = self.height, self.height_tolerance
        return [
            Criterion(f"swing sole lifted {h * 100:g} cm ± {tol * 1e3:g} mm", "lift_height_m", "<=", tol, minus=h),
            Criterion(f"swing sole held up ≥ {self.hold:g} s", "lift_hold_s", ">=", self.hold),
            Criterion("CoM ≥ 0.01 m inside the stance sole from arrival to touch-down", "min_stance_margin_m", ">=",
                      0.01),
            Criterion("swing sole put back within 2 mm", "touchdown_error_m", "<=", 2e-3),
        ]
