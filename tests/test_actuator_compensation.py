"""Controller-side compensation of the drives: armature in M (against MuJoCo's mass matrix), the friction and
damping feed-forward (closed form), joint speed bounds kept by the relaxed QP."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

import wbc
from wbc.constraints.joint_velocity import JointSpeedBounds
from wbc.dynamics.actuator_compensation import JointFrictionCompensation
from wbc.dynamics.balance import BalanceController
from wbc.exceptions import InvalidInputError
from wbc.sim.mujoco_model import build_mujoco_model
from wbc.state import DynamicsState


def test_friction_feedforward_closed_form():
    comp = JointFrictionCompensation([0.5, 1.0, 0.0], [1.0, 2.0, 3.0], velocity_scale=0.1)
    v = np.array([0.2, -0.05, 0.0])
    expected = [0.5 * 0.2 + 1.0 * np.tanh(2.0), -1.0 * 0.05 - 2.0 * np.tanh(0.5), 0.0]
    np.testing.assert_allclose(comp.torque(v), expected, rtol=1e-14)
    with pytest.raises(InvalidInputError):
        JointFrictionCompensation([1.0], [-1.0])
    with pytest.raises(InvalidInputError):
        JointFrictionCompensation([1.0], [1.0], velocity_scale=0.0)


def test_controller_mass_matrix_with_armature_equals_mujoco_realistic_plant():
    robot = wbc.load_robot("talos")
    sim = build_mujoco_model(robot, plant="realistic")
    robot.model.armature[6:] = sim.drive.armature
    st = DynamicsState(robot)
    q = robot.q_ref
    st.update(q, np.zeros(robot.nv))
    mujoco.mj_forward(sim.model, sim.data)
    M = np.zeros((sim.model.nv, sim.model.nv))
    mujoco.mj_fullM(sim.model, sim.data, M)
    idx = sim.state_map.mj_qvel
    np.testing.assert_allclose(st.M[6:, 6:], M[np.ix_(idx, idx)], atol=1e-9)
    legs = [i for i, n in enumerate(robot.model.names[2:]) if n.startswith(("leg_", "arm_", "torso_"))]
    assert len(legs) == 28 and np.all(np.diag(st.M)[6:][legs] > 0.1)  # SRDF: 0.1 kg·m² on each of them


def test_compensation_adds_the_feedforward_at_the_commanded_velocity():
    robot = wbc.load_robot("talos")
    n = robot.nv - 6
    comp = JointFrictionCompensation(np.full(n, 0.5), np.full(n, 1.0))
    plain = BalanceController(robot)
    compensated = BalanceController(robot, compensation=comp)
    q = robot.q_ref
    v = np.zeros(robot.nv)
    v[6:] = np.linspace(-0.3, 0.3, n)
    for c in (plain, compensated):
        c.reset(q, v)
    a, b = plain.compute(q, v), compensated.compute(q, v)
    vj = v[6:] + a.dv[6:] * plain.dt
    expected = np.clip(a.tau + 0.5 * vj + 1.0 * np.tanh(vj / 0.05), -robot.model.effortLimit[6:],
                       robot.model.effortLimit[6:])
    np.testing.assert_allclose(b.tau, expected, atol=1e-8)
    with pytest.raises(InvalidInputError, match="compensation"):
        BalanceController(robot, compensation=JointFrictionCompensation([1.0], [1.0]))


def test_relaxed_qp_keeps_joint_speed_limits():
    """A posture target 1 rad away with a stiff gain at a state where the arms move at 99 % of their URDF limit
    (legs at rest on the floor):
    the relaxed QP (no joint bounds, no torque limits) commands v + v̇ dt beyond the limit without the speed
    bounds, within 95 % of it with them."""
    robot = wbc.load_robot("talos")
    ctrl = BalanceController(robot, speed_margin=0.05, gains={"posture_kp": 1e4, "posture_weight": 100.0})
    arms = np.array([i for i, n in enumerate(robot.model.names[2:]) if n.startswith("arm_")])
    q = robot.q_ref.copy()
    lo, hi = robot.model.lowerPositionLimit[7:], robot.model.upperPositionLimit[7:]
    q[7 + arms] = np.clip(q[7 + arms] - 1.0, lo[arms] + 0.05, hi[arms])
    v = np.zeros(robot.nv)
    vmax = robot.model.velocityLimit[6:]
    v[6 + arms] = 0.99 * vmax[arms] * np.sign(robot.q_ref[7 + arms] - q[7 + arms] + 1e-12)
    ctrl.reset(q, v)
    ctrl.posture.set_target(robot.q_ref)
    qp, st = ctrl.qp, ctrl.state
    st.update(q, v)
    dt = ctrl.dt
    bounds = qp.joint_speed_limits
    assert isinstance(bounds, JointSpeedBounds)
    sol = qp.solve_relaxed(st, dt)
    nxt = np.abs(v + sol.dv * dt)[bounds.indices]
    assert np.all(nxt <= 0.95 * robot.model.velocityLimit[bounds.indices] + 1e-6)
    qp.joint_speed_limits = None
    sol = qp.solve_relaxed(st, dt)
    assert np.any(np.abs(v + sol.dv * dt)[bounds.indices] > robot.model.velocityLimit[bounds.indices])
    with pytest.raises(InvalidInputError, match="margin"):
        JointSpeedBounds(robot, 1.0)
