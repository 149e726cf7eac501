"""State conversion between Pinocchio (free-flyer) and MuJoCo (free joint) vectors.

Numpy (the per-tick MuJoCo → Pinocchio state conversion: one compiled kernel); the conventions themselves are
documented once, in :mod:`wbc.sim.mujoco_model`. A :class:`StateMap` holds the index maps (joints matched by name)
and converts configurations, velocities, accelerations and generalized forces both ways.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba as nb
import numpy as np

from wbc.compiled import once_per_process
from wbc.exceptions import InvalidInputError
from wbc.geometry import check_vector

__all__ = ["StateMap", "quat_xyzw_to_matrix", "check_vector"]

_QUAT_NORM_TOL = 1e-3


def quat_xyzw_to_matrix(quat_xyzw: np.ndarray) -> np.ndarray:
    """(3, 3) rotation matrix of a unit quaternion given as (x, y, z, w) (normalized first)."""
    quat = np.asarray(quat_xyzw, dtype=float).ravel()
    x, y, z, w = (quat / math.sqrt(quat.dot(quat))).tolist()  # (the norm as numpy.linalg.norm computes it)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


@nb.njit(cache=True, inline="always")
def _state_into(qpos, qvel, q_gather, v_gather, tol, q, v):
    """:meth:`StateMap.state_from_mj` of a model without continuous joints, written into ``q``, ``v``: status 0
    done, 1 an entry of ``qpos``/``qvel`` not finite or a base quaternion not within ``tol`` of unit norm (q, v then
    not all written: the checked path raises)."""
    nq, nv = q_gather.size, v_gather.size
    for i in range(qpos.size):
        if not math.isfinite(qpos[i]):
            return 1
    for i in range(nv):
        if not math.isfinite(qvel[i]):
            return 1
    for i in range(nq):
        q[i] = qpos[q_gather[i]]
    for i in range(nv):
        v[i] = qvel[v_gather[i]]
    x, y, z, w = q[3], q[4], q[5], q[6]
    n = math.sqrt(x * x + y * y + z * z + w * w)
    if not math.isfinite(n) or abs(n - 1.0) > tol:
        return 1
    x, y, z, w = x / n, y / n, z / n, w / n  # _check_quat
    n = math.sqrt(x * x + y * y + z * z + w * w)
    x, y, z, w = x / n, y / n, z / n, w / n  # quat_xyzw_to_matrix
    r00, r01, r02 = 1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)
    r10, r11, r12 = 2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)
    r20, r21, r22 = 2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)
    a0, a1, a2 = qvel[0], qvel[1], qvel[2]
    v[0] = r00 * a0 + r10 * a1 + r20 * a2  # Rᵀ qvel[0:3]
    v[1] = r01 * a0 + r11 * a1 + r21 * a2
    v[2] = r02 * a0 + r12 * a1 + r22 * a2
    return 0


@nb.njit(cache=True)
def _state_kernel(qpos, qvel, q_gather, v_gather, tol):
    """:func:`_state_into` into new arrays: ``(q, v, status)``."""
    q, v = np.empty(q_gather.size), np.empty(v_gather.size)
    return q, v, _state_into(qpos, qvel, q_gather, v_gather, tol, q, v)


@nb.njit(cache=True)
def _states_kernel(qpos, qvel, q_gather, v_gather, tol, q, v):
    """:func:`_state_into` row by row (rows of qpos (N, nq_mj), qvel (N, nv) into q (N, nq), v (N, nv)): the
    number of rows converted before the first that is not (N when all are)."""
    for k in range(qpos.shape[0]):
        if _state_into(qpos[k], qvel[k], q_gather, v_gather, tol, q[k], v[k]) != 0:
            return k
    return qpos.shape[0]


@once_per_process
def _warm_up() -> None:
    """Load :func:`_state_kernel` and :func:`_states_kernel` (on-disk cache) once per process."""
    q_gather = np.array([0, 1, 2, 4, 5, 6, 3], dtype=np.intp)
    qpos = np.array([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0])
    v_gather = np.arange(6, dtype=np.intp)
    _state_kernel(qpos, np.zeros(6), q_gather, v_gather, _QUAT_NORM_TOL)
    _states_kernel(qpos[None], np.zeros((1, 6)), q_gather, v_gather, _QUAT_NORM_TOL, np.empty((1, 7)),
                   np.empty((1, 6)))


@dataclass(frozen=True)
class StateMap:
    """Index maps between Pinocchio's and MuJoCo's state vectors (root joint first in both).

    Attributes:
        nq, nv: Pinocchio sizes; MuJoCo has ``nq - n_continuous`` qpos entries and ``nv`` qvel entries.
        pin_q: (k,) Pinocchio q indices of the 1-coordinate joints (revolute, prismatic).
        mj_qpos: (k,) matching MuJoCo qpos indices.
        pin_q_cs: (c, 2) Pinocchio q indices (cos, sin) of continuous (unbounded revolute) joints.
        mj_qpos_cs: (c,) matching MuJoCo qpos indices (hinge angle, rad).
        mj_qvel: (nv - 6,) MuJoCo qvel index of Pinocchio ``v[6 + i]``.
    """

    nq: int
    nv: int
    nq_mj: int
    pin_q: np.ndarray
    mj_qpos: np.ndarray
    pin_q_cs: np.ndarray
    mj_qpos_cs: np.ndarray
    mj_qvel: np.ndarray

    def __post_init__(self) -> None:
        # gathers of the entries copied from MuJoCo in one take: q[i] = qpos[q_gather[i]], v[i] = qvel[v_gather[i]]
        # (the continuous joints' cos/sin and v[0:3] are computed over their placeholders)
        q_gather = np.zeros(self.nq, dtype=np.intp)
        q_gather[0:7] = (0, 1, 2, 4, 5, 6, 3)
        q_gather[self.pin_q] = self.mj_qpos
        v_gather = np.arange(self.nv, dtype=np.intp)
        v_gather[6:] = self.mj_qvel
        object.__setattr__(self, "_q_gather", q_gather)
        object.__setattr__(self, "_v_gather", v_gather)
        _warm_up()

    # -- configuration ---------------------------------------------------------------------------------------
    def base_rotation(self, q) -> np.ndarray:
        """(3, 3) world rotation of the base from a Pinocchio q (quaternion x, y, z, w at q[3:7])."""
        return quat_xyzw_to_matrix(self._check_quat(np.asarray(q, dtype=float)[3:7]))

    def q_to_mj(self, q) -> np.ndarray:
        """Pinocchio q (nq,) -> MuJoCo qpos (nq_mj,). The quaternion is normalized (|norm - 1| <= 1e-3).

        Raises:
            InvalidInputError: wrong shape, NaN/inf, or a base quaternion that is far from unit norm.
        """
        q = check_vector(q, self.nq, "q")
        quat = self._check_quat(q[3:7])
        qpos = np.empty(self.nq_mj)
        qpos[0:3] = q[0:3]
        qpos[3] = quat[3]
        qpos[4:7] = quat[0:3]
        qpos[self.mj_qpos] = q[self.pin_q]
        if len(self.mj_qpos_cs):
            qpos[self.mj_qpos_cs] = np.arctan2(q[self.pin_q_cs[:, 1]], q[self.pin_q_cs[:, 0]])
        return qpos

    def q_from_mj(self, qpos) -> np.ndarray:
        """MuJoCo qpos (nq_mj,) -> Pinocchio q (nq,)."""
        qpos = check_vector(qpos, self.nq_mj, "qpos")
        q = qpos[self._q_gather]
        if len(self.mj_qpos_cs):
            q[self.pin_q_cs[:, 0]] = np.cos(qpos[self.mj_qpos_cs])
            q[self.pin_q_cs[:, 1]] = np.sin(qpos[self.mj_qpos_cs])
        return q

    def state_from_mj(self, qpos, qvel) -> tuple[np.ndarray, np.ndarray]:
        """MuJoCo (qpos (nq_mj,), qvel (nv,)) -> Pinocchio (q (nq,), v (nv,)): :meth:`q_from_mj` and
        :meth:`v_from_mj` at that q, each input checked once.

        Raises:
            ConfigurationError: wrong shapes or NaN/inf. InvalidInputError: a base quaternion far from unit norm.
        """
        if not len(self.mj_qpos_cs) and type(qpos) is np.ndarray and type(qvel) is np.ndarray \
                and qpos.shape == (self.nq_mj,) and qvel.shape == (self.nv,) and qpos.dtype == qvel.dtype == float:
            q, v, status = _state_kernel(qpos, qvel, self._q_gather, self._v_gather, _QUAT_NORM_TOL)
            if status == 0:
                return q, v
        q = self.q_from_mj(qpos)  # (the checked path: raises on bad input)
        return q, self._v_from_mj(q, check_vector(qvel, self.nv, "qvel"))

    def states_from_mj(self, qpos, qvel, q_out: np.ndarray, v_out: np.ndarray) -> None:
        """:meth:`state_from_mj` of every row: MuJoCo qpos (N, nq_mj) and qvel (N, nv) → Pinocchio rows written
        into ``q_out`` (N, nq) and ``v_out`` (N, nv) (float arrays), the same numbers row by row.

        Raises:
            ConfigurationError: wrong shapes or NaN/inf. InvalidInputError: a base quaternion far from unit norm.
        """
        n = len(qpos)
        if not (isinstance(q_out, np.ndarray) and isinstance(v_out, np.ndarray) and q_out.dtype == v_out.dtype == float
                and q_out.shape == (n, self.nq) and v_out.shape == (n, self.nv)):
            raise InvalidInputError(f"q_out, v_out must be float arrays of shapes ({n}, {self.nq}) and ({n}, {self.nv})")
        done = 0
        if not len(self.mj_qpos_cs) and type(qpos) is np.ndarray and type(qvel) is np.ndarray \
                and qpos.shape == (n, self.nq_mj) and qvel.shape == (n, self.nv) and qpos.dtype == qvel.dtype == float:
            done = _states_kernel(qpos, qvel, self._q_gather, self._v_gather, _QUAT_NORM_TOL, q_out, v_out)
        for k in range(done, n):  # (the per-row path: raises on a bad row)
            q_out[k], v_out[k] = self.state_from_mj(qpos[k], qvel[k])

    # -- velocity, acceleration, force ----------------------------------------------------------------------
    def v_to_mj(self, q, v) -> np.ndarray:
        """Pinocchio v (nv,) at configuration q -> MuJoCo qvel (nv,): ``qvel = T(q) v``."""
        v = check_vector(v, self.nv, "v")
        rot = self.base_rotation(check_vector(q, self.nq, "q"))
        qvel = np.empty(self.nv)
        qvel[0:3] = rot @ v[0:3]
        qvel[3:6] = v[3:6]
        qvel[self.mj_qvel] = v[6:]
        return qvel

    def v_from_mj(self, q, qvel) -> np.ndarray:
        """MuJoCo qvel (nv,) -> Pinocchio v (nv,) at Pinocchio configuration q: ``v = T(q)⁻¹ qvel``."""
        qvel = check_vector(qvel, self.nv, "qvel")
        return self._v_from_mj(check_vector(q, self.nq, "q"), qvel)

    def _v_from_mj(self, q: np.ndarray, qvel: np.ndarray) -> np.ndarray:
        """:meth:`v_from_mj` of checked (nq,) q and (nv,) qvel."""
        v = qvel[self._v_gather]
        v[0:3] = self.base_rotation(q).T @ qvel[0:3]
        return v

    def velocity_transform(self, q) -> np.ndarray:
        """(nv, nv) matrix T(q) with ``qvel = T v``: blockdiag(R_base, I3, permutation)."""
        T = np.zeros((self.nv, self.nv))
        T[0:3, 0:3] = self.base_rotation(check_vector(q, self.nq, "q"))
        T[3:6, 3:6] = np.eye(3)
        T[self.mj_qvel, np.arange(6, self.nv)] = 1.0
        return T

    def acceleration_offset(self, q, v) -> np.ndarray:
        """(nv,) term ``Ṫ v`` of ``qacc = T a + Ṫ v``: only ``[0:3] = R (ω × v_lin)`` is non-zero."""
        v = check_vector(v, self.nv, "v")
        off = np.zeros(self.nv)
        off[0:3] = self.base_rotation(check_vector(q, self.nq, "q")) @ np.cross(v[3:6], v[0:3])
        return off

    def a_from_mj(self, q, v, qacc) -> np.ndarray:
        """MuJoCo qacc (nv,) -> Pinocchio a (nv,) = dv/dt at state (q, v) in Pinocchio conventions."""
        qacc = check_vector(qacc, self.nv, "qacc")
        return self.v_from_mj(q, qacc - self.acceleration_offset(q, v))

    def force_to_pin(self, q, f_mj) -> np.ndarray:
        """Generalized force in MuJoCo coordinates (nv,) -> Pinocchio coordinates: ``Tᵀ f`` (same power).

        Note: for a bias force, ``b_pin = Tᵀ (qfrc_bias + M_mj Ṫ v)`` (see :meth:`acceleration_offset`).
        """
        f_mj = check_vector(f_mj, self.nv, "generalized force")
        return self.velocity_transform(q).T @ f_mj

    def _check_quat(self, quat: np.ndarray) -> np.ndarray:
        n = math.sqrt(quat.dot(quat))  # (the norm as numpy.linalg.norm computes it)
        if not math.isfinite(n) or abs(n - 1.0) > _QUAT_NORM_TOL:
            raise InvalidInputError(
                f"base quaternion q[3:7] (x, y, z, w) = {quat} has norm {n:.6g}; expected a unit quaternion"
            )
        return quat / n
