"""The joint acceleration limit (wbc.constraints.acceleration): a step in the command is smoothed to the limit; typed input errors."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import standing_controller
from wbc.configuration import Configuration
from wbc.constraints import JointAccelerationLimit
from wbc.exceptions import InvalidInputError

DT = 0.002


def test_acceleration_limit_smooths_a_step(robots):
    """A 3 cm CoM target step: every tick |Δv| ≤ a_max dt on the actuated joints (the controller feeds v_prev);
    without the constraint the first tick jumps far more."""
    robot = robots("talos")
    a_max = 30.0
    for with_limit in (True, False):
        config = Configuration(robot)
        extra = [JointAccelerationLimit(robot, a_max=a_max)] if with_limit else []
        ctrl, com = standing_controller(robot, config, *extra)
        com.set_target(config.com + [0.0, 0.03, 0.0])
        v_prev, worst = np.zeros(robot.nv), 0.0
        for _ in range(100):
            res = ctrl.solve(config, DT)
            assert res.ok, res.message
            worst = max(worst, float(np.max(np.abs(res.v[6:] - v_prev[6:]))))
            v_prev = res.v
            config.update(config.integrate(res.v, DT))
        if with_limit:
            assert worst <= a_max * DT + 1e-9
        else:
            assert worst > 5 * a_max * DT


def test_acceleration_limit_inputs(robots):
    robot = robots("g1")
    with pytest.raises(InvalidInputError):
        JointAccelerationLimit(robot, a_max=0.0)
    with pytest.raises(InvalidInputError):
        JointAccelerationLimit(robot, a_max=np.ones(3))
    acc = JointAccelerationLimit(robot, a_max=np.full(robot.nv - 6, 5.0))
    with pytest.raises(InvalidInputError):
        acc.set_previous(np.zeros(3))
