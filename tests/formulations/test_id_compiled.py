"""The compiled inverse-dynamics route (:class:`wbc.formulations.id_compiled.CompiledIDAssembly` and the chain's
compiled solver, through ``InverseDynamicsQP.solve``): Talos standing, its answer against two independent oracles — quadprog (dense
Goldfarb–Idnani) on the QP ``build()`` assembles at the same state, and Pinocchio's equations of motion
(τ = (M v̇ + h − J_cᵀ f)[6:], with M from CRBA, h = g(q) at v = 0 and the sole Jacobians from Pinocchio)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from conftest import dense_quadprog
from wbc.dynamics.balance import IDBalanceController

DT = 0.002


def test_the_kernel_answer_is_quadprogs_optimum_and_its_torques_close_the_equations_of_motion(robots):
    robot = robots("talos")
    ctrl = IDBalanceController(robot, dt=DT)
    ctrl.reset(robot.q_ref.copy(), np.zeros(robot.nv))
    ctrl.state.update(robot.q_ref.copy(), np.zeros(robot.nv))
    qp = ctrl.qp
    sol = qp.solve(ctrl.state, DT)
    assert str(sol.path) == "kernel", sol.path
    H, g, A, b, C, l, u, lb, ub = qp.build(ctrl.state, DT)
    xq = dense_quadprog(H, g, A, b, C, l, u, lb, ub)
    x = np.concatenate([sol.dv, sol.forces])
    np.testing.assert_allclose(x, xq, rtol=0, atol=1e-6 * max(1.0, np.abs(xq).max()))
    # torques: Pinocchio's equations of motion with the answer's v̇ and corner forces (sole frames, LOCAL)
    model, data = robot.model, robot.model.createData()
    q = robot.q_ref
    M = pin.crba(model, data, q)
    h = pin.computeGeneralizedGravity(model, data, q)
    pin.computeJointJacobians(model, data, q)
    rhs = M @ sol.dv + h
    for k, contact in enumerate(qp.contacts):  # corner forces in the sole frame (LOCAL), as the module states
        J = pin.getFrameJacobian(model, data, contact.frame_id, pin.LOCAL)
        for c, corner in enumerate(contact.corners):  # corner positions in the sole frame, m
            Jc = J[:3] - pin.skew(corner) @ J[3:]  # LOCAL linear Jacobian of the corner point: v + ω × c
            rhs -= Jc.T @ sol.forces[12 * k + 3 * c: 12 * k + 3 * c + 3]
    np.testing.assert_allclose(rhs[:6], 0.0, atol=1e-6 * np.abs(h).max())  # the base rows: no actuation
    np.testing.assert_allclose(sol.tau, rhs[6:], rtol=0, atol=1e-6 * np.abs(h).max())
