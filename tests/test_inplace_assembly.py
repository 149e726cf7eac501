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


@pytest.mark.parametrize("name", CATALOG)
def test_position_limit_bounds_closed_form(robots, name):
    """The compiled position-limit bounds: lb = min((q_min − q)/dt, v_max), ub = max((q_max − q)/dt, −v_max) on
    every bounded joint, written out here from the model's limits, with joints inside and outside their range."""
    from wbc.constraints import JointPositionLimit

    robot = robots(name)
    model = robot.model
    rng = np.random.default_rng(3)
    q = random_configuration(robot, rng)
    lim = JointPositionLimit(robot, margin=0.0)
    iq = lim.idx_q
    q[iq[::3]] = model.upperPositionLimit[iq[::3]] + 0.1  # some joints beyond their range
    config = Configuration(robot, q)
    dt = 0.002
    lb, ub = lim.compute(config, dt)
    vmax = model.velocityLimit[lim.indices]
    vmax = np.where(np.isfinite(vmax) & (vmax > 0), vmax, np.inf)
    for k, (i_q, lo, hi) in enumerate(zip(iq, model.lowerPositionLimit[iq], model.upperPositionLimit[iq])):
        assert lb[k] == min((lo - q[i_q]) / dt, vmax[k])
        assert ub[k] == max((hi - q[i_q]) / dt, -vmax[k])
