"""Joint position limits reached with bounded deceleration (wbc.constraints.braking): moving one tick at the upper
(lower) bound and then braking at a_max stops exactly at q_max (q_min) — v dt + v²/(2 a_max) = q_max − q, closed
form; the compiled intersection gives the generic clip's numbers; typed error of a bad a_max."""

from __future__ import annotations

import math

import numpy as np
import pytest

from conftest import random_configuration
from wbc.configuration import Configuration
from wbc.constraints.braking import JointBrakingLimit
from wbc.exceptions import InvalidInputError


def test_the_bounds_stop_exactly_at_the_limits(robots):
    robot = robots("g1")
    a, dt = 40.0, 0.002
    con = JointBrakingLimit(robot, a_max=a)
    config = Configuration(robot, random_configuration(robot, np.random.default_rng(4)))
    lb, ub = (x.copy() for x in con.compute(config, dt))
    gap_up = con.q_max - config.q[con.idx_q]
    gap_down = config.q[con.idx_q] - con.q_min
    inside = (gap_up > 0) & (gap_down > 0)
    assert inside.sum() > 10
    np.testing.assert_allclose((ub * dt + ub ** 2 / (2 * a))[inside], gap_up[inside], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose((-lb * dt + lb ** 2 / (2 * a))[inside], gap_down[inside], rtol=1e-9, atol=1e-12)
    box_lb, box_ub = np.full(robot.nv, -3.0), np.full(robot.nv, 3.0)
    con.intersect_into(config, dt, box_lb, box_ub)
    ref_lb, ref_ub = np.full(robot.nv, -3.0), np.full(robot.nv, 3.0)
    ref_lb[con.indices] = np.clip(np.maximum(-3.0, lb), -3.0, 3.0)
    ref_ub[con.indices] = np.clip(np.minimum(3.0, ub), ref_lb[con.indices], 3.0)
    np.testing.assert_allclose(box_lb, ref_lb, atol=1e-15)
    np.testing.assert_allclose(box_ub, ref_ub, atol=1e-15)
    for bad in (0.0, -1.0, math.inf, True):
        with pytest.raises(InvalidInputError, match="a_max"):
            JointBrakingLimit(robot, a_max=bad)
