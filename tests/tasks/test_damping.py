"""The joint-velocity damping task: e ≡ 0 and identity rows, so it adds exactly its weights to the diagonal."""

from __future__ import annotations

import numpy as np

from wbc.configuration import Configuration
from wbc.tasks import DampingTask
from wbc.tasks.base import Task


def test_damping_task_adds_its_weights_to_the_diagonal(robots):
    """Velocity-level task: e ≡ 0 and J = identity rows, so its cost is exactly Σ w_j v_j² (H += diag(w), g += 0)."""
    robot = robots("talos")
    config = Configuration(robot)
    for actuated_only, first in ((False, 0), (True, 6)):
        w = np.linspace(1.0, 2.0, robot.nv - first)
        task = DampingTask(robot, weight=w, actuated_only=actuated_only)
        error, J = task.compute(config)
        assert task.dim == robot.nv - first and np.all(error == 0)
        np.testing.assert_array_equal(J, np.eye(robot.nv)[first:])
        H, g = np.zeros((robot.nv, robot.nv)), np.zeros(robot.nv)
        task.add_cost(config, H, g)
        np.testing.assert_array_equal(H, np.diag(np.r_[np.zeros(first), w]))
        assert not g.any()
        H2, g2 = np.zeros((robot.nv, robot.nv)), np.zeros(robot.nv)
        Task.add_cost(task, config, H2, g2)  # the generic Jᵀ W J path gives the same
        np.testing.assert_allclose(H2, H, atol=0)
