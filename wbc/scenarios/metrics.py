"""Executed-motion metrics shared by the walk and balance summaries.

The ZMP reported by a summary is the ZMP of the motion the robot EXECUTED, not of the plan: the CoM c_k is the one
of the integrated configuration q_k at the start of tick k (``Configuration.com``), and its acceleration is the
central second finite difference of that executed CoM,

    c̈_k = (c_{k+1} − 2 c_k + c_{k−1}) / dt²          (interior ticks; the first and last tick take their
                                                     neighbour's value),

so acceleration spikes at start-up and lift-off are seen. The ZMP on flat ground of height z_g, neglecting the
rate of angular momentum about the CoM (Kajita et al., "Introduction to Humanoid Robotics", 2014, eq. 4.62 with
L̇ = 0; Vukobratović & Borovac 2004), is

    p_xy = c_xy − (c_z − z_g) c̈_xy / (c̈_z + g).
"""

from __future__ import annotations

import math

import numpy as np

from wbc.gait.support import convex_hull, signed_distance, sole_polygon

__all__ = ["GRAVITY", "executed_com_acceleration", "executed_zmp", "stance_ground_z", "support_margin"]

#: Standard gravity (m/s²), the value Pinocchio's default model uses.
GRAVITY = 9.81


def executed_com_acceleration(com: np.ndarray, dt: float) -> np.ndarray:
    """CoM acceleration (N, 3) m/s² by central second differences of the executed CoM ``com`` (N, 3) m, period
    ``dt`` s. Rows 0 and N−1 copy rows 1 and N−2 (N ≥ 3); with N < 3 the acceleration is zero."""
    com = np.asarray(com, dtype=float)
    acc = np.zeros_like(com)
    if len(com) >= 3:
        acc[1:-1] = (com[2:] - 2.0 * com[1:-1] + com[:-2]) / dt**2
        acc[0], acc[-1] = acc[1], acc[-2]
    return acc


def executed_zmp(com: np.ndarray, dt: float, ground_z: np.ndarray | float = 0.0,
                 gravity: float = GRAVITY) -> np.ndarray:
    """ZMP (N, 2) m in the world frame of the executed CoM trajectory ``com`` (N, 3) m sampled every ``dt`` s.

    ``ground_z`` (scalar or (N,)) is the height of the support plane at each tick (the stance sole height).
    See the module docstring for the formula and how c̈ is obtained.
    """
    com = np.asarray(com, dtype=float)
    acc = executed_com_acceleration(com, dt)
    h = com[:, 2] - np.asarray(ground_z, dtype=float)
    return com[:, :2] - (h / (acc[:, 2] + gravity))[:, None] * acc[:, :2]


def support_margin(points: np.ndarray, left: np.ndarray, right: np.ndarray, support: np.ndarray,
                   length: float, width: float, double: int, left_stance: int, right_stance: int) -> np.ndarray:
    """Signed distance (N,) m, > 0 inside, of each point ``points`` (N, 2) to the support polygon of tick k: the
    ``length`` × ``width`` rectangles of the sole poses ``left[k]`` / ``right[k]`` (4×4, world) that are in stance
    (``support[k]`` equal to ``double`` or to that side's code), convex hull of both in double support."""
    out = np.empty(len(points))
    for k in range(len(points)):
        polys = []
        for side, pose in ((left_stance, left[k]), (right_stance, right[k])):
            if support[k] in (double, side):
                polys.append(sole_polygon(pose[0, 3], pose[1, 3], math.atan2(pose[1, 0], pose[0, 0]), length, width))
        poly = polys[0] if len(polys) == 1 else convex_hull(np.vstack(polys))
        out[k] = float(signed_distance(points[k], poly))
    return out


def stance_ground_z(left: np.ndarray, right: np.ndarray, support: np.ndarray, double: int,
                    left_stance: int) -> np.ndarray:
    """Height (N,) m of the support plane at each tick: the stance sole's z (mean of both in double support)."""
    zl, zr = left[:, 2, 3], right[:, 2, 3]
    return np.where(support == double, 0.5 * (zl + zr), np.where(support == left_stance, zl, zr))
