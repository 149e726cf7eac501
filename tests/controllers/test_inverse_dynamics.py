"""Inverse-dynamics QP (wbc.dynamics): equations of motion, RNEA agreement and constraints at every tick."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

import wbc
from wbc.dynamics import (
    AccelerationReference,
    IDBalanceController,
    DynamicsState,
    InverseDynamicsController,
    InverseDynamicsQP,
    SoleContact,
)
from wbc.exceptions import (
    ConfigurationError,
    InvalidInputError,
    InvalidTargetError,
    SolverError,
    UnknownFrameError,
    UnknownSolverError,
)
from wbc.sim.mujoco_model import build_mujoco_model
from wbc.tasks import AngularMomentumTask, ComTask, FrameTask, PositionTask, PostureTask

TOL = 1e-6


def _independent_contact_jacobian(robot, q, contact: SoleContact) -> np.ndarray:
    """(12, nv) Jacobians of the 4 corner points, rows in the sole frame, from Pinocchio only."""
    model = robot.model
    data = model.createData()
    J6 = pin.computeFrameJacobian(model, data, q, contact.frame_id, pin.LOCAL)
    rows = [J6[:3] - pin.skew(c) @ J6[3:] for c in contact.corners]  # v_corner = v_o + ω × c (sole axes)
    return np.vstack(rows)


def _run_and_check(robot_name: str, ticks: int, push: float):
    robot = wbc.load_robot(robot_name)
    sim = build_mujoco_model(robot)
    ctrl = IDBalanceController(robot, dt=sim.timestep, f_min=1.0)
    q, v = sim.get_state()
    ctrl.reset(q, v)
    model = robot.model
    data = model.createData()
    effort = np.asarray(model.effortLimit[6:])
    worst = {"residual": 0.0, "rnea": 0.0, "friction": np.inf, "normal": np.inf, "cop": np.inf, "torque": np.inf,
             "contact_acc": 0.0}
    for k in range(ticks):
        if k == ticks // 3:
            sim.apply_external_force(robot.torso, [0.0, push, 0.0])
        if k == ticks // 3 + 50:
            sim.clear_external_forces()
        q, v = sim.get_state()
        cmd = ctrl.solve(q, v)
        assert cmd.ok and not cmd.relaxed, cmd.message
        dv, f, tau = cmd.dv, cmd.forces, cmd.tau
        # Equations of motion with independently computed M, h, J_c.
        M = pin.crba(model, data, q)
        M = np.triu(M) + np.triu(M, 1).T
        h = pin.nonLinearEffects(model, data, q, v)
        gen_c = np.zeros(model.nv)
        for i, c in enumerate(ctrl.qp.contacts):
            gen_c += _independent_contact_jacobian(robot, q, c).T @ f[12 * i:12 * i + 12]
        residual = M @ dv + h - np.r_[np.zeros(6), tau] - gen_c
        worst["residual"] = max(worst["residual"], float(np.abs(residual).max()))
        # τ = RNEA(q, v, v̇) − J_cᵀ f on the actuated rows.
        rnea = pin.rnea(model, data, q, v, dv)
        worst["rnea"] = max(worst["rnea"], float(np.abs(tau - (rnea - gen_c)[6:]).max()))
        # Friction pyramid, unilaterality, CoP in the sole, torque limits.
        for i, c in enumerate(ctrl.qp.contacts):
            fc = f[12 * i:12 * i + 12].reshape(4, 3)
            mu_in = c.mu / math.sqrt(2)
            worst["friction"] = min(worst["friction"], float((mu_in * fc[:, 2:3] - np.abs(fc[:, :2])).min()))
            worst["normal"] = min(worst["normal"], float((fc[:, 2] - c.f_min).min()))
            cop = c.cop(f[12 * i:12 * i + 12])
            a, b = c.corners[0, 0], c.corners[0, 1]
            worst["cop"] = min(worst["cop"], float(min(a - abs(cop[0]), b - abs(cop[1]))))
            # Stance sole does not accelerate: J v̇ + J̇ v = −K_d J v.
            pin.forwardKinematics(model, data, q, v, dv)
            acc = pin.getFrameClassicalAcceleration(model, data, c.frame_id, pin.LOCAL).vector
            vel = pin.getFrameVelocity(model, data, c.frame_id, pin.LOCAL).vector
            worst["contact_acc"] = max(worst["contact_acc"], float(np.abs(acc + c.kd * vel).max()))
        worst["torque"] = min(worst["torque"], float((effort - np.abs(tau)).min()))
        sim.set_torques(tau)
        sim.step()
    return worst


@pytest.mark.parametrize("robot_name,push", [("talos", 300.0), ("g1", 80.0)])
def test_dynamics_rnea_and_constraints_every_tick(robot_name, push):
    """400 ticks (0.8 s) in MuJoCo with a lateral push: every tick satisfies the acceptance equations."""
    w = _run_and_check(robot_name, 400, push)
    assert w["residual"] < TOL, w
    assert w["rnea"] < TOL, w
    assert w["friction"] > -TOL and w["normal"] > -TOL and w["cop"] > -TOL, w
    assert w["torque"] > -TOL, w
    assert w["contact_acc"] < 1e-5, w


@pytest.mark.parametrize("robot_name", ["talos", "g1"])
def test_state_matches_pinocchio_algorithms(robots, robot_name):
    """Every DynamicsState quantity against Pinocchio's own algorithm for it, at a random base pose (rotated and
    translated: the centroidal quantities are derived from M's base rows and the base placement) and velocity."""
    robot = robots(robot_name)
    model = robot.model
    rng = np.random.default_rng(0)
    q = robot.q_ref.copy()
    q[:3] = rng.normal(size=3)
    quat = rng.normal(size=4)
    q[3:7] = quat / np.linalg.norm(quat)
    q[7:] += rng.uniform(-0.1, 0.1, robot.nq - 7)
    v = rng.normal(size=robot.nv)
    st = DynamicsState(robot, q, v)
    data = model.createData()
    M = pin.crba(model, data, q)
    M = np.triu(M) + np.triu(M, 1).T
    assert np.abs(st.M - M).max() < 1e-10  # both triangles filled
    assert np.abs(st.h - pin.nonLinearEffects(model, data, q, v)).max() < 1e-10
    pin.centerOfMass(model, data, q, v, np.zeros(robot.nv))
    assert np.abs(st.com - data.com[0]).max() < 1e-12
    assert np.abs(st.com_velocity - data.vcom[0]).max() < 1e-12
    assert np.abs(st.com_drift - data.acom[0]).max() < 1e-10
    assert np.abs(st.com_jacobian - pin.jacobianCenterOfMass(model, data, q)).max() < 1e-12
    assert np.abs(st.centroidal_momentum_matrix - pin.computeCentroidalMap(model, data, q)).max() < 1e-10
    pin.computeCentroidalMomentumTimeVariation(model, data, q, v, np.zeros(robot.nv))
    assert np.abs(st.centroidal_drift - data.dhg.vector).max() < 1e-10
    assert np.abs(st.angular_momentum - data.hg.angular).max() < 1e-10
    pin.forwardKinematics(model, data, q, v, np.zeros(robot.nv))
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    fid = model.getFrameId(robot.torso)
    assert np.abs(st.frame_jacobian(fid, pin.LOCAL) - pin.getFrameJacobian(model, data, fid, pin.LOCAL)).max() < 1e-12
    assert np.abs(st.frame_classical_drift(fid) - pin.getFrameClassicalAcceleration(
        model, data, fid, pin.LOCAL_WORLD_ALIGNED).vector).max() < 1e-12


