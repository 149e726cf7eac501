"""A task's entry in the acceleration-level (inverse-dynamics) QP: the shared task plus its PD reference.

The task itself (any :class:`wbc.tasks.base.Task`) states its error e(q), Jacobian J and drift J̇v once
(:meth:`~wbc.tasks.base.Task.compute`, :meth:`~wbc.tasks.base.Task.drift`). The acceleration formulation asks

    J v̇ = r,    r = a* − J̇ v,    a* = ä_ff − Kp e − Kd (J v − ė_ff)                                    (1)

with ė_ff the task's own feed-forward (:meth:`~wbc.tasks.base.Task.feedforward`), ä_ff an acceleration feed-forward
and the gains Kp (1/s²), Kd (1/s; default the critically damped 2√Kp), held with the weight and ä_ff by
:class:`AccelerationReference` (not a second task class: the velocity formulation uses the same task object).

Centroidal angular-momentum regulation L̇ = L̇_ff − K (L − L*) is an :class:`AccelerationReference` with Kp = 0 and
Kd = K on a :class:`~wbc.tasks.AngularMomentumTask` (e ≡ 0, J = A_g[3:6], ė_ff = its target L*).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from wbc.compiled import FASTMATH
from wbc.configuration import check_vector
from wbc.exceptions import InvalidInputError, InvalidTargetError
from wbc.geometry import check_scalar
from wbc.state import DynamicsState
from wbc.tasks.base import Task, ValidatedAttribute, as_weight

__all__ = ["AccelerationReference"]


@nb.njit(cache=True, nogil=True, fastmath=FASTMATH, inline="always")
def reference_rhs(acc_ff, kp, e, kd, e_dot, e_dot_ff, drift):
    """Eq. 1 for one task row, ė = J v given (task units /s²): the one formula of r, for hard and weighted tasks."""
    return acc_ff - kp * e - kd * (e_dot - e_dot_ff) - drift


class AccelerationReference:
    """A shared task in the acceleration-level QP with the PD reference of eq. 1.

    Args:
        task: the task (:class:`wbc.tasks.base.Task` with a :meth:`~wbc.tasks.base.Task.drift`).
        kp: stiffness Kp (1/s²), ≥ 0.
        kd: damping Kd (1/s), ≥ 0; default 2√Kp.
        weight: scalar or (m,) cost weights; default a copy of the task's weight at construction.
        name: label (default the task's name).

    Attributes:
        task: the shared task. dim: rows m. last_error: (m,) error at the last :meth:`compute` (task units).

    Raises:
        InvalidInputError: not a task, or a task type without an acceleration-level form (no
            :meth:`~wbc.tasks.base.Task.drift` of its own); negative/non-finite gains or weights (at construction, or
            on assignment of ``kp``, ``kd``, ``weight``).
    """

    def __init__(self, task: Task, *, kp: float, kd: float | None = None, weight=None, name: str | None = None):
        if not isinstance(task, Task):
            raise InvalidInputError(f"an acceleration reference needs a wbc.tasks Task, got {type(task).__name__}")
        if type(task).drift is Task.drift:
            raise InvalidInputError(f"{type(task).__name__} has no acceleration-level form: it defines no drift J̇v "
                                    "(override Task.drift)")
        self.task = task
        self.dim = task.dim
        self.name = name or task.name
        self.kp = kp
        self.kd = 2.0 * math.sqrt(self.kp) if kd is None else kd
        self.weight = task.weight if weight is None else weight
        self._acc_ff: np.ndarray | None = None
        self.last_error = np.zeros(self.dim)

    kp = ValidatedAttribute(lambda ref, kp: check_scalar(kp, f"{ref.name} kp", "1/s²"),
                            "Kp (1/s², finite, ≥ 0). Raises InvalidInputError on assignment of anything else.")
    kd = ValidatedAttribute(lambda ref, kd: check_scalar(kd, f"{ref.name} kd", "1/s"),
                            "Kd (1/s, finite, ≥ 0). Raises InvalidInputError on assignment of anything else.")

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

    def set_feedforward_acceleration_trusted(self, acceleration: np.ndarray | None) -> None:
        """:meth:`set_feedforward_acceleration` without validation or copy (a controller's own loop): ``acceleration``
        None or a finite (m,) float array, kept by reference (the caller must not modify it)."""
        self._acc_ff = acceleration

    @property
    def feedforward_acceleration(self) -> np.ndarray | None:
        """(m,) ä_ff of eq. 1 (None: zero); set by :meth:`set_feedforward_acceleration`."""
        return self._acc_ff

    def compute(self, state: DynamicsState) -> tuple[np.ndarray, np.ndarray]:
        """(J (m, nv), r (m,)) of eq. 1 (the task asks J v̇ = r), arrays the caller may not keep across ticks."""
        task = self.task
        e, J = task.compute(state)
        self.last_error = e
        e_dot_ff = task.feedforward()  # (eq. 1 as the compiled assembly writes it, in numpy: hard tasks only)
        r = reference_rhs.py_func(0.0 if self._acc_ff is None else self._acc_ff, self.kp, e, self.kd, J @ state.v,
                                  0.0 if e_dot_ff is None else e_dot_ff, task.drift(state))
        return J, np.asarray(r, dtype=float)
