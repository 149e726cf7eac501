"""Controller-side compensation of the drives: armature in M (against MuJoCo's mass matrix), the friction and
damping feed-forward (closed form), joint speed bounds kept by the relaxed QP."""

from __future__ import annotations

import mujoco
import numpy as np
import pinocchio as pin
import pytest

import wbc
from wbc.constraints.joint_velocity import JointSpeedBounds
from wbc.dynamics.actuator_compensation import JointFrictionCompensation
from wbc.dynamics.balance import IDBalanceController
from wbc.exceptions import InvalidInputError
from wbc.sim.actuators import actuator_model, compensation_options
from wbc.sim.mujoco_model import build_mujoco_model
from wbc.state import DynamicsState


def _assert_arms_brake_to(robot, margin, h: float, start: float, bound: float):
    """The arms moving at ``start`` × their URDF speed limit, the rest at rest: the full and the relaxed ID QP of an
    IDBalanceController with speed margin ``margin`` and horizon ``h`` both brake them (v̇ < 0) and command
    v + h v̇ dt ≤ ``bound`` × the limit. Returns (the controller's QP, v (nv,), dt)."""
    ctrl = IDBalanceController(robot, speed_margin=margin, speed_horizon=h,
                               gains={"posture_kp": 1e4, "posture_weight": 100.0})
    arms = np.array([i for i, n in enumerate(robot.model.names[2:]) if n.startswith("arm_")])
    vmax = robot.model.velocityLimit[6:]
    q = robot.q_ref.copy()
    v = np.zeros(robot.nv)
    v[6 + arms] = start * vmax[arms]
    ctrl.reset(q, v)
    qp, st, dt = ctrl.qp, ctrl.state, ctrl.dt
    st.update(q, v)
    idx = 6 + arms
    for sol in (qp.solve(st, dt), qp.solve_relaxed(st, dt)):
        assert np.all(v[idx] + h * dt * sol.dv[idx] <= bound * vmax[arms] + 1e-6)
        assert np.all(sol.dv[idx] < 0)  # braking: above the bound
    return qp, v, dt


def test_friction_feedforward_closed_form():
    comp = JointFrictionCompensation([0.5, 1.0, 0.0], [1.0, 2.0, 3.0], velocity_scale=0.1)
    v = np.array([0.2, -0.05, 0.0])
    expected = [0.5 * 0.2 + 1.0 * np.tanh(2.0), -1.0 * 0.05 - 2.0 * np.tanh(0.5), 0.0]
    np.testing.assert_allclose(comp.torque(v), expected, rtol=1e-14)
    with pytest.raises(InvalidInputError):
        JointFrictionCompensation([1.0], [-1.0])
    with pytest.raises(InvalidInputError):
        JointFrictionCompensation([1.0], [1.0], velocity_scale=0.0)


def test_compensated_is_torque_then_numpy_clip():
    """compensated(τ, v, v̇, dt, lo, hi) = numpy's minimum(maximum(τ + torque(v[6:] + v̇[6:] dt), lo), hi), bit for bit
    (the same elementwise operations), over random commands that reach both bounds; bad shapes raise."""
    rng = np.random.default_rng(4)
    n = 30
    comp = JointFrictionCompensation(rng.uniform(0.0, 2.0, n), rng.uniform(0.0, 5.0, n), velocity_scale=0.05)
    hi = np.where(np.arange(n) % 7 == 0, np.inf, rng.uniform(20.0, 60.0, n))
    for _ in range(50):
        tau, v, dv = rng.normal(0.0, 40.0, n), rng.normal(0.0, 1.0, n + 6), rng.normal(0.0, 50.0, n + 6)
        expected = np.minimum(np.maximum(tau + comp.torque(v[6:] + dv[6:] * 0.002).copy(), -hi), hi)
        np.testing.assert_array_equal(comp.compensated(tau, v, dv, 0.002, -hi, hi), expected)
    with pytest.raises(InvalidInputError):
        comp.compensated(tau[:-1], v, dv, 0.002, -hi, hi)
    with pytest.raises(InvalidInputError):
        comp.compensated(tau, v[6:], dv, 0.002, -hi, hi)


