"""Executed-motion metrics shared by the walk and balance summaries.

The ZMP reported by a summary is the ZMP of the motion the robot EXECUTED, not of the plan. Row k of a run is the
configuration q_k at the start of tick k and v_k the command applied over [t_k, t_k + dt] (q_{k+1} = q_k ⊕ v_k dt).

* CoM c_k of q_k (``Configuration.com``); its acceleration is the central second finite difference of that
  executed CoM, c̈_k = (c_{k+1} − 2 c_k + c_{k−1}) / dt² (interior ticks; the first and last tick take their
  neighbour's value), so acceleration spikes at start-up and lift-off are seen;
* centroidal angular momentum L_k = A_G,ang(q_k) v_k (Pinocchio ``computeCentroidalMomentum``, about the CoM, world
  axes) and its rate by backward difference L̇_k = (L_k − L_{k−1}) / dt (the change of momentum from the tick before
  to the tick after state k, the same instants as c̈_k; L̇_0 = L̇_1).

The ZMP on flat ground of height z_g (Newton–Euler of the whole body about the CoM with the ground wrench applied
at p; Kajita et al., "Introduction to Humanoid Robotics", 2014, ch. 3), h = c_z − z_g, m the total mass:

    p_x = c_x − (m h c̈_x + L̇_y) / (m (c̈_z + g)),      p_y = c_y − (m h c̈_y − L̇_x) / (m (c̈_z + g)).

With L̇ = 0 this is the CoM-only ("cart-table") ZMP p = c_xy − h c̈_xy / (c̈_z + g), which a summary reports beside
(``min_zmp_margin_com_only_m``): it misses the momentum of limbs that move against each other, so the verdict
uses the multi-body ZMP.
"""

from __future__ import annotations

import math

import numpy as np

from wbc.constants import GRAVITY
from wbc.exceptions import InvalidInputError
from wbc.geometry import signed_distance_point, support_corners

__all__ = ["executed_multibody_zmp", "executed_angular_momentum", "executed_com_acceleration", "executed_zmp", "stance_ground_z",
           "support_margin"]

#: Standard gravity (m/s²), the value Pinocchio's default model uses.


def executed_com_acceleration(com: np.ndarray, dt: float) -> np.ndarray:
    """CoM acceleration (N, 3) m/s² by central second differences of the executed CoM ``com`` (N, 3) m, period
    ``dt`` s. Rows 0 and N−1 copy rows 1 and N−2 (N ≥ 3); with N < 3 the acceleration is zero."""
    com = np.asarray(com, dtype=float)
    acc = np.zeros_like(com)
    if len(com) >= 3:
        acc[1:-1] = (com[2:] - 2.0 * com[1:-1] + com[:-2]) / dt**2
        acc[0], acc[-1] = acc[1], acc[-2]
    return acc


