"""Task interface shared by both control levels.

A task is a residual e(q) ∈ R^m that should vanish, with its Jacobian J(q) = ∂e/∂q ∈ R^{m×nv} (derivative
along the configuration manifold: e(q ⊕ δv) ≈ e(q) + J δv) and its drift J̇ v ∈ R^m (the part of ë that does not
depend on v̇: ë = J v̇ + J̇ v, evaluated at a :class:`~wbc.state.DynamicsState`, i.e. after Pinocchio's forward
kinematics with (q, v, v̇ = 0)). Each task states e, J and J̇v once (:meth:`Task.compute`, :meth:`Task.drift`); the
formulations use them as they need:

* velocity level (:mod:`wbc.formulations.velocity`): J v = v*,   v* = ė* − K e,
  with K the task gain (1/s) and ė* an optional feed-forward rate of the error (e.g. a reference velocity);
* acceleration level (:mod:`wbc.formulations.acceleration`): J v̇ = a* − J̇ v,  a* = ä* − Kp e − Kd (J v − ė*),
  with the PD gains and ä* held by the formulation's :class:`~wbc.formulations.reference.AccelerationReference`.
"""

from __future__ import annotations

import operator
from abc import ABC, abstractmethod

import numpy as np

from wbc.configuration import Configuration
from wbc.exceptions import InvalidInputError

__all__ = ["Task", "as_weight", "ValidatedAttribute"]


class ValidatedAttribute(property):
    """An attribute validated on assignment (of a task, a contact, an acceleration reference...): ``check(obj,
    value)`` returns the value to store (in ``obj._<name>``) or raises; reading returns the stored value (a property
    whose getter is :func:`operator.attrgetter`: no Python call per read, as the attribute is read every tick).

    Args:
        check: ``(obj, value) -> stored value``, raising a typed error from :mod:`wbc.exceptions`.
        doc: docstring of the attribute (shape, units, frame, errors).
    """

    def __init__(self, check, doc: str = ""):
        super().__init__(doc=doc)
        self.__doc__ = doc  # the attribute's own docstring (a property subclass would show the class's)
        self.check = check

    def __set_name__(self, owner, name: str) -> None:
        attr = "_" + name
        check = self.check

        def store(obj, value) -> None:
            setattr(obj, attr, check(obj, value))

        property.__init__(self, operator.attrgetter(attr), store, None, self.__doc__)
        self.attr = attr


def _as_gain(task, value) -> float:
    """A task's gain K (1/s) as a float, finite and ≥ 0.

    Raises:
        InvalidInputError: negative, NaN/inf or not a number.
    """
    try:
        k = float(value)
    except (TypeError, ValueError):
        k = float("nan")
    if isinstance(value, bool) or not (np.isfinite(k) and k >= 0):
        raise InvalidInputError(f"{task.name} gain must be a finite number ≥ 0 (1/s), got {value!r}")
    return k


def as_weight(weight, dim: int, what: str) -> np.ndarray:
    """Broadcast a scalar or (dim,) weight to a non-negative finite (dim,) array of its own (a copy: later edits of
    the caller's array do not reach it, so that each weight array has one owner).

    Raises:
        InvalidInputError: not numbers (e.g. a string or a bool), wrong shape, negative or non-finite entries.
    """
    try:
        w = np.array(weight, dtype=float)
    except (TypeError, ValueError):
        w = None
    if w is None or isinstance(weight, (bool, np.bool_)):
        raise InvalidInputError(f"{what} must be a non-negative finite scalar or ({dim},) array of numbers, got "
                                f"{weight!r}")
    if w.ndim == 0:
        w = np.full(dim, float(w))
    if w.shape != (dim,) or not np.isfinite(w).all() or (w < 0).any():
        raise InvalidInputError(f"{what} must be a non-negative finite scalar or ({dim},) array, got {weight!r}")
    return w


