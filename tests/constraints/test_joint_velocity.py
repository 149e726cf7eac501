"""Joint speed bounds on the commanded accelerations (wbc.constraints.joint_velocity): the velocity reached after
h ticks at the bound's acceleration, v + v̇ h dt, is exactly ±(1 − margin) q̇_max (closed form) for the 1-DoF joints
with a URDF velocity limit; intersect only tightens; typed errors of bad margins and horizons."""

from __future__ import annotations

import numpy as np
import pytest

from wbc.constraints.joint_velocity import JointSpeedBounds, speed_margins
from wbc.exceptions import InvalidInputError


@pytest.mark.parametrize("horizon", [1.0, 4.0])
def test_the_bounds_reach_the_scaled_limit_after_the_horizon(robots, horizon):
    robot = robots("talos")
    model = robot.model
    con = JointSpeedBounds(robot, margin=0.05, horizon=horizon)
    limited = [model.joints[j].idx_v for j in range(2, model.njoints)
               if model.joints[j].nv == 1 and 0 < model.velocityLimit[model.joints[j].idx_v] < np.inf]
    assert con.indices.tolist() == limited and con.dim == len(limited) > 0
    rng = np.random.default_rng(1)
    v, dt = rng.normal(size=robot.nv), 0.002
    lo, hi = con.bounds(v, dt)
    qd_max = 0.95 * model.velocityLimit[con.indices]
    np.testing.assert_allclose(v[con.indices] + lo * horizon * dt, -qd_max, atol=1e-12)
    np.testing.assert_allclose(v[con.indices] + hi * horizon * dt, qd_max, atol=1e-12)
    lb, ub = np.full(robot.nv + 6, -1e3), np.full(robot.nv + 6, 1e3)
    con.intersect(v, dt, lb, ub)
    np.testing.assert_array_equal(lb[con.indices], np.maximum(-1e3, lo))
    np.testing.assert_array_equal(ub[con.indices], np.minimum(1e3, hi))
    others = np.setdiff1d(np.arange(robot.nv + 6), con.indices)
    assert (lb[others] == -1e3).all() and (ub[others] == 1e3).all()


def test_typed_errors(robots):
    robot = robots("talos")
    n = robot.nv - 6
    assert speed_margins(robot, 0.1).shape == (n,)
    for bad in (1.0, -0.1, np.nan, True, "x", np.zeros(n + 1)):
        with pytest.raises(InvalidInputError, match="margin"):
            JointSpeedBounds(robot, margin=bad)
    for bad in (0.5, np.inf, np.nan):
        with pytest.raises(InvalidInputError, match="horizon"):
            JointSpeedBounds(robot, horizon=bad)
