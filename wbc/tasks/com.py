"""Centre-of-mass task: e = c(q) − c* (world, m), J = Pinocchio's CoM Jacobian (3, nv), drift J̇v = c̈ at v̇ = 0
= (dAg v)[0:3] / m (``DynamicsState.com_drift``; equal to ``data.acom[0]`` of ``pin.centerOfMass(model, data, q, v,
0)``)."""

from __future__ import annotations

import numba as nb
import numpy as np

from wbc.compiled import CHECK_TYPES, NO_NRT, once_per_process, specialise
from wbc.configuration import Configuration, check_vector
from wbc.exceptions import InvalidTargetError
from wbc.tasks.base import Task, ValidatedAttribute

__all__ = ["ComTask"]


@nb.njit(cache=True, **NO_NRT)  # GIL kept: releasing it costs more than this call's work
def _com_rows(com, target, jac, error_out, jac_out):
    """error_out = com − target, jac_out = jac (one compiled call instead of two numpy ones)."""
    for i in range(jac.shape[0]):
        error_out[i] = com[i] - target[i]
        for j in range(jac.shape[1]):
            jac_out[i, j] = jac[i, j]


@once_per_process
def _warm_up() -> None:
    """Load :func:`_com_rows` (on-disk cache) once per process, at construction, specialised for arguments of any
    strides (numba layout 'A'): one version for every caller's arrays, a read-only target too (a
    :class:`~wbc.gait.WalkPlan` row given to :meth:`ComTask.set_target_trusted`); with kernel type checks on
    (:data:`wbc.compiled.CHECK_TYPES`), the dispatcher's versions for a writeable and a read-only target."""
    global _com_rows_any
    vector, matrix = np.zeros(6)[::2], np.zeros((3, 2))[:, ::2]
    _com_rows_any = _com_rows if CHECK_TYPES else specialise(_com_rows, vector, vector, matrix, vector, matrix)
    if not CHECK_TYPES:
        return
    frozen = np.zeros(3)
    frozen.flags.writeable = False
    for target in (np.zeros(3), frozen):
        _com_rows(np.zeros(3), target, np.zeros((3, 1)), np.zeros(3), np.zeros((3, 1)))


_com_rows_any = None  # _com_rows specialised by _warm_up (wbc.compiled.specialise; run by every ComTask's constructor)


def _checked_target(task, com) -> np.ndarray:
    """A copy of ``com`` as a finite float (3,) array: the stored CoM target.

    Raises:
        InvalidTargetError: wrong shape, not numeric, or NaN/inf entries.
    """
    return check_vector(com, 3, "CoM target", InvalidTargetError).copy()


class ComTask(Task):
    """Track a CoM position (and velocity feed-forward) in world.

    Args:
        weight: scalar or (3,) weights of the x, y, z rows.
        gain: K (1/s).
    """

    dim = 3
    name = "com"

    def __init__(self, *, weight=1.0, gain: float = 100.0, name: str | None = None):
        super().__init__(gain=gain, weight=weight, name=name)
        self.target = np.zeros(3)
        self._ff: np.ndarray | None = None
        _warm_up()

    def set_target(self, com, velocity=None) -> None:
        """Target CoM (3,) in world (m) and optional CoM velocity (3,) (m/s).

        Raises:
            InvalidTargetError: wrong shape or NaN.
        """
        self._target = check_vector(com, 3, "CoM target", InvalidTargetError).copy()  # as _checked_target
        self._ff = None if velocity is None else check_vector(velocity, 3, "CoM velocity", InvalidTargetError).copy()

    target = ValidatedAttribute(_checked_target, "Target CoM (3,) m, world; validated on assignment (raises "
                                "InvalidTargetError: wrong shape or NaN).")

    def set_target_trusted(self, com: np.ndarray, velocity: np.ndarray | None = None) -> None:
        """:meth:`set_target` without validation or copies, for a controller's own loop feeding targets it built
        and validated once (e.g. the rows of a :class:`~wbc.gait.WalkPlan`): ``com`` (3,) m and ``velocity``
        (3,) m/s or None, float arrays, finite, world, kept by reference (the caller must not modify them)."""
        self._target = com
        self._ff = velocity

    def compute(self, config: Configuration) -> tuple[np.ndarray, np.ndarray]:
        return config.com - self._target, config.com_jacobian

    def compute_into(self, config: Configuration, error_out: np.ndarray, jac_out: np.ndarray) -> None:
        _com_rows_any(config.com, self._target, config.com_jacobian, error_out, jac_out)

    def feedforward(self) -> np.ndarray | None:
        return self._ff

    def drift(self, state) -> np.ndarray:
        """(3,) c̈ at v̇ = 0 (m/s², world)."""
        return state.com_drift
