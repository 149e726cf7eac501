"""Footsteps of a walk (wbc.gait.footsteps): straight and turning geometry, first side, one step, overlapping feet."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gait_plans import HALF_WIDTH, one_step_plan, straight_plan, talos_size_walk
from wbc.gait import (DOUBLE_SUPPORT, LEFT_SUPPORT, RIGHT_SUPPORT, feet_overlap, plan_footsteps, polygons_overlap,
                      sole_polygon)


def test_straight_footsteps_geometry():
    steps = plan_footsteps((0, HALF_WIDTH, 0), (0, -HALF_WIDTH, 0), 8, 0.15, 0.17)
    assert [s.side for s in steps] == ["left", "right"] * 4
    for i, s in enumerate(steps[:-1]):
        assert s.x == pytest.approx(0.15 * (i + 1)) and s.yaw == 0.0
        assert s.y == pytest.approx(HALF_WIDTH if s.side == "left" else -HALF_WIDTH)
    assert steps[-1].x == pytest.approx(steps[-2].x)  # closing step alongside
    assert steps[-1].y - steps[-2].y == pytest.approx(-0.17)
    plan = straight_plan()
    assert plan.planned_distance == pytest.approx(7 * 0.15, abs=1e-12)
    assert plan.footsteps == tuple(steps)


def test_turning_footsteps_geometry():
    L, w, turn = 0.1, 0.17, 0.15
    steps = plan_footsteps((0, HALF_WIDTH, 0), (0, -HALF_WIDTH, 0), 6, L, w, turn, "right")
    feet = {"left": (0, HALF_WIDTH, 0.0), "right": (0, -HALF_WIDTH, 0.0)}
    for i, s in enumerate(steps):
        stance = feet["left" if s.side == "right" else "right"]
        closing = i == len(steps) - 1
        assert s.yaw - stance[2] == pytest.approx(0.0 if closing else turn)
        c, sn = math.cos(s.yaw), math.sin(s.yaw)
        dx, dy = s.x - stance[0], s.y - stance[1]
        local = (c * dx + sn * dy, -sn * dx + c * dy)  # offset in the new heading frame
        sign = 1.0 if s.side == "left" else -1.0
        assert local == pytest.approx((0.0 if closing else L, sign * w), abs=1e-12)
        feet[s.side] = (s.x, s.y, s.yaw)
    assert steps[-1].yaw == pytest.approx(5 * turn)


def test_first_side_right_and_one_step():
    plan = talos_size_walk(n_steps=3, first_side="right")
    assert [s.side for s in plan.footsteps] == ["right", "left", "right"]
    assert plan.support[plan.phases[1].first] == LEFT_SUPPORT
    one = one_step_plan()
    assert len(one.footsteps) == 1 and one.planned_distance == pytest.approx(0.0, abs=1e-12)
    assert one.footsteps[0].side == "left"
    assert [ph.support for ph in one.phases] == [DOUBLE_SUPPORT, RIGHT_SUPPORT, DOUBLE_SUPPORT]


def test_polygons_overlap_and_feet_overlap():
    a = sole_polygon(0, 0, 0, 0.2, 0.1)
    assert polygons_overlap(a, sole_polygon(0, 0.09, 0, 0.2, 0.1))
    assert not polygons_overlap(a, sole_polygon(0, 0.11, 0, 0.2, 0.1))
    assert polygons_overlap(a, sole_polygon(0, 0.11, 0, 0.2, 0.1), clearance=0.011)  # 1 cm gap < clearance
    assert polygons_overlap(a, sole_polygon(0.2, 0.0, math.pi / 4, 0.2, 0.1))  # rotated corner reaches in
    assert not polygons_overlap(a, sole_polygon(0.25, 0.0, math.pi / 4, 0.2, 0.1))
    got = feet_overlap(np.array([[0, 0, 0]] * 4),
                       np.array([[0, 0.09, 0], [0, 0.11, 0], [0.2, 0, math.pi / 4], [0.25, 0, math.pi / 4]]),
                       0.2, 0.1)
    assert got.tolist() == [True, False, True, False]
