"""The task constraint (a task held as an equality, wbc.constraints.task): its rows are the task's J and v*."""

from __future__ import annotations

import numpy as np

from wbc.configuration import Configuration
from wbc.constraints import TaskConstraint
from wbc.tasks import ComTask

DT = 0.002


def test_task_constraint_rows(robots):
    robot = robots("humanoid15")
    config = Configuration(robot)
    com = ComTask(gain=7.0)
    com.set_target(config.com + [0.01, 0.0, 0.0])
    A, b = TaskConstraint(com).compute(config, DT)
    np.testing.assert_array_equal(A, config.com_jacobian)
    np.testing.assert_allclose(b, [0.07, 0.0, 0.0], atol=1e-12)
