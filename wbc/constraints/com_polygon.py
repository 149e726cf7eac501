"""Static balance: the CoM ground projection stays inside the support polygon shrunk by a margin.

The support polygon is the convex hull of the sole rectangles (``robot.sole_length`` × ``robot.sole_width``,
centred on each sole frame, heading = the sole's yaw; :func:`wbc.geometry.support_polygon`). Written as half-planes n_iᵀ x ≤ d_i (n_i the unit outward normal of edge
i), the shrunk polygon is n_iᵀ x ≤ d_i − margin. Over one period the CoM moves to c + J_com v dt (first order), so
each edge gives the row

    n_iᵀ J_com,xy v ≤ u_i,   u_i = max((d_i − margin − n_iᵀ c_xy) / dt,  −recovery_speed)      (m/s)

When the CoM is inside, u_i ≥ 0 and the step lands inside (on the boundary when the row is active). When it is
already outside edge i, u_i < 0 asks it to move back towards the inside at no more than ``recovery_speed`` along
n_i, like the recoverable joint limits, instead of demanding an impossible one-tick jump. The rows stay
satisfiable in CoM-velocity space: for any interior point x0 every violated edge has n_i·(c − x0) > 0, so a CoM
velocity −α (c_xy − x0) with α large enough satisfies all of them at once.

The row count is fixed (4 × ``max_soles``): unused rows are 0 ≤ +inf.

Acceleration level (:meth:`ComPolygonConstraint.barrier`, held by :class:`wbc.constraints.barrier.AccelerationBarrier`):
h_i = d_i − margin − n_iᵀ c_xy ≥ 0 (m), G_i = −n_iᵀ J_com,xy, drift −n_iᵀ c̈_xy at v̇ = 0 (``DynamicsState.com_drift``).
"""

from __future__ import annotations

import numpy as np

from wbc.configuration import Configuration
from wbc.constraints.base import InequalityConstraint
from wbc.exceptions import InvalidInputError
from wbc.geometry import as_se3, check_count, check_scalar, support_polygon

__all__ = ["ComPolygonConstraint", "halfplanes"]


def halfplanes(polygon: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(k, 2) unit outward normals n and (k,) offsets d of a counter-clockwise convex polygon (k, 2):
    the polygon is {x : n_i·x ≤ d_i for all i}."""
    edge = np.roll(polygon, -1, axis=0) - polygon
    normal = np.stack([edge[:, 1], -edge[:, 0]], axis=1)
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    return normal, np.einsum("ij,ij->i", normal, polygon)


class ComPolygonConstraint(InequalityConstraint):
    """Keep the CoM ground projection inside the support polygon shrunk by ``margin`` (module docstring).

    Args:
        robot: the robot (sole size from ``robot.sole_length``, ``robot.sole_width``).
        margin: inward shrink of the polygon (m, ≥ 0).
        recovery_speed: largest inward CoM speed (m/s, > 0) demanded when the CoM is outside the shrunk polygon.
        max_soles: most soles ever passed to :meth:`set_support` (sets the row count 4 × max_soles).
        name: label in reports.

    Call :meth:`set_support` before the first solve (until then every row is inactive).

    Raises:
        InvalidInputError: negative margin, non-positive recovery speed or max_soles < 1.
    """

    def __init__(self, robot, *, margin: float = 0.01, recovery_speed: float = 0.05, max_soles: int = 2,
                 name: str = "com_polygon"):
        self.margin = check_scalar(margin, "margin", "m")
        self.recovery_speed = check_scalar(recovery_speed, "recovery_speed", "m/s", strict=True)
        self.max_soles = check_count(max_soles, "max_soles")
        self.robot, self.name = robot, name
        self.dim = 4 * self.max_soles
        self.polygon = np.zeros((0, 2))
        self.normals = np.zeros((0, 2))
        self.offsets = np.zeros(0)
        self._C = np.zeros((self.dim, robot.model.nv))
        self._l = np.full(self.dim, -np.inf)
        self._u = np.full(self.dim, np.inf)

    def set_support(self, sole_placements) -> None:
        """Support polygon = hull of the sole rectangles at these world placements (pin.SE3 or (4, 4) each; the
        rectangle is centred on the frame origin, heading its x-axis yaw).

        Raises:
            InvalidInputError: no sole, more than ``max_soles``, malformed pose, or a polygon too small for the
                margin (its shrunk version is empty).
        """
        poses = [as_se3(p, "sole placement") for p in sole_placements]
        if not 1 <= len(poses) <= self.max_soles:
            raise InvalidInputError(f"set_support needs 1..{self.max_soles} sole placements, got {len(poses)}")
        poly = support_polygon(poses, self.robot.sole_length, self.robot.sole_width)
        normals, offsets = halfplanes(poly)
        if not _contains_disc(normals, offsets, poly, self.margin):
            raise InvalidInputError(f"{self.name}: support polygon is too small for margin {self.margin} m")
        self.polygon, self.normals, self.offsets = poly, normals, offsets
        self._C[len(offsets):] = 0.0
        self._u[len(offsets):] = np.inf

    def compute(self, config: Configuration, dt: float):
        """(C (dim, nv), l, u) of the module docstring; rows beyond the polygon's edge count are 0 ≤ +inf."""
        k = len(self.offsets)
        if k:
            C, u = self._C, self._u
            np.matmul(self.normals, config.com_jacobian[:2], out=C[:k])
            slack = self.offsets - self.margin - self.normals @ config.com[:2]
            u[:k] = np.maximum(slack / dt, -self.recovery_speed)
        return self._C, self._l, self._u

    def barrier(self, state, dt: float):
        """(h (dim,) m, G (dim, nv), Ġv (dim,) m/s²) of the module docstring at a DynamicsState; h = +inf on the
        rows beyond the polygon's edge count."""
        k = len(self.offsets)
        h = np.full(self.dim, np.inf)
        G = np.zeros((self.dim, state.model.nv))
        drift = np.zeros(self.dim)
        if k:
            h[:k] = self.offsets - self.margin - self.normals @ state.com[:2]
            G[:k] = -(self.normals @ state.com_jacobian[:2])
            drift[:k] = -(self.normals @ state.com_drift[:2])
        return h, G, drift

    def shrunk_distance(self, point_xy) -> float:
        """Signed distance (m, > 0 inside) from a ground point to the nearest edge line of the shrunk polygon:
        min_i (d_i − margin − n_i·x)."""
        return float(np.min(self.offsets - self.margin - self.normals @ np.asarray(point_xy, dtype=float)))


def _contains_disc(normals: np.ndarray, offsets: np.ndarray, poly: np.ndarray, radius: float) -> bool:
    """Whether the polygon contains a disc of ``radius`` (m): checked at the vertex centroid first, else at the
    Chebyshev centre (a 3-variable LP, only for thin polygons)."""
    if float(np.min(offsets - normals @ poly.mean(axis=0))) > radius:
        return True
    from scipy.optimize import linprog

    res = linprog([0, 0, -1], A_ub=np.hstack([normals, np.ones((len(offsets), 1))]), b_ub=offsets,
                  bounds=[(None, None), (None, None), (0, None)], method="highs")
    return res.status == 0 and -res.fun > radius
