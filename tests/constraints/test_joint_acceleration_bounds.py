"""Joint position / velocity / viability bounds on the accelerations (wbc.constraints.joint_acceleration_bounds):
a joint driven at its upper bound every tick (q⁺ = q + v dt + ½ v̇ dt², v⁺ = v + v̇ dt, the bound's own model) never
passes its position or speed limit and comes to rest at the position limit; the same mirrored at the lower bound;
the constraint's bounds are the kernel's at the state; typed errors of a bad braking acceleration or speed horizon,
at construction and on assignment; per-joint braking accelerations (a joint's bounds are those of its own a_brk) and
the drives' braking (drive_braking, against Pinocchio's RNEA)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from wbc.constraints.base import IDContext
from wbc.constraints.joint_acceleration_bounds import JointAccelerationLimits, joint_acceleration_bounds
from wbc.exceptions import InvalidInputError


@pytest.mark.parametrize("side", [1.0, -1.0])
def test_driving_at_the_bound_stops_at_the_limit(side):
    qmin, qmax, vmax, a, dt = np.array([-1.0]), np.array([0.8]), np.array([3.0]), 50.0, 0.002
    i0 = np.array([0], np.int64)
    q, v = np.array([0.0]), np.array([-2.0 * side])  # moving away first: the bound turns it round
    for _ in range(3000):
        lo, hi = joint_acceleration_bounds(q, v, i0, i0, qmin, qmax, vmax, a, dt)
        acc = hi[0] if side > 0 else lo[0]
        q[0] += v[0] * dt + 0.5 * acc * dt * dt
        v[0] += acc * dt
        assert qmin[0] - 1e-9 <= q[0] <= qmax[0] + 1e-9 and abs(v[0]) <= vmax[0] + 1e-9
    limit = qmax[0] if side > 0 else qmin[0]
    assert abs(q[0] - limit) < 1e-3


def test_the_constraint_writes_the_kernels_bounds(robots):
    robot = robots("talos")
    con = JointAccelerationLimits(robot, braking_acceleration=30.0)
    rng = np.random.default_rng(2)
    state = SimpleNamespace(q=robot.q_ref.copy(), v=rng.normal(size=robot.nv))
    lb, ub = np.zeros(con.dim), np.zeros(con.dim)
    con.write(IDContext(state, 0.002, robot.nv, np.zeros((robot.nv, 0)), {}), None, lb, ub)
    lo, hi = joint_acceleration_bounds(state.q, state.v, con.iq, con.iv, con.qmin, con.qmax, con.vmax, 30.0, 0.002)
    np.testing.assert_array_equal(lb, lo)
    np.testing.assert_array_equal(ub, hi)
    assert (lb <= ub).all()
    with pytest.raises(InvalidInputError, match="braking_acceleration"):
        JointAccelerationLimits(robot, braking_acceleration=0.0)


def test_braking_acceleration_and_speed_horizon_are_checked_on_assignment(robots):
    con = JointAccelerationLimits(robots("talos"))
    for bad in (0.0, -1.0, np.inf, np.nan, True, None, "50"):
        with pytest.raises(InvalidInputError, match="braking_acceleration"):
            con.braking_acceleration = bad
    for bad in (0.5, np.inf, np.nan, False, None, "4"):
        with pytest.raises(InvalidInputError, match="speed_horizon"):
            con.speed_horizon = bad
    assert (con.braking_acceleration, con.speed_horizon) == (50.0, 1.0)
    con.braking_acceleration, con.speed_horizon = 20, np.float64(4.0)
    assert (con.braking_acceleration, con.speed_horizon) == (20.0, 4.0)
    assert type(con.braking_acceleration) is float and type(con.speed_horizon) is float


def test_a_joints_own_braking_gives_the_bounds_of_its_own_a_brk(robots):
    """Per-joint braking: joint j's bounds with joint_braking[j] = b_j and the common a_brk are the bounds computed
    with the scalar min(a_brk, b_j) alone (the kernel run joint by joint, one scalar each), over random states with
    joints inside and past their position and speed limits; ∞ leaves a joint at a_brk."""
    robot = robots("talos")
    model = robot.model
    con = JointAccelerationLimits(robot, braking_acceleration=50.0)
    rng = np.random.default_rng(75)
    own = rng.uniform(5.0, 80.0, con.dim)
    own[::5] = np.inf
    con.joint_braking = own
    assert con.joint_braking is con.joint_braking and np.array_equal(con.joint_braking, own)
    dt, h = 0.002, 4.0
    con.speed_horizon = h
    for _ in range(50):
        q = robot.q_ref.copy()
        span = con.qmax - con.qmin
        q[con.iq] = rng.uniform(con.qmin - 0.05 * span, con.qmax + 0.05 * span)
        v = np.zeros(robot.nv)
        v[con.iv] = rng.uniform(-1.5, 1.5, con.dim) * model.velocityLimit[con.iv]
        lo, hi = con.bounds(SimpleNamespace(q=q, v=v), dt)
        for j in range(con.dim):
            one = np.array([j], np.int64)
            a_j = min(50.0, own[j])
            lo_j, hi_j = joint_acceleration_bounds(q, v, con.iq[one], con.iv[one], con.qmin[one], con.qmax[one],
                                                   con.vmax[one], a_j, dt, speed_horizon=h)
            assert (lo[j], hi[j]) == (lo_j[0], hi_j[0])
    np.testing.assert_array_equal(con.braking_at(con.iv[:3], 20.0), np.minimum(20.0, np.minimum(50.0, own[:3])))


def test_joint_braking_is_checked_on_assignment_and_kept_in_place(robots):
    con = JointAccelerationLimits(robots("talos"))
    buffer = con.joint_braking
    assert np.all(np.isinf(buffer))
    for bad in (np.zeros(con.dim), -np.ones(con.dim), np.full(con.dim, np.nan), np.ones(con.dim - 1), 10.0):
        with pytest.raises(InvalidInputError, match="joint_braking"):
            con.joint_braking = bad
    con.joint_braking = np.full(con.dim, 12.0)
    assert con.joint_braking is buffer and np.all(buffer == 12.0)  # the compiled tick's array, written in place


def test_drive_braking_is_the_share_of_the_torque_limit_over_the_joints_own_inertia(robots):
    """drive_braking × M_jj / share = τ_max,j, with M_jj measured independently: the j-th torque of Pinocchio's RNEA
    for a unit acceleration of joint j alone, at zero velocity, minus its gravity torque (armature included, as
    RNEA includes it); Talos's shoulder roll (22.3 N·m, the arm's inertia) gives far less than the common 50."""
    import pinocchio as pin

    from wbc.constraints.joint_acceleration_bounds import drive_braking

    robot = robots("talos")
    model = robot.model.copy()
    model.armature[6:] = 0.05
    con = JointAccelerationLimits(robot)
    q = robot.q_ref.copy()
    b = drive_braking(model, con.iv, 0.5, q)
    data = model.createData()
    zero = np.zeros(model.nv)
    g = pin.rnea(model, data, q, zero, zero).copy()
    for j, i in enumerate(con.iv):
        e = zero.copy()
        e[i] = 1.0
        mjj = pin.rnea(model, data, q, zero, e)[i] - g[i]
        assert b[j] * mjj / 0.5 == pytest.approx(model.effortLimit[i], rel=1e-9)
    roll = list(con.iv).index(model.joints[model.getJointId("arm_left_2_joint")].idx_v)
    assert b[roll] < 15.0
    tau = np.full(con.dim, 10.0)
    np.testing.assert_allclose(drive_braking(model, con.iv, 1.0, q, tau), 2.0 * 10.0 / (model.effortLimit[con.iv])
                               * b, rtol=1e-12)
    for bad in (0.0, 1.5, -0.5, np.nan, True):
        with pytest.raises(InvalidInputError, match="share"):
            drive_braking(model, con.iv, bad, q)
