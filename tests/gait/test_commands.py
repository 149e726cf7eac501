""":mod:`wbc.gait.commands`: the command → steps logic of both commanded walks (the kinematic one, backward steps
allowed, and the physics one, none), without a simulator; the footsteps are checked with
:func:`wbc.gait.footsteps.plan_footsteps` and the limits written here."""

import math

import numpy as np
import pytest

from wbc.exceptions import GaitError, InvalidInputError
from wbc.gait.commands import CommandLimits, Stance, check_finite, check_velocity, goal_steps
from wbc.gait.footsteps import plan_footsteps, pose_to_xy_yaw

T = 0.8  # step duration (s)
KINEMATIC = CommandLimits(0.3, 0.3, 0.1, 0.5, True, "talos")  # CommandedWalk's defaults: backward as fast as forward
PHYSICS = CommandLimits(0.3, 0.0, 0.1, 0.5, True, "talos")  # SimCommandedWalk's defaults: no backward step
NO_YAW = CommandLimits(0.3, 0.3, 0.1, 0.5, False, "humanoid15")


def _sole(x, y, yaw=0.0):
    m = np.eye(4)
    m[:2, :2] = [[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]]
    m[:2, 3] = x, y
    return m


LF, RF = _sole(0.0, 0.1), _sole(0.0, -0.1)
STANCE = Stance.of((-0.02, 0.0), LF, RF)  # the base 2 cm behind the feet mid-point


def _end_pose(lf, rf, steps, stance):
    """Where the base stands over the last two footsteps of ``steps`` (x, y, yaw)."""
    n, length, lateral, turn, side = steps
    feet = plan_footsteps(pose_to_xy_yaw(lf), pose_to_xy_yaw(rf), n, length, stance.width, turn, side, lateral)
    a, b = feet[-1], feet[-2]
    return stance.footprint_pose(_sole(a.x, a.y, a.yaw), _sole(b.x, b.y, b.yaw))


def test_stance_and_footprint():
    assert STANCE == pytest.approx((-0.02, 0.0, 0.2), abs=1e-15)
    assert STANCE.footprint_pose(LF, RF) == pytest.approx((-0.02, 0.0, 0.0), abs=1e-15)
    turned = Stance.of((0.0, 0.0), _sole(0.1, 0.0, math.pi / 2), _sole(-0.1, 0.0, math.pi / 2))
    assert turned == pytest.approx((0.0, 0.0, 0.2), abs=1e-15)


@pytest.mark.parametrize("limits", [KINEMATIC, PHYSICS])
@pytest.mark.parametrize("goal", [(1.0, 0.0, 0.0), (0.6, 0.25, 0.4), (0.5, -0.3, -0.6), (0.05, 0.0, 0.0)])
def test_goal_steps_reach_the_goal_within_the_limits(limits, goal):
    """The base ends at the goal (to 1e-9 m, 1e-9 rad), with the smallest count of walking steps keeping the feet
    mid-point's travel per step (from (0, 0), heading 0) within the limits."""
    steps = goal_steps(LF, RF, goal, T, limits, STANCE)
    n, length, lateral, turn, side = steps
    assert _end_pose(LF, RF, steps, STANCE) == pytest.approx(goal, abs=1e-9)
    assert abs(turn) <= limits.max_turn * T + 1e-12 and abs(lateral) <= 0.3
    assert side == ("right" if goal[1] < 0 else "left")
    gx, gy, gyaw = goal
    tx, ty = gx + 0.02 * math.cos(gyaw), gy + 0.02 * math.sin(gyaw)  # the feet mid-point at the goal
    need = max(abs(tx) / (limits.max_velocity * T), abs(ty) / (limits.max_lateral * T),
               abs(gyaw) / (limits.max_turn * T))
    assert n - 1 == max(1, math.ceil(need - 1e-9))


def test_a_goal_behind_is_walked_backward_only_by_the_kinematic_walk():
    goal = (-0.5, 0.0, 0.0)
    steps = goal_steps(LF, RF, goal, T, KINEMATIC, STANCE)
    assert steps[1] < 0 and _end_pose(LF, RF, steps, STANCE) == pytest.approx(goal, abs=1e-9)
    with pytest.raises(GaitError, match="behind the robot"):
        goal_steps(LF, RF, goal, T, PHYSICS, STANCE)


def test_legs_that_cannot_turn_keep_the_heading():
    with pytest.raises(GaitError, match="cannot yaw"):
        goal_steps(LF, RF, (0.5, 0.0, 0.3), T, NO_YAW, STANCE)
    steps = goal_steps(LF, RF, (0.5, 0.1, 0.0), T, NO_YAW, STANCE)
    assert steps[3] == 0.0 and _end_pose(LF, RF, steps, STANCE) == pytest.approx((0.5, 0.1, 0.0), abs=1e-9)


def test_check_velocity_limits():
    assert check_velocity(-0.2, 0.05, 0.1, KINEMATIC) == (-0.2, 0.05, 0.1)
    with pytest.raises(InvalidInputError, match=r"vx \(m/s\) = -0.2 is out of range: valid is \[0, 0.3\]"):
        check_velocity(-0.2, 0.0, 0.0, PHYSICS)
    with pytest.raises(InvalidInputError, match="no hip yaw joint"):
        check_velocity(0.1, 0.0, 0.2, NO_YAW)
    with pytest.raises(InvalidInputError, match="vy"):
        check_velocity(0.1, 0.2, 0.0, KINEMATIC)


def test_accepts_numbers_in_range():
    assert check_finite(1, "x") == 1.0 and type(check_finite(np.int64(2), "x")) is float
    assert check_finite(0.4, "T", 0.4, 3.0) == 0.4 and check_finite(3.0, "T", 0.4, 3.0) == 3.0


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf, True, "1", None, [1.0]])
def test_refuses_non_numbers(bad):
    with pytest.raises(InvalidInputError, match="x must be a finite number"):
        check_finite(bad, "x")


def test_refuses_out_of_range():
    with pytest.raises(InvalidInputError, match=r"max_velocity \(m/s\) = 2.5 is out of range: valid is \[0.001, 2\]"):
        check_finite(2.5, "max_velocity (m/s)", 1e-3, 2.0)
