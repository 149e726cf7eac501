""":class:`wbc.tasks.base.Task`'s weight: one owner. A task keeps its own copy of an assigned weight; an
:class:`~wbc.formulations.reference.AccelerationReference` keeps its own copy of the task's weight; only
``share_weight`` (a controller's stacked rows) makes the task's weight a view of another array, and an in-place
edit of the task's weight then reaches those rows and nothing else."""

from __future__ import annotations

import numpy as np

from conftest import standing_controller
from wbc.configuration import Configuration
from wbc.formulations.reference import AccelerationReference
from wbc.tasks import ComTask


def test_an_assigned_weight_is_copied():
    """Editing the array a weight was assigned from leaves the task's weight unchanged (on 9470a38 the task kept
    the caller's array: the edit changed the task)."""
    w = np.array([1.0, 2.0, 3.0])
    task = ComTask(weight=w)
    w[0] = 9.0
    assert task.weight[0] == 1.0
    task.weight = w
    w[1] = 9.0
    assert np.array_equal(task.weight, [9.0, 2.0, 3.0])


def test_an_acceleration_reference_owns_its_weight(robots):
    """An in-place edit of an AccelerationReference's weight leaves its task's weight, and the rows of a kinematic
    controller that shares the task, unchanged, and conversely (on 9470a38 the reference's default weight was the
    task's own array, itself a view of the controller's rows: one in-place edit changed all three)."""
    robot = robots("talos")
    config = Configuration(robot)
    com = ComTask(weight=[1.0, 2.0, 3.0])
    ctrl, _ = standing_controller(robot, config, tasks=(com,))
    com.set_target(config.com + np.array([0.002, 0.001, -0.001]))
    ctrl.solve(config, 0.002)  # the controller's rows now hold the task's weights (share_weight)
    ref = AccelerationReference(com, kp=100.0)
    assert np.array_equal(ref.weight, [1.0, 2.0, 3.0])
    before = ctrl.solve(config, 0.002).v
    ref.weight[:] = [50.0, 60.0, 70.0]
    assert np.array_equal(com.weight, [1.0, 2.0, 3.0])
    assert np.array_equal(ctrl.solve(config, 0.002).v, before)  # the kinematic QP did not see the edit
    com.weight[:] = [4.0, 5.0, 6.0]
    assert np.array_equal(ref.weight, [50.0, 60.0, 70.0])
