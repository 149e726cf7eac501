"""The in-place task rows the kinematic controller stacks (``Task.compute_into``, compiled for frame tasks) are the
rows of ``Task.compute``, and their Jacobian is the finite-difference derivative of the error (independent)."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import CATALOG, fd_jacobian, make_tasks, random_configuration
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


def test_support_switch_reuses_the_layout_and_solves_as_a_fresh_controller(robots):
    """Removing a contact and adding it back (a step) reuses the layout built the first time for that constraint
    list (same buffers), and every tick equals the tick of a controller built fresh with that constraint list."""
    from wbc.constraints import ContactConstraint, JointPositionLimit, JointVelocityLimit
    from wbc import KinematicController
    from wbc.tasks import ComTask, PostureTask

    robot = robots("talos")
    config = Configuration(robot)
    dt = 0.002

    def problem():
        com = ComTask(weight=10.0, gain=1 / dt)
        com.set_target(config.com + np.array([0.01, 0.02, -0.01]))
        contacts = [ContactConstraint(robot, f, gain=1 / dt) for f in (robot.left_sole, robot.right_sole)]
        for c in contacts:
            c.set_placement_from_configuration(config)
        return [com, PostureTask(robot, weight=1e-2)], contacts, [JointPositionLimit(robot), JointVelocityLimit(robot)]

    tasks, (left, right), limits = problem()
    ctrl = KinematicController(robot, tasks, [left, right, *limits])
    ctrl.solve(config, dt)
    ctrl.remove_constraint(right)
    single = ctrl.solve(config, dt).v
    A_single = ctrl._A
    ctrl.add_constraint(right)
    double = ctrl.solve(config, dt).v
    ctrl.remove_constraint(right)
    again = ctrl.solve(config, dt).v
    assert ctrl._A is A_single  # the single-support layout came back, not rebuilt
    for order, v in (([left, *limits], single), ([left, *limits, right], double), ([left, *limits], again)):
        t2, (l2, r2), lim2 = problem()
        fresh = KinematicController(robot, t2, [{id(left): l2, id(right): r2}.get(id(c), None) or
                                                lim2[limits.index(c)] for c in order])
        np.testing.assert_allclose(v, fresh.solve(config, dt).v, rtol=0, atol=1e-9)  # same optimum, other warm start
