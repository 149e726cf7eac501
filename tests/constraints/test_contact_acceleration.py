"""Two flat soles on 5-DoF legs (humanoid15, no hip yaw): the nearly dependent direction of the stacked contact rows
is dropped from the ID QP (``wbc.constraints.contact_acceleration.independent_contact_rows``), so the pelvis orientation stays
controllable while standing.

Independent references: numpy's SVD for the kept rows; the torso orientation task's demand in closed form (at rest,
Kp × the target's rotation angle about its axis); the commanded torso and sole accelerations from Pinocchio's frame
Jacobians (v = 0: the frame acceleration is J v̇). Thresholds are written here.
"""

import numpy as np
import pinocchio as pin
import pytest

from wbc.solvers import make_backend
from wbc.constraints.contact_acceleration import independent_contact_rows
from wbc.dynamics.balance import IDBalanceController


def test_independent_contact_rows_keeps_the_well_conditioned_directions():
    rng = np.random.default_rng(3)
    U, _, Vt = np.linalg.svd(rng.standard_normal((12, 20)), full_matrices=False)
    s = np.linspace(1.0, 0.5, 12)
    s[-1] = 1e-3  # σ_min / σ_max = 1e-3 < 1e-2: dependent
    J = U @ np.diag(s) @ Vt
    b = rng.standard_normal(12)
    A, bb = J.copy(), b.copy()
    r = independent_contact_rows(A, bb)
    assert r == 11
    # the kept rows span the 11 leading right singular vectors (numpy SVD) and are orthogonal to the weak one
    np.testing.assert_allclose(A[:r] @ Vt[-1], 0.0, atol=1e-12)
    P = Vt[:11].T @ Vt[:11]
    np.testing.assert_allclose(A[:r] @ P, A[:r], atol=1e-12)
    # same solutions along those directions: u_iᵀ J x = u_iᵀ b for the 11 leading left singular vectors
    x = np.linalg.lstsq(A[:r], bb[:r], rcond=None)[0]
    np.testing.assert_allclose(U[:, :11].T @ (J @ x), U[:, :11].T @ b, atol=1e-10)
    # well conditioned (two 6-DoF legs): nothing dropped, nothing changed
    J2 = rng.standard_normal((12, 20))
    A2, b2 = J2.copy(), b.copy()
    assert independent_contact_rows(A2, b2) == 12
    assert np.array_equal(A2, J2) and np.array_equal(b2, b)


@pytest.mark.parametrize("solver", ["proxqp", "daqp"])
def test_humanoid15_standing_qp_turns_the_pelvis_towards_its_target(robots, solver):
    """Standing near its reference stance (leg joints q_ref + N(0, 0.005) rad, 6 seeded draws: σ_min / σ_max of the
    two soles' rows 4e-4–2e-3), with the torso (on the pelvis through the torso yaw joint) asked 3° of roll, then of
    pitch: the QP's torso angular acceleration points along the asked axis with ≥ 40 % of the PD demand and ≤ 10 %
    across, and both soles stay still (≤ 1e-3 m/s², rad/s²) but for a yaw ≤ 1 % of the demand (the relative foot yaw
    of the dropped direction). Keeping the weak row as an equality (the
    previous behaviour) forbade a pelvis roll or pitch over the fixed feet: ≤ 2 % of the demand on one axis at some
    draws, up to 21 % across."""
    robot = robots("humanoid15")
    model = robot.model
    data = model.createData()
    kp, angle = 100.0, np.radians(3.0)
    demand = kp * angle  # at rest: a* = −Kp e, e the rotation angle about the axis
    rng = np.random.default_rng(0)
    fid_t = robot.frame_id(robot.torso)
    soles = [robot.frame_id(f) for f in (robot.left_sole, robot.right_sole)]
    for draw in range(6):
        q = robot.q_ref.copy()
        q[7:17] += rng.normal(0.0, 0.005, 10)  # the ten leg joints
        backend = make_backend("proxqp", eps_abs=1e-7) if solver == "proxqp" else make_backend(
            "daqp", primal_tol=1e-6, warm_start="dual")
        ctl = IDBalanceController(robot, solver=backend, sole_margin=0.02, gains={"torso_kp": kp, "torso_kd": 20.0})
        ctl.reset(q)
        target = ctl.torso.task.target
        pin.computeJointJacobians(model, data, q)
        pin.framesForwardKinematics(model, data, q)
        Jt = pin.getFrameJacobian(model, data, fid_t, pin.LOCAL_WORLD_ALIGNED)[3:]
        Js = [pin.getFrameJacobian(model, data, f, pin.LOCAL_WORLD_ALIGNED) for f in soles]
        for axis in (0, 1):
            rpy = np.zeros(3)
            rpy[axis] = angle
            ctl.torso.set_target(pin.SE3(pin.rpy.rpyToMatrix(*rpy) @ target.rotation, target.translation))
            cmd = ctl.solve(q, np.zeros(model.nv))
            assert cmd.ok, (draw, axis, cmd.message)
            w = Jt @ cmd.dv  # rad/s², world axes
            assert w[axis] >= 0.4 * demand, (draw, axis, w)
            assert abs(w[1 - axis]) <= 0.1 * demand, (draw, axis, w)
            for J in Js:
                a = J @ cmd.dv
                # still, but for the sole yaw the legs can only produce through the dropped direction (≤ 1 %)
                assert np.abs(a[:5]).max() <= 1e-3 and abs(a[5]) <= 0.01 * demand, (draw, axis, a)
