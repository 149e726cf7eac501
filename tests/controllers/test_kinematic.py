"""The kinematic controller's public API (:mod:`wbc.controllers.kinematic`): typed errors for bad construction
arguments, attributes and tasks/constraints; a tick's command holds its hard constraints, checked with Pinocchio's
frame Jacobians (contacts) and the model's limits (joint positions after the step, joint velocities). Its topic
files: ``tests/controllers/test_kinematic_*.py``."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from conftest import standing_controller
from wbc.configuration import Configuration
from wbc.constraints import ContactConstraint
from wbc.controllers.kinematic import KinematicController
from wbc.exceptions import InvalidInputError
from wbc.tasks import FrameTask, PostureTask

DT = 0.01


@pytest.mark.parametrize("option, value, named", [
    ("damping", 0.0, "damping"), ("damping", -1e-6, "damping"), ("damping", float("nan"), "damping"),
    ("damping", True, "damping"), ("sole_drift_tolerance", 0.0, "sole_drift_tolerance"),
    ("sole_drift_tolerance", float("inf"), "sole_drift_tolerance"), ("sole_rotation_tolerance", -3e-4,
                                                                      "sole_rotation_tolerance"),
    ("contact_correction", -1e-6, "contact_correction"), ("contact_correction", float("nan"), "contact_correction"),
    ("budget", 0.0, "budget"), ("budget", True, "budget"), ("budget", "fast", "budget")])
def test_bad_construction_arguments_raise_typed_errors(robots, option, value, named):
    with pytest.raises(InvalidInputError, match=named):
        KinematicController(robots("humanoid15"), **{option: value})


def test_bad_tasks_constraints_and_attributes_raise_typed_errors(robots):
    robot = robots("humanoid15")
    config = Configuration(robot)
    ctrl, com = standing_controller(robot, config)
    posture = PostureTask(robot)
    with pytest.raises(InvalidInputError, match="Task"):
        ctrl.add_task("com")
    with pytest.raises(InvalidInputError, match="level"):
        ctrl.add_task(posture, level=-1)
    with pytest.raises(InvalidInputError, match="level"):
        ctrl.add_task(posture, level=1.5)
    with pytest.raises(InvalidInputError, match="hard"):
        ctrl.add_task(posture, level=0, hard=True)
    with pytest.raises(InvalidInputError, match="Constraint"):
        ctrl.add_constraint(com)
    with pytest.raises(InvalidInputError, match="index"):
        ctrl.add_constraint(ContactConstraint(robot, robot.left_sole), index=len(ctrl.constraints) + 1)
    with pytest.raises(InvalidInputError, match="task"):
        ctrl.add_task(FrameTask(robots("talos"), robots("talos").left_sole))  # built for another robot
    with pytest.raises(InvalidInputError, match="budget"):
        ctrl.budget = -0.01
    with pytest.raises(InvalidInputError, match="dt"):
        ctrl.solve(config, 0.0)
    with pytest.raises(ValueError, match="not in the controller"):
        ctrl.remove_task(posture)
    ctrl.budget = math.inf  # a valid value is taken
    assert ctrl.budget == math.inf and ctrl.solve(config, DT).ok


def test_a_tick_holds_its_contacts_and_limits(robots):
    """Talos standing, CoM target 4 cm forward and a right-hand target 20 cm away: over 15 ticks each command is ok,
    leaves both soles where they were placed (Pinocchio's forward kinematics at the stepped configuration: within
    1e-4 m and 1e-3 rad of the start, the per-tick tolerances being 5e-5 m and 3e-4 rad) and keeps the joints within
    their velocity limits and, after the step, within their position limits (1e-9)."""
    robot = robots("talos")
    model, data = robot.model, robot.model.createData()
    config = Configuration(robot)
    hand = FrameTask(robot, robot.right_hand, gain=5.0, orientation_weight=0.0)
    target = config.frame_placement(hand.frame_id).copy()
    target.translation += [0.1, -0.1, 0.15]
    hand.set_target(target)
    ctrl, com = standing_controller(robot, config, tasks=[hand])
    com.set_target(config.com + np.array([0.04, 0.0, 0.0]))
    soles = [model.getFrameId(f) for f in (robot.left_sole, robot.right_sole)]
    start = [config.frame_placement(f).copy() for f in soles]
    moved = 0.0
    for _ in range(15):
        res = ctrl.solve(config, DT)
        assert res.ok, res.message
        q = config.q
        assert np.all(np.abs(res.v[6:]) <= model.velocityLimit[6:] + 1e-9)
        q_next = pin.integrate(model, q, res.v * DT)
        assert np.all(q_next[7:] >= model.lowerPositionLimit[7:] - 1e-9)
        assert np.all(q_next[7:] <= model.upperPositionLimit[7:] + 1e-9)
        pin.framesForwardKinematics(model, data, q_next)
        for f, before in zip(soles, start):
            err = pin.log6(before.actInv(data.oMf[f])).vector
            assert np.linalg.norm(err[:3]) < 1e-4 and np.linalg.norm(err[3:]) < 1e-3, err
        moved = max(moved, np.abs(res.v[6:]).max())
        config.update(q_next)
    assert moved > 1e-3  # the targets made the joints move
