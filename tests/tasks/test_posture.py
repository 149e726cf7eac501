"""The posture task: its error is the regulated joints' coordinate difference (closed form for revolute joints),
its rows select those joints' columns of v, and its diagonal cost equals the generic Jᵀ W J path."""

from __future__ import annotations

import numpy as np

from conftest import random_configuration
from wbc.configuration import Configuration
from wbc.tasks import PostureTask
from wbc.tasks.base import Task


def test_posture_error_and_rows_of_a_joint_subset(robots):
    robot = robots("talos")
    model = robot.model
    rng = np.random.default_rng(8)
    names = robot.joint_names[2:7]
    task = PostureTask(robot, joints=names, weight=np.linspace(1.0, 2.0, len(names)), gain=4.0)
    target = random_configuration(robot, rng)
    task.set_target(target)
    q = random_configuration(robot, rng)
    error, J = task.compute(Configuration(robot, q))
    iq = [model.joints[robot.joint_id(n)].idx_q for n in names]
    iv = [model.joints[robot.joint_id(n)].idx_v for n in names]
    np.testing.assert_allclose(error, q[iq] - target[iq], atol=1e-12)  # revolute joints: q ⊖ q* = q − q*
    np.testing.assert_array_equal(J, np.eye(robot.nv)[iv])
    H, g = np.zeros((robot.nv, robot.nv)), np.zeros(robot.nv)
    task.add_cost(Configuration(robot, q), H, g)
    H2, g2 = np.zeros((robot.nv, robot.nv)), np.zeros(robot.nv)
    Task.add_cost(task, Configuration(robot, q), H2, g2)
    np.testing.assert_allclose(H, H2, atol=1e-12)
    np.testing.assert_allclose(g, g2, atol=1e-12)
    np.testing.assert_allclose(g[iv], -np.linspace(1.0, 2.0, len(names)) * (-4.0 * error), atol=1e-12)


def test_row_difference_is_pinocchios_difference_on_the_regulated_rows(robots):
    """row_difference (q − q* on contiguous revolute coordinates, else Pinocchio) equals pin.difference(q*, q) bit
    for bit on the regulated rows: every actuated joint, a subset, a target assigned after construction."""
    import pinocchio as pin

    robot = robots("talos")
    rng = np.random.default_rng(5)
    names = robot.joint_names
    for task in (PostureTask(robot), PostureTask(robot, joints=names[3:9]), PostureTask(robot, joints=names[9:3:-1])):
        for _ in range(3):
            q, task.target = random_configuration(robot, rng), random_configuration(robot, rng)
            ref = pin.difference(robot.model, task.target, q)
            assert np.array_equal(task.row_difference(q)[task.rows], ref[task.rows])
