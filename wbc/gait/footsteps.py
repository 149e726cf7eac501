"""Footstep plans on flat ground: where each swing foot lands.

Convention (``plan_footsteps``): a walk of ``n_steps`` has ``n_steps`` swing phases, the feet alternating,
``first_side`` swinging first. The stance foot of a step is the other foot, at its latest pose
``(x_s, y_s, yaw_s)``.

* Steps ``1 .. n-1`` (walking steps): the swing foot lands with yaw ``yaw_s + turn`` (the walking heading of
  that step) at ``(x_s, y_s) + R(yaw_s + turn) @ (step_length, ±step_width)`` — ``+`` for a left swing foot,
  ``-`` for a right one. So each step puts the swing foot ``step_length`` ahead of the stance foot and
  ``step_width`` beside it, both measured along / across the new heading.
* Lateral walking (``step_lateral = d ≠ 0``, side-stepping): the **leading** foot (left for ``d > 0``, right for
  ``d < 0``) lands ``2|d|`` further out, at ``R(yaw_s + turn) @ (step_length, ±(step_width + 2|d|))``; the trailing
  foot lands at the normal ``step_width`` beside it. Each walking step then moves the feet mid-point by ``d``
  sideways and the soles never come closer than ``step_width`` (no crossing, no collision between the legs).
* Step ``n`` (closing step): the swing foot lands alongside the stance foot, same yaw, at
  ``(x_s, y_s) + R(yaw_s) @ (0, ±step_width)``.

For a straight walk (``turn = 0``) from feet side by side, the feet mid-point travels ``(n - 1) * step_length``
and the final heading is ``yaw + (n - 1) * turn``. A one-step walk only re-places the first swing foot
alongside the other one (stepping in place when the feet are already ``step_width`` apart).
"""

from __future__ import annotations

import math
from typing import Literal, NamedTuple

import numpy as np

from wbc.exceptions import GaitError

__all__ = ["Footstep", "plan_footsteps", "pose_to_xy_yaw", "feet_overlap"]

Side = Literal["left", "right"]


class Footstep(NamedTuple):
    """Where a sole lands: flat on z = 0.

    Attributes:
        side: ``"left"`` or ``"right"``.
        x, y: sole-frame origin in world (m).
        yaw: heading of the sole's x axis about the world z axis (rad, not wrapped: a walk's yaws are continuous).
    """

    side: Side
    x: float
    y: float
    yaw: float

    def pose(self) -> np.ndarray:
        """(4, 4) homogeneous world pose of the sole frame (z = 0, z axis up)."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return np.array([[c, -s, 0.0, self.x], [s, c, 0.0, self.y], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]])


def pose_to_xy_yaw(pose: np.ndarray) -> tuple[float, float, float]:
    """``(x, y, yaw)`` of a (4, 4) pose: origin position and heading of its x axis projected on the ground."""
    return float(pose[0, 3]), float(pose[1, 3]), math.atan2(float(pose[1, 0]), float(pose[0, 0]))


def plan_footsteps(
    left: tuple[float, float, float],
    right: tuple[float, float, float],
    n_steps: int,
    step_length: float,
    step_width: float,
    turn: float = 0.0,
    first_side: Side = "left",
    step_lateral: float = 0.0,
) -> list[Footstep]:
    """Landing poses of the ``n_steps`` swing phases (see the module docstring for the convention).

    Args:
        left, right: current ``(x, y, yaw)`` of the soles (m, m, rad), world frame.
        n_steps: number of swing phases (>= 1).
        step_length: forward displacement (m) of each walking step relative to the stance foot (negative walks
            backwards).
        step_width: lateral distance (m) between the feet, > 0.
        turn: yaw change (rad) of each walking step.
        first_side: the foot that swings first.
        step_lateral: lateral displacement (m, + left) of the feet mid-point per walking step (side-stepping, see
            the module docstring).

    Returns:
        ``n_steps`` :class:`Footstep` in swing order, sides alternating.

    Raises:
        GaitError: ``n_steps < 1``, ``step_width <= 0`` or ``first_side`` not ``"left"``/``"right"``.
    """
    if isinstance(n_steps, bool) or not isinstance(n_steps, (int, np.integer)) or n_steps < 1:
        raise GaitError(f"n_steps must be an integer >= 1; got {n_steps!r}")
    if first_side not in ("left", "right"):
        raise GaitError(f"first_side must be 'left' or 'right'; got {first_side!r}")
    if not step_width > 0:
        raise GaitError(f"step_width must be > 0 m; got {step_width}")
    if not math.isfinite(step_lateral):
        raise GaitError(f"step_lateral must be a finite number (m); got {step_lateral}")
    leading = "left" if step_lateral > 0 else "right"
    feet = {"left": tuple(map(float, left)), "right": tuple(map(float, right))}
    swing: Side = first_side
    steps: list[Footstep] = []
    for i in range(int(n_steps)):
        stance: Side = "right" if swing == "left" else "left"
        xs, ys, yaws = feet[stance]
        sign = 1.0 if swing == "left" else -1.0
        closing = i == n_steps - 1
        yaw = yaws if closing else yaws + turn
        fwd = 0.0 if closing else step_length
        c, s = math.cos(yaw), math.sin(yaw)
        lat = sign * step_width
        if not closing and step_lateral != 0.0 and swing == leading:
            lat += 2.0 * step_lateral
        step = Footstep(swing, xs + c * fwd - s * lat, ys + s * fwd + c * lat, yaw)
        steps.append(step)
        feet[swing] = (step.x, step.y, step.yaw)
        swing = stance
    return steps


def _rects_overlap(a: tuple[float, float, float], b: tuple[float, float, float], hl: float, hw: float) -> bool:
    dx, dy = b[0] - a[0], b[1] - a[1]
    cd, sd = abs(math.cos(b[2] - a[2])), abs(math.sin(b[2] - a[2]))
    reach_x = hl + hl * cd + hw * sd  # half-extent of both rectangles along a length axis
    reach_y = hw + hl * sd + hw * cd  # ... along a width axis
    for yaw in (a[2], b[2]):
        c, s = math.cos(yaw), math.sin(yaw)
        if abs(c * dx + s * dy) > reach_x or abs(-s * dx + c * dy) > reach_y:
            return False
    return True


def feet_overlap(a: np.ndarray, b: np.ndarray, length: float, width: float) -> np.ndarray:
    """Whether pairs of equal sole rectangles intersect (separating-axis test on the 4 edge normals).

    Args:
        a, b: (n, 3) rows ``(x, y, yaw)`` (m, m, rad) of the two soles of each pair.
        length, width: sole rectangle size (m).

    Returns:
        (n,) bool, True where the pair's rectangles intersect or touch.
    """
    rows_a = np.atleast_2d(np.asarray(a, dtype=float)).tolist()
    rows_b = np.atleast_2d(np.asarray(b, dtype=float)).tolist()
    return np.array([_rects_overlap(p, q, 0.5 * length, 0.5 * width) for p, q in zip(rows_a, rows_b)], dtype=bool)
