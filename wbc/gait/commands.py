"""Commands → walking steps: the goal and velocity logic of both commanded walks.

The kinematic walk (:class:`wbc.scenarios.commanded_walk.CommandedWalk`) and the physics walk
(:class:`wbc.sim.commanded.SimCommandedWalk`) validate commands and turn a base pose goal into steps here; what
differs between them is only what their planners can walk, stated in :class:`CommandLimits` (backward steps,
turning).

* A **velocity command** ``(vx, vy, wz)`` (m/s, m/s, rad/s, walking frame: x forward along the mean heading of the
  soles, y left) is accepted within ``[−max_backward, max_velocity]`` × ``±max_lateral`` × ``±max_turn``
  (:func:`check_velocity`); a step of duration ``T`` then has length ``vx T``, lateral step ``vy T`` and turn
  ``wz T``.
* A **pose goal** ``(x, y, yaw)`` of the base (world) becomes ``n`` walking steps with equal turn ``dyaw / n`` and
  the step length and lateral step that put the feet mid-point at the goal exactly (:func:`steps_to_midpoint`),
  then a closing step (:func:`goal_steps`). ``n`` is the smallest count keeping each step within the limits. The
  base pose is the free flyer's (x, y, yaw); its offset from the feet mid-point at rest (:class:`Stance`, heading
  frame) is kept.

Frames and units: world (``odom``), z up, flat ground; m, s, rad.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
import pinocchio as pin

from wbc.exceptions import GaitError, InvalidInputError
from wbc.gait.footsteps import plan_footsteps, pose_to_xy_yaw
from wbc.geometry import mean_heading

__all__ = ["CommandLimits", "Stance", "check_finite", "check_velocity", "feet_can_yaw", "feet_midpoint", "goal_steps",
           "steps_to_midpoint", "wrap_angle"]


class CommandLimits(NamedTuple):
    """What a commanded walk may be asked: speeds (m/s, rad/s, ≥ 0) and what its planner can walk.

    Attributes:
        max_velocity: forward speed limit. max_backward: backward speed limit (0: no backward steps, and goals
            behind the robot are refused). max_lateral: lateral speed limit. max_turn: yaw rate limit.
        can_turn: False when the legs cannot yaw one sole relative to the other (no hip yaw joint): turning
            commands are refused and goals must keep the heading.
        name: the robot's name (for the messages).
    """

    max_velocity: float
    max_backward: float
    max_lateral: float
    max_turn: float
    can_turn: bool = True
    name: str = "the robot"


class Stance(NamedTuple):
    """The reference stance: the base's offset from the feet mid-point (m, heading frame: x forward, y left) and
    the lateral distance between the soles (m), at rest."""

    offset_x: float
    offset_y: float
    width: float

    @classmethod
    def of(cls, base_xy, lf: np.ndarray, rf: np.ndarray) -> Stance:
        """The stance of a base at ``base_xy`` (x, y) (m, world) over soles ``lf``, ``rf`` ((4, 4), world)."""
        mx, my, yaw = feet_midpoint(lf, rf)
        c, s = math.cos(yaw), math.sin(yaw)
        dx, dy = base_xy[0] - mx, base_xy[1] - my
        return cls(c * dx + s * dy, -s * dx + c * dy,
                   abs(-s * (lf[0, 3] - rf[0, 3]) + c * (lf[1, 3] - rf[1, 3])))

    def footprint_pose(self, lf: np.ndarray, rf: np.ndarray) -> tuple[float, float, float]:
        """(x, y, yaw) where the base stands at rest over the soles ``lf``, ``rf`` (m, m, rad, world)."""
        mx, my, yaw = feet_midpoint(lf, rf)
        c, s = math.cos(yaw), math.sin(yaw)
        return mx + c * self.offset_x - s * self.offset_y, my + s * self.offset_x + c * self.offset_y, yaw


def wrap_angle(a: float) -> float:
    """``a`` (rad) wrapped to [−π, π)."""
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def check_finite(value, name: str, lo: float = -math.inf, hi: float = math.inf) -> float:
    """``value`` as a float if it is a finite number (int or float, Python or numpy; not a bool) in [lo, hi].

    Raises:
        InvalidInputError: not such a number ("<name> must be a finite number"), or out of [lo, hi].
    """
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)) \
            or not math.isfinite(float(value)):
        raise InvalidInputError(f"{name} must be a finite number; got {value!r}")
    v = float(value)
    if not lo <= v <= hi:
        raise InvalidInputError(f"{name} = {v} is out of range: valid is [{lo:g}, {hi:g}]")
    return v


def check_velocity(vx, vy, wz, limits: CommandLimits) -> tuple[float, float, float]:
    """The command (vx, vy, wz) (m/s, m/s, rad/s) as floats within ``limits``.

    Raises:
        InvalidInputError: non-finite, beyond the limits, or a turn for legs that cannot turn (named, with the
            valid range).
    """
    if wz and not limits.can_turn:
        raise InvalidInputError(f"wz = {wz} rad/s: {limits.name}'s legs cannot yaw one sole relative to the other "
                                "(no hip yaw joint); valid: wz = 0")
    return (check_finite(vx, "vx (m/s)", 0.0 - limits.max_backward, limits.max_velocity),
            check_finite(vy, "vy (m/s)", -limits.max_lateral, limits.max_lateral),
            check_finite(wz, "wz (rad/s)", -limits.max_turn, limits.max_turn))


def feet_can_yaw(robot, q: np.ndarray) -> bool:
    """Whether the joints can change the relative yaw of the two soles of ``robot`` at ``q``: the z row of the
    Jacobian of ω_left − ω_right (world axes; the floating base cancels) is non-zero (> 1e-6 of a unit joint rate).
    False for legs without a hip yaw joint, whose feet then cannot turn relative to each other."""
    model, data = robot.model, robot.model.createData()
    pin.computeJointJacobians(model, data, q)
    pin.framesForwardKinematics(model, data, q)
    jl, jr = (pin.getFrameJacobian(model, data, robot.frame_id(f), pin.LOCAL_WORLD_ALIGNED)
              for f in (robot.left_sole, robot.right_sole))
    return bool(np.abs(jl[5] - jr[5]).max() > 1e-6)


def feet_midpoint(lf: np.ndarray, rf: np.ndarray) -> tuple[float, float, float]:
    """(x, y, yaw) of the mid-point of two soles (4, 4) (m, world) and their mean heading (rad)."""
    return 0.5 * (lf[0, 3] + rf[0, 3]), 0.5 * (lf[1, 3] + rf[1, 3]), mean_heading(lf, rf)


def goal_steps(lf: np.ndarray, rf: np.ndarray, goal, step_duration: float, limits: CommandLimits, stance: Stance,
               first: str | None = None) -> tuple[int, float, float, float, str]:
    """(n_steps, step_length (m), step_lateral (m), turn (rad per step), first swinging side) of the walk that puts
    the base at ``goal`` (x, y, yaw) (module docstring), from the soles ``lf``, ``rf`` ((4, 4), world): ``n`` walking
    steps of duration ``step_duration`` (s) and a closing step (n_steps = n + 1). ``first``: the side that must swing
    first (None: the side towards the goal).

    Raises:
        GaitError: a heading change for legs that cannot turn; a goal behind the robot (more than 1 cm) or one that
            needs backward steps when ``limits.max_backward`` is 0.
        numpy.linalg.LinAlgError: no such steps (:func:`steps_to_midpoint`).
    """
    gx, gy, gyaw = goal
    c, s = math.cos(gyaw), math.sin(gyaw)
    tx, ty = gx - (c * stance.offset_x - s * stance.offset_y), gy - (s * stance.offset_x + c * stance.offset_y)
    mx, my, yaw0 = feet_midpoint(lf, rf)
    dyaw = wrap_angle(gyaw - yaw0)
    c0, s0 = math.cos(yaw0), math.sin(yaw0)
    fwd, lat = c0 * (tx - mx) + s0 * (ty - my), -s0 * (tx - mx) + c0 * (ty - my)
    if not limits.can_turn and abs(dyaw) > math.radians(0.5):
        raise GaitError(f"{limits.name}'s legs cannot yaw one sole relative to the other (no hip yaw joint): a goal "
                        f"heading change of {math.degrees(dyaw):.1f} deg cannot be walked; valid: the current heading")
    if limits.max_backward == 0.0 and fwd < -0.01:
        raise GaitError(f"the goal is {-fwd:.3f} m behind the robot: this walk plans no backward steps; valid: a goal "
                        "ahead (turn first)")
    T = step_duration
    n = max(1, math.ceil(max(abs(fwd) / (limits.max_velocity * T), abs(lat) / (limits.max_lateral * T),
                             abs(dyaw) / (limits.max_turn * T) if limits.can_turn else 0.0) - 1e-9))
    turn = dyaw / n if limits.can_turn else 0.0
    side = first or ("right" if lat < 0 else "left")
    length, lateral = steps_to_midpoint(pose_to_xy_yaw(lf), pose_to_xy_yaw(rf), (tx, ty), n, stance.width, turn,
                                        side, lat >= 0)
    if limits.max_backward == 0.0 and length < 0:
        raise GaitError(f"the goal needs backward steps ({length:.3f} m): this walk plans none; valid: a goal ahead")
    return n + 1, length, lateral, float(turn), side


def steps_to_midpoint(left, right, target, n_walk: int, width: float, turn: float, side: str,
                      to_the_left: bool) -> tuple[float, float]:
    """(step_length, step_lateral) (m) of a walk of ``n_walk`` walking steps and a closing step
    (:func:`wbc.gait.footsteps.plan_footsteps` with ``turn`` rad per step, ``width`` m, ``side`` swinging first)
    whose final feet mid-point is ``target`` (x, y) (m, world) exactly, from the soles ``left``, ``right``
    ``(x, y, yaw)``: the mid-point is affine in both for a fixed turn, solved from three evaluations.
    ``to_the_left``: whether the target lies left of the current heading (the side of the leading foot tried first;
    the other is tried when the solve gives a negative lateral step).

    Raises:
        numpy.linalg.LinAlgError: a singular solve (no such steps).
    """
    def end(L, d):
        steps = plan_footsteps(left, right, n_walk + 1, L, width, turn, side, d)
        a, b = steps[-1], steps[-2]
        return np.array([0.5 * (a.x + b.x), 0.5 * (a.y + b.y)])

    goal = np.asarray(target, dtype=float)
    e0 = end(0.0, 0.0)
    sign = 1.0 if to_the_left else -1.0
    J = np.column_stack([end(1.0, 0.0) - e0, end(0.0, sign) - e0])
    L, dd = np.linalg.solve(J, goal - e0)
    if dd < 0:  # the lateral step's sign flipped: solve with the other leading foot
        sign = -sign
        J[:, 1] = end(0.0, sign) - e0
        L, dd = np.linalg.solve(J, goal - e0)
    return float(L), float(sign * dd)