def _mujoco_mass_matrix(sim):
    mujoco.mj_forward(sim.model, sim.data)
    M = np.zeros((sim.model.nv, sim.model.nv))
    mujoco.mj_fullM(sim.model, sim.data, M)
    idx = sim.state_map.mj_qvel
    return M[np.ix_(idx, idx)]


def test_controller_mass_matrix_with_armature_equals_mujoco_realistic_plant():
    robot = wbc.load_robot("talos")
    sim = build_mujoco_model(robot, plant="realistic")
    ctrl = IDBalanceController(robot, **compensation_options(robot, actuator_model(robot)))
    st = DynamicsState(ctrl.robot)
    st.update(robot.q_ref, np.zeros(robot.nv))
    np.testing.assert_allclose(st.M[6:, 6:], _mujoco_mass_matrix(sim), atol=1e-9)
    legs = [i for i, n in enumerate(robot.model.names[2:]) if n.startswith(("leg_", "arm_", "torso_"))]
    assert len(legs) == 28 and np.all(np.diag(st.M)[6:][legs] > 0.1)  # SRDF: 0.1 kg·m² on each of them


def test_the_controllers_joint_bounds_brake_within_the_plants_drives():
    """compensation_options gives the controller the braking of its drives (braking_share 1): each joint's braking
    acceleration is its torque limit over its inertia in the realistic MuJoCo plant (the diagonal of MuJoCo's mass
    matrix, rotor armature included), capped at the common a_brk of 50 rad/s²; Talos's shoulder rolls get about
    16.5 rad/s², its shoulder pitches, knees and ankles the common 50."""
    robot = wbc.load_robot("talos")
    sim = build_mujoco_model(robot, plant="realistic")
    options = compensation_options(robot, actuator_model(robot))
    assert options["braking_share"] == 1.0
    ctrl = IDBalanceController(robot, **options)
    jl = ctrl.qp.joint_acceleration_limits
    m_diag = np.diag(_mujoco_mass_matrix(sim))  # actuated joints, Pinocchio's order
    tau = robot.model.effortLimit[jl.iv]
    expected = np.minimum(tau / m_diag[jl.iv - 6], 50.0)
    np.testing.assert_allclose(np.minimum(jl.joint_braking, jl.braking_acceleration), expected, rtol=1e-6)
    names = [robot.model.names[j] for j in range(2, robot.model.njoints)]
    by_name = dict(zip(names, np.minimum(jl.joint_braking, 50.0)))
    assert 15.0 < by_name["arm_left_2_joint"] < 18.0 and 15.0 < by_name["arm_right_2_joint"] < 18.0
    assert by_name["arm_left_1_joint"] == by_name["leg_left_4_joint"] == by_name["leg_right_6_joint"] == 50.0


def test_compensation_leaves_the_shared_robot_unchanged():
    """Two controllers and a plant built from one robot: the compensated controller's armature stays its own —
    the robot's model, a second (plain) controller and an ideal MuJoCo plant built afterwards keep zero armature
    (mass matrices compared with Pinocchio's CRBA on the untouched model and with MuJoCo's)."""
    robot = wbc.load_robot("talos")
    options = compensation_options(robot, actuator_model(robot))
    compensated = IDBalanceController(robot, **options)
    assert np.all(np.asarray(robot.model.armature) == 0.0)
    np.testing.assert_array_equal(compensated.robot.model.armature[6:], options["armature"])
    assert np.count_nonzero(options["armature"] == 0.1) == 30  # Talos SRDF rotor_params (grippers: none)
    plain = IDBalanceController(robot)
    q, v = robot.q_ref, np.zeros(robot.nv)
    for c in (compensated, plain):
        c.reset(q, v)
    M0 = pin.crba(robot.model, robot.model.createData(), q)
    M0 = np.triu(M0) + np.triu(M0, 1).T
    np.testing.assert_allclose(plain.state.M, M0, atol=1e-9)
    np.testing.assert_allclose(np.diag(compensated.state.M - M0)[6:], options["armature"], atol=1e-9)
    ideal = build_mujoco_model(robot, plant="ideal")
    np.testing.assert_allclose(_mujoco_mass_matrix(ideal), M0[6:, 6:], atol=1e-9)
    with pytest.raises(InvalidInputError, match="armature"):
        IDBalanceController(robot, armature=np.full(3, 0.1))
    with pytest.raises(InvalidInputError, match="armature"):
        IDBalanceController(robot, armature=np.full(robot.nv - 6, -0.1))


