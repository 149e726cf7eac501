"""Joint position and velocity limits as bounds on the actuated part of v.

Position limits over one period dt: q_min ≤ q + v dt ≤ q_max  ⇔  (q_min − q)/dt ≤ v ≤ (q_max − q)/dt.
A joint already outside its range gets a bound that pushes it back at no more than its velocity limit, so the
box stays non-empty and the joint returns inside instead of making the QP infeasible. That recovery bound has box
priority 1: it yields to :class:`JointVelocityLimit` (priority 0, e.g. a ``scale`` < 1 slows the return), and
acceleration limits (priority 2) yield to it (see :mod:`wbc.constraints.base`).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from wbc.compiled import NO_NRT, once_per_process
from wbc.configuration import Configuration
from wbc.constraints.base import BoxConstraint
from wbc.exceptions import InvalidInputError
from wbc.solvers.linalg import clip_entry_into

__all__ = ["JointPositionLimit", "JointVelocityLimit", "bounded_joints", "intersect_position_bounds"]


def bounded_joints(model) -> tuple[np.ndarray, np.ndarray]:
    """(idx_q, idx_v) of the one-DoF joints with finite position limits (revolute/prismatic), in model order
    (a zero-width range counts: the joint is locked)."""
    idx_q, idx_v = [], []
    for joint in model.joints[2:]:  # universe and the free-flyer root are unbounded
        if joint.nq == 1 and joint.nv == 1:
            lo, hi = model.lowerPositionLimit[joint.idx_q], model.upperPositionLimit[joint.idx_q]
            if np.isfinite(lo) and np.isfinite(hi) and lo <= hi:  # lo = hi: a locked joint, pinned
                idx_q.append(joint.idx_q)
                idx_v.append(joint.idx_v)
    return np.asarray(idx_q, dtype=int), np.asarray(idx_v, dtype=int)


@nb.njit(cache=True, nogil=True)
def _position_bounds(q, idx_q, q_min, q_max, v_max, neg_v_max, dt, lb, ub):
    """lb = min((q_min − q)/dt, v_max), ub = max((q_max − q)/dt, −v_max) on the bounded joints (compiled)."""
    for k in range(idx_q.shape[0]):
        qk = q[idx_q[k]]
        lb[k] = min((q_min[k] - qk) / dt, v_max[k])
        ub[k] = max((q_max[k] - qk) / dt, neg_v_max[k])


@nb.njit(cache=True, nogil=True, **NO_NRT)
def intersect_position_bounds(q, idx, limits, dt, lb, ub):
    """The velocity bounds of :class:`JointPositionLimit` (module docstring) intersected with a running box, in place
    (compiled): for each bounded joint k, lo = min((q_min − q)/dt, v_max), hi = max((q_max − q)/dt, −v_max), and at
    its velocity index i = ``idx[1, k]``: lb[i] ← min(max(lo, lb[i]), ub[i]), ub[i] ← max(min(hi, ub[i]), lb[i]),
    both from the running values (clipped into the running box: a non-empty box stays non-empty;
    :func:`~wbc.solvers.linalg.clip_entry_into`).

    Args:
        q (nq,): configuration (Pinocchio's order; rad or m at the bounded joints).
        idx (2, n) int64: (idx_q, idx_v) of the n bounded joints (:meth:`JointPositionLimit.packed`).
        limits (3, n): (q_min (rad or m), q_max (rad or m), v_max (rad/s or m/s, > 0, inf: no cap)).
        dt: period (s), > 0.
        lb, ub (nv,): the running box (rad/s or m/s), updated in place.

    Nothing is checked here (a per-tick kernel): the arrays come validated from :class:`JointPositionLimit`.
    """
    for k in range(idx.shape[1]):
        qk = q[idx[0, k]]
        lo = min((limits[0, k] - qk) / dt, limits[2, k])
        hi = max((limits[1, k] - qk) / dt, -limits[2, k])
        clip_entry_into(lb, ub, idx[1, k], lo, hi)


@once_per_process
def _warm_up() -> None:
    """Load :func:`_position_bounds` and :func:`intersect_position_bounds` (on-disk cache) once per process, at
    construction."""
    z = np.zeros(1)
    _position_bounds(z, np.zeros(1, dtype=np.int64), z, z, z, z, 0.002, np.empty(1), np.empty(1))
    intersect_position_bounds(z, np.zeros((2, 1), dtype=np.int64), np.zeros((3, 1)), 0.002, np.zeros(1), np.zeros(1))


def _limit_row(row: int, name: str, doc: str) -> property:
    """Property ``name`` of :class:`JointPositionLimit`: row ``row`` of its packed (3, dim) limits, validated on
    assignment by ``JointPositionLimit._set_row``."""
    return property(lambda self: self._limits[row], lambda self, value: self._set_row(row, name, value), doc=doc)


class JointPositionLimit(BoxConstraint):
    """Keep every bounded joint inside [lowerPositionLimit, upperPositionLimit] after the step.

    Args:
        robot: the robot (limits read from ``robot.model``).
        margin: keep this far (rad) inside each limit, ≥ 0. The default 1e-9 rad absorbs the round-off of
            q + ((q_max − q)/dt)·dt, which can otherwise land one ulp outside the limit.

    Raises:
        InvalidInputError: ``margin`` negative or not finite (a negative margin would widen the limits).
    """

    name = "joint_position_limit"
    priority = 1

    def __init__(self, robot, *, margin: float = 1e-9):
        if isinstance(margin, bool) or not (np.isfinite(margin) and margin >= 0):
            raise InvalidInputError(f"JointPositionLimit margin must be a finite number ≥ 0 (rad), got {margin!r}")
        model = robot.model
        self.idx_q, self.indices = bounded_joints(model)
        self.dim = int(self.indices.size)
        q_min = model.lowerPositionLimit[self.idx_q] + margin
        q_max = model.upperPositionLimit[self.idx_q] - margin
        # a zero-width range (lower = upper: a locked joint) would cross under the margin (lb > ub by 2·margin/dt,
        # measured 5e-7 per joint): pin such joints at the middle of their range instead
        crossed = q_min > q_max
        mid = 0.5 * (model.lowerPositionLimit[self.idx_q] + model.upperPositionLimit[self.idx_q])
        vmax = model.velocityLimit[self.indices]
        # the compiled kernels' packed arguments (3, dim): q_min, q_max, v_max are views of its rows
        self._limits = np.ascontiguousarray([np.where(crossed, mid, q_min), np.where(crossed, mid, q_max),
                                             np.where(np.isfinite(vmax) & (vmax > 0), vmax, np.inf)])
        self._idx = np.ascontiguousarray([self.idx_q, self.indices], dtype=np.int64)
        _warm_up()

    def _set_row(self, row: int, what: str, value) -> None:
        """Validate ``value`` (dim,) and write it into row ``row`` of the packed limits (what the kernels read)."""
        arr = np.asarray(value, dtype=float)
        if arr.shape != (self.dim,) or np.isnan(arr).any():
            raise InvalidInputError(f"JointPositionLimit.{what} must be a ({self.dim},) array without NaN (one entry "
                                    f"per bounded joint), got shape {arr.shape}")
        if row == 2 and not (arr > 0).all():
            raise InvalidInputError(f"JointPositionLimit.v_max must be > 0 (rad/s or m/s; inf: no cap), got "
                                    f"{arr[~(arr > 0)][:3]}")
        lo = arr if row == 0 else self._limits[0]
        hi = arr if row == 1 else self._limits[1]
        if row < 2 and not (lo <= hi).all():
            raise InvalidInputError(f"JointPositionLimit.{what}: q_min must be ≤ q_max for every joint (rad or m); "
                                    f"violated at {int(np.argmax(~(lo <= hi)))} of the bounded joints")
        self._limits[row] = arr

    q_min = _limit_row(0, "q_min", """(dim,) lower position limits of the bounded joints (rad or m), margin included; a
        view of what the compiled kernels read, so an in-place change is seen. Assigning validates (shape, no NaN,
        ≤ q_max) and raises :class:`~wbc.exceptions.InvalidInputError`.""")
    q_max = _limit_row(1, "q_max", """(dim,) upper position limits (rad or m), as :attr:`q_min`.""")
    v_max = _limit_row(2, "v_max", """(dim,) speed cap of a joint returning from outside its range (rad/s or m/s,
        > 0, inf: none), as :attr:`q_min` (velocity-space order of ``indices``).""")

    def compute(self, config: Configuration, dt: float) -> tuple[np.ndarray, np.ndarray]:
        # lb = min((q_min − q)/dt, v_max), ub = max((q_max − q)/dt, −v_max): only the recovery side is capped (a
        # joint outside its range returns at ≤ v_max, and lb ≤ ub always); the other side is the velocity limit's
        lb, ub = np.empty(self.dim), np.empty(self.dim)
        lim = self._limits
        _position_bounds(config.q, self.idx_q, lim[0], lim[1], lim[2], -lim[2], float(dt), lb, ub)
        return lb, ub

    def intersect_into(self, config: Configuration, dt: float, lb: np.ndarray, ub: np.ndarray) -> None:
        """:meth:`wbc.constraints.base.BoxConstraint.intersect_into` in one compiled pass (the same numbers)."""
        intersect_position_bounds(config.q, self._idx, self._limits, float(dt), lb, ub)

    def packed(self) -> tuple[np.ndarray, np.ndarray]:
        """The arrays :meth:`intersect_into` hands :func:`intersect_position_bounds`: (idx (2, dim) int64 = (idx_q,
        indices), limits (3, dim) float64 = (q_min (rad or m), q_max (rad or m), v_max (rad/s or m/s))), for a
        caller that intersects the bounds inside a compiled call of its own. The constraint's own arrays
        (read-only use): an in-place change of :attr:`q_min`, :attr:`q_max` or :attr:`v_max` is seen in them."""
        return self._idx, self._limits


class JointVelocityLimit(BoxConstraint):
    """|v_j| ≤ scale · velocityLimit_j for every actuated joint (rad/s).

    Args:
        robot: the robot (limits read from ``robot.model``).
        scale: fraction of the URDF velocity limit allowed, finite and > 0 (default 1).

    Raises:
        InvalidInputError: ``scale`` ≤ 0 or not finite (it would switch the limits off or invert them).
    """

    name = "joint_velocity_limit"
    priority = 0
    constant = True

    def __init__(self, robot, *, scale: float = 1.0):
        if isinstance(scale, bool) or not (np.isfinite(scale) and scale > 0):
            raise InvalidInputError(f"JointVelocityLimit scale must be a finite number > 0, got {scale!r}")
        model = robot.model
        self.indices = np.arange(6, model.nv)
        self.dim = int(self.indices.size)
        vmax = scale * model.velocityLimit[self.indices]
        # velocity limit 0 = a locked joint (zero-width range, KinematicController.locked_joints); inf = none
        self.v_max = np.where(np.isfinite(vmax) & (vmax >= 0), vmax, np.inf)
        self._neg_v_max = -self.v_max

    def compute(self, config: Configuration, dt: float) -> tuple[np.ndarray, np.ndarray]:
        return self._neg_v_max, self.v_max
