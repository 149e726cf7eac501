""":mod:`wbc.gait.commanded`: the command logic of both commanded walks.

Without a plant: the state machine on a stand-in walk (what is due, when, and the steps of it, against the rules
written here: the module docstring's table, ``v T`` per step, the closed-form step count). With the kinematic walk
(:class:`wbc.scenarios.commanded_walk.CommandedWalk`, a subclass): a goal is reached, checked by Pinocchio's forward
kinematics of the final configuration (not the walk's own pose), in the closed-form number of steps.
"""

import math
from types import SimpleNamespace

import numpy as np
import pinocchio as pin
import pytest

from wbc.exceptions import GaitError, InvalidInputError
from wbc.gait.commanded import CLOSE, GOAL, Steps, WalkCommands
from wbc.gait.commands import Stance

T = 0.8  # s, step duration


def _sole(x, y):
    m = np.eye(4)
    m[:2, 3] = x, y
    return m


LF, RF = _sole(0.0, 0.1), _sole(0.0, -0.1)


class _Walk(WalkCommands):
    """A stand-in walk: standing or walking as told, base at the origin over soles LF, RF."""

    walking = False
    q = np.array([0.0, 0.0, 0.9, 0.0, 0.0, 0.0, 1.0])

    def soles(self):
        return LF, RF


def _walk(receding: bool, **kw) -> _Walk:
    args = dict(max_velocity=0.3, max_lateral=0.1, max_turn=0.5, can_turn=True, steps_per_plan=3,
                plan_name="horizon", backward=receding, receding=receding, retry=0.5 if receding else None,
                top_speed=2.0)
    args.update(kw)
    w = _Walk(SimpleNamespace(name="biped"), **args)
    w.stance = Stance.of((0.0, 0.0), LF, RF)
    return w


@pytest.mark.parametrize("receding", [True, False])
def test_commands_and_their_validation(receding):
    w = _walk(receding)
    assert w.idle and w.start_due(0.0) is None
    w.set_velocity(0.2, -0.05, 0.1)
    assert w.command.tolist() == [0.2, -0.05, 0.1] and not w.idle
    assert w.start_due(0.0) == (0.2, -0.05, 0.1)
    with pytest.raises(InvalidInputError, match="vx"):
        w.set_velocity(0.31)  # beyond max_velocity
    with pytest.raises(InvalidInputError, match="vx"):
        w.set_velocity(-0.01 if not receding else -0.31)  # backward: none for segments, max_velocity otherwise
    assert w.command.tolist() == [0.2, -0.05, 0.1]  # a refused command changes nothing
    assert w.max_backward == (0.3 if receding else 0.0)
    w.set_goal(1.0, 0.5, 0.2)
    assert w.pending_goal == (1.0, 0.5, 0.2) and not np.any(w.command) and w.start_due(0.0) == GOAL
    with pytest.raises(InvalidInputError, match="goal y"):
        w.set_goal(1.0, math.nan, 0.0)
    w.set_velocity(0.1)
    assert w.pending_goal is None and w.goal is None  # a command replaces the goal
    w.stop()
    assert w.idle and w.start_due(0.0) is None


def test_limits_and_arguments_are_checked():
    with pytest.raises(InvalidInputError, match=r"horizon must be an integer >= 2"):
        _walk(True, steps_per_plan=1)
    with pytest.raises(InvalidInputError, match=r"max_velocity \(m/s\) = 1.5 is out of range: valid is \[0.001, 1\]"):
        _walk(False, max_velocity=1.5, top_speed=1.0)
    w = _walk(True, can_turn=False, max_turn=99.0)  # not checked: the legs cannot turn
    assert w.max_turn == 0.0
    with pytest.raises(InvalidInputError, match="no hip yaw joint"):
        w.set_velocity(0.1, 0.0, 0.1)


def test_the_steps_of_a_command_are_v_times_t():
    w = _walk(True)
    assert w.steps((0.2, -0.05, 0.1), T) == Steps(3, 0.2 * T, -0.05 * T, 0.1 * T, "right", (0.2, -0.05, 0.1))
    assert w.steps((0.2, 0.0, -0.1), T).first_side == "right"  # turning right: the right foot first
    assert w.steps((0.2, 0.0, 0.1), T).first_side == "left"
    assert w.steps((0.2, 0.0, 0.1), T, "right").first_side == "right"  # a side imposed by the stance
    assert w.steps(CLOSE, T, "left") == Steps(1, 0.0, 0.0, 0.0, "left", CLOSE)


def test_a_goal_is_planned_once_in_the_closed_form_step_count():
    """1 m ahead at 0.3 m/s and 0.8 s per step: ceil(1 / 0.24) = 5 walking steps and the closing one."""
    w = _walk(True)
    w.set_goal(1.0, 0.0, 0.0)
    s = w.steps(w.start_due(0.0), T, soles=w.soles())
    assert s.n_steps == math.ceil(1.0 / (0.3 * T)) + 1 and s.due == GOAL and s.goal == (1.0, 0.0, 0.0)
    assert w.pending_goal is None and w.goal is None  # taken out of the queue; the goal once the plan is taken
    w.taken(s)
    assert w.goal == (1.0, 0.0, 0.0) and w.planned == GOAL and w.replans == 1
    w.walk_ended()
    assert w.goal is None


def test_a_goal_behind_is_refused_by_the_walk_without_backward_steps():
    w = _walk(False)
    w.set_goal(-0.5, 0.0, 0.0)
    with pytest.raises(GaitError, match="behind the robot"):
        w.steps(w.start_due(0.0), T, soles=w.soles())