def _numeric_drift(robot, q, v, f, eps=1e-7):
    """d/dt (J v) at v̇ = 0 by finite differences along q(t) = q ⊕ t v."""
    q1 = pin.integrate(robot.model, q, v * eps)
    q0 = pin.integrate(robot.model, q, -v * eps)
    return (f(q1) - f(q0)) / (2 * eps)


def test_reference_rows_are_the_shared_task_terms(robots):
    """The acceleration-level rows of a task are (J, a* − J̇v) from the SAME task object the velocity level uses:
    r = −Kp e − Kd (J v − ė_ff) − J̇v (+ ä_ff), with e, J, J̇v the task's own (its drift is checked against finite
    differences in tests/tasks/test_tasks_base.py); the angular-momentum reference asks L̇ = −K (L − L*) − (dAg v)[3:6] with L
    from Pinocchio's centroidal momentum and the drift against finite differences of Ag v."""
    robot = robots("talos")
    rng = np.random.default_rng(1)
    q = robot.q_ref.copy()
    q[7:] += rng.uniform(-0.1, 0.1, robot.nq - 7)
    v = rng.normal(scale=0.5, size=robot.nv)
    st = DynamicsState(robot, q, v)
    pos_task = PositionTask(robot, robot.left_sole)
    pos = AccelerationReference(pos_task, kp=30.0, kd=7.0)
    pos.set_target(pin.SE3.Identity())
    assert pos.task is pos_task
    J, r = pos.compute(st)
    # independent: position error, LWA linear Jacobian, classical acceleration from Pinocchio
    pin.forwardKinematics(robot.model, st.data, q, v, np.zeros(robot.nv))
    fid = pos_task.frame_id
    e = st.data.oMf[fid].translation
    J_ref = pin.getFrameJacobian(robot.model, st.data, fid, pin.LOCAL_WORLD_ALIGNED)[:3]
    acc = pin.getFrameClassicalAcceleration(robot.model, st.data, fid, pin.LOCAL_WORLD_ALIGNED).linear
    assert np.abs(J - J_ref).max() < 1e-12
    assert np.abs(r - (-30.0 * e - 7.0 * (J_ref @ v) - acc)).max() < 1e-9
    am = AccelerationReference(AngularMomentumTask(), kp=0.0, kd=4.0)
    am.set_target([0.1, -0.2, 0.3])
    J, r = am.compute(st)
    L = pin.computeCentroidalMomentum(robot.model, robot.model.createData(), q, v).angular
    num = _numeric_drift(robot, q, v, lambda qq: DynamicsState(robot, qq, v).centroidal_momentum_matrix[3:] @ v)
    assert np.abs(st.centroidal_drift[3:] - num).max() < 1e-5 * max(1.0, np.abs(num).max())
    assert np.abs(r - (-4.0 * (L - [0.1, -0.2, 0.3]) - num)).max() < 1e-5 * max(1.0, np.abs(num).max())


