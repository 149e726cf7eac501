"""wbc.geometry, the layer below tasks, constraints and gait: checked against scipy and closed forms."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest
from scipy.spatial import ConvexHull

from wbc.exceptions import ConfigurationError, GaitError, InvalidInputError, InvalidTargetError
from wbc.geometry import (
    as_se3, check_scalar, check_vector, convex_hull, hull, mean_heading, signed_distance, signed_distance_point, sole_corners,
    sole_polygon, support_corners, support_polygon, yaw_of,
)


def test_hull_matches_scipy():
    rng = np.random.default_rng(0)
    for _ in range(20):
        pts = rng.normal(size=(12, 2))
        ours = np.array(hull([tuple(p) for p in pts.tolist()]))
        ref = pts[ConvexHull(pts).vertices]  # counter-clockwise in 2-D
        assert len(ours) == len(ref)
        assert {tuple(np.round(p, 12)) for p in ours} == {tuple(np.round(p, 12)) for p in ref}
        x, y = ours[:, 0], ours[:, 1]
        assert np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y) > 0  # CCW


def test_support_polygon_of_two_soles_closed_form():
    """Two 0.2 × 0.1 m soles side by side at y = ±0.1: the hull is the 0.2 × 0.3 rectangle."""
    left = pin.SE3(np.eye(3), np.array([0.0, 0.1, 0.0]))
    right = np.eye(4)
    right[1, 3] = -0.1
    poly = support_polygon([left, right], 0.2, 0.1)
    assert poly.min(axis=0) == pytest.approx([-0.1, -0.15]) and poly.max(axis=0) == pytest.approx([0.1, 0.15])
    assert signed_distance(np.zeros(2), poly) == pytest.approx(0.1)  # nearest edges: x = ±0.1
    assert signed_distance_point(0.3, 0.0, [tuple(p) for p in poly.tolist()]) == pytest.approx(-0.2)
    one = support_polygon([left], 0.2, 0.1)
    assert len(one) == 4 and signed_distance(np.array([0.0, 0.1]), one) == pytest.approx(0.05)


def test_support_corners_is_support_polygon_in_plain_floats():
    """The plain-float support polygon of the gait plan, the ZMP constraint and the executed-ZMP metric: the same
    numbers, bit for bit, as support_polygon and as the hull of the sole polygons; its vertices those of scipy's hull of the sole rectangles (corners
    in closed form); one sole its 4 corners, none an empty polygon."""
    rng = np.random.default_rng(1)
    length, width = 0.22, 0.12
    for n in (1, 2, 3):
        poses = [pin.SE3(pin.rpy.rpyToMatrix(0.0, 0.0, yaw), np.array([x, y, 0.0]))
                 for x, y, yaw in rng.uniform(-0.3, 0.3, size=(n, 3))]
        soles = [(float(M.translation[0]), float(M.translation[1]), yaw_of(M)) for M in poses]
        ours = support_corners(soles, length, width)
        rects = [sole_polygon(*sole, length, width) for sole in soles]
        assert np.array_equal(np.array(ours), support_polygon(poses, length, width))
        assert np.array_equal(np.array(ours), rects[0] if n == 1 else convex_hull(np.vstack(rects)))
        corners = np.array([[x + math.cos(yaw) * u - math.sin(yaw) * v, y + math.sin(yaw) * u + math.cos(yaw) * v]
                            for x, y, yaw in soles for u in (-length / 2, length / 2) for v in (-width / 2, width / 2)])
        ref = corners[ConvexHull(corners).vertices]
        assert len(ours) == len(ref) and (n > 1 or len(ours) == 4)
        assert {tuple(np.round(p, 12)) for p in ours} == {tuple(np.round(p, 12)) for p in ref}
    assert support_corners([], length, width) == []


def test_yaw_and_mean_heading_closed_form():
    a = pin.SE3(pin.rpy.rpyToMatrix(0.0, 0.0, 0.3), np.zeros(3))
    b = pin.SE3(pin.rpy.rpyToMatrix(0.0, 0.0, -0.1), np.zeros(3)).homogeneous
    assert yaw_of(a) == pytest.approx(0.3) and yaw_of(b) == pytest.approx(-0.1)
    assert mean_heading(a, b) == pytest.approx(0.1)
    c = sole_corners(1.0, 2.0, math.pi / 2, 0.2, 0.1)  # rotated a quarter turn: front-left at (x − 0.05, y + 0.1)
    assert c[0] == pytest.approx((0.95, 2.1))


def test_checks_raise_typed_errors():
    assert check_vector([1, 2, 3], 3, "v").dtype == float
    with pytest.raises(ConfigurationError, match="shape"):
        check_vector([1, 2], 3, "v")
    with pytest.raises(GaitError, match="finite"):
        check_vector([1, np.nan, 3], 3, "com", GaitError)
    with pytest.raises(InvalidTargetError, match="rotation"):
        as_se3(np.diag([1.0, 1.0, -1.0, 1.0]))
    M = as_se3(np.eye(4))
    assert isinstance(M, pin.SE3) and as_se3(M) is M


def test_a_scalar_check_takes_numbers_only():
    assert check_scalar(np.float32(0.5), "x", "m") == 0.5 and check_scalar(2, "x", "m") == 2.0
    for bad in ("0.04", b"1", True, None, math.nan, math.inf, -1e-12, [0.1]):
        with pytest.raises(InvalidInputError, match="x must be finite"):
            check_scalar(bad, "x", "m")
    with pytest.raises(InvalidInputError, match="> 0"):
        check_scalar(0.0, "x", "m", strict=True)


def test_a_read_only_attribute_returns_its_store_and_refuses_assignment():
    from wbc.geometry import ReadOnly

    class Holder:
        value = ReadOnly("(3,) a buffer (m)")
        other = ReadOnly("a renamed buffer", "_buffer")

        def __init__(self):
            self._value, self._buffer = np.zeros(3), [1, 2]

    h = Holder()
    assert h.value is h._value and h.other is h._buffer
    h._value = np.ones(3)  # the attribute follows its store
    assert h.value is h._value
    assert Holder.value.__doc__ == "(3,) a buffer (m)" and Holder.other.__doc__ == "a renamed buffer"
    from wbc.exceptions import InvalidInputError, ReadOnlyAttributeError

    for name in ("value", "other"):
        with pytest.raises(ReadOnlyAttributeError, match=f"Holder.{name} is read-only") as raised:
            setattr(h, name, 1.0)
        assert isinstance(raised.value, AttributeError) and isinstance(raised.value, InvalidInputError)
    assert h.value is h._value and h.other is h._buffer  # the refused assignment left the store alone
    assert isinstance(Holder.__dict__["value"], property)


def test_a_flag_takes_true_or_false_only_on_every_assignment():
    from wbc.exceptions import InvalidInputError
    from wbc.geometry import Flag

    class Holder:
        switch = Flag("a switch")

        def __init__(self, value):
            self.switch = value

    h = Holder(np.bool_(True))
    assert h.switch is True and Holder.switch.__doc__ == "a switch"
    h.switch = False
    assert h.switch is False
    for bad in (0, 1, "yes", None, 1.0):
        with pytest.raises(InvalidInputError, match="switch must be True or False"):
            h.switch = bad
        assert h.switch is False  # the refused value left the attribute as it was
    with pytest.raises(InvalidInputError, match="switch"):
        Holder("no")


def test_sole_polygon_corners_ccw():
    poly = sole_polygon(1.0, 2.0, math.pi / 2, 0.2, 0.1)
    np.testing.assert_allclose(poly, [[0.95, 2.1], [0.95, 1.9], [1.05, 1.9], [1.05, 2.1]], atol=1e-12)
    x, y = poly[:, 0], poly[:, 1]
    assert np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y) > 0  # CCW: positive signed area


def test_convex_hull_matches_scipy():
    rng = np.random.default_rng(0)
    for _ in range(20):
        pts = rng.normal(size=(30, 2))
        hull = convex_hull(pts)
        ref = pts[ConvexHull(pts).vertices]
        assert {tuple(p) for p in hull.tolist()} == {tuple(p) for p in ref.tolist()}
        x, y = hull[:, 0], hull[:, 1]
        assert np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y) > 0


def test_convex_hull_drops_collinear_and_rejects_degenerate():
    square = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [0.5, 0], [0.5, 0.5]], dtype=float)
    assert len(convex_hull(square)) == 4
    with pytest.raises(InvalidInputError):
        convex_hull(np.array([[0, 0], [1, 1], [2, 2.0]]))
    with pytest.raises(InvalidInputError):
        convex_hull(np.zeros((2, 2)))


def test_signed_distance_values_and_vectorisation():
    square = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float)
    pts = np.array([[0.5, 0.5], [0.9, 0.5], [2.0, 0.5], [2.0, 2.0], [-0.5, 0.5], [1.0, 0.3]])
    expected = [0.5, 0.1, -1.0, -math.sqrt(2), -0.5, 0.0]
    np.testing.assert_allclose(signed_distance(pts, square), expected, atol=1e-12)
    np.testing.assert_allclose(signed_distance(pts, square[::-1]), expected, atol=1e-12)  # CW input
    for p, e in zip(pts, expected):
        d = signed_distance(p, square)
        assert isinstance(d, float) and d == pytest.approx(e, abs=1e-12)
    with pytest.raises(InvalidInputError):
        signed_distance(np.array([np.nan, 0.0]), square)
    with pytest.raises(InvalidInputError):
        signed_distance(np.zeros(3), square)


def test_signed_distance_random_against_brute_force():
    rng = np.random.default_rng(1)
    poly = convex_hull(rng.normal(size=(12, 2)))
    pts = rng.normal(scale=2.0, size=(500, 2))
    d = signed_distance(pts, poly)
    # Brute force: distance to densely sampled boundary; sign from the half-planes.
    edges = [(poly[i], poly[(i + 1) % len(poly)]) for i in range(len(poly))]
    boundary = np.vstack([a + np.linspace(0, 1, 2001)[:, None] * (b - a) for a, b in edges])
    dist = np.min(np.linalg.norm(pts[:, None, :] - boundary[None], axis=2), axis=1)
    inside = np.all([(b - a)[0] * (pts[:, 1] - a[1]) - (b - a)[1] * (pts[:, 0] - a[0]) >= 0 for a, b in edges],
                    axis=0)
    np.testing.assert_allclose(np.abs(d), dist, atol=2e-3)
    assert np.all((d > 0) == inside)
