"""Terrain: the ground geometry shared by the planner, the controller, the plant and the viewer.

A :class:`Terrain` is a horizontal base plane ``z = floor_z`` plus a list of solid boxes (:class:`Box`, any
orientation whose top face points up) plus an optional :class:`Heightfield`. The ground height at ``(x, y)`` is
the highest of the three there; the surface normal is the one of the part that gives the height.

Frames and units: world frame, z up, metres and radians. The robot starts at the origin on ``z = 0`` for every
built-in terrain (stairs down start from a platform at ``z = 0``, the base plane being ``N · rise`` below).

Textual descriptions (:func:`parse_terrain`, the ``--terrain`` option of the command line):

* ``flat``: the plane ``z = 0``.
* ``stairs:RISE:TREAD:N[:up|down|updown]``: ``N`` steps of ``RISE`` m rise and ``TREAD`` m tread along +x, the
  first riser at ``x = max(TREAD / 2, 0.2)``, 2 m wide (``|y| <= 1``). ``up`` (default) ends on a 1.5 m landing (then a drop to the floor);
  ``down`` starts on a platform at ``z = 0`` and ends on the base plane ``z = −N · RISE``; ``updown`` climbs, crosses
  a ``3 · TREAD`` landing and descends back to ``z = 0``.
* ``slope:DEG[:LENGTH]``: a ramp up at ``DEG`` degrees over ``LENGTH`` m (horizontal, default 2) starting at
  ``x = 0.3``, a 1 m plateau, and a ramp down at the same angle back to ``z = 0``.
* ``rough:AMPLITUDE:SEED``: a heightfield of 0.1 m cells over ``x ∈ [−1, 12]``, ``y ∈ [−1.5, 1.5]`` with node
  heights uniform in ``[−AMPLITUDE, AMPLITUDE]`` (numpy ``default_rng(SEED)``), 0 for ``x <= 0.4`` (the start
  area), linear on two triangles per cell as MuJoCo's ``hfield``; the base plane is 5 cm below the lowest possible node.
* a ``.json`` or ``.toml`` file: ``floor_z`` (m, default 0), ``boxes`` (a list of tables with ``center`` [x, y, z]
  and ``size`` [lx, ly, lz] in m, full edge lengths, and optional ``rpy_deg`` [roll, pitch, yaw] in degrees), and
  an optional ``heightfield`` table (``origin`` [x0, y0] m of node (0, 0), ``spacing`` m, ``heights`` a list of
  rows, row i at ``y0 + i · spacing``, column j at ``x0 + j · spacing``).
"""

from __future__ import annotations

import json
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from wbc.exceptions import TerrainError

__all__ = ["Box", "Heightfield", "Terrain", "parse_terrain", "TERRAIN_KINDS", "FLOOR", "HEIGHTFIELD", "EDGE_HEIGHT"]

#: The textual kinds :func:`parse_terrain` accepts (a file path is accepted too).
TERRAIN_KINDS = ("flat", "stairs:RISE:TREAD:N[:up|down|updown]", "slope:DEG[:LENGTH]", "rough:AMPLITUDE:SEED",
                 "FILE.json|FILE.toml")
FLOOR = -1  #: :meth:`Terrain.part_at` index of the base plane
HEIGHTFIELD = -2  #: :meth:`Terrain.part_at` index of the heightfield

EDGE_HEIGHT = 0.02  #: m: ground this far above a landing surface's plane is a step edge (swing_clearance)
_MAX_TILT = math.radians(60.0)  # a box top face steeper than this is a wall, not ground


def _rpy_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    cr, sr, cp, sp, cy, sy = (math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch), math.cos(yaw),
                              math.sin(yaw))
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