def executed_angular_momentum(model, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Centroidal angular momentum (N, 3) kg·m²/s, about the CoM in world axes, of each row (q_k (nq,), v_k (nv,))
    of a run (Pinocchio ``computeCentroidalMomentum``)."""
    import pinocchio as pin

    data = model.createData()
    return np.array([pin.computeCentroidalMomentum(model, data, qk, vk).angular for qk, vk in zip(q, v)])


def executed_zmp(com: np.ndarray, dt: float, ground_z: np.ndarray | float = 0.0,
                 gravity: float = GRAVITY, *, angular_momentum: np.ndarray | None = None,
                 mass: float | None = None) -> np.ndarray:
    """ZMP (N, 2) m in the world frame of the executed CoM trajectory ``com`` (N, 3) m sampled every ``dt`` s.

    ``ground_z`` (scalar or (N,)) is the height of the support plane at each tick (the stance sole height).
    ``angular_momentum`` (N, 3) kg·m²/s (:func:`executed_angular_momentum`) with the total ``mass`` (kg) gives the
    multi-body ZMP; without it L̇ = 0 (CoM-only ZMP). See the module docstring for the formula, how c̈ and L̇ are
    obtained.
    """
    com = np.asarray(com, dtype=float)
    acc = executed_com_acceleration(com, dt)
    h = com[:, 2] - np.asarray(ground_z, dtype=float)
    zmp = com[:, :2] - (h / (acc[:, 2] + gravity))[:, None] * acc[:, :2]
    if angular_momentum is not None:
        L = np.asarray(angular_momentum, dtype=float)
        ldot = np.zeros_like(L)
        if len(L) >= 2:
            ldot[1:] = np.diff(L, axis=0) / dt
            ldot[0] = ldot[1]
        fz = float(mass) * (acc[:, 2] + gravity)
        zmp[:, 0] -= ldot[:, 1] / fz
        zmp[:, 1] += ldot[:, 0] / fz
    return zmp


def support_margin(points: np.ndarray, left: np.ndarray, right: np.ndarray, support: np.ndarray,
                   length: float, width: float, double: int, left_stance: int, right_stance: int) -> np.ndarray:
    """Signed distance (N,) m, > 0 inside, of each point ``points`` (N, 2) to the support polygon of tick k: the
    ``length`` × ``width`` rectangles of the sole poses ``left[k]`` / ``right[k]`` (4×4, world) that are in stance
    (``support[k]`` equal to ``double`` or to that side's code), convex hull of both in double support."""
    points = np.asarray(points, dtype=float)
    if points.ndim != 2 or points.shape[1] != 2:
        raise InvalidInputError(f"points must have shape (N, 2); got {points.shape}")
    if not (math.isfinite(length) and math.isfinite(width) and length > 0 and width > 0):
        raise InvalidInputError(f"sole length and width must be finite and > 0 m; got length={length}, width={width}")
    out = np.empty(len(points))
    # plain Python floats per tick: the same arithmetic as support_polygon and signed_distance on one point, without
    # their array round trips
    xy = points.tolist()
    soles = ((left_stance, *_ground_pose_columns(left)), (right_stance, *_ground_pose_columns(right)))
    codes = np.asarray(support).tolist()
    for k in range(len(xy)):
        stance = []
        for side, xs, ys, r10, r00 in soles:
            if codes[k] in (double, side):
                x, y, yaw = xs[k], ys[k], math.atan2(r10[k], r00[k])
                if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(yaw)):
                    raise InvalidInputError(f"the stance sole pose of tick {k} is not finite")
                stance.append((x, y, yaw))
        poly = support_corners(stance, length, width)  # counter-clockwise
        if len(poly) < 3:
            raise InvalidInputError(f"no stance sole at tick {k} (support code {codes[k]})")
        px, py = xy[k]
        if not (math.isfinite(px) and math.isfinite(py)):
            raise InvalidInputError("points must be finite; got NaN or inf")
        out[k] = signed_distance_point(px, py, poly)
    return out


def _ground_pose_columns(poses: np.ndarray) -> tuple[list[float], ...]:
    """x, y, R[1, 0] and R[0, 0] of each (4, 4) pose of ``poses`` (N, 4, 4), as four lists of N Python floats."""
    m = np.asarray(poses, dtype=float)
    return m[:, 0, 3].tolist(), m[:, 1, 3].tolist(), m[:, 1, 0].tolist(), m[:, 0, 0].tolist()


def stance_ground_z(left: np.ndarray, right: np.ndarray, support: np.ndarray, double: int,
                    left_stance: int) -> np.ndarray:
    """Height (N,) m of the support plane at each tick: the stance sole's z (mean of both in double support)."""
    zl, zr = left[:, 2, 3], right[:, 2, 3]
    return np.where(support == double, 0.5 * (zl + zr), np.where(support == left_stance, zl, zr))


def executed_multibody_zmp(model, mass: float, dt: float, com: np.ndarray, q: np.ndarray, v: np.ndarray,
                           left: np.ndarray, right: np.ndarray, support: np.ndarray, *, double: int = 0,
                           left_stance: int = 1) -> np.ndarray:
    """Multi-body ZMP (N, 2) m, world, of an executed kinematic run, as the walk and balance summaries judge it:
    :func:`executed_zmp` on the stance plane (:func:`stance_ground_z`) with the centroidal angular momentum of
    every (q_k, v_k) (:func:`executed_angular_momentum`). ``com`` (N, 3) m, ``q`` (N, nq), ``v`` (N, nv), ``left``
    and ``right`` (N, 4, 4) sole poses, ``support`` (N,) codes (keyword-only ``double``, ``left_stance``, else right
    stance), ``mass`` kg, ``dt`` s."""
    ground = stance_ground_z(left, right, support, double, left_stance)
    return executed_zmp(com, dt, ground, angular_momentum=executed_angular_momentum(model, q, v), mass=mass)

