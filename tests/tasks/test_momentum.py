"""The angular-momentum task: J v against Pinocchio's centroidal momentum and an independent sum over bodies."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from conftest import CATALOG, random_configuration
from wbc.configuration import Configuration
from wbc.tasks import AngularMomentumTask


@pytest.mark.parametrize("name", CATALOG)
def test_angular_momentum_matrix(robots, name):
    """J v (J = rows 3:6 of A_g) equals Pinocchio's computeCentroidalMomentum(q, v).angular and an independent
    sum over bodies Σ (c_i − c) × m_i ċ_i + R_i I_i R_iᵀ ω_i (body velocities from pin.forwardKinematics);
    computing it leaves the configuration's cached kinematics unchanged."""
    robot = robots(name)
    model = robot.model
    rng = np.random.default_rng(7)
    q = random_configuration(robot, rng)
    config = Configuration(robot, q)
    before = (config.com_jacobian.copy(), config.frame_jacobian(robot.frame_id(robot.torso)).copy(),
              config.frame_placement(robot.frame_id(robot.left_sole)).homogeneous.copy())
    task = AngularMomentumTask(robot, weight=[1, 2, 3])
    error, J = task.compute(config)
    assert J.shape == (3, robot.nv) and not error.any()
    np.testing.assert_allclose(config.com_jacobian, before[0], atol=1e-14)
    np.testing.assert_allclose(config.frame_jacobian(robot.frame_id(robot.torso)), before[1], atol=1e-14)
    np.testing.assert_allclose(config.frame_placement(robot.frame_id(robot.left_sole)).homogeneous, before[2],
                               atol=1e-14)
    data = model.createData()
    for _ in range(3):
        v = rng.standard_normal(robot.nv)
        h = pin.computeCentroidalMomentum(model, data, q, v)
        np.testing.assert_allclose(J @ v, h.angular, atol=1e-10)
        pin.forwardKinematics(model, data, q, v)
        c = pin.centerOfMass(model, data, q)
        k = np.zeros(3)
        for i in range(1, model.njoints):
            inertia, M, vel = model.inertias[i], data.oMi[i], data.v[i]  # vel: body velocity in joint frame
            ci = M.act(inertia.lever)
            vi = M.rotation @ (vel.linear + np.cross(vel.angular, inertia.lever))
            wi = M.rotation @ vel.angular
            Iw = M.rotation @ inertia.inertia @ M.rotation.T  # rotational inertia about c_i, world axes
            k += np.cross(ci - c, inertia.mass * vi) + Iw @ wi
        np.testing.assert_allclose(J @ v, k, atol=1e-9 * max(1.0, np.abs(k).max()))
    task.set_target([0.0, 0.1, 0.0])
    np.testing.assert_array_equal(task.velocity_target(error), [0.0, 0.1, 0.0])
