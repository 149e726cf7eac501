"""Acceleration-level tasks for the inverse-dynamics QP.

Each task has an error e(q) ∈ R^m, a Jacobian J(q) (m, nv) with ė = J v − ė_ff, and a drift J̇ v (m,), so that

    ë = J v̇ + J̇ v.

The QP cost of a task is ``Σ_r w_r (J_r v̇ + (J̇v)_r − a*_r)²`` with the PD + feed-forward desired acceleration

    a* = ä_ff − Kp e − Kd (J v − ė_ff)                                                    (1)

(Kp in 1/s², Kd in 1/s; ``kd`` defaults to the critically damped 2√Kp). The kinematic tasks of :mod:`wbc.tasks`
give e and J unchanged (they are evaluated on a :class:`~wbc.state.DynamicsState`); this module adds
J̇ v from Pinocchio:

* CoM (:class:`ComAccelerationTask`): J̇ v = ``(dAg v)[0:3] / m`` (= ``data.acom[0]`` of
  ``pin.centerOfMass(model, data, q, v, 0)``).
* Frame (:class:`FrameAccelerationTask`, wraps :class:`~wbc.tasks.FrameTask` / ``PositionTask`` /
  ``OrientationTask``): position rows e = p − p* (world), J̇ v = classical linear acceleration of the frame origin
  at v̇ = 0 (``pin.getFrameClassicalAcceleration``, LOCAL_WORLD_ALIGNED). Orientation rows e = log₃(R*ᵀR),
  ė = Jlog₃ ω_local, ë = Jlog₃ ω̇_local + (d/dt Jlog₃) ω_local. We use J̇ v = Jlog₃ · (angular acceleration
  drift in LOCAL) and **drop (d/dt Jlog₃) ω**: it is second order (∝ |e|·|ω|² near the target, where
  Jlog₃ = I + ½[e]× + O(|e|²)), negligible for the small orientation errors of balance tasks.
* Posture (:class:`PostureAccelerationTask`): J is a constant selection, J̇ v = 0 (exact for 1-DoF joints).
* Centroidal angular momentum rate (:class:`AngularMomentumRateTask`; its former name ``AngularMomentumTask`` stays
  an alias — the kinematic :class:`wbc.tasks.AngularMomentumTask` is the velocity-level task): not a position task; L = Ag[3:6] v, L̇ = Ag[3:6] v̇ +
  (dAg v)[3:6]; the target rate is ``L̇* = L̇_ff − K (L − L*)`` (1/s). (Lee & Goswami 2012, "A momentum-based
  balance controller for humanoid robots on non-level and non-stationary ground", Auton. Robots 33:399–414.)
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from wbc.configuration import check_vector
from wbc.state import DynamicsState
from wbc.exceptions import InvalidInputError, InvalidTargetError
from wbc.tasks.base import Task, as_weight
from wbc.tasks.com import ComTask
from wbc.tasks.frame import FrameTask, frame_error_and_jacobian
from wbc.tasks.posture import PostureTask

__all__ = [
    "AccelerationTask",
    "ComAccelerationTask",
    "FrameAccelerationTask",
    "PostureAccelerationTask",
    "AngularMomentumRateTask",
    "AngularMomentumTask",
    "acceleration_task",
]


def _gain(value, what: str) -> float:
    if not (np.isfinite(value) and value >= 0):
        raise InvalidInputError(f"{what} must be finite and ≥ 0, got {value!r}")
    return float(value)


class AccelerationTask:
    """A weighted acceleration-level task (module docstring, eq. 1).

    Subclasses implement :meth:`error_jacobian_drift`.

    Args:
        kp: stiffness Kp (1/s²), ≥ 0.
        kd: damping Kd (1/s), ≥ 0; default 2√Kp.
        weight: scalar or (m,) cost weights.
        name: label.

    Attributes:
        dim: number of rows m.
        last_error: (m,) error at the last :meth:`compute` (task units).

    Raises:
        InvalidInputError: negative/non-finite gains or weights.
    """

    dim: int = 0
    name: str = "task"

    def __init__(self, *, kp: float, kd: float | None = None, weight=1.0, name: str | None = None):
        self.kp = _gain(kp, f"{name or self.name} kp")
        self.kd = _gain(2.0 * math.sqrt(self.kp) if kd is None else kd, f"{name or self.name} kd")
        if name is not None:
            self.name = name
        self.weight = as_weight(weight, self.dim, f"{self.name} weight")
        self._acc_ff: np.ndarray | None = None
        self.last_error = np.zeros(self.dim)

    def set_feedforward_acceleration(self, acceleration) -> None:
        """Feed-forward ä_ff (m,) of eq. 1 (None clears it).

        Raises:
            InvalidTargetError: wrong shape or NaN.
        """
        self._acc_ff = None if acceleration is None else check_vector(
            acceleration, self.dim, f"{self.name} feed-forward acceleration", InvalidTargetError).copy()

    def error_jacobian_drift(self, state: DynamicsState) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                                   np.ndarray | None]:
        """(e (m,), J (m, nv), J̇v (m,), ė_ff (m,) or None) at ``state``."""
        raise NotImplementedError

    def compute(self, state: DynamicsState) -> tuple[np.ndarray, np.ndarray]:
        """(J (m, nv), r (m,)) such that the task asks J v̇ = r, i.e. r = a* − J̇ v (eq. 1).

        Returns arrays the caller may not keep across ticks.
        """
        e, J, drift, e_dot_ff = self.error_jacobian_drift(state)
        self.last_error = e
        e_dot = J @ state.v
        if e_dot_ff is not None:
            e_dot = e_dot - e_dot_ff
        r = -self.kp * e - self.kd * e_dot - drift
        if self._acc_ff is not None:
            r += self._acc_ff
        return J, r


class _WrappedTask(AccelerationTask):
    """An acceleration task built on a kinematic :class:`~wbc.tasks.base.Task` (its e, J, target, ė_ff)."""

    kinematic_type: type = Task

    def __init__(self, task: Task, *, kp: float, kd: float | None = None, weight=None, name: str | None = None):
        if not isinstance(task, self.kinematic_type):
            raise InvalidInputError(
                f"{type(self).__name__} wraps a {self.kinematic_type.__name__}, got {type(task).__name__}")
        self.task = task
        self.dim = task.dim
        super().__init__(kp=kp, kd=kd, weight=task.weight if weight is None else weight,
                         name=name or task.name)

    def set_target(self, *args, **kwargs) -> None:
        """Forwarded to the wrapped kinematic task's ``set_target`` (position/pose and optional velocity)."""
        self.task.set_target(*args, **kwargs)


