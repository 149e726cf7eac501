"""A task's entry in the acceleration-level (inverse-dynamics) QP: the shared task plus its PD reference.

The task itself (any :class:`wbc.tasks.base.Task`) states its error e(q), Jacobian J and drift J̇v once
(:meth:`~wbc.tasks.base.Task.compute`, :meth:`~wbc.tasks.base.Task.drift`). The acceleration formulation asks

    J v̇ = r,    r = a* − J̇ v,    a* = ä_ff − Kp e − Kd (J v − ė_ff)                                    (1)

with ė_ff the task's own feed-forward (:meth:`~wbc.tasks.base.Task.feedforward`, the same one the velocity level
uses), ä_ff an acceleration feed-forward and the gains Kp (1/s²), Kd (1/s; default the critically damped 2√Kp).
This module holds only those gains, the weight and ä_ff: :class:`AccelerationReference`. It is not a second task
class (there is no per-task subclass); the velocity formulation uses the same task object with (J, v*).

The former acceleration-task classes of ``wbc.dynamics`` are kept as constructors returning an
:class:`AccelerationReference` on the given shared task (deprecated names): :func:`ComAccelerationTask`,
:func:`FrameAccelerationTask`, :func:`PostureAccelerationTask`, :func:`AngularMomentumRateTask` (a
:class:`~wbc.tasks.AngularMomentumTask`, e ≡ 0, with Kp = 0 and Kd = ``gain``) and :func:`acceleration_task`.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from wbc.configuration import check_vector
from wbc.exceptions import InvalidInputError, InvalidTargetError
from wbc.state import DynamicsState
from wbc.tasks.base import Task, as_weight
from wbc.tasks.com import ComTask
from wbc.tasks.frame import FrameTask
from wbc.tasks.momentum import AngularMomentumTask
from wbc.tasks.posture import PostureTask

__all__ = [
    "AccelerationReference", "AccelerationTask", "ComAccelerationTask", "FrameAccelerationTask",
    "PostureAccelerationTask", "AngularMomentumRateTask", "acceleration_task",
]


def _gain(value, what: str) -> float:
    try:
        g = float(value)
    except (TypeError, ValueError):
        raise InvalidInputError(f"{what} must be a finite number ≥ 0, got {value!r}") from None
    if not (math.isfinite(g) and g >= 0):
        raise InvalidInputError(f"{what} must be finite and ≥ 0, got {value!r}")
    return g


class AccelerationReference:
    """A shared task in the acceleration-level QP with the PD reference of eq. 1.

    Args:
        task: the task (:class:`wbc.tasks.base.Task` with a :meth:`~wbc.tasks.base.Task.drift`).
        kp: stiffness Kp (1/s²), ≥ 0.
        kd: damping Kd (1/s), ≥ 0; default 2√Kp.
        weight: scalar or (m,) cost weights; default the task's own weight.
        name: label (default the task's name).

    Attributes:
        task: the shared task. dim: rows m. last_error: (m,) error at the last :meth:`compute` (task units).

    Raises:
        InvalidInputError: not a task; negative/non-finite gains or weights (at construction, or on assignment of
            ``kp``, ``kd``, ``weight``).
    """

    def __init__(self, task: Task, *, kp: float, kd: float | None = None, weight=None, name: str | None = None):
        if not isinstance(task, Task):
            raise InvalidInputError(f"an acceleration reference needs a wbc.tasks Task, got {type(task).__name__}")
        self.task = task
        self.dim = task.dim
        self.name = name or task.name
        self.kp = kp
        self.kd = 2.0 * math.sqrt(self.kp) if kd is None else kd
        self.weight = task.weight if weight is None else weight
        self._acc_ff: np.ndarray | None = None
        self.last_error = np.zeros(self.dim)

    @property
    def kp(self) -> float:
        """Kp (1/s², finite, ≥ 0). Raises InvalidInputError on assignment of anything else."""
        return self._kp

    @kp.setter
    def kp(self, value) -> None:
        self._kp = _gain(value, f"{self.name} kp")

    @property
    def kd(self) -> float:
        """Kd (1/s, finite, ≥ 0). Raises InvalidInputError on assignment of anything else."""
        return self._kd

    @kd.setter
    def kd(self, value) -> None:
        self._kd = _gain(value, f"{self.name} kd")

    @property
    def weight(self) -> np.ndarray:
        """(m,) cost weights (finite, ≥ 0); assign a scalar or an (m,) array. Raises InvalidInputError on
        assignment of anything else."""
        return self._weight

    @weight.setter
    def weight(self, value) -> None:
        try:
            self._weight = as_weight(value, self.dim, f"{self.name} weight")
        except (TypeError, ValueError):
            raise InvalidInputError(f"{self.name} weight must be a non-negative finite scalar or ({self.dim},) array, "
                                    f"got {value!r}") from None

    def set_target(self, *args, **kwargs) -> None:
        """Forwarded to the task's ``set_target`` (its validation and errors)."""
        self.task.set_target(*args, **kwargs)

    def set_feedforward_acceleration(self, acceleration) -> None:
        """Feed-forward ä_ff (m,) of eq. 1 (None clears it).

        Raises:
            InvalidTargetError: wrong shape or NaN.
        """
        self._acc_ff = None if acceleration is None else check_vector(
            acceleration, self.dim, f"{self.name} feed-forward acceleration", InvalidTargetError).copy()

    @property
    def feedforward_acceleration(self) -> np.ndarray | None:
        """(m,) ä_ff of eq. 1 (None: zero); set by :meth:`set_feedforward_acceleration`."""
        return self._acc_ff

    def compute(self, state: DynamicsState) -> tuple[np.ndarray, np.ndarray]:
        """(J (m, nv), r (m,)) such that the task asks J v̇ = r, r = a* − J̇ v (eq. 1).

        Returns arrays the caller may not keep across ticks.
        """
        task = self.task
        e, J = task.compute(state)
        drift = task.drift(state)
        e_dot_ff = task.feedforward()
        self.last_error = e
        e_dot = J @ state.v
        if e_dot_ff is not None:
            e_dot = e_dot - e_dot_ff
        r = -self.kp * e - self.kd * e_dot - drift
        if self._acc_ff is not None:
            r += self._acc_ff
        return J, r


def deprecated(old: str, new: str, stacklevel: int = 3) -> None:
    """Warn (DeprecationWarning, at the caller of the deprecated name) that ``old`` is deprecated for ``new``."""
    warnings.warn(f"{old} is deprecated: use {new}", DeprecationWarning, stacklevel=stacklevel)


def __getattr__(name: str):
    if name == "AccelerationTask":  # former name of AccelerationReference (deprecated)
        deprecated("AccelerationTask", "AccelerationReference")
        return AccelerationReference
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def _reference_on(kind: type, task, kp, kd, weight, name) -> AccelerationReference:
    if not isinstance(task, kind):
        raise InvalidInputError(f"expected a {kind.__name__}, got {type(task).__name__}")
    return AccelerationReference(task, kp=kp, kd=kd, weight=weight, name=name)


def ComAccelerationTask(task: ComTask | None = None, *, kp: float = 100.0, kd: float | None = None, weight=None,
                        name: str | None = None) -> AccelerationReference:
    """Deprecated constructor: :class:`AccelerationReference` on a :class:`~wbc.tasks.ComTask` (a new one with unit
    weights when ``task`` is None). Raises InvalidInputError for another task type or bad gains; warns
    DeprecationWarning."""
    deprecated("ComAccelerationTask", "AccelerationReference(ComTask(), kp=..., kd=..., weight=...)")
    return _reference_on(ComTask, ComTask() if task is None else task, kp, kd, weight, name)


def FrameAccelerationTask(task: FrameTask, *, kp: float = 100.0, kd: float | None = None, weight=None,
                          name: str | None = None) -> AccelerationReference:
    """Deprecated constructor: :class:`AccelerationReference` on a :class:`~wbc.tasks.FrameTask` (or its
    Position/Orientation/Relative forms). Raises InvalidInputError for another task type or bad gains; warns
    DeprecationWarning."""
    deprecated("FrameAccelerationTask", "AccelerationReference(frame_task, kp=..., kd=..., weight=...)")
    return _reference_on(FrameTask, task, kp, kd, weight, name)


def PostureAccelerationTask(task: PostureTask, *, kp: float = 50.0, kd: float | None = None, weight=None,
                            name: str | None = None) -> AccelerationReference:
    """Deprecated constructor: :class:`AccelerationReference` on a :class:`~wbc.tasks.PostureTask`. Raises
    InvalidInputError for another task type or bad gains; warns DeprecationWarning."""
    deprecated("PostureAccelerationTask", "AccelerationReference(posture_task, kp=..., kd=..., weight=...)")
    return _reference_on(PostureTask, task, kp, kd, weight, name)


def AngularMomentumRateTask(*, gain: float = 10.0, weight=1.0, name: str | None = None) -> AccelerationReference:
    """Deprecated constructor: centroidal angular momentum regulation L̇ = L̇_ff − K (L − L*), i.e. an
    :class:`AccelerationReference` with Kp = 0, Kd = ``gain`` (1/s) on a new :class:`~wbc.tasks.AngularMomentumTask`
    (e ≡ 0, J = Ag[3:6], ė_ff = its target L*, N·m·s); ``set_target(L*)`` sets L*. Raises InvalidInputError for bad
    gain or weights; warns DeprecationWarning."""
    deprecated("AngularMomentumRateTask", "AccelerationReference(wbc.tasks.AngularMomentumTask(), kp=0, kd=gain)")
    return AccelerationReference(AngularMomentumTask(weight=weight), kp=0.0, kd=gain, weight=weight,
                                 name=name or AngularMomentumTask.name)


def acceleration_task(task: Task, *, kp: float, kd: float | None = None, weight=None) -> AccelerationReference:
    """:class:`AccelerationReference` on any task with a drift.

    Raises:
        InvalidInputError: not a task, or a task type without an acceleration-level form (no drift).
    """
    if not isinstance(task, Task) or type(task).drift is Task.drift:
        raise InvalidInputError(f"no acceleration-level form for {type(task).__name__}")
    return AccelerationReference(task, kp=kp, kd=kd, weight=weight)
