"""wbc.scenarios.metrics.support_margin (the walk and balance summaries' ZMP margins): per tick, the signed distance
of the point to the stance soles' rectangle (single support) or to the convex hull of both (double support), against
closed forms and against geometry's validated array functions (sole_polygon, convex_hull, signed_distance)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wbc.exceptions import InvalidInputError
from wbc.geometry import convex_hull, signed_distance, sole_polygon
from wbc.scenarios.metrics import support_margin

DOUBLE, LEFT, RIGHT = 0, 1, 2
LENGTH, WIDTH = 0.2, 0.1


def _pose(x, y, yaw, z=0.0):
    m = np.eye(4)
    m[:2, :2] = [[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]]
    m[:3, 3] = x, y, z
    return m


def test_closed_forms():
    left = np.array([_pose(0.0, 0.1, 0.0)] * 3)
    right = np.array([_pose(0.0, -0.1, 0.0)] * 3)
    points = np.array([[0.0, 0.1], [0.0, 0.0], [0.3, -0.1]])
    support = np.array([LEFT, DOUBLE, RIGHT])
    out = support_margin(points, left, right, support, LENGTH, WIDTH, DOUBLE, LEFT, RIGHT)
    # left sole centre: half the width to the nearest edge; double support, between the soles: half the length to
    # the hull's front/rear edges; 0.3 m ahead of the right sole's centre: 0.2 m outside its front edge
    assert out == pytest.approx([WIDTH / 2, LENGTH / 2, -(0.3 - LENGTH / 2)], abs=1e-15)


def test_equals_geometry_on_random_stances():
    rng = np.random.default_rng(7)
    n = 300
    left = np.array([_pose(*rng.uniform(-1, 1, 2), rng.uniform(-np.pi, np.pi), rng.uniform(0, 0.1)) for _ in range(n)])
    right = np.array([_pose(*rng.uniform(-1, 1, 2), rng.uniform(-np.pi, np.pi)) for _ in range(n)])
    support = rng.choice([DOUBLE, LEFT, RIGHT], n)
    points = rng.uniform(-1.2, 1.2, (n, 2))
    out = support_margin(points, left, right, support, LENGTH, WIDTH, DOUBLE, LEFT, RIGHT)
    for k in range(n):
        polys = [sole_polygon(p[0, 3], p[1, 3], math.atan2(p[1, 0], p[0, 0]), LENGTH, WIDTH)
                 for side, p in ((LEFT, left[k]), (RIGHT, right[k])) if support[k] in (DOUBLE, side)]
        poly = polys[0] if len(polys) == 1 else convex_hull(np.vstack(polys))
        assert out[k] == signed_distance(points[k], poly), k  # the same arithmetic: equal to the last bit


def test_refuses_non_finite_points_and_bad_sizes():
    left, right = np.array([_pose(0, 0.1, 0)]), np.array([_pose(0, -0.1, 0)])
    with pytest.raises(InvalidInputError, match="finite"):
        support_margin(np.array([[np.nan, 0.0]]), left, right, np.array([DOUBLE]), LENGTH, WIDTH, DOUBLE, LEFT, RIGHT)
    with pytest.raises(InvalidInputError, match="length and width"):
        support_margin(np.zeros((1, 2)), left, right, np.array([DOUBLE]), 0.0, WIDTH, DOUBLE, LEFT, RIGHT)
    with pytest.raises(InvalidInputError, match="shape"):
        support_margin(np.zeros((1, 3)), left, right, np.array([DOUBLE]), LENGTH, WIDTH, DOUBLE, LEFT, RIGHT)
