"""Torque limits of the inverse-dynamics QP (wbc.constraints.torque_limits): l ≤ C x ≤ u holds exactly when the
joint torques of x = [v̇; f] — Pinocchio's RNEA(q, v, v̇) less J_cᵀ f — are within the scaled URDF effort limits."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from conftest import random_configuration
from wbc.constraints.base import IDContext
from wbc.constraints.torque_limits import TorqueLimits
from wbc.exceptions import InvalidInputError
from wbc.state import DynamicsState


def test_rows_are_the_rnea_torques_against_the_limits(robots):
    robot = robots("talos")
    rng = np.random.default_rng(6)
    q, v = random_configuration(robot, rng), rng.normal(scale=0.5, size=robot.nv)
    state = DynamicsState(robot, q, v)
    JcT = rng.standard_normal((robot.nv, 24))
    con = TorqueLimits(robot, scale=0.5)
    C, l, u = np.zeros((con.dim, robot.nv + 24)), np.zeros(con.dim), np.zeros(con.dim)
    con.write(IDContext(state, 0.002, robot.nv, JcT, {}), C, l, u)
    data = robot.model.createData()
    for scale in (0.01, 100.0):  # small torques (inside) and large ones (outside)
        dv, f = scale * rng.standard_normal(robot.nv), scale * rng.standard_normal(24)
        tau = pin.rnea(robot.model, data, q, v, dv) - JcT @ f
        tau_a = tau[6:][con.joints]
        x = np.concatenate([dv, f])
        np.testing.assert_allclose(C @ x + state.h[con.velocity_indices], tau_a, atol=1e-8 * max(1, abs(tau_a).max()))
        inside = (np.abs(tau_a) <= 0.5 * robot.model.effortLimit[6:][con.joints]).all()
        assert ((l <= C @ x) & (C @ x <= u)).all() == inside
    with pytest.raises(InvalidInputError, match="torque_limit_scale"):
        TorqueLimits(robot, scale=1.5)
