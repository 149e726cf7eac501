"""Geometry below tasks, constraints and gait: vector and SE3 checks, ground-plane headings, and planar support polygons
(sole rectangles, convex hulls, signed distances, overlap tests).

This module imports nothing of wbc but :mod:`wbc.exceptions`; every higher layer (tasks, constraints, gait,
scenarios, viz) takes its geometry from here.

All planar points are 2-D ground-plane coordinates ``(x, y)`` in metres, in whatever frame the caller uses (the world
frame in the gait layer). Polygons are ``(k, 2)`` arrays of vertices; the functions that need a convex polygon
accept either orientation and do not repeat the first vertex at the end.

These helpers are shared by the gait planner (ZMP margins) and by other modules (CoM-projection and CoP margins).
Small inputs (one point, a few vertices) take plain-Python paths (:func:`sole_corners`, :func:`hull`,
:func:`support_corners`, :func:`signed_distance_point`: lists of ``(x, y)`` tuples, no validation, for callers that built their input
themselves): numpy's per-call overhead would dominate.
"""

from __future__ import annotations

import math
import operator

import numpy as np
import pinocchio as pin

from wbc.exceptions import ConfigurationError, InvalidInputError, InvalidTargetError, ReadOnlyAttributeError

__all__ = [
    "FLOAT64", "check_vector", "check_scalar", "check_count", "as_se3", "yaw_of", "mean_heading", "sole_corners", "sole_polygon", "hull", "convex_hull", "support_corners", "support_polygon",
    "rectangle_in_polygon", "signed_distance_point", "signed_distance", "polygons_overlap", "polygon_margin", "closest_point_in_polygon",
    "projected_sole_corners",
]

Point = tuple[float, float]

#: numpy's float64 dtype, native byte order: ``x.dtype is FLOAT64`` is the cheap test of a float array that
#: ``np.asarray(x, dtype=float)`` returns unchanged and that the compiled kernels take
FLOAT64 = np.dtype(np.float64)


def check_vector(x, size: int, what: str, error=ConfigurationError) -> np.ndarray:
    """Return ``x`` as a float (size,) array, or raise ``error`` (a :class:`~wbc.exceptions.WbcError` subclass)
    saying what was wrong.

    Raises:
        error (default ConfigurationError): not numeric, wrong shape, or NaN/inf entries.
    """
    if type(x) is np.ndarray and x.dtype is FLOAT64:
        arr = x  # already a float array (np.asarray would return it)
    else:
        try:
            arr = np.asarray(x, dtype=float)
        except (TypeError, ValueError) as exc:
            raise error(f"{what} must be a ({size},) array of finite numbers, got {x!r} ({exc})") from exc
    if arr.shape != (size,):
        raise error(f"{what} must have shape ({size},), got {arr.shape}")
    # NaN/inf propagate into the sum (an overflow also lands here; the test below then finds no bad entry): a sum
    # of Python floats for a short vector, one BLAS call (ndarray.dot: no ufunc dispatch) for a long one
    if not math.isfinite(sum(arr.tolist()) if size <= 64 else arr.dot(arr)):
        bad = np.flatnonzero(~np.isfinite(arr))[:5].tolist()
        if bad:
            raise error(f"{what} must be finite; NaN/inf at indices {bad}")
    return arr


def check_scalar(x, what: str, unit: str, *, minimum: float = 0.0, strict: bool = False,
                 error=InvalidInputError) -> float:
    """Return ``x`` as a float if it is finite and ≥ ``minimum`` (> with ``strict``), else raise ``error``
    ("<what> must be finite and ≥ <minimum> (<unit>), got <x>"); a bool or a string (even "0.5") is refused."""
    try:
        v = float(x)
    except (TypeError, ValueError):
        v = math.nan
    if isinstance(x, (bool, str, bytes)) or not math.isfinite(v) or v < minimum or (strict and v == minimum):
        raise error(f"{what} must be finite and {'>' if strict else '≥'} {minimum:g} ({unit}), got {x!r}")
    return v