class Task(ABC):
    """A weighted velocity-level task.

    Attributes:
        name: label used in reports.
        dim: number of rows m of e and J.
        gain: K (1/s), ≥ 0. Deadbeat at K = 1/dt.
        weight: (m,) cost weight of each row (the QP cost is Σ w_r (J_r v − v*_r)²).
    """

    name: str = "task"
    dim: int = 0

    def __init__(self, *, gain: float, weight, name: str | None = None):
        if name is not None:
            self.name = name
        self.gain = gain
        self._weight = as_weight(weight, self.dim, f"{self.name} weight")

    gain = ValidatedAttribute(lambda task, k: _as_gain(task, k),
                              "K (1/s), finite and ≥ 0; validated on assignment (raises InvalidInputError: negative, "
                              "NaN/inf or not a number).")

    weight = ValidatedAttribute(lambda task, w: as_weight(w, task.dim, f"{task.name} weight"),
                                "(m,) cost weight of each row, ≥ 0 (raises InvalidInputError like as_weight).")

    def share_weight(self, rows: np.ndarray) -> None:
        """Keep the weights in ``rows`` from now on: the current (m,) weights are copied into it and it becomes the
        array :attr:`weight` returns, so that in-place edits of ``task.weight`` reach the owner of ``rows`` (a
        controller's stacked weight rows) with no copy per tick. Assigning ``task.weight = ...`` replaces it again
        by a new validated array.

        Args:
            rows: writable (m,) float64 array (typically a view of a larger buffer).

        Raises:
            InvalidInputError: ``rows`` is not a writable (m,) float64 array.
        """
        if not (isinstance(rows, np.ndarray) and rows.shape == (self.dim,) and rows.dtype == np.float64
                and rows.flags.writeable):
            raise InvalidInputError(f"{self.name} weight rows must be a writable ({self.dim},) float64 array, got "
                                    f"{type(rows).__name__} {getattr(rows, 'shape', '')}")
        rows[:] = self._weight
        self._weight = rows

    @abstractmethod
    def compute(self, config: Configuration) -> tuple[np.ndarray, np.ndarray]:
        """Return (e (m,), J (m, nv)) at ``config``."""

    def compute_error(self, config: Configuration) -> np.ndarray:
        """(m,) task error e(q) (units of the task: m, rad, ...)."""
        return self.compute(config)[0]

    def compute_jacobian(self, config: Configuration) -> np.ndarray:
        """(m, nv) Jacobian ∂e/∂q of the task error."""
        return self.compute(config)[1]

    def compute_into(self, config: Configuration, error_out: np.ndarray, jac_out: np.ndarray) -> None:
        """Write e (m,) and J (m, nv) at ``config`` into the given arrays (views of a controller's stacked
        buffers): the same numbers as :meth:`compute`, without returning new arrays. Tasks with a cheaper
        in-place form override it."""
        error, jac = self.compute(config)
        error_out[:] = error
        jac_out[:] = jac

    def compute_with_drift_into(self, state, error_out: np.ndarray, jac_out: np.ndarray,
                                drift_out: np.ndarray) -> None:
        """:meth:`compute_into`, then :meth:`drift` written into drift_out (m,), at ``state`` (a
        :class:`~wbc.state.DynamicsState`). Tasks that share work between the two override it.

        Raises:
            NotImplementedError: a task without an acceleration-level form.
        """
        self.compute_into(state, error_out, jac_out)
        drift_out[:] = self.drift(state)

    def feedforward(self) -> np.ndarray | None:
        """(m,) desired rate of the error ė* (None: zero)."""
        return None

    def drift(self, state) -> np.ndarray:
        """(m,) J̇ v at ``state`` (a :class:`~wbc.state.DynamicsState`: Pinocchio data after the forward kinematics
        with (q, v, v̇ = 0)), so that ë = J v̇ + J̇ v (task units /s²). Checked against finite differences of J v
        along q(t) = q ⊕ t v in ``tests/tasks/test_tasks_base.py``.

        Raises:
            NotImplementedError: a task without an acceleration-level form.
        """
        raise NotImplementedError(f"{type(self).__name__} has no drift J̇v (no acceleration-level form)")

    def velocity_target(self, error: np.ndarray) -> np.ndarray:
        """(m,) v* = ė* − K e for the given error."""
        ff = self.feedforward()
        target = -self.gain * error
        if ff is not None:
            target += ff
        return target

    def add_cost(self, config: Configuration, H: np.ndarray, g: np.ndarray) -> None:
        """Add this task's cost Σ_r w_r (J_r v − v*_r)² to the QP as H += Jᵀ W J, g −= Jᵀ W v* (the constant
        term is dropped). H (nv, nv) and g (nv,) are modified in place."""
        error, jac = self.compute(config)
        wj = jac * self._weight[:, None]
        H += jac.T @ wj
        g -= wj.T @ self.velocity_target(error)
