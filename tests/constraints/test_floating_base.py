"""The floating-base rows of the inverse-dynamics QP (wbc.constraints.floating_base): A x − b is the unactuated part
of Pinocchio's RNEA(q, v, v̇) less J_cᵀ f, so A x = b says the base gets no torque; the contact columns of J_cᵀ are
Jᵀ G (G: the corner-force to sole-wrench map)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from conftest import random_configuration
from wbc.constraints.base import IDContext
from wbc.constraints.floating_base import FloatingBaseDynamics, contact_force_columns
from wbc.constraints.sole_contact import SoleContact
from wbc.state import DynamicsState


def test_rows_are_the_base_part_of_the_equations_of_motion(robots):
    robot = robots("g1")
    rng = np.random.default_rng(9)
    q, v = random_configuration(robot, rng), rng.normal(scale=0.5, size=robot.nv)
    state = DynamicsState(robot, q, v)
    contact = SoleContact(robot, robot.left_sole)
    data = robot.model.createData()
    pin.computeJointJacobians(robot.model, data, q)
    pin.framesForwardKinematics(robot.model, data, q)
    J = pin.getFrameJacobian(robot.model, data, robot.frame_id(robot.left_sole), pin.LOCAL)
    G = np.vstack([np.hstack([np.eye(3)] * 4), np.hstack([pin.skew(c) for c in contact.corners])])
    JcT = np.full((robot.nv, 12), 3.0)  # stale numbers: the kernel must overwrite them
    contact_force_columns(J, G, JcT, 0)
    np.testing.assert_allclose(JcT, J.T @ G, atol=1e-12)
    A, b = np.zeros((6, robot.nv + 12)), np.zeros(6)
    FloatingBaseDynamics().write(IDContext(state, 0.002, robot.nv, JcT, {}), A, b, None)
    dv, f = rng.standard_normal(robot.nv), rng.standard_normal(12)
    tau = pin.rnea(robot.model, data, q, v, dv) - JcT @ f
    np.testing.assert_allclose(A @ np.concatenate([dv, f]) - b, tau[:6], atol=1e-9 * max(1.0, abs(tau).max()))