def check_flag(x, what: str, error=InvalidInputError) -> bool:
    """Return ``x`` as a bool if it is ``True`` or ``False`` (Python or numpy), else raise ``error``
    ("<what> must be True or False, got <x>"): 0, 1, "yes" or None are refused, not read as truth values."""
    if not isinstance(x, (bool, np.bool_)):
        raise error(f"{what} must be True or False, got {x!r}")
    return bool(x)


class Flag(property):
    """A bool attribute checked on every assignment by :func:`check_flag` (a property whose getter is
    :func:`operator.attrgetter`: no Python call per read): declared in a class body as
    ``name = Flag("what it switches")``, stored on the instance as ``_name``.

    Raises:
        InvalidInputError: on assignment of anything but True or False.
    """

    def __init__(self, doc: str):
        super().__init__(doc=doc)
        self.__doc__ = doc  # the attribute's own docstring (a property subclass would show the class's)

    def __set_name__(self, owner, name: str) -> None:
        self.name, self.slot = name, "_" + name
        slot = self.slot

        def store(obj, value) -> None:
            setattr(obj, slot, check_flag(value, name))

        property.__init__(self, operator.attrgetter(slot), store, None, self.__doc__)


class ReadOnly(property):
    """A read-only attribute (a property whose getter is :func:`operator.attrgetter`: no Python call per read),
    declared in a class body as ``name = ReadOnly("docstring")``: reading returns the instance's ``_name``, or the
    attribute named by ``attr`` (e.g. ``ReadOnly("docstring", "_buffer")``).

    Raises:
        ReadOnlyAttributeError: on assignment (a :class:`~wbc.exceptions.InvalidInputError` and an
            ``AttributeError``), naming the attribute; the object updates it itself.
    """

    def __init__(self, doc: str, attr: str | None = None):
        super().__init__(doc=doc)
        self.__doc__ = doc  # the attribute's own docstring (a property subclass would show the class's)
        self.attr = attr

    def __set_name__(self, owner, name: str) -> None:
        if self.attr is None:
            self.attr = "_" + name
        what = f"{owner.__name__}.{name}"

        def refuse(obj, value) -> None:
            raise ReadOnlyAttributeError(f"{what} is read-only: the object updates it itself; read it (copy it to "
                                         "keep a value), or change the inputs it is computed from")

        property.__init__(self, operator.attrgetter(self.attr), refuse, None, self.__doc__)


def check_count(n, what: str, minimum: int = 1, error=InvalidInputError) -> int:
    """Return ``int(n)`` if it is ≥ ``minimum``, else raise ``error`` ("<what> must be ≥ <minimum>, got <n>")."""
    if int(n) < minimum:
        raise error(f"{what} must be ≥ {minimum}, got {n!r}")
    return int(n)


def as_se3(pose, what: str = "target pose") -> pin.SE3:
    """Convert a pin.SE3 or a (4, 4) homogeneous matrix to pin.SE3 (a pin.SE3 is returned as is).

    Args:
        pose: pin.SE3 or (4, 4) homogeneous matrix (translation in m).
        what: name of the argument in the error message.

    Raises:
        InvalidTargetError: wrong type/shape, non-finite entries, or a 3×3 block that is not a rotation
            (|RᵀR − I| > 1e-6 or det R < 0).
    """
    if isinstance(pose, pin.SE3):
        mat = pose.homogeneous
    else:
        mat = np.asarray(pose, dtype=float)
        if mat.shape != (4, 4):
            raise InvalidTargetError(f"{what} must be a pin.SE3 or a (4, 4) matrix, got shape {mat.shape}")
    if not np.isfinite(mat).all():
        raise InvalidTargetError(f"{what} contains NaN/inf")
    rot = mat[:3, :3]
    if np.abs(rot.T @ rot - np.eye(3)).max() > 1e-6 or np.linalg.det(rot) < 0:
        raise InvalidTargetError(f"{what} rotation block is not a rotation matrix")
    return pose if isinstance(pose, pin.SE3) else pin.SE3(rot.copy(), mat[:3, 3].copy())