def test_compensation_adds_the_feedforward_at_the_commanded_velocity():
    robot = wbc.load_robot("talos")
    n = robot.nv - 6
    comp = JointFrictionCompensation(np.full(n, 0.5), np.full(n, 1.0))
    plain = IDBalanceController(robot)
    compensated = IDBalanceController(robot, compensation=comp)
    q = robot.q_ref
    v = np.zeros(robot.nv)
    v[6:] = np.linspace(-0.3, 0.3, n)
    for c in (plain, compensated):
        c.reset(q, v)
    a, b = plain.solve(q, v), compensated.solve(q, v)
    vj = v[6:] + a.dv[6:] * plain.dt
    expected = np.clip(a.tau + 0.5 * vj + 1.0 * np.tanh(vj / 0.05), -robot.model.effortLimit[6:],
                       robot.model.effortLimit[6:])
    np.testing.assert_allclose(b.tau, expected, atol=1e-8)
    with pytest.raises(InvalidInputError, match="compensation"):
        IDBalanceController(robot, compensation=JointFrictionCompensation([1.0], [1.0]))


def test_relaxed_qp_keeps_joint_speed_limits():
    """A posture target 1 rad away with a stiff gain at a state where the arms move at 99 % of their URDF limit
    (legs at rest on the floor):
    the relaxed QP (no joint bounds, no torque limits) commands v + v̇ dt beyond the limit without the speed
    bounds; with them, each arm joint either reaches 95 % of it at the next tick or brakes at the full QP's
    braking acceleration (50 rad/s²) or harder: the full QP's rule (eq. 9 with its braking floor), which the relaxed
    QP keeps so that its hard set contains the full one's."""
    robot = wbc.load_robot("talos")
    ctrl = IDBalanceController(robot, speed_margin=0.05, gains={"posture_kp": 1e4, "posture_weight": 100.0})
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
    idx = bounds.indices
    nxt = np.abs(v + sol.dv * dt)[idx]
    within = nxt <= 0.95 * robot.model.velocityLimit[idx] + 1e-6
    braking = np.sign(v[idx]) * sol.dv[idx] <= -50.0 + 1e-6
    assert np.all(within | braking)
    assert np.any(~within) and np.any(within & (np.abs(v[idx]) > 0))  # both cases met (arm limits 1.76-4.58 rad/s)
    qp.joint_speed_limits = None
    sol = qp.solve_relaxed(st, dt)
    assert np.any(np.abs(v + sol.dv * dt)[bounds.indices] > robot.model.velocityLimit[bounds.indices])
    with pytest.raises(InvalidInputError, match="margin"):
        JointSpeedBounds(robot, 1.0)


def test_speed_horizon_bounds_in_both_qps():
    """Arms at 99 % of their URDF speed, bound at 95 % over h = 4 ticks: the full QP (compiled tick, eq. 9's
    velocity term) and the relaxed QP both command v + 4 v̇ dt within ±0.95 q̇_max, i.e. v̇ ≤ (0.95 q̇_max − v)/(4 dt)."""
    robot = wbc.load_robot("talos")
    h = 4.0
    _assert_arms_brake_to(robot, 0.05, h, 0.99, 0.95)
    with pytest.raises(InvalidInputError, match="horizon"):
        JointSpeedBounds(robot, 0.05, 0.5)


