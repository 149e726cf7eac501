"""Kinematic state of a robot: a configuration q and every Pinocchio quantity derived from it.

:class:`Configuration` runs Pinocchio once per control tick (joint Jacobians, frame placements, CoM and its
Jacobian) and then answers frame placement / Jacobian / CoM queries from that cache. Nothing here re-derives
kinematics: every number comes from Pinocchio.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from wbc.exceptions import ConfigurationError
from wbc.geometry import check_vector
from wbc.robot import Robot

__all__ = ["Configuration", "check_vector"]

LOCAL = pin.ReferenceFrame.LOCAL
LOCAL_WORLD_ALIGNED = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
WORLD = pin.ReferenceFrame.WORLD


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
        self.data = robot.model.createData()
        self.q = np.array(robot.q_ref if q is None else q, dtype=float)
        self.update(self.q)
        self._com = self.data.com[0]  # a view of Pinocchio's data.com[0] (eigenpy): follows every update

    def update(self, q: np.ndarray | None = None) -> None:
        """Set q (if given) and recompute joint Jacobians, frame placements, CoM and CoM Jacobian.

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
        pin.computeJointJacobians(self.model, self.data, self.q)
        pin.updateFramePlacements(self.model, self.data)
        self._com_jacobian = pin.jacobianCenterOfMass(self.model, self.data, False)

    # -- queries (all from the cache filled by update) -------------------------------------------------------
    def frame_placement(self, frame_id: int) -> pin.SE3:
        """World placement ``oMf`` of a frame (SE3, translation in m)."""
        return self.data.oMf[frame_id]

    def frame_jacobian(self, frame_id: int, reference: pin.ReferenceFrame = LOCAL_WORLD_ALIGNED) -> np.ndarray:
        """(6, nv) frame Jacobian: rows (linear m/s, angular rad/s) per unit of v, in ``reference``
        (``LOCAL``: frame axes; ``LOCAL_WORLD_ALIGNED``: world axes at the frame origin; ``WORLD``)."""
        return pin.getFrameJacobian(self.model, self.data, frame_id, reference)

    @property
    def com(self) -> np.ndarray:
        """(3,) centre of mass in world (m): a view of Pinocchio's ``data.com[0]``, updated in place by
        :meth:`update` (copy it to keep a value)."""
        return self._com

    @property
    def com_jacobian(self) -> np.ndarray:
        """(3, nv) CoM Jacobian in world axes (m/s per unit of v)."""
        return self._com_jacobian

    @property
    def centroidal_momentum_matrix(self) -> np.ndarray:
        """(6, nv) centroidal momentum matrix Ag(q): ``[m ċ ; L] = Ag v`` (linear N·s, angular N·m·s about the CoM,
        world axes). Computed on demand (``pin.computeCentroidalMap``, which rewrites the joint placements, joint
        Jacobians and CoM of ``data`` with the values they already hold);
        :class:`~wbc.state.DynamicsState` returns the one of its ``computeAllTerms``."""
        return pin.computeCentroidalMap(self.model, self.data, self.q)

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
        if not isinstance(v, np.ndarray) or v.shape != (self.model.nv,) or v.dtype != np.float64 \
                or not math.isfinite(v @ v):
            v = check_vector(v, self.model.nv, "velocity v")  # raises with the details, else a float array
        self.q = pin.integrate(self.model, self.q, v * dt)
        self.update()

    def integrate(self, v: np.ndarray, dt: float) -> np.ndarray:
        """(nq,) configuration reached by applying velocity v (nv,) for dt seconds, on the manifold
        (``pin.integrate``)."""
        return pin.integrate(self.model, self.q, v * dt)
