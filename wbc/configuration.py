"""Kinematic state of a robot: a configuration q and every Pinocchio quantity derived from it.

:class:`Configuration` runs Pinocchio once per control tick (joint Jacobians, CoM and its Jacobian; the frame
placements on the first read of ``data`` after it) and then answers frame placement / Jacobian / CoM queries from that
cache. Nothing here re-derives kinematics: every number comes from Pinocchio.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
import pinocchio as pin

from wbc.compiled import once_per_process
from wbc.exceptions import ConfigurationError
from wbc.geometry import ReadOnly, check_vector
from wbc.robot import Robot

__all__ = ["Configuration", "check_vector"]

LOCAL = pin.ReferenceFrame.LOCAL
LOCAL_WORLD_ALIGNED = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
WORLD = pin.ReferenceFrame.WORLD


@nb.njit(cache=True, nogil=True)
def _scaled_if_finite(v, dt, out):
    """out = v dt and True when every entry of v is finite, else False with out untouched (compiled: one call
    instead of a finiteness check and a product)."""
    for i in range(v.shape[0]):
        if not np.isfinite(v[i]):
            return False
    for i in range(v.shape[0]):
        out[i] = v[i] * dt
    return True


@once_per_process
def _warm_up() -> None:
    """Load :func:`_scaled_if_finite` (on-disk cache) once per process, at construction."""
    _scaled_if_finite(np.zeros(1), 0.002, np.zeros(1))


class Configuration:
    """A robot configuration with its kinematics computed by Pinocchio.

    Args:
        robot: the :class:`~wbc.robot.Robot`.
        q: (nq,) configuration (default ``robot.q_ref``). Base position (m) in world, base quaternion
            (x, y, z, w), then joint angles (rad) in Pinocchio's joint order.

    Raises:
        ConfigurationError: ``q`` has the wrong size, is not finite, or has a non-unit base quaternion.
    """

    def __init__(self, robot: Robot, q: np.ndarray | None = None):
        self.robot = robot
        self.model = robot.model
        self._data = robot.model.createData()
        self._frames_stale = False
        self._nv = robot.model.nv
        self._vdt = np.zeros(self._nv)  # v dt of step
        self._keep_ag = False
        self._ag = None
        self.q = np.array(robot.q_ref if q is None else q, dtype=float)
        self.update(self.q)
        self._com = self._data.com[0]  # a view of Pinocchio's data.com[0] (eigenpy): follows every update
        _warm_up()

    def update(self, q: np.ndarray | None = None) -> None:
        """Set q (if given) and recompute joint Jacobians, CoM and CoM Jacobian; the frame placements are placed on
        the next read of :attr:`data` (or :meth:`frame_placement`).

        Raises:
            ConfigurationError: see the class docstring.
        """
        if q is not None:
            q = check_vector(q, self.model.nq, "configuration q")
            quat = q[3:7]
            quat_norm = float(quat @ quat)
            if abs(quat_norm - 1.0) > 1e-6:
                raise ConfigurationError(f"base quaternion q[3:7] must have unit norm, got norm² {quat_norm:.6g}")
            # a read-only q is copied: the compiled tick (wbc.formulations.velocity_kernel) reads q, and a read-only
            # array is another argument type for it (one more compilation)
            self.q = q if q.flags.writeable else q.copy()
        if self._keep_ag:  # the joint placements and Jacobians of computeJointJacobians (the same numbers), and Ag
            self._ag = pin.computeCentroidalMap(self.model, self._data, self.q)
            self._com_jacobian = pin.jacobianCenterOfMass(self.model, self._data, False)
        else:  # forward kinematics, then the joint Jacobians data.J, the CoM and its Jacobian in one backward pass
            self._com_jacobian = pin.jacobianCenterOfMass(self.model, self._data, self.q, False)
        self._frames_stale = True  # data.oMf: every frame placed on the next read of data

    @property
    def data(self) -> pin.Data:
        """Pinocchio Data at q: joint placements ``oMi`` and Jacobians ``J``, CoM and its Jacobian, and every frame's
        placement ``oMf`` (the frames are placed, ``pin.updateFramePlacements``, on the first read after an update).
        A Data kept from an earlier read has its ``oMf`` current only once :attr:`data` has been read again."""
        if self._frames_stale:
            pin.updateFramePlacements(self.model, self._data)
            self._frames_stale = False
        return self._data

    kinematics_data = ReadOnly("""The Pinocchio Data of :attr:`data`, read without placing the frames: joint
        placements, joint Jacobians and CoM at q; a frame's ``oMf`` is current only after ``pin.getFrameJacobian`` or
        ``pin.updateFramePlacement`` of that frame (or a read of :attr:`data`). For per-tick readers that call one of
        them before reading the frame's placement (the tasks' and contacts' rows).""", "_data")

    # -- queries (all from the cache filled by update) -------------------------------------------------------
    def frame_placement(self, frame_id: int) -> pin.SE3:
        """World placement ``oMf`` of a frame (SE3, translation in m)."""
        return self.data.oMf[frame_id]

    def frame_jacobian(self, frame_id: int, reference: pin.ReferenceFrame = LOCAL_WORLD_ALIGNED) -> np.ndarray:
        """(6, nv) frame Jacobian: rows (linear m/s, angular rad/s) per unit of v, in ``reference``
        (``LOCAL``: frame axes; ``LOCAL_WORLD_ALIGNED``: world axes at the frame origin; ``WORLD``)."""
        return pin.getFrameJacobian(self.model, self._data, frame_id, reference)

    com = ReadOnly("""(3,) centre of mass in world (m), updated in place by :meth:`update` (copy it to keep a value): a
        view of Pinocchio's ``data.com[0]``; a :class:`~wbc.state.DynamicsState`'s own array, computed with its
        centroidal quantities.""")
    com_jacobian = ReadOnly("(3, nv) CoM Jacobian in world axes (m/s per unit of v).")

    @property
    def centroidal_momentum_matrix(self) -> np.ndarray:
        """(6, nv) centroidal momentum matrix Ag(q): ``[m ċ ; L] = Ag v`` (linear N·s, angular N·m·s about the CoM,
        world axes). Computed on demand (``pin.computeCentroidalMap``, which rewrites the joint placements, joint
        Jacobians and CoM of ``data`` with the values they already hold), or, after :meth:`keep_centroidal_map`, the
        one of the last update (do not modify it);
        :class:`~wbc.state.DynamicsState` returns the one of its ``computeAllTerms``."""
        if self._keep_ag:
            return self._ag
        return pin.computeCentroidalMap(self.model, self._data, self.q)

    @property
    def keeps_centroidal_map(self) -> bool:
        """Whether every update computes the centroidal momentum matrix (:meth:`keep_centroidal_map`)."""
        return self._keep_ag

    def keep_centroidal_map(self) -> None:
        """From now on, compute the centroidal momentum matrix in every update: ``pin.computeCentroidalMap`` in place
        of the forward kinematics of ``pin.jacobianCenterOfMass`` (its forward pass writes the same joint placements
        and joint Jacobians, the CoM and its Jacobian are computed after it), so :attr:`centroidal_momentum_matrix`
        is read without another pass over the model (e.g. by :class:`~wbc.constraints.zmp.ExecutedZmpConstraint`
        every tick)."""
        if not self._keep_ag:
            self._keep_ag = True
            self.update()

    def step(self, v: np.ndarray, dt: float) -> None:
        """Apply the generalized velocity v (nv,) for dt seconds (q ← ``pin.integrate(q, v dt)``) and update the
        kinematics. q stays valid by construction, so it is not re-validated (unlike :meth:`update`).

        Raises:
            ConfigurationError: v has the wrong size or is not finite; dt is not a finite number > 0 (s).
        """
        try:
            dt_ok = not isinstance(dt, bool) and math.isfinite(dt) and dt > 0
        except TypeError:
            dt_ok = False
        if not dt_ok:
            raise ConfigurationError(f"dt must be a finite number > 0 (s), got {dt!r}")
        vdt = self._vdt
        if not (type(v) is np.ndarray and v.shape == (self._nv,) and v.dtype == np.float64
                and _scaled_if_finite(v, float(dt), vdt)):
            v = check_vector(v, self._nv, "velocity v")  # raises with the details, else a finite float array
            np.multiply(v, dt, out=vdt)
        self.q = pin.integrate(self.model, self.q, vdt)
        self.update()

    def integrate(self, v: np.ndarray, dt: float) -> np.ndarray:
        """(nq,) configuration reached by applying velocity v (nv,) for dt seconds, on the manifold
        (``pin.integrate``)."""
        return pin.integrate(self.model, self.q, v * dt)