def yaw_of(pose) -> float:
    """Heading (rad) of a pose's x axis projected on the ground plane: ``atan2(R[1, 0], R[0, 0])``.

    Args:
        pose: pin.SE3 or (4, 4) homogeneous matrix (no validation: for poses the caller built or checked).
    """
    rot = pose.rotation if isinstance(pose, pin.SE3) else pose
    return math.atan2(float(rot[1, 0]), float(rot[0, 0]))


def mean_heading(a, b) -> float:
    """Heading (rad) halfway between the :func:`yaw_of` of two poses (pin.SE3 or (4, 4)): the direction of the
    sum of their unit heading vectors (undefined when they are opposite)."""
    ya, yb = yaw_of(a), yaw_of(b)
    return math.atan2(math.sin(ya) + math.sin(yb), math.cos(ya) + math.cos(yb))


def sole_corners(x: float, y: float, yaw: float, length: float, width: float) -> list[Point]:
    """Plain-Python :func:`sole_polygon` without validation: the 4 corners (m) as ``(x, y)`` tuples, CCW."""
    a, b = 0.5 * length, 0.5 * width
    c, s = math.cos(yaw), math.sin(yaw)
    return [(x + c * u - s * v, y + s * u + c * v) for u, v in ((a, b), (-a, b), (-a, -b), (a, -b))]


def sole_polygon(x: float, y: float, yaw: float, length: float, width: float) -> np.ndarray:
    """Corners of a sole rectangle centred at ``(x, y)``, rotated by ``yaw`` about the vertical.

    Args:
        x, y: rectangle centre (m).
        yaw: heading of the sole's x axis (rad, counter-clockwise from the frame's x axis).
        length: size along the sole's x axis (m, > 0).
        width: size along the sole's y axis (m, > 0).

    Returns:
        (4, 2) corners, counter-clockwise: front-left, rear-left, rear-right, front-right.

    Raises:
        InvalidInputError: non-finite input or non-positive size.
    """
    _check_sole(x, y, yaw, length, width)
    return np.array(sole_corners(x, y, yaw, length, width))


def _check_sole(x: float, y: float, yaw: float, length: float, width: float) -> None:
    vals = (x, y, yaw, length, width)
    if not all(math.isfinite(v) for v in vals):
        raise InvalidInputError(f"sole_polygon needs finite x, y, yaw, length, width; got {vals}")
    if length <= 0 or width <= 0:
        raise InvalidInputError(f"sole length and width must be > 0 m; got length={length}, width={width}")


def hull(points: list[Point]) -> list[Point]:
    """Plain-Python :func:`convex_hull` without validation: CCW hull vertices of ``(x, y)`` tuples (m); fewer
    than 3 vertices when the points are collinear."""
    pts = sorted(points)
    return _chain(pts)[:-1] + _chain(pts[::-1])[:-1]


def _chain(pts: list[Point]) -> list[Point]:
    """One half of Andrew's monotone chain over sorted ``pts``: the turn (a − o) × (p − o) ≤ 0 pops ``a``."""
    out: list[Point] = []
    n = 0
    for p in pts:
        px, py = p
        while n >= 2:
            ox, oy = out[-2]
            ax, ay = out[-1]
            if not (ax - ox) * (py - oy) - (ay - oy) * (px - ox) <= 0.0:
                break
            out.pop()
            n -= 1
        out.append(p)
        n += 1
    return out