class ComAccelerationTask(_WrappedTask):
    """CoM tracking at acceleration level (world axes, m). Wraps a :class:`~wbc.tasks.ComTask` (created with
    unit weights when ``task`` is None)."""

    kinematic_type = ComTask

    def __init__(self, task: ComTask | None = None, *, kp: float = 100.0, kd: float | None = None, weight=None,
                 name: str | None = None):
        super().__init__(task if task is not None else ComTask(), kp=kp, kd=kd, weight=weight, name=name)

    def error_jacobian_drift(self, state):
        e, J = self.task.compute(state)
        return e, J, state.com_drift, self.task.feedforward()


class FrameAccelerationTask(_WrappedTask):
    """Frame pose/position/orientation at acceleration level. Wraps a :class:`~wbc.tasks.FrameTask` (or its
    Position/Orientation forms); J̇v as in the module docstring (Jlog₃ derivative term dropped)."""

    kinematic_type = FrameTask

    def __init__(self, task: FrameTask, *, kp: float = 100.0, kd: float | None = None, weight=None,
                 name: str | None = None):
        super().__init__(task, kp=kp, kd=kd, weight=weight, name=name)
        self._drift6 = np.empty(6)

    def error_jacobian_drift(self, state):
        task = self.task
        fid = task.frame_id
        rows = task.rows
        model, data = state.model, state.data
        if rows.size == 6:
            e, J = frame_error_and_jacobian(state, fid, task.target)
        else:  # the kinematic task's own row-selected path (same formulas, only the rows it has)
            e, J = task.compute(state)
        d = self._drift6
        if rows[0] < 3:
            d[:3] = pin.getFrameClassicalAcceleration(model, data, fid, pin.LOCAL_WORLD_ALIGNED).linear
        if rows[-1] >= 3:
            rel = task.target.rotation.T @ data.oMf[fid].rotation
            d[3:] = pin.Jlog3(rel) @ pin.getFrameAcceleration(model, data, fid, pin.LOCAL).angular
        return e, J, (d if rows.size == 6 else d[rows]), task.feedforward()


class PostureAccelerationTask(_WrappedTask):
    """Joint posture at acceleration level (rad). Wraps a :class:`~wbc.tasks.PostureTask`; J̇v = 0."""

    kinematic_type = PostureTask

    def __init__(self, task: PostureTask, *, kp: float = 50.0, kd: float | None = None, weight=None,
                 name: str | None = None):
        super().__init__(task, kp=kp, kd=kd, weight=weight, name=name)
        self._zero = np.zeros(self.dim)

    def error_jacobian_drift(self, state):
        e, J = self.task.compute(state)
        return e, J, self._zero, self.task.feedforward()


class AngularMomentumRateTask(AccelerationTask):
    """Centroidal angular momentum regulation: ask L̇ = L̇_ff − K (L − L*) (module docstring).

    Args:
        gain: K (1/s), ≥ 0.
        weight: scalar or (3,) weights of the x, y, z rows (world axes).

    Attributes:
        target: (3,) L* (N·m·s), default zero.
    """

    dim = 3
    name = "angular_momentum"

    def __init__(self, *, gain: float = 10.0, weight=1.0, name: str | None = None):
        super().__init__(kp=0.0, kd=gain, weight=weight, name=name)
        self.target = np.zeros(3)

    @property
    def gain(self) -> float:
        return self.kd

    def set_target(self, momentum) -> None:
        """L* (3,) (N·m·s, world axes about the CoM).

        Raises:
            InvalidTargetError: wrong shape or NaN.
        """
        self.target = check_vector(momentum, 3, "angular momentum target", InvalidTargetError).copy()

    def compute(self, state: DynamicsState) -> tuple[np.ndarray, np.ndarray]:
        J = state.centroidal_momentum_matrix[3:6]
        L = J @ state.v
        self.last_error = L - self.target
        r = -self.kd * self.last_error - state.centroidal_drift[3:6]
        if self._acc_ff is not None:
            r += self._acc_ff
        return J, r


#: Former name of :class:`AngularMomentumRateTask` (kept so existing callers run; it shadowed
#: :class:`wbc.tasks.AngularMomentumTask`, the velocity-level task).
AngularMomentumTask = AngularMomentumRateTask


def acceleration_task(task: Task, *, kp: float, kd: float | None = None, weight=None) -> AccelerationTask:
    """Wrap a kinematic task (ComTask, FrameTask and its forms, PostureTask) at acceleration level.

    Raises:
        InvalidInputError: a task type without an acceleration-level form.
    """
    for cls in (ComAccelerationTask, FrameAccelerationTask, PostureAccelerationTask):
        if isinstance(task, cls.kinematic_type):
            return cls(task, kp=kp, kd=kd, weight=weight)
    raise InvalidInputError(f"no acceleration-level form for {type(task).__name__}")