def test_solvers_agree_and_fallback(robots):
    robot = robots("g1")
    sols = {}
    for name in ("daqp", "proxqp"):
        ctrl = IDBalanceController(robot, solver=name)
        ctrl.reset(robot.q_ref)
        cmd = ctrl.solve(robot.q_ref, np.zeros(robot.nv))
        assert cmd.ok
        sols[name] = cmd
    assert np.abs(sols["daqp"].tau - sols["proxqp"].tau).max() < 1e-3
    assert np.abs(sols["daqp"].dv - sols["proxqp"].dv).max() < 1e-4

    class Broken:
        name = "broken"
        tolerance = 1e-6

        def solve(self, *args):
            raise SolverError("broken on purpose")

    # the general path (the default compiled tick only reaches its backend on a fallback)
    ctrl = IDBalanceController(robot, solver="daqp")
    ctrl.reset(robot.q_ref)
    ctrl.qp.backend = Broken()
    cmd = ctrl.solve(robot.q_ref, np.zeros(robot.nv))
    assert not cmd.ok and "broken on purpose" in cmd.message
    assert np.all(np.isfinite(cmd.tau)) and np.all(np.abs(cmd.tau) <= robot.model.effortLimit[6:] + 1e-9)
    # The fallback's gravity compensation carries the weight: Σ f_z of its wrenches = m g.
    fz = sum(w[2] for w in cmd.wrenches.values())
    assert abs(fz - robot.mass * 9.81) < 1e-6 * robot.mass * 9.81


def test_joint_acceleration_bounds_keep_limits(robots):
    robot = robots("talos")
    qp = InverseDynamicsQP(robot, [AccelerationReference(PostureTask(robot), kp=50.0)])
    dt = 0.002
    q = robot.q_ref.copy()
    v = np.zeros(robot.nv)
    j = qp.joint_acceleration_limits.iv[0]  # first 1-DoF joint
    iq = qp.joint_acceleration_limits.iq[0]
    q[iq] = qp.joint_acceleration_limits.qmax[0] - 1e-3
    v[j] = 0.2  # moving towards the upper limit
    st = DynamicsState(robot, q, v)
    lo, hi = qp.joint_acceleration_limits.bounds(st, dt)
    assert np.all(lo <= hi)
    # Applying the upper bound for one tick keeps the joint below its limit and the velocity stoppable.
    v1 = v[j] + hi[0] * dt
    q1 = q[iq] + v[j] * dt + 0.5 * hi[0] * dt**2
    assert q1 <= qp.joint_acceleration_limits.qmax[0] + 1e-12
    assert v1 <= math.sqrt(2 * qp.joint_acceleration_limits.braking_acceleration * max(qp.joint_acceleration_limits.qmax[0] - q1, 0.0)) + 1e-9