def convex_hull(points: np.ndarray) -> np.ndarray:
    """Convex hull of planar points (Andrew's monotone chain).

    Args:
        points: (n, 2) points (m), n >= 3, finite.

    Returns:
        (k, 2) hull vertices, counter-clockwise, starting from the lowest-x (then lowest-y) point, without
        collinear vertices or a repeated first vertex.

    Raises:
        InvalidInputError: wrong shape, non-finite values, or all points collinear (no area).
    """
    pts = np.asarray(points, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 2 or pts.shape[0] < 3:
        raise InvalidInputError(f"convex_hull needs an (n, 2) array with n >= 3; got shape {pts.shape}")
    if not np.all(np.isfinite(pts)):
        raise InvalidInputError("convex_hull needs finite points; got NaN or inf")
    vertices = hull([(p[0], p[1]) for p in pts.tolist()])
    if len(vertices) < 3:
        raise InvalidInputError("convex_hull: the points are collinear, their hull has no area")
    return np.array(vertices)


def rectangle_in_polygon(polygon: np.ndarray, length: float, width: float) -> tuple[float, float]:
    """The largest rectangle of the proportions ``length`` : ``width``, centred on the origin and aligned with the
    axes (x along ``length``), inside a convex polygon: ``(s·length, s·width)`` with s the largest scale that keeps
    its four corners inside (a convex polygon holds a rectangle when it holds its corners). Each edge, with inward
    normal n and a vertex v on it (n·p ≥ n·v inside), bounds s ≤ −n·v / (|nₓ| length/2 + |n_y| width/2).

    Args:
        polygon: (k, 2) vertices of a convex polygon (m), either orientation, containing the origin.
        length, width: proportions of the rectangle (> 0).

    Returns:
        (length, width) m of the rectangle; (0, 0) when the origin is on or outside the polygon.

    Raises:
        InvalidInputError: malformed polygon (see :func:`signed_distance`), non-positive or non-finite size.
    """
    poly = _ccw_polygon(polygon)
    for value, what in ((length, "length"), (width, "width")):
        if not (math.isfinite(value) and value > 0.0):
            raise InvalidInputError(f"rectangle_in_polygon: {what} must be finite and > 0, got {value}")
    edges = np.roll(poly, -1, axis=0) - poly
    normals = np.column_stack([-edges[:, 1], edges[:, 0]])  # inward for a counter-clockwise polygon
    offsets = -np.einsum("ij,ij->i", normals, poly)  # n·p ≥ n·v  ⇔  −n·v ≥ −n·p; at p = 0: offsets ≥ 0 inside
    if np.any(offsets <= 0.0):
        return 0.0, 0.0
    reach = 0.5 * (np.abs(normals[:, 0]) * length + np.abs(normals[:, 1]) * width)
    s = float(np.min(offsets / reach))
    return s * length, s * width


def support_polygon(sole_placements, length: float, width: float) -> np.ndarray:
    """Support polygon (k, 2) (m, ground xy of the placements' frame), counter-clockwise, of soles in contact:
    the ``length`` × ``width`` sole rectangle centred on each placement, heading its :func:`yaw_of`; one sole
    gives its rectangle, several the convex hull of their rectangles.

    Args:
        sole_placements: sequence of pin.SE3 or (4, 4) sole poses (at least one).
        length, width: sole rectangle size (m, > 0).

    Raises:
        InvalidInputError: no placement, non-finite pose or non-positive size.
    """
    soles = []
    for pose in sole_placements:
        m = pose.homogeneous if isinstance(pose, pin.SE3) else np.asarray(pose, dtype=float)
        soles.append((float(m[0, 3]), float(m[1, 3]), yaw_of(m)))
        _check_sole(*soles[-1], length, width)
    if not soles:
        raise InvalidInputError("support_polygon needs at least one sole placement")
    return np.array(support_corners(soles, length, width))


def support_corners(soles, length: float, width: float) -> list[Point]:
    """Plain-Python :func:`support_polygon` without validation, from the soles' ``(x, y, yaw)`` (m, m, rad): one
    sole gives its 4 corners (:func:`sole_corners`, CCW), several the CCW :func:`hull` of all their corners, none
    an empty list."""
    corners = [c for x, y, yaw in soles for c in sole_corners(x, y, yaw, length, width)]
    return corners if len(corners) == 4 else hull(corners)


def _ccw_polygon(polygon: np.ndarray, name: str = "polygon") -> np.ndarray:
    poly = np.asarray(polygon, dtype=float)
    if poly.ndim != 2 or poly.shape[1] != 2 or poly.shape[0] < 3:
        raise InvalidInputError(f"{name} must be a (k, 2) array with k >= 3 vertices; got shape {poly.shape}")
    if not np.all(np.isfinite(poly)):
        raise InvalidInputError(f"{name} vertices must be finite; got NaN or inf")
    x, y = poly[:, 0], poly[:, 1]
    area2 = float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))
    if area2 == 0.0:
        raise InvalidInputError(f"{name} has zero area")
    return poly if area2 > 0 else poly[::-1]