@dataclass(frozen=True)
class Box:
    """A solid box of the terrain.

    Attributes:
        center: (3,) centre (m, world).
        size: (3,) full edge lengths (m) along the box's own x, y, z axes, each > 0.
        rotation: (3, 3) world ← box rotation; its z axis must point up within 60° (the top face is ground).
    """

    center: np.ndarray
    size: np.ndarray
    rotation: np.ndarray = field(default_factory=lambda: np.eye(3))

    def __post_init__(self):
        c = np.asarray(self.center, dtype=float)
        s = np.asarray(self.size, dtype=float)
        r = np.asarray(self.rotation, dtype=float)
        if c.shape != (3,) or not np.isfinite(c).all():
            raise TerrainError(f"box center must be 3 finite numbers (m); got {self.center!r}")
        if s.shape != (3,) or not (np.isfinite(s).all() and (s > 0).all()):
            raise TerrainError(f"box size must be 3 finite numbers > 0 (m, full edge lengths); got {self.size!r}")
        if r.shape != (3, 3) or not np.isfinite(r).all() or np.abs(r.T @ r - np.eye(3)).max() > 1e-9 \
                or np.linalg.det(r) < 0:
            raise TerrainError("box rotation must be a (3, 3) rotation matrix")
        if r[2, 2] < math.cos(_MAX_TILT):
            raise TerrainError(f"box top face tilted by {math.degrees(math.acos(max(-1.0, r[2, 2]))):.1f} deg; "
                               f"valid: at most {math.degrees(_MAX_TILT):.0f} deg from horizontal")
        for name, a in (("center", c), ("size", s), ("rotation", r)):
            a = a.copy()
            a.flags.writeable = False
            object.__setattr__(self, name, a)

    @property
    def top_center(self) -> np.ndarray:
        """(3,) centre of the top face (m, world)."""
        return self.center + 0.5 * self.size[2] * self.rotation[:, 2]

    @property
    def normal(self) -> np.ndarray:
        """(3,) unit normal of the top face (world)."""
        return self.rotation[:, 2].copy()

    def top_height(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Height (m) of the top face's plane over ``(x, y)`` (arrays of one shape), ``-inf`` outside the face."""
        n, ct = self.rotation[:, 2], self.top_center
        z = ct[2] - (n[0] * (x - ct[0]) + n[1] * (y - ct[1])) / n[2]
        d = np.stack([x - ct[0], y - ct[1], z - ct[2]], axis=-1)
        u = d @ self.rotation[:, 0]
        w = d @ self.rotation[:, 1]
        inside = (np.abs(u) <= 0.5 * self.size[0] + 1e-12) & (np.abs(w) <= 0.5 * self.size[1] + 1e-12)
        return np.where(inside, z, -np.inf)


@dataclass(frozen=True)
class Heightfield:
    """A heightfield on a regular grid, linear on two triangles per cell (MuJoCo's ``hfield`` triangulation).

    Attributes:
        origin: (2,) world xy (m) of node (0, 0).
        spacing: distance between nodes (m, > 0), equal in x and y.
        heights: (ny, nx) node heights (m, world z); row i at ``y = origin[1] + i · spacing``, column j at
            ``x = origin[0] + j · spacing``; at least 2 × 2.
    """

    origin: np.ndarray
    spacing: float
    heights: np.ndarray

    def __post_init__(self):
        o = np.asarray(self.origin, dtype=float)
        h = np.asarray(self.heights, dtype=float)
        if o.shape != (2,) or not np.isfinite(o).all():
            raise TerrainError(f"heightfield origin must be 2 finite numbers (m); got {self.origin!r}")
        if not (isinstance(self.spacing, (int, float)) and math.isfinite(self.spacing) and self.spacing > 0):
            raise TerrainError(f"heightfield spacing must be a finite number > 0 (m); got {self.spacing!r}")
        if h.ndim != 2 or min(h.shape) < 2 or not np.isfinite(h).all():
            raise TerrainError(f"heightfield heights must be a finite (ny, nx) grid with ny, nx >= 2; got shape "
                               f"{h.shape}")
        o.flags.writeable = h.flags.writeable = False
        object.__setattr__(self, "origin", o)
        object.__setattr__(self, "heights", h)
        object.__setattr__(self, "spacing", float(self.spacing))

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """``(x_min, x_max, y_min, y_max)`` of the grid (m)."""
        ny, nx = self.heights.shape
        return (float(self.origin[0]), float(self.origin[0] + (nx - 1) * self.spacing),
                float(self.origin[1]), float(self.origin[1] + (ny - 1) * self.spacing))

    def _cell(self, x, y):
        ny, nx = self.heights.shape
        gx = (x - self.origin[0]) / self.spacing
        gy = (y - self.origin[1]) / self.spacing
        inside = (gx >= 0) & (gx <= nx - 1) & (gy >= 0) & (gy <= ny - 1)
        j = np.clip(np.floor(gx).astype(int), 0, nx - 2)
        i = np.clip(np.floor(gy).astype(int), 0, ny - 2)
        return inside, i, j, gx - j, gy - i

    def height(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Height (m) at ``(x, y)``, ``-inf`` outside the grid: linear on the two triangles of each cell, split
        along the diagonal from node ``(i, j)`` to ``(i + 1, j + 1)`` (MuJoCo's triangulation of an ``hfield``)."""
        inside, i, j, fx, fy = self._cell(x, y)
        h = self.heights
        h00, h01, h10, h11 = h[i, j], h[i, j + 1], h[i + 1, j], h[i + 1, j + 1]  # 01: +x neighbour, 10: +y
        lower = fx >= fy
        z = np.where(lower, h00 + fx * (h01 - h00) + fy * (h11 - h01), h00 + fy * (h10 - h00) + fx * (h11 - h10))
        return np.where(inside, z, -np.inf)

    def gradient(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(∂z/∂x, ∂z/∂y)`` of the triangle under ``(x, y)`` (0 outside the grid)."""
        inside, i, j, fx, fy = self._cell(x, y)
        h, d = self.heights, self.spacing
        h00, h01, h10, h11 = h[i, j], h[i, j + 1], h[i + 1, j], h[i + 1, j + 1]
        lower = fx >= fy
        gx = np.where(lower, h01 - h00, h11 - h10) / d
        gy = np.where(lower, h11 - h01, h10 - h00) / d
        return np.where(inside, gx, 0.0), np.where(inside, gy, 0.0)


@dataclass(frozen=True)
class Terrain:
    """The ground: base plane ``z = floor_z``, boxes and an optional heightfield (module docstring).

    Attributes:
        name: the description it was built from (e.g. ``"stairs:0.1:0.3:3:up"``).
        floor_z: height of the base plane (m).
        boxes: tuple of :class:`Box`.
        heightfield: a :class:`Heightfield` or None.
        treads: for stairs, ``(x_start, x_end, z)`` of each flat tread along +x in walking order (m); empty for
            other terrains (informative: the planner works from :meth:`height` and :meth:`normal` alone).
        end_x: x (m) from which a walk along +x has crossed the terrain's features (stairs up: the top landing;
            down and updown: the floor after the last step; slope: the foot of the ramp down); None when the
            terrain has no such end (flat, rough, a file).
    """

    name: str = "flat"
    floor_z: float = 0.0
    boxes: tuple[Box, ...] = ()
    heightfield: Heightfield | None = None
    treads: tuple[tuple[float, float, float], ...] = ()
    end_x: float | None = None

    def __post_init__(self):
        if not (isinstance(self.floor_z, (int, float)) and math.isfinite(self.floor_z)):
            raise TerrainError(f"floor_z must be a finite number (m); got {self.floor_z!r}")
        if not all(isinstance(b, Box) for b in self.boxes):
            raise TerrainError("boxes must be wbc.terrain.Box objects")
        object.__setattr__(self, "boxes", tuple(self.boxes))

    @property
    def is_flat(self) -> bool:
        """True for the plane ``z = 0`` alone (the flat-ground walk applies unchanged)."""
        return self.floor_z == 0.0 and not self.boxes and self.heightfield is None

    def _parts(self, x, y) -> np.ndarray:
        """(P, ...) heights of every part at the points: base plane, boxes, heightfield."""
        parts = [np.full(np.shape(x), float(self.floor_z))]
        parts += [b.top_height(x, y) for b in self.boxes]
        if self.heightfield is not None:
            parts.append(self.heightfield.height(x, y))
        return np.stack(parts)

    def height(self, x, y) -> np.ndarray | float:
        """Ground height (m, world z) at ``(x, y)`` (m; scalars or arrays of one shape, broadcast)."""
        x, y = np.broadcast_arrays(np.asarray(x, dtype=float), np.asarray(y, dtype=float))
        z = self._parts(x, y).max(axis=0)
        return float(z) if z.ndim == 0 else z

    def part_at(self, x: float, y: float) -> int:
        """Which part gives the height at the point ``(x, y)``: a box index, :data:`FLOOR` or :data:`HEIGHTFIELD`
        (the first of equal heights, boxes before the heightfield, the base plane last)."""
        parts = self._parts(np.asarray(float(x)), np.asarray(float(y)))
        top = parts.max()
        order = list(range(1, len(parts))) + [0]
        k = next(k for k in order if parts[k] >= top - 1e-12)
        if k == 0:
            return FLOOR
        if k <= len(self.boxes):
            return k - 1
        return HEIGHTFIELD

    def normal(self, x: float, y: float) -> np.ndarray:
        """(3,) unit upward normal of the ground at the point ``(x, y)`` (world): the top face of the box that gives
        the height, the heightfield's ``(−∂z/∂x, −∂z/∂y, 1)`` normalised, or ``(0, 0, 1)`` on the base plane."""
        k = self.part_at(x, y)
        if k == FLOOR:
            return np.array([0.0, 0.0, 1.0])
        if k == HEIGHTFIELD:
            gx, gy = self.heightfield.gradient(np.asarray(float(x)), np.asarray(float(y)))
            n = np.array([-float(gx), -float(gy), 1.0])
            return n / np.linalg.norm(n)
        return self.boxes[k].normal

    def sole_support(self, x: float, y: float, yaw: float, length: float, width: float, margin: float = 0.0,
                     n: int = 9) -> float:
        """Largest gap (m) between the ground and the plane of the ground under the sole centre, over a grid of
        ``n × n`` points of the sole rectangle grown by ``margin`` on every side.

        A sole of ``length × width`` (m) centred at ``(x, y)`` with heading ``yaw`` (rad) lies fully on one planar
        surface, at least ``margin`` (m) from its edges, when the result is ~0 (a step edge under or beside the
        sole gives the rise; overhanging a tread gives the drop).
        """
        nrm = self.normal(x, y)
        z0 = self.height(x, y)
        u = np.linspace(-0.5 * length - margin, 0.5 * length + margin, n)
        w = np.linspace(-0.5 * width - margin, 0.5 * width + margin, n)
        U, W = np.meshgrid(u, w)
        c, s = math.cos(yaw), math.sin(yaw)
        px, py = x + c * U - s * W, y + s * U + c * W
        plane = z0 - (nrm[0] * (px - x) + nrm[1] * (py - y)) / nrm[2]
        return float(np.abs(self.height(px, py) - plane).max())


    def swing_clearance(self, poses: np.ndarray, start_xy: np.ndarray, land_xy: np.ndarray, length: float,
                        width: float, approach: float) -> float:
        """Smallest height (m) of a swinging sole's underside above the ground, away from lift-off and touch-down.

        The sole rectangle ``length × width`` (m, centred on the sole frame, in its xy plane) is sampled at 5 × 3
        points (corners, edge midpoints, centre) at every pose of ``poses``; a pose counts when its origin is more
        than ``approach`` m (horizontally) from both ``start_xy`` and ``land_xy``, so the vertical lift-off
        and touch-down near the footholds are not counted, the crossing of step edges in between is. Given a 3-D
        ``land_xy`` (``start_xy``), the points of a pose near the landing (lift-off) still count over ground more
        than :data:`EDGE_HEIGHT` above the plane of the landing (lift-off) surface: the edge of the tread a foot
        steps down from, the riser just ahead of a toe stepping up.

        Args:
            poses: (n, 4, 4) world poses of the sole frame along the swing.
            start_xy, land_xy: (2,) lift-off position, (2,) or (3,) landing position of the sole origin (m, world).

        Returns:
            The minimum of ``z(point) − height(x, y of point)`` over the counted poses; ``inf`` when none counts.
        """
        P = np.asarray(poses, dtype=float)
        c = P[:, :2, 3]
        start, land = np.asarray(start_xy, dtype=float), np.asarray(land_xy, dtype=float)
        near_start = np.linalg.norm(c - start[:2], axis=1) <= approach
        near_land = np.linalg.norm(c - land[:2], axis=1) <= approach
        u, w = np.meshgrid(np.linspace(-0.5 * length, 0.5 * length, 5), np.linspace(-0.5 * width, 0.5 * width, 3))
        local = np.stack([u.ravel(), w.ravel(), np.zeros(u.size)])  # (3, 15)
        pts = np.matmul(P[:, :3, :3], local) + P[:, :3, 3:4]  # (n, 3, 15)
        ground = self.height(pts[:, 0], pts[:, 1])
        count = np.ones(ground.shape, dtype=bool)
        for foothold, near in ((start, near_start), (land, near_land)):
            if len(foothold) == 3:  # near the foothold: ground above its surface's plane (an edge) still counts
                n = self.normal(float(foothold[0]), float(foothold[1]))
                plane = foothold[2] - (n[0] * (pts[:, 0] - foothold[0]) + n[1] * (pts[:, 1] - foothold[1])) / n[2]
                count[near] &= ground[near] > plane[near] + EDGE_HEIGHT
            else:
                count[near] = False
        if not count.any():
            return math.inf
        return float((pts[:, 2] - ground)[count].min())


# ----------------------------------------------------------------------------------------------------- parsing
def _num(text: str, what: str, lo: float, hi: float, spec: str, *, lo_open: bool = False) -> float:
    try:
        v = float(text)
    except ValueError:
        raise TerrainError(f"terrain {spec!r}: {what} must be a number; got {text!r}") from None
    if not (math.isfinite(v) and (v > lo if lo_open else v >= lo) and v <= hi):
        raise TerrainError(f"terrain {spec!r}: {what} = {text} is out of range (valid: {lo:g} "
                           f"{'<' if lo_open else '<='} {what} <= {hi:g})")
    return v


def _int(text: str, what: str, lo: int, hi: int, spec: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise TerrainError(f"terrain {spec!r}: {what} must be an integer; got {text!r}") from None
    if not lo <= v <= hi:
        raise TerrainError(f"terrain {spec!r}: {what} = {v} is out of range (valid: {lo} <= {what} <= {hi})")
    return v


_WIDTH = 2.0  # m, width (y) of the stairs and ramps


def _flat_box(x0: float, x1: float, z_bottom: float, z_top: float) -> Box:
    return Box([0.5 * (x0 + x1), 0.0, 0.5 * (z_bottom + z_top)], [x1 - x0, _WIDTH, z_top - z_bottom])


def stairs(rise: float, tread: float, n: int, direction: str = "up") -> Terrain:
    """Straight stairs along +x (module docstring): ``n`` steps of ``rise`` × ``tread`` m, ``direction`` ``"up"``,
    ``"down"`` or ``"updown"``.

    Raises:
        TerrainError: a non-positive rise or tread, ``n < 1`` or an unknown direction.
    """
    if not (rise > 0 and tread > 0 and n >= 1) or direction not in ("up", "down", "updown"):
        raise TerrainError(f"stairs need rise > 0, tread > 0, n >= 1 and direction up|down|updown; got {rise}, "
                           f"{tread}, {n}, {direction!r}")
    x0 = max(0.5 * tread, 0.2)
    landing = 1.5
    boxes, treads = [], [(-math.inf, x0, 0.0)]
    name = f"stairs:{rise:g}:{tread:g}:{n}:{direction}"
    if direction == "down":
        floor = -n * rise
        boxes.append(_flat_box(-2.0, x0, floor, 0.0))
        for i in range(1, n):
            a = x0 + (i - 1) * tread
            boxes.append(_flat_box(a, a + tread, floor, -i * rise))
            treads.append((a, a + tread, -i * rise))
        treads.append((x0 + (n - 1) * tread, math.inf, floor))
        return Terrain(name, floor, tuple(boxes), None, tuple(treads), end_x=treads[-1][0])
    top_len = landing if direction == "up" else 3.0 * tread
    for i in range(1, n + 1):
        a = x0 + (i - 1) * tread
        b = a + (top_len if i == n else tread)
        boxes.append(_flat_box(a, b, 0.0, i * rise))
        treads.append((a, b, i * rise))
    if direction == "updown":
        a = x0 + (n - 1) * tread + top_len
        for i in range(n - 1, 0, -1):
            boxes.append(_flat_box(a, a + tread, 0.0, i * rise))
            treads.append((a, a + tread, i * rise))
            a += tread
        treads.append((a, math.inf, 0.0))
        end = a
    else:
        end = treads[-1][0]  # the top landing
        treads.append((treads[-1][1], math.inf, 0.0))  # beyond the landing: the floor
    return Terrain(name, 0.0, tuple(boxes), None, tuple(treads), end_x=end)


def slope(degrees: float, length: float = 2.0) -> Terrain:
    """A ramp up at ``degrees`` over ``length`` m (horizontal) from ``x = 0.3``, a 1 m plateau, a ramp down.

    Raises:
        TerrainError: ``degrees`` outside (0, 30] or ``length`` outside (0, 20].
    """
    if not (0 < degrees <= 30 and 0 < length <= 20):
        raise TerrainError(f"slope needs 0 < degrees <= 30 and 0 < length <= 20 m; got {degrees}, {length}")
    th = math.radians(degrees)
    x0, plateau, thick = 0.3, 1.0, 0.1
    top = length * math.tan(th)
    half_face = 0.5 * length / math.cos(th)
    boxes = []
    for x_mid, z_mid, pitch in ((x0 + 0.5 * length, 0.5 * top, -th),
                                (x0 + 1.5 * length + plateau, 0.5 * top, th)):
        rot = _rpy_matrix(0.0, pitch, 0.0)  # pitch < 0 about y raises the +x end
        center = np.array([x_mid, 0.0, z_mid]) - 0.5 * thick * rot[:, 2]
        boxes.append(Box(center, [2 * half_face, _WIDTH, thick], rot))
    boxes.insert(1, _flat_box(x0 + length, x0 + length + plateau, 0.0, top))
    return Terrain(f"slope:{degrees:g}:{length:g}", 0.0, tuple(boxes), end_x=x0 + 2 * length + plateau)


def rough(amplitude: float, seed: int) -> Terrain:
    """Random heightfield (module docstring), node heights uniform in ``[−amplitude, amplitude]``.

    Raises:
        TerrainError: ``amplitude`` outside [0, 0.1] m or a negative seed.
    """
    if not (0 <= amplitude <= 0.1) or seed < 0:
        raise TerrainError(f"rough needs 0 <= amplitude <= 0.1 m and seed >= 0; got {amplitude}, {seed}")
    d = 0.1
    xs = np.arange(-1.0, 12.0 + 1e-9, d)
    ys = np.arange(-1.5, 1.5 + 1e-9, d)
    h = np.random.default_rng(int(seed)).uniform(-amplitude, amplitude, (len(ys), len(xs)))
    h[:, xs <= 0.4 + 1e-9] = 0.0
    return Terrain(f"rough:{amplitude:g}:{seed}", -amplitude - 0.05, (), Heightfield(np.array([xs[0], ys[0]]), d, h))


def _from_file(path: Path, spec: str) -> Terrain:
    try:
        raw = path.read_bytes()
        data = tomllib.loads(raw.decode()) if path.suffix == ".toml" else json.loads(raw)
    except OSError as exc:
        raise TerrainError(f"terrain file {spec!r} cannot be read: {exc.strerror}") from None
    except (tomllib.TOMLDecodeError, json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise TerrainError(f"terrain file {spec!r} is not valid {path.suffix[1:].upper()}: {exc}") from None
    if not isinstance(data, dict):
        raise TerrainError(f"terrain file {spec!r}: the top level must be a table with floor_z, boxes, heightfield")
    unknown = set(data) - {"floor_z", "boxes", "heightfield"}
    if unknown:
        raise TerrainError(f"terrain file {spec!r}: unknown key(s) {sorted(unknown)} (valid: floor_z, boxes, "
                           "heightfield)")
    boxes = []
    for i, b in enumerate(data.get("boxes", [])):
        if not isinstance(b, dict) or not {"center", "size"} <= set(b) or set(b) - {"center", "size", "rpy_deg"}:
            raise TerrainError(f"terrain file {spec!r}: boxes[{i}] must be a table with center, size and optional "
                               f"rpy_deg; got {b!r}")
        try:
            rpy = [math.radians(float(a)) for a in b.get("rpy_deg", [0.0, 0.0, 0.0])]
            if len(rpy) != 3:
                raise ValueError
            boxes.append(Box(np.array(b["center"], dtype=float), np.array(b["size"], dtype=float),
                             _rpy_matrix(*rpy)))
        except (TypeError, ValueError) as exc:
            detail = str(exc) if isinstance(exc, TerrainError) else "numbers expected (rpy_deg: 3 of them)"
            raise TerrainError(f"terrain file {spec!r}: boxes[{i}]: {detail}") from None
    hf = None
    if "heightfield" in data:
        t = data["heightfield"]
        if not isinstance(t, dict) or set(t) != {"origin", "spacing", "heights"}:
            raise TerrainError(f"terrain file {spec!r}: heightfield must be a table with origin, spacing, heights")
        try:
            hf = Heightfield(np.array(t["origin"], dtype=float), t["spacing"], np.array(t["heights"], dtype=float))
        except (TypeError, ValueError) as exc:
            detail = str(exc) if isinstance(exc, TerrainError) else "numbers expected"
            raise TerrainError(f"terrain file {spec!r}: heightfield: {detail}") from None
    floor = data.get("floor_z", 0.0)
    if isinstance(floor, bool) or not isinstance(floor, (int, float)):
        raise TerrainError(f"terrain file {spec!r}: floor_z must be a number (m); got {floor!r}")
    return Terrain(str(path), float(floor), tuple(boxes), hf)


def parse_terrain(spec: str | Terrain) -> Terrain:
    """Build a :class:`Terrain` from its description (module docstring); a :class:`Terrain` is returned as is.

    Raises:
        TerrainError: an unknown kind, a wrong number of fields, a number out of range (the message names the
            field and its valid range), or an unreadable / malformed file.
    """
    if isinstance(spec, Terrain):
        return spec
    if not isinstance(spec, str) or not spec.strip():
        raise TerrainError(f"terrain must be a non-empty string; got {spec!r} (valid: {', '.join(TERRAIN_KINDS)})")
    s = spec.strip()
    if s.endswith((".json", ".toml")):
        return _from_file(Path(s), s)
    kind, *fields = s.split(":")
    if kind == "flat":
        if fields:
            raise TerrainError(f"terrain {s!r}: flat takes no parameters")
        return Terrain("flat")
    if kind == "stairs":
        if len(fields) not in (3, 4):
            raise TerrainError(f"terrain {s!r}: expected stairs:RISE:TREAD:N[:up|down|updown]")
        rise = _num(fields[0], "RISE", 0.0, 0.5, s, lo_open=True)
        tread = _num(fields[1], "TREAD", 0.05, 2.0, s, lo_open=True)
        n = _int(fields[2], "N", 1, 100, s)
        direction = fields[3] if len(fields) == 4 else "up"
        if direction not in ("up", "down", "updown"):
            raise TerrainError(f"terrain {s!r}: direction {direction!r} is not one of up, down, updown")
        return stairs(rise, tread, n, direction)
    if kind == "slope":
        if len(fields) not in (1, 2):
            raise TerrainError(f"terrain {s!r}: expected slope:DEG[:LENGTH]")
        deg = _num(fields[0], "DEG", 0.0, 30.0, s, lo_open=True)
        length = _num(fields[1], "LENGTH", 0.0, 20.0, s, lo_open=True) if len(fields) == 2 else 2.0
        return slope(deg, length)
    if kind == "rough":
        if len(fields) != 2:
            raise TerrainError(f"terrain {s!r}: expected rough:AMPLITUDE:SEED")
        return rough(_num(fields[0], "AMPLITUDE", 0.0, 0.1, s), _int(fields[1], "SEED", 0, 2**31 - 1, s))
    raise TerrainError(f"unknown terrain {s!r} (valid: {', '.join(TERRAIN_KINDS)})")
