"""Posture task: e = q ⊖ q* on the actuated joints (rad), J = the matching rows of the identity (nv columns),
drift J̇v = 0 (J is constant: the rows of 1-DoF and continuous joints, whose q ⊖ q* has derivative 1 along v).

q ⊖ q* is ``pin.difference(model, q*, q)``, so continuous joints and the manifold are handled by Pinocchio.
"""

from __future__ import annotations

import numba as nb
import numpy as np
import pinocchio as pin

from wbc.compiled import CHECK_TYPES, NO_NRT, once_per_process, specialise
from wbc.configuration import Configuration, check_vector
from wbc.exceptions import InvalidTargetError
from wbc.tasks.base import Task, ValidatedAttribute

__all__ = ["PostureTask"]

#: joints whose q ⊖ q* is q − q* (Pinocchio's vector-space joints of one coordinate per velocity)
_VECTOR_JOINTS = frozenset({"JointModelRX", "JointModelRY", "JointModelRZ", "JointModelRevoluteUnaligned",
                            "JointModelPX", "JointModelPY", "JointModelPZ", "JointModelPrismaticUnaligned",
                            "JointModelTranslation"})


@nb.njit(cache=True, nogil=True)
def _diagonal_cost(diff, start, weight, gain, H, g):
    """H[i, i] += w_k and g[i] −= w_k (−K e_k) for the contiguous rows i = start + k, e = diff[start:start + k]
    (``pin.difference``): the cost of a selection Jacobian with v* = −K e, compiled (assembly arithmetic)."""
    for k in range(weight.shape[0]):
        i = start + k
        H[i, i] += weight[k]
        g[i] -= weight[k] * (-gain * diff[i])


@nb.njit(cache=True, **NO_NRT)  # GIL kept: releasing it costs more than this call's work
def _vector_difference(q, target, start, out):
    """out[k] = q[start + k] − q*[start + k]: q ⊖ q* on contiguous vector-space coordinates (Pinocchio's q1 − q0)."""
    for k in range(out.shape[0]):
        out[k] = q[start + k] - target[start + k]


@once_per_process
def _warm_up() -> None:
    """Load :func:`_diagonal_cost` (on-disk cache) once per process, at task construction, and
    :func:`_vector_difference` specialised for q and q* of any strides (the dispatcher with kernel type checks on)."""
    global _vector_difference_any
    _diagonal_cost(np.zeros(1), 0, np.zeros(1), 1.0, np.zeros((1, 1)), np.zeros(1))
    specialise(_vector_difference, np.zeros(4), np.zeros(4), 0, np.zeros(2))  # the dispatcher's call (CHECK_TYPES)
    _vector_difference_any = _vector_difference if CHECK_TYPES else specialise(
        _vector_difference, np.zeros(4)[::2], np.zeros(4)[::2], 0, np.zeros(2))


_vector_difference_any = None  # _vector_difference specialised by _warm_up (run by every PostureTask's constructor)


class PostureTask(Task):
    """Pull joints towards a reference configuration.

    Args:
        robot: the robot (its ``q_ref`` is the initial target).
        joints: joint names to regulate (default: every actuated joint — grippers too).
        weight: scalar or (len(rows),) weights.
        gain: K (1/s).

    Raises:
        UnknownJointError: a joint name is not in the model.
    """

    name = "posture"

    def __init__(self, robot, *, joints: list[str] | None = None, weight=1e-2, gain: float = 10.0,
                 name: str | None = None):
        model = robot.model
        names = robot.joint_names if joints is None else joints
        rows: list[int] = []
        for jname in names:
            joint = model.joints[robot.joint_id(jname)]
            rows.extend(range(joint.idx_v, joint.idx_v + joint.nv))
        self.model = model
        self.rows = np.asarray(rows, dtype=int)
        self.dim = int(self.rows.size)
        super().__init__(gain=gain, weight=weight, name=name)
        self._jac = np.zeros((self.dim, model.nv))
        self._jac[np.arange(self.dim), self.rows] = 1.0
        self._zero = np.zeros(self.dim)
        nv = model.nv
        contiguous = self.dim and np.array_equal(self.rows, np.arange(self.rows[0], self.rows[0] + self.dim))
        self._span = slice(self.rows[0] * (nv + 1), (self.rows[-1] + 1) * (nv + 1), nv + 1) if contiguous else None
        self._vspan = slice(int(self.rows[0]), int(self.rows[-1]) + 1) if contiguous else None  # rows of v as a slice
        self.target = np.array(robot.q_ref, dtype=float)
        # row_difference: the rows' q − q* on contiguous coordinates when every regulated joint is a vector space
        joints = [model.joints[robot.joint_id(j)] for j in names]
        q0 = joints[0].idx_q if joints and all(j.shortname() in _VECTOR_JOINTS for j in joints) else -1
        self._q_start = q0 if contiguous and q0 >= 0 and all(
            j.idx_q - q0 == j.idx_v - self.rows[0] for j in joints) else -1
        self._diff = np.zeros(nv)
        self._diff_rows = self._diff[self._vspan] if self._q_start >= 0 else None
        _warm_up()

    def set_target(self, q) -> None:
        """Target configuration (nq,) (only the regulated joints matter).

        Raises:
            InvalidTargetError: wrong size or NaN.
        """
        self.target = q

    target = ValidatedAttribute(
        lambda task, q: check_vector(q, task.model.nq, "posture target", InvalidTargetError).copy(),
        "Target configuration (nq,); validated on assignment (raises InvalidTargetError: wrong size or NaN).")

    def compute(self, config: Configuration) -> tuple[np.ndarray, np.ndarray]:
        return pin.difference(self.model, self.target, config.q)[self.rows], self._jac

    def row_difference(self, q: np.ndarray) -> np.ndarray:
        """(nv,) array whose regulated rows hold q ⊖ q* (``pin.difference(model, target, q)``, the same numbers: q − q*
        where every regulated joint is a revolute or prismatic one, on contiguous coordinates) at a configuration q
        (nq,); its other entries are unspecified. The task's own buffer (overwritten at the next call) or Pinocchio's
        array."""
        if self._q_start < 0:
            return pin.difference(self.model, self._target, q)
        _vector_difference_any(q, self._target, self._q_start, self._diff_rows)
        return self._diff

    def drift(self, state) -> np.ndarray:
        """(dim,) zeros: J is a constant selection."""
        return self._zero

    def add_cost(self, config: Configuration, H: np.ndarray, g: np.ndarray) -> None:
        """J selects coordinates of v, so Jᵀ W J is diagonal: added without forming J."""
        if self._span is not None and type(self).velocity_target is Task.velocity_target and \
                type(self).feedforward is Task.feedforward:  # contiguous rows, v* = −K e: one compiled loop
            _diagonal_cost(pin.difference(self.model, self._target, config.q), self._vspan.start, self._weight,
                           self._gain, H, g)
        elif self._span is not None:  # contiguous rows: views (a strided one of H's diagonal), no fancy indexing
            error = pin.difference(self.model, self._target, config.q)[self._vspan]
            H.ravel()[self._span] += self._weight
            g[self._vspan] -= self._weight * self.velocity_target(error)
        else:
            error = pin.difference(self.model, self._target, config.q)[self.rows]
            H[self.rows, self.rows] += self._weight
            g[self.rows] -= self._weight * self.velocity_target(error)
