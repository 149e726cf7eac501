"""The in-place task rows the kinematic controller stacks (``Task.compute_into``, compiled for frame tasks) are the
rows of ``Task.compute``, and their Jacobian is the finite-difference derivative of the error (independent)."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import CATALOG, random_configuration
from test_tasks import fd_jacobian, make_tasks
from wbc.configuration import Configuration


@pytest.mark.parametrize("name", CATALOG)
def test_compute_into_equals_compute_and_finite_differences(robots, name):
    robot = robots(name)
    rng = np.random.default_rng(7)
    q = random_configuration(robot, rng)
    config = Configuration(robot, q)
    for task in make_tasks(robot, rng):
        error, jac = task.compute(config)
        e_out = np.full(task.dim, np.nan)
        j_out = np.full((task.dim, robot.nv), np.nan)
        task.compute_into(config, e_out, j_out)
        np.testing.assert_allclose(e_out, error, rtol=0, atol=1e-12, err_msg=task.name)
        np.testing.assert_allclose(j_out, jac, rtol=0, atol=1e-12, err_msg=task.name)
        np.testing.assert_allclose(j_out, fd_jacobian(task, robot, q), atol=2e-6, err_msg=task.name)
