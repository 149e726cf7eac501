"""Joint position / velocity / viability bounds on the accelerations (wbc.constraints.joint_acceleration_bounds):
a joint driven at its upper bound every tick (q⁺ = q + v dt + ½ v̇ dt², v⁺ = v + v̇ dt, the bound's own model) never
passes its position or speed limit and comes to rest at the position limit; the same mirrored at the lower bound;
the constraint's bounds are the kernel's at the state; typed errors of a bad braking acceleration or speed horizon,
at construction and on assignment."""

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