def test_speed_horizon_keeps_a_lagging_velocity_loop_under_the_limit():
    """One joint (a unit double integrator, the plant) driven as hard as the speed bound allows, its velocity read
    through the estimator's encoder differencing + 80 Hz low-pass (wbc.estimation.JointStateFilter, ~1.5 ticks of
    lag): the dead-beat bound (h = 1) lets the true velocity overshoot the URDF limit; h = 4 keeps it under it.
    With a 2-tick control delay on top, h = 4 + 2 × 2 = 8 (wbc.sim.actuators.speed_horizon) keeps it under."""
    from wbc.estimation import JointStateFilter
    from wbc.sim.actuators import speed_horizon

    robot = wbc.load_robot("talos")
    dt = 0.002
    j = robot.joint_names.index("arm_right_6_joint")

    def peak(h, delay):
        bounds = JointSpeedBounds(robot, 0.05, h)
        col = int(np.nonzero(bounds.indices == 6 + j)[0][0])
        filt = JointStateFilter(robot.nv - 6, dt)
        filt.reset(np.zeros(robot.nv - 6))
        q, vt = np.zeros(robot.nv - 6), 0.0
        v_meas = np.zeros(robot.nv)
        queue = [0.0] * delay
        top = 0.0
        for _ in range(300):
            v_meas[6:] = filt.update(q)
            queue.append(min(5000.0, bounds.bounds(v_meas, dt)[1][col]))  # as hard as the bound allows
            vt += queue.pop(0) * dt
            q[j] += vt * dt
            top = max(top, vt)
        return top / robot.model.velocityLimit[6 + j]

    assert peak(1.0, 0) > 1.0
    assert peak(speed_horizon(0), 0) <= 1.0
    assert peak(speed_horizon(0), 2) > 1.0
    assert peak(speed_horizon(2), 2) <= 1.0


def test_per_joint_speed_margins_in_both_qps():
    """compensation_options' margins: 5 % on the leg joints (the chains from the base to the soles), 30 % on the
    others. Arms moving at 74 % of their URDF speed (above their 70 % bound, well under the legs' 95 %; soles on the
    floor): the full QP (compiled tick) and the relaxed QP brake them to v + h v̇ dt within 70 % of the URDF limit;
    the bounds of every joint match ±(1 − margin) q̇_max in closed form."""
    from wbc.sim.actuators import joint_speed_margins, leg_joints

    robot = wbc.load_robot("talos")
    names = robot.model.names[2:]
    np.testing.assert_array_equal(leg_joints(robot), [n.startswith("leg_") for n in names])
    margins = joint_speed_margins(robot)
    np.testing.assert_array_equal(margins, np.where([n.startswith("leg_") for n in names], 0.05, 0.3))
    options = compensation_options(robot, actuator_model(robot))
    np.testing.assert_array_equal(options["speed_margin"], margins)
    h = options["speed_horizon"]
    qp, v, dt = _assert_arms_brake_to(robot, options["speed_margin"], h, 0.74, 0.7)
    # the bounds themselves, closed form, on every bounded joint
    bounds = qp.joint_speed_limits
    lo, hi = bounds.bounds(v, dt)
    lim = (1.0 - margins[bounds.indices - 6]) * robot.model.velocityLimit[bounds.indices]
    np.testing.assert_allclose(hi, (lim - v[bounds.indices]) / (h * dt))
    np.testing.assert_allclose(lo, (-lim - v[bounds.indices]) / (h * dt))
    with pytest.raises(InvalidInputError, match="margin"):
        JointSpeedBounds(robot, np.full(3, 0.05))
    with pytest.raises(InvalidInputError, match="margin"):
        JointSpeedBounds(robot, np.r_[1.0, np.zeros(robot.nv - 7)])
    with pytest.raises(InvalidInputError, match="upper_body_margin"):
        joint_speed_margins(robot, 0.05, 1.0)
