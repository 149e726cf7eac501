"""The robot check of a kinematic controller's inputs: objects of another robot refused with a typed error naming
why, this robot's accepted (and remembered), and the locked joints found from the model's own limits."""

from __future__ import annotations

import copy

import pytest

from wbc.constraints import ContactConstraint, JointPositionLimit
from wbc.controllers.robot_check import RobotCheck, zero_range_joints
from wbc.exceptions import InvalidInputError
from wbc.tasks import FrameTask, PostureTask


def test_this_robots_objects_pass_and_are_remembered(robots):
    robot = robots("talos")
    check = RobotCheck(robot.model, remember=2)
    objs = [ContactConstraint(robot, robot.left_sole), JointPositionLimit(robot), PostureTask(robot)]
    check.check(objs[0], "constraint")
    check.check(objs[1], "constraint")
    contact = objs[0]
    contact.frame_id = 0  # now inconsistent, but remembered as checked ... until the memory is full
    check.check(contact, "constraint")
    check.check(objs[2], "task")  # a third object: the memory (2) is cleared first
    with pytest.raises(InvalidInputError, match="its frame"):
        check.check(contact, "constraint")


def test_objects_of_another_robot_are_refused_naming_why(robots):
    talos, g1 = robots("talos"), robots("g1")
    check = RobotCheck(talos.model)
    with pytest.raises(InvalidInputError, match=r"task .* was built for another robot \(model .*this controller's "
                                                r"robot is"):
        check.check(PostureTask(g1), "task")
    with pytest.raises(InvalidInputError, match="limits on|another robot"):
        check.check(JointPositionLimit(g1), "constraint")
    foot = FrameTask(g1, g1.left_sole)
    with pytest.raises(InvalidInputError, match="another robot"):
        check.check(foot, "task")


def test_locked_joints_from_the_model_limits(robots):
    robot = copy.copy(robots("humanoid15"))
    model = robot.model.copy()
    assert zero_range_joints(model) == []
    j = model.njoints - 1
    model.velocityLimit[model.joints[j].idx_v] = 0.0
    iq = model.joints[2].idx_q
    model.lowerPositionLimit[iq] = model.upperPositionLimit[iq]
    assert zero_range_joints(model) == [model.names[2], model.names[j]]
