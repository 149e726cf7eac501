"""Joint position limits reached with bounded deceleration: a joint may only move towards a limit as fast as it can
still stop before it with deceleration a_max.

The plain position bound v ≤ (q_max − q)/dt (:class:`~wbc.constraints.JointPositionLimit`) lets a joint run into
its limit at full speed and stop within one tick: an unbounded joint acceleration, which shows as a spike of the
CoM acceleration and of the executed ZMP. Moving at v over one tick and then braking at a_max covers
v dt + v²/(2 a_max), so

    v ≤ −a_max dt + √((a_max dt)² + 2 a_max (q_max − q)),     v ≥ a_max dt − √((a_max dt)² + 2 a_max (q − q_min))

(the velocity-damper idea of Faverjon & Tournassoud, ICRA 1987, with the braking distance of a constant
deceleration; Del Prete, "Joint position and velocity bounds in discrete-time acceleration/torque control of robot
manipulators", IEEE RA-L 2018). Box priority 2 (:mod:`wbc.constraints.base`): the bound yields to the velocity
limits and to the position limits' recovery bound, so the box never empties; it is relaxable like the acceleration
limits it complements.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from wbc.compiled import NO_NRT, once_per_process
from wbc.configuration import Configuration
from wbc.constraints.base import BoxConstraint
from wbc.constraints.limits import bounded_joints
from wbc.exceptions import InvalidInputError
from wbc.solvers.linalg import clip_entry_into

__all__ = ["JointBrakingLimit"]


@nb.njit(cache=True, nogil=True)
def _braking_bounds(q, idx_q, q_min, q_max, a, dt, lb, ub):
    """ub = √((a dt)² + 2 a max(q_max − q, 0)) − a dt, lb = a dt − √((a dt)² + 2 a max(q − q_min, 0)) (compiled)."""
    adt = a * dt
    for k in range(idx_q.shape[0]):
        qk = q[idx_q[k]]
        up = max(q_max[k] - qk, 0.0)
        down = max(qk - q_min[k], 0.0)
        ub[k] = math.sqrt(adt * adt + 2.0 * a * up) - adt
        lb[k] = adt - math.sqrt(adt * adt + 2.0 * a * down)


@nb.njit(cache=True, nogil=True, **NO_NRT)
def _intersect_braking_bounds(q, idx_q, idx_v, q_min, q_max, a, dt, bounds, box_lb, box_ub):
    """:func:`_braking_bounds` into the rows lb, ub of ``bounds`` (2, n), intersected with the running box box_lb, box_ub (nv,) at the velocity
    indices ``idx_v``, each clipped into it: box_lb ← min(max(lb, box_lb), box_ub), box_ub ← max(min(ub, box_ub),
    box_lb) (compiled: :func:`wbc.solvers.linalg.clip_entry_into` inlined)."""
    adt = a * dt
    for k in range(idx_q.shape[0]):
        qk = q[idx_q[k]]
        up = max(q_max[k] - qk, 0.0)
        down = max(qk - q_min[k], 0.0)
        hi = math.sqrt(adt * adt + 2.0 * a * up) - adt
        lo = adt - math.sqrt(adt * adt + 2.0 * a * down)
        bounds[1, k] = hi
        bounds[0, k] = lo
        clip_entry_into(box_lb, box_ub, idx_v[k], lo, hi)


@once_per_process
def _warm_up() -> None:
    """Load :func:`_braking_bounds` and :func:`_intersect_braking_bounds` (on-disk cache) once per process, at
    construction."""
    z, i = np.zeros(1), np.zeros(1, dtype=np.int64)
    _braking_bounds(z, i, z, z, 1.0, 1.0, np.empty(1), np.empty(1))
    _intersect_braking_bounds(z, i, i, z, z, 1.0, 1.0, np.zeros((2, 1)), np.zeros(1), np.zeros(1))


class JointBrakingLimit(BoxConstraint):
    """Velocity towards each position limit bounded by the braking distance (module docstring).

    Args:
        robot: the robot (limits from ``robot.model``).
        a_max: deceleration available to stop (rad/s², finite, > 0).
        name: label in reports.

    Raises:
        InvalidInputError: a_max not finite or ≤ 0.
    """

    name = "joint_braking_limit"
    priority = 2
    relaxable = True

    def __init__(self, robot, *, a_max: float = 50.0, name: str | None = None):
        if isinstance(a_max, bool) or not (math.isfinite(a_max) and a_max > 0):
            raise InvalidInputError(f"a_max must be finite and > 0 (rad/s²), got {a_max!r}")
        model = robot.model
        self.a_max = float(a_max)
        self.idx_q, self.indices = bounded_joints(model)
        self.dim = int(self.indices.size)
        self.q_min = model.lowerPositionLimit[self.idx_q].copy()
        self.q_max = model.upperPositionLimit[self.idx_q].copy()
        if name is not None:
            self.name = name
        self._bounds = np.zeros((2, self.dim))  # rows lb, ub of compute
        self._lb, self._ub = self._bounds
        _warm_up()

    def compute(self, config: Configuration, dt: float) -> tuple[np.ndarray, np.ndarray]:
        _braking_bounds(config.q, self.idx_q, self.q_min, self.q_max, self.a_max, float(dt), self._lb, self._ub)
        return self._lb, self._ub

    def intersect_into(self, config: Configuration, dt: float, lb: np.ndarray, ub: np.ndarray) -> None:
        """:meth:`wbc.constraints.base.BoxConstraint.intersect_into` in one compiled pass (the same numbers; the
        bounds of :meth:`compute` are left in its buffers as well)."""
        _intersect_braking_bounds(config.q, self.idx_q, self.indices, self.q_min, self.q_max, self.a_max, float(dt),
                                  self._bounds, lb, ub)