def signed_distance_point(px: float, py: float, poly: list[Point]) -> float:
    """Plain-Python :func:`signed_distance` of one point ``(px, py)`` (m) to a CCW convex polygon given as a
    list of ``(x, y)`` vertex tuples, without validation (m, positive inside)."""
    best = math.inf
    outside = False
    n = len(poly)
    for i in range(n):
        x0, y0 = poly[i]
        x1, y1 = poly[(i + 1) % n]
        ex, ey = x1 - x0, y1 - y0
        rx, ry = px - x0, py - y0
        if rx * ey - ry * ex > 0.0:
            outside = True
        u = min(1.0, max(0.0, (rx * ex + ry * ey) / (ex * ex + ey * ey)))
        dx, dy = rx - u * ex, ry - u * ey
        best = min(best, dx * dx + dy * dy)
    d = math.sqrt(best)
    return -d if outside else d


def signed_distance(points: np.ndarray, polygon: np.ndarray) -> np.ndarray | float:
    """Signed Euclidean distance from points to the boundary of a convex polygon, positive inside.

    Inside, the value is the distance to the nearest edge (the margin before leaving the polygon); outside it
    is minus the distance to the nearest boundary point.

    Args:
        points: (2,) one point or (N, 2) points (m).
        polygon: (k, 2) vertices of a convex polygon, k >= 3, either orientation (e.g. from
            :func:`convex_hull` or :func:`sole_polygon`).

    Returns:
        A float for a (2,) point, else an (N,) array (m).

    Raises:
        InvalidInputError: wrong shapes, non-finite values, or a zero-area polygon.
    """
    pts = np.asarray(points, dtype=float)
    single = pts.ndim == 1
    if single:
        pts = pts[None, :]
    if pts.ndim != 2 or pts.shape[1] != 2:
        raise InvalidInputError(f"points must have shape (2,) or (N, 2); got {np.shape(points)}")
    if not np.all(np.isfinite(pts)):
        raise InvalidInputError("points must be finite; got NaN or inf")
    poly = _ccw_polygon(polygon)
    if single:
        return signed_distance_point(float(pts[0, 0]), float(pts[0, 1]), [tuple(p) for p in poly.tolist()])
    nxt = np.concatenate((poly[1:], poly[:1]))
    ex, ey = nxt[:, 0] - poly[:, 0], nxt[:, 1] - poly[:, 1]  # (k,) edges
    rx = pts[:, :1] - poly[:, 0]  # (N, k) point relative to each edge start
    ry = pts[:, 1:] - poly[:, 1]
    # Outward normal of a CCW edge (ex, ey) is (ey, -ex): positive cross means the point is outside that edge.
    outside = np.any(rx * ey - ry * ex > 0.0, axis=1)
    u = np.clip((rx * ex + ry * ey) / (ex * ex + ey * ey), 0.0, 1.0)
    dx, dy = rx - u * ex, ry - u * ey
    dist = np.sqrt(np.min(dx * dx + dy * dy, axis=1))
    return np.where(outside, -dist, dist)


