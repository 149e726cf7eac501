"""Each task's error and Jacobian against finite differences along the configuration manifold."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from conftest import CATALOG, random_configuration
from wbc.configuration import Configuration
from wbc.constraints import ContactConstraint
from wbc.exceptions import InvalidTargetError, UnknownFrameError, UnknownJointError
from wbc.tasks import ComTask, FrameTask, OrientationTask, PositionTask, PostureTask

EPS = 1e-6


def make_tasks(robot, rng):
    target = pin.SE3(pin.rpy.rpyToMatrix(*rng.uniform(-0.5, 0.5, 3)), rng.uniform(-0.3, 0.3, 3))
    frame = FrameTask(robot, robot.left_sole, position_weight=[1, 2, 3], orientation_weight=[0.5, 1, 1])
    frame.set_target(target)
    partial = FrameTask(robot, robot.torso, position_weight=[1, 0, 1], orientation_weight=[0, 1, 0])
    partial.set_target(target)
    pos = PositionTask(robot, robot.right_sole)
    pos.set_target(target)
    ori = OrientationTask(robot, robot.torso)
    ori.set_target(target)
    com = ComTask()
    com.set_target(rng.uniform(-0.2, 0.2, 3))
    posture = PostureTask(robot)
    posture.set_target(random_configuration(robot, rng))
    subset = PostureTask(robot, joints=robot.joint_names[:3])
    return [frame, partial, pos, ori, com, posture, subset]


def fd_jacobian(task, robot, q):
    J = np.empty((task.dim, robot.nv))
    for i in range(robot.nv):
        dq = np.zeros(robot.nv)
        dq[i] = EPS
        ep = task.compute_error(Configuration(robot, pin.integrate(robot.model, q, dq)))
        em = task.compute_error(Configuration(robot, pin.integrate(robot.model, q, -dq)))
        J[:, i] = (ep - em) / (2 * EPS)
    return J


@pytest.mark.parametrize("name", CATALOG)
def test_task_jacobians_match_finite_differences(robots, name):
    robot = robots(name)
    rng = np.random.default_rng(2)
    q = random_configuration(robot, rng)
    config = Configuration(robot, q)
    for task in make_tasks(robot, rng):
        error, J = task.compute(config)
        assert error.shape == (task.dim,) and J.shape == (task.dim, robot.nv)
        np.testing.assert_allclose(J, fd_jacobian(task, robot, q), atol=2e-6, err_msg=task.name)


@pytest.mark.parametrize("name", CATALOG)
def test_task_errors_against_independent_values(robots, name):
    """Errors vanish at the current placement and equal the independent geometric difference elsewhere."""
    robot = robots(name)
    config = Configuration(robot, random_configuration(robot, np.random.default_rng(3)))
    task = FrameTask(robot, robot.right_sole)
    task.set_target_from_configuration(config)
    np.testing.assert_allclose(task.compute_error(config), 0, atol=1e-12)
    M = config.frame_placement(task.frame_id)
    shifted = pin.SE3(M.rotation @ pin.exp3(np.array([0.0, 0.0, 0.2])), M.translation + [0.1, 0, 0])
    task.set_target(shifted)
    np.testing.assert_allclose(task.compute_error(config), [-0.1, 0, 0, 0, 0, -0.2], atol=1e-12)
    com = ComTask()
    com.set_target(config.com + [0, 0.05, 0])
    np.testing.assert_allclose(com.compute_error(config), [0, -0.05, 0], atol=1e-12)
    contact = ContactConstraint(robot, robot.left_sole)
    contact.set_placement_from_configuration(config)
    np.testing.assert_allclose(contact.compute_error(config), 0, atol=1e-12)


def test_bad_task_inputs_raise_typed_errors(robots):
    robot = robots("talos")
    with pytest.raises(UnknownFrameError, match="left_sole_link"):
        FrameTask(robot, "left_sole")
    with pytest.raises(UnknownJointError):
        PostureTask(robot, joints=["no_such_joint"])
    task = FrameTask(robot, robot.left_sole)
    with pytest.raises(InvalidTargetError, match="4, 4"):
        task.set_target(np.eye(3))
    bad = np.eye(4)
    bad[0, 3] = np.nan
    with pytest.raises(InvalidTargetError, match="NaN"):
        task.set_target(bad)
    com = ComTask()
    with pytest.raises(InvalidTargetError):
        com.set_target([0.0, np.nan, 0.8])
    with pytest.raises(InvalidTargetError, match=r"\(3,\)"):
        com.set_target([0.0, 0.8])