def test_wrap_and_typed_errors(robots):
    robot = robots("talos")
    for task in (ComTask(), FrameTask(robot, robot.torso), PostureTask(robot)):
        ref = AccelerationReference(task, kp=10.0)
        assert ref.task is task and ref.kd == pytest.approx(2 * math.sqrt(10.0))
    with pytest.raises(InvalidInputError):
        AccelerationReference(object(), kp=1.0)
    with pytest.raises(InvalidInputError):
        AccelerationReference(ComTask(), kp=-1.0)
    with pytest.raises(InvalidInputError):
        AccelerationReference(ComTask(), kp=1.0, kd=-1.0)
    with pytest.raises(InvalidTargetError):
        AccelerationReference(ComTask(), kp=1.0).set_feedforward_acceleration([0.0, np.nan, 0.0])
    with pytest.raises(InvalidInputError):
        SoleContact(robot, robot.left_sole, mu=0.0)
    with pytest.raises(InvalidInputError):
        SoleContact(robot, robot.left_sole, f_min=10.0, f_max=5.0)
    with pytest.raises(UnknownFrameError):
        SoleContact(robot, "no_such_sole")
    with pytest.raises(UnknownSolverError):
        InverseDynamicsQP(robot, solver="no_such_solver")
    with pytest.raises(InvalidInputError):
        InverseDynamicsQP(robot, force_regularization=0.0)
    with pytest.raises(InvalidInputError):
        InverseDynamicsController(InverseDynamicsQP(robot), dt=0.0)
    with pytest.raises(InvalidInputError):
        IDBalanceController(robot, gains={"no_such_gain": 1.0})
    ctrl = IDBalanceController(robot)
    ctrl.reset(robot.q_ref)
    with pytest.raises(ConfigurationError):
        ctrl.solve(robot.q_ref[:-1], np.zeros(robot.nv))
    with pytest.raises(ConfigurationError):
        ctrl.solve(robot.q_ref, np.full(robot.nv, np.nan))
    bad = robot.q_ref.copy()
    bad[3:7] = [0.0, 0.0, 0.0, 2.0]
    with pytest.raises(ConfigurationError):
        ctrl.solve(bad, np.zeros(robot.nv))
    with pytest.raises(InvalidInputError):
        ctrl.qp.solve(ctrl.state, -1.0)


def test_former_names_are_gone():
    """The former aliases and constructors were removed: importing them fails (one name per concept)."""
    import wbc.dynamics as dynamics
    import wbc.dynamics.balance as balance
    import wbc.formulations.reference as reference

    for module, old in ((dynamics, "BalanceController"), (balance, "BalanceController"),
                        (dynamics, "AccelerationTask"), (reference, "AccelerationTask"),
                        (dynamics, "AngularMomentumTask"), (dynamics, "ComAccelerationTask"),
                        (reference, "FrameAccelerationTask"), (reference, "PostureAccelerationTask"),
                        (reference, "AngularMomentumRateTask"), (dynamics, "acceleration_task")):
        with pytest.raises(AttributeError):
            getattr(module, old)



