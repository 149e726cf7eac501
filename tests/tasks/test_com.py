"""The centre-of-mass task: e = c(q) − c* and J against Pinocchio's centre of mass and its Jacobian computed on a
data of their own; the compiled rows equal the plain ones; a bad target is a typed error."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from conftest import CATALOG, random_configuration
from wbc.configuration import Configuration
from wbc.exceptions import InvalidTargetError
from wbc.tasks import ComTask


@pytest.mark.parametrize("name", CATALOG)
def test_com_error_and_jacobian_are_pinocchios(robots, name):
    robot = robots(name)
    rng = np.random.default_rng(5)
    q = random_configuration(robot, rng)
    data = robot.model.createData()
    com = pin.centerOfMass(robot.model, data, q)
    jac = pin.jacobianCenterOfMass(robot.model, data, q)
    target = rng.uniform(-0.2, 0.2, 3)
    task = ComTask(weight=[1.0, 2.0, 3.0])
    task.set_target(target)
    error, J = task.compute(Configuration(robot, q))
    np.testing.assert_allclose(error, com - target, atol=1e-12)
    np.testing.assert_allclose(J, jac, atol=1e-12)
    e2, J2 = np.empty(3), np.empty((3, robot.nv))
    task.compute_into(Configuration(robot, q), e2, J2)
    np.testing.assert_array_equal(e2, error)
    np.testing.assert_array_equal(J2, J)


def test_com_target_must_be_three_finite_numbers():
    task = ComTask()
    for bad in ([0.0, 0.0], [0.0, np.nan, 0.0], "up"):
        with pytest.raises(InvalidTargetError):
            task.set_target(bad)