@pytest.mark.parametrize("receding", [True, False])
def test_what_is_due_at_a_touch_down(receding):
    """The module docstring's rules, case by case: receding horizon (True) and segments (False)."""
    w = _walk(receding)
    w.walking = True
    w.set_velocity(0.2)
    w.taken(w.steps(w.start_due(0.0), T))
    cmd = (0.2, 0.0, 0.0)
    # the same command, steps left: re-planned at every touch-down only with a receding horizon
    assert w.touchdown_due(2) == (cmd if receding else None)
    assert w.touchdown_due(1) == cmd  # the next step closes the plan: walk on
    w.set_velocity(0.1, 0.0, 0.2)
    assert w.touchdown_due(2) == (0.1, 0.0, 0.2)  # a changed command
    w.taken(w.steps((0.1, 0.0, 0.2), T, "left"))
    w.stop()
    assert w.touchdown_due(2) == CLOSE and w.touchdown_due(1) is None  # one step left: it is the closing one
    w.taken(w.steps(CLOSE, T, "right"))
    assert w.touchdown_due(2) is None  # closing already
    w.set_goal(0.5, 0.0, 0.0)  # a goal while walking: planned at once, or after a stop
    assert w.touchdown_due(2) == (GOAL if receding else None)  # (segments: the closing step is planned already)
    w.set_velocity(0.2)
    w.taken(w.steps((0.2, 0.0, 0.0), T, "left"))
    w.set_goal(0.5, 0.0, 0.0)
    assert w.touchdown_due(2) == (GOAL if receding else CLOSE)
    w.taken(w.steps(GOAL, T, "left", w.soles()))
    assert w.goal == (0.5, 0.0, 0.0) and w.touchdown_due(2) is None  # walking to the goal: its plan ends there
    w.set_goal(0.8, 0.0, 0.0)  # a second goal while walking to the first
    assert w.touchdown_due(2) == (GOAL if receding else None)  # segments: walked once standing


def test_a_failed_start_is_retried_or_dropped():
    kin, phys = _walk(True), _walk(False)
    for w in (kin, phys):
        w.set_velocity(0.2)
        w.failed(GaitError("no"), t=1.0)
        assert w.replan_failures == 1 and w.last_error == "no"
    assert kin.start_due(1.2) is None and kin.start_due(1.5) == (0.2, 0.0, 0.0)  # retried 0.5 s later
    assert not np.any(phys.command) and phys.start_due(1.2) is None  # dropped
    kin.failed(GaitError("again"))  # a re-plan while walking: counted, no retry time
    assert kin.replan_failures == 2 and kin.start_due(1.5) is not None


def _base_xy_yaw(robot, q):
    """Pinocchio FK of the root joint: (x, y, yaw) of the base (m, m, rad, world)."""
    data = robot.model.createData()
    pin.forwardKinematics(robot.model, data, q)
    M = data.oMi[1]
    return M.translation[0], M.translation[1], math.atan2(M.rotation[1, 0], M.rotation[0, 0])


@pytest.mark.parametrize("goal, max_turn, stop_first", [((0.6, 0.0, 0.0), 0.5, False), ((0.35, 0.1, 0.4), 0.1, False),
                                                        ((0.6, 0.0, 0.0), 0.5, True)])
def test_the_kinematic_walk_reaches_a_goal_in_the_closed_form_step_count(robots, goal, max_turn, stop_first):
    """Walk to the goal until standing: the base (Pinocchio FK) within the node's goal tolerance (5 cm, 5 deg),
    and the steps taken = n walking steps + 1 closing, n the smallest count within the limits, from the feet
    mid-point at the start (FK) and the base's offset from it. ``stop_first``: a stop while standing (a
    NavigateToPose cancel before the walk's first tick) changes nothing (on 68ddb34 it replaced the goal's plan by a
    closing step on the walk's second tick: one step, base at x = 0.002 m)."""
    from wbc.scenarios.commanded_walk import CommandedWalk

    robot = robots("talos")
    walk = CommandedWalk(robot, max_turn=max_turn)
    assert isinstance(walk, WalkCommands)
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, walk.q)
    lf, rf = (data.oMf[robot.frame_id(f)].translation for f in (robot.left_sole, robot.right_sole))
    mid = 0.5 * (lf + rf)
    x0, y0, _ = _base_xy_yaw(robot, walk.q)
    gx, gy, gyaw = goal  # the feet mid-point at the goal: the base's offset at the start, turned by the goal yaw
    ox, oy = x0 - mid[0], y0 - mid[1]
    tx, ty = gx - (math.cos(gyaw) * ox - math.sin(gyaw) * oy), gy - (math.sin(gyaw) * ox + math.cos(gyaw) * oy)
    T_step = walk.step_duration
    n = max(1, math.ceil(max(abs(tx - mid[0]) / (walk.max_velocity * T_step),
                             abs(ty - mid[1]) / (walk.max_lateral * T_step),
                             abs(gyaw) / (max_turn * T_step)) - 1e-9))
    if stop_first:
        walk.stop()
    walk.set_goal(*goal)
    walk.tick()
    while walk.walking and walk.t < 30.0:
        walk.tick()
    x, y, yaw = _base_xy_yaw(robot, walk.q)
    print(f"goal {goal}: base ({x:.4f}, {y:.4f}, {math.degrees(yaw):.2f} deg), steps {walk.touchdowns}, "
          f"closed form {n} + 1")
    assert walk.idle and walk.replan_failures == 0 and walk.goal is None
    assert math.hypot(x - gx, y - gy) <= 0.05 and abs(math.remainder(yaw - gyaw, 2 * math.pi)) <= math.radians(5)
    assert walk.touchdowns == n + 1
