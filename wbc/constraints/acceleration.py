"""Joint acceleration limits: the actuated velocity may change by at most a_max·dt per tick (smooth commands).

    v_prev − a_max dt ≤ v[6:] ≤ v_prev + a_max dt          (rad/s; a_max in rad/s²)

v_prev is the command of the previous tick. The controller feeds it: the constraint declares
``needs_previous_command`` and :class:`~wbc.controllers.kinematic.KinematicController` calls :meth:`set_previous` with
``TickResult.v`` after every tick (a fallback command included). Before the first tick v_prev = 0 (robot at
rest); call :meth:`set_previous` yourself when starting from motion or when integrating another velocity.

Acceleration limits yield to position safety, in two ways:

* box priority 2: per joint, the bound is clipped into the joint velocity limits and the recovery bound of the
  joint position limits (see :mod:`wbc.constraints.base`), so a joint that must come back inside its range (or
  stop at it) may do so faster than a_max — the box never empties;
* ``relaxable``: when the QP is still infeasible with them — a recovering leg joint drags the rest of the leg
  through the contact closure faster than a_max allows — the controller leaves them out of that tick
  (``TickResult.relaxed``) instead of failing.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from wbc.compiled import NO_NRT, once_per_process
from wbc.configuration import Configuration, check_vector
from wbc.constraints.base import BoxConstraint
from wbc.exceptions import InvalidInputError
from wbc.solvers.linalg import clip_entry_into

__all__ = ["JointAccelerationLimit"]


@nb.njit(cache=True, nogil=True)
def _acceleration_bounds(v_prev, a_max, dt, lb, ub):
    """lb = v_prev − a_max dt, ub = v_prev + a_max dt, in place (compiled: one call instead of three ufuncs)."""
    for j in range(v_prev.shape[0]):
        step = a_max[j] * dt
        lb[j] = v_prev[j] - step
        ub[j] = v_prev[j] + step


@nb.njit(cache=True, nogil=True, **NO_NRT)
def _intersect_acceleration_bounds(v_prev, a_max, dt, lb, ub, start, box_lb, box_ub):
    """:func:`_acceleration_bounds` into lb, ub, intersected with the running box box_lb, box_ub (nv,) from index
    ``start`` on, each clipped into it: box_lb ← min(max(lb, box_lb), box_ub), box_ub ← max(min(ub, box_ub),
    box_lb) (compiled: :func:`wbc.solvers.linalg.clip_entry_into` inlined)."""
    for j in range(v_prev.shape[0]):
        step = a_max[j] * dt
        lo = v_prev[j] - step
        hi = v_prev[j] + step
        lb[j] = lo
        ub[j] = hi
        clip_entry_into(box_lb, box_ub, start + j, lo, hi)


@nb.njit(cache=True, nogil=True, **NO_NRT)
def _copy_if_finite(v, out):
    """out = v and True when every entry of v is finite, else False with out untouched (compiled: one call instead
    of a finiteness check and a copy)."""
    for j in range(v.shape[0]):
        if not np.isfinite(v[j]):
            return False
    for j in range(v.shape[0]):
        out[j] = v[j]
    return True


@once_per_process
def _warm_up() -> None:
    """Load :func:`_acceleration_bounds` and :func:`_copy_if_finite` (on-disk cache) once per process, at
    construction."""
    z = np.zeros(1)
    _acceleration_bounds(z, np.ones(1), 0.002, np.empty(1), np.empty(1))
    _copy_if_finite(z, np.zeros(1))
    _intersect_acceleration_bounds(z, np.ones(1), 0.002, np.empty(1), np.empty(1), 0, np.zeros(1), np.zeros(1))


class JointAccelerationLimit(BoxConstraint):
    """|v_j − v_prev,j| ≤ a_max,j dt on every actuated joint (module docstring).

    Args:
        robot: the robot.
        a_max: scalar or (nv − 6,) acceleration bounds (rad/s², > 0; inf = unbounded joint).
        name: label in reports (default ``"joint_acceleration_limit"``).

    Raises:
        InvalidInputError: a_max of the wrong shape, NaN, or ≤ 0.
    """

    name = "joint_acceleration_limit"
    priority = 2
    needs_previous_command = True
    relaxable = True

    def __init__(self, robot, *, a_max=50.0, name: str | None = None):
        nv = robot.model.nv
        self.indices = np.arange(6, nv)
        self.dim = int(self.indices.size)
        a = np.asarray(a_max, dtype=float)
        if a.ndim == 0:
            a = np.full(self.dim, float(a))
        if a.shape != (self.dim,) or np.isnan(a).any() or (a <= 0).any():
            raise InvalidInputError(f"a_max must be a positive scalar or ({self.dim},) array (rad/s²), got {a_max!r}")
        self.a_max = a
        if name is not None:
            self.name = name
        self.nv = nv
        self._v = np.zeros(nv)  # the last command; v_prev is a view of its actuated part
        self.v_prev = self._v[6:]
        self._lb = np.empty(self.dim)
        self._ub = np.empty(self.dim)
        _warm_up()

    def set_previous(self, v) -> None:
        """Record the command v (nv,) sent at the previous tick (only v[6:] is used).

        Raises:
            ConfigurationError: wrong shape or NaN.
        """
        if not (type(v) is np.ndarray and v.shape == (self.nv,) and v.dtype == np.float64
                and _copy_if_finite(v, self._v)):
            v = check_vector(v, self.nv, "previous command v")  # raises with the details (or converts)
            np.copyto(self._v, v)
        if self.v_prev.base is not self._v:  # v_prev was assigned: a view of the buffer again
            self.v_prev = self._v[6:]

    def compute(self, config: Configuration, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """(lb, ub) of the module docstring, buffers owned by the constraint (overwritten at the next call)."""
        v_prev = self.v_prev
        if not (type(v_prev) is np.ndarray and v_prev.dtype == np.float64 and v_prev.shape == (self.dim,)):
            v_prev = self.v_prev = check_vector(v_prev, self.dim, "v_prev (actuated velocities)")
        _acceleration_bounds(v_prev, self.a_max, float(dt), self._lb, self._ub)
        return self._lb, self._ub

    def intersect_into(self, config: Configuration, dt: float, lb: np.ndarray, ub: np.ndarray) -> None:
        """:meth:`wbc.constraints.base.BoxConstraint.intersect_into` in one compiled pass (the same numbers; the
        bounds of :meth:`compute` are left in its buffers as well)."""
        v_prev = self.v_prev
        if not (type(v_prev) is np.ndarray and v_prev.dtype == np.float64 and v_prev.shape == (self.dim,)):
            v_prev = self.v_prev = check_vector(v_prev, self.dim, "v_prev (actuated velocities)")
        _intersect_acceleration_bounds(v_prev, self.a_max, float(dt), self._lb, self._ub, 6, lb, ub)