def polygons_overlap(a: np.ndarray, b: np.ndarray, clearance: float = 0.0) -> bool:
    """Whether two convex polygons intersect or come closer than ``clearance`` (separating-axis test).

    Conservative for ``clearance > 0``: polygons count as overlapping unless one edge normal separates them by
    more than ``clearance`` (two corners facing each other diagonally may be reported although farther apart).

    Args:
        a, b: (k, 2) and (m, 2) convex polygons (m), either orientation.
        clearance: required gap (m, >= 0).

    Returns:
        True when no edge normal separates them by more than ``clearance`` (touching counts as overlapping).

    Raises:
        InvalidInputError: wrong shapes or non-finite values.
    """
    pa, pb = _ccw_polygon(a, "a"), _ccw_polygon(b, "b")
    for p, q in ((pa, pb), (pb, pa)):
        edge = np.roll(p, -1, axis=0) - p
        normal = np.stack([edge[:, 1], -edge[:, 0]], axis=1)
        normal /= np.linalg.norm(normal, axis=1, keepdims=True)
        # The max of p along its own outward edge normal is reached on that edge; q is separated by that
        # normal if all its vertices lie beyond.
        p_max = np.einsum("kj,kj->k", p, normal)
        q_min = np.min(q @ normal.T, axis=0)
        if np.any(q_min - p_max > clearance):
            return False
    return True


def polygon_margin(point: np.ndarray, polygon: np.ndarray) -> float:
    """Edge-line margin (m) of a (2,) point in a counter-clockwise convex polygon (m, 2): min over the edges of the
    signed distance to the edge's line, positive inside (there: the distance to the boundary, as
    :func:`signed_distance`), negative outside (there: minus the largest violation of an edge's half-plane, which
    is smaller in magnitude than the Euclidean distance of :func:`signed_distance` near a vertex). No validation."""
    px, py = float(point[0]), float(point[1])
    poly = polygon.tolist() if isinstance(polygon, np.ndarray) else polygon
    d = math.inf
    ax, ay = poly[-1]
    for bx, by in poly:  # edges (last, first), (first, second), ...: the same set as (i, i + 1 mod m)
        ex, ey = bx - ax, by - ay
        # inward normal (ccw) (−e_y, e_x)/|e| dotted with (point − a)
        d = min(d, (ex * (py - ay) - ey * (px - ax)) / math.sqrt(ex * ex + ey * ey))
        ax, ay = bx, by
    return d


def closest_point_in_polygon(point: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    """Closest point (2,) of a counter-clockwise convex polygon (m, 2) to a (2,) ``point`` (m): the point itself
    when inside (:func:`polygon_margin` ≥ 0), else its projection on the nearest edge. No validation."""
    if polygon_margin(point, polygon) >= 0:
        return point
    best, dbest = point, np.inf
    for i in range(len(polygon)):
        a, b = polygon[i], polygon[(i + 1) % len(polygon)]
        e = b - a
        s = min(max(float((point - a) @ e / (e @ e)), 0.0), 1.0)
        p = a + s * e
        dd = float(np.linalg.norm(point - p))
        if dd < dbest:
            best, dbest = p, dd
    return best


def projected_sole_corners(pose: pin.SE3, length: float, width: float) -> np.ndarray:
    """(4, 2) ground projection (m, world xy) of the corners of the ``length`` × ``width`` sole rectangle centred
    on a (possibly tilted) sole pose, in the order of :func:`sole_polygon` (front-left, rear-left, rear-right,
    front-right; CCW when the sole is not upside down). For a level sole this is :func:`sole_polygon` at the
    pose's (x, y, yaw). No validation."""
    a, b = 0.5 * length, 0.5 * width
    c = np.array([[a, b, 0.0], [-a, b, 0.0], [-a, -b, 0.0], [a, -b, 0.0]])
    return (c @ pose.rotation.T + pose.translation)[:, :2]