def test_trusted_references_set_what_the_validated_setters_set(robots):
    """set_com_reference_trusted / set_foot_reference_rows give the tasks the targets, velocity and acceleration
    feed-forwards that the validated set_com_reference / set_foot_reference give them (an identical second
    controller as the reference); the validated setters keep raising InvalidTargetError on NaN."""
    robot = robots("talos")
    q = robot.q_ref.copy()
    a, b = (IDBalanceController(robot, dt=0.002) for _ in range(2))
    for c in (a, b):
        c.reset(q)
    rng = np.random.default_rng(3)
    com, com_vel, com_acc = rng.normal(size=3), rng.normal(size=3), rng.normal(size=3)
    a.set_com_reference(com, com_vel, com_acc)
    b.set_com_reference_trusted(com.copy(), com_vel.copy(), com_acc.copy())
    for x, y in ((a.com.task.target, b.com.task.target), (a.com.task.feedforward(), b.com.task.feedforward()),
                 (a.com.feedforward_acceleration, b.com.feedforward_acceleration), (a.com_ref, b.com_ref),
                 (a.com_vel_ref, b.com_vel_ref), (a.com_acc_ref, b.com_acc_ref)):
        assert np.array_equal(x, y)
    pose = pin.SE3(pin.rpy.rpyToMatrix(*rng.normal(scale=0.3, size=3)), rng.normal(size=3))
    vel, acc = rng.normal(size=6), rng.normal(size=6)
    for side in ("left", "right"):
        a.release_foot(side)
        b.release_foot(side)
        a.set_foot_reference(side, pose, vel, acc)
        b.set_foot_reference_rows(side, pose.rotation.T.copy(), pose.translation.copy(), vel.copy(), acc.copy())
        fa, fb = a.feet[side], b.feet[side]
        assert np.array_equal(fa.task.target.homogeneous, fb.task.target.homogeneous)
        assert np.array_equal(fa.task.feedforward(), fb.task.feedforward())
        assert np.array_equal(fa.feedforward_acceleration, fb.feedforward_acceleration)
    with pytest.raises(InvalidTargetError):
        a.set_com_reference(np.array([0.0, np.nan, 0.9]))
    with pytest.raises(InvalidTargetError):
        a.set_foot_reference("left", pose, np.full(6, np.nan), acc)


@pytest.mark.parametrize("name", ["talos", "g1"])
def test_gravity_fallback_matches_a_numpy_reference(robots, name):
    """The safe command (``fallback:gravity``, compiled :func:`gravity_torques`) against the formula of the module
    docstring computed here with numpy from Pinocchio alone (CRBA, RNEA, LOCAL sole Jacobians; the least-norm wrench
    by SVD least squares, I_eff from the inverse of M): torques and world sole wrenches to 1e-9 relative, on random
    states with both, one and no sole active."""
    from conftest import random_configuration

    robot = robots(name)
    model = robot.model
    data = model.createData()
    rng = np.random.default_rng(7)
    ctrl = IDBalanceController(robot)
    inner = ctrl.controller
    contacts = inner.qp.contacts
    for trial in range(6):
        q = random_configuration(robot, rng, spread=0.3)
        v = rng.normal(size=robot.nv) * 0.5
        for c in contacts:
            c.active = True
        if trial % 3 == 1:
            contacts[0].active = False
        elif trial % 3 == 2:
            for c in contacts:
                c.active = False
        inner.state.update(q, v)
        cmd = inner.fallback("test")
        M = pin.crba(model, data, q)
        M = np.triu(M) + np.triu(M, 1).T
        h = pin.rnea(model, data, q, v, np.zeros(robot.nv))
        pin.framesForwardKinematics(model, data, q)
        active = [c for c in contacts if c.active]
        Js = [pin.computeFrameJacobian(model, data, q, c.frame_id, pin.LOCAL) for c in active]
        tau = h[6:].copy()
        wrenches = {c.name: np.zeros(6) for c in contacts}
        if Js:
            Jc = np.vstack(Js)
            W = np.linalg.lstsq(Jc[:, :6].T, h[:6], rcond=None)[0]
            tau -= (Jc.T @ W)[6:]
            for i, c in enumerate(active):
                R = data.oMf[c.frame_id].rotation
                wrenches[c.name] = np.r_[R @ W[6 * i:6 * i + 3], R @ W[6 * i + 3:6 * i + 6]]
        tau -= 0.5 / np.diag(np.linalg.inv(M))[6:] / inner.dt * v[6:]
        lim = np.where(np.isfinite(inner.qp.tau_max) & (inner.qp.tau_max > 0), inner.qp.tau_max, np.inf)
        tau = np.clip(tau, -lim, lim)
        assert cmd.path == "fallback:gravity" and not cmd.ok
        assert np.abs(cmd.tau - tau).max() <= 1e-9 * max(1.0, np.abs(tau).max())
        for c in contacts:
            ref = wrenches[c.name]
            assert np.abs(cmd.wrenches[c.name] - ref).max() <= 1e-9 * max(1.0, np.abs(ref).max())
