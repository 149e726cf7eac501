"""Dynamic state of a robot: (q, v) and every Pinocchio quantity the inverse-dynamics QP needs, computed once.

:class:`DynamicsState` extends :class:`wbc.configuration.Configuration` (so every kinematic task of
:mod:`wbc.tasks` evaluates its error e(q) and Jacobian J(q) on it unchanged) with the velocity v and one call of
``pin.computeAllTerms(model, data, q, v)`` per tick, which fills (Pinocchio 3 documentation of
``computeAllTerms``):

* ``data.M`` joint-space inertia matrix M(q) (nv, nv) (both triangles filled in Pinocchio 3.8, checked in the
  tests), ``data.nle`` = h(q, v) = C(q, v) v + g(q) (nv,),
* joint Jacobians (``data.J``), frame placements after ``pin.updateFramePlacements``,
* ``data.com[0]``, ``data.vcom[0]``, ``data.Jcom`` (3, nv), centroidal momentum matrix ``data.Ag`` (6, nv) and its
  time derivative ``data.dAg`` (6, nv) (Orin, Goswami & Lee 2013, "Centroidal dynamics of a humanoid robot",
  Auton. Robots 35:161–176),
* the spatial accelerations ``data.a`` of every joint **with v̇ = 0**, so ``pin.getFrameClassicalAcceleration``
  and ``pin.getFrameAcceleration`` return the drift terms J̇ v of frames.

Nothing is re-derived: the drift of the CoM is ``(dAg v)[0:3] / m`` and that of the centroidal angular
momentum ``(dAg v)[3:6]``, both from Pinocchio.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from wbc.configuration import Configuration, check_vector
from wbc.exceptions import ConfigurationError
from wbc.robot import Robot

__all__ = ["DynamicsState"]


class DynamicsState(Configuration):
    """(q, v) of a floating-base robot with M, h, Jacobians, centroidal quantities and drifts (module docstring).

    Args:
        robot: the robot.
        q: (nq,) configuration (default ``robot.q_ref``), Pinocchio conventions (base quaternion x, y, z, w).
        v: (nv,) generalized velocity (default zeros); base twist in the base frame (LOCAL).

    Raises:
        ConfigurationError: wrong sizes, NaN/inf, or a non-unit base quaternion.
    """

    def __init__(self, robot: Robot, q: np.ndarray | None = None, v: np.ndarray | None = None):
        self.v = np.zeros(robot.model.nv) if v is None else check_vector(v, robot.model.nv, "velocity v").copy()
        self.mass = robot.mass
        self._dAg_v = np.zeros(6)
        self._com_drift = np.zeros(3)
        self._views: tuple | None = None
        super().__init__(robot, q)

    def update(self, q: np.ndarray | None = None, v: np.ndarray | None = None) -> None:  # type: ignore[override]
        """Set (q, v) when given and recompute every quantity (one ``computeAllTerms`` + frame placements).

        Raises:
            ConfigurationError: see the class docstring.
        """
        if q is not None:
            q = check_vector(q, self.model.nq, "configuration q")
            quat_norm = float(np.dot(q[3:7], q[3:7]))
            if abs(quat_norm - 1.0) > 1e-6:
                raise ConfigurationError(f"base quaternion q[3:7] must have unit norm, got norm² {quat_norm:.6g}")
            self.q = q
        if v is not None:
            self.v = check_vector(v, self.model.nv, "velocity v")
        pin.computeAllTerms(self.model, self.data, self.q, self.v)
        pin.updateFramePlacements(self.model, self.data)
        if self._views is None:
            # numpy views of Data's fixed-size storage, which computeAllTerms overwrites in place: fetched once
            # (each attribute access through the bindings costs ≈ 1.5 µs)
            d = self.data
            self._views = (d.M, d.nle, d.Jcom, d.Ag, d.dAg, d.com[0])
            self._com_jacobian = self._views[2]
        views = self._views
        np.matmul(views[4], self.v, out=self._dAg_v)
        np.multiply(self._dAg_v[0:3], 1.0 / self.mass, out=self._com_drift)

    # -- dynamics --------------------------------------------------------------------------------------------
    @property
    def M(self) -> np.ndarray:
        """(nv, nv) joint-space inertia matrix (kg, kg·m, kg·m² blocks)."""
        return self._views[0]

    @property
    def h(self) -> np.ndarray:
        """(nv,) non-linear effects C(q, v) v + g(q) (N, N·m)."""
        return self._views[1]

    # -- centroidal ------------------------------------------------------------------------------------------
    @property
    def com_velocity(self) -> np.ndarray:
        """(3,) CoM velocity in world (m/s)."""
        return self.data.vcom[0]

    @property
    def com(self) -> np.ndarray:
        """(3,) centre of mass in world (m): a view of ``data.com[0]``, updated in place by :meth:`update`."""
        return self._views[5]

    @property
    def com_drift(self) -> np.ndarray:
        """(3,) CoM acceleration at v̇ = 0 (m/s²): ``(dAg v)[0:3] / m`` (an array rewritten by :meth:`update`)."""
        return self._com_drift

    @property
    def centroidal_momentum_matrix(self) -> np.ndarray:
        """(6, nv) Ag: ``[m ċ ; L] = Ag v`` (linear N·s, angular N·m·s about the CoM, world axes)."""
        return self._views[3]

    @property
    def centroidal_drift(self) -> np.ndarray:
        """(6,) dAg v: centroidal momentum rate at v̇ = 0 (N, N·m)."""
        return self._dAg_v

    @property
    def angular_momentum(self) -> np.ndarray:
        """(3,) centroidal angular momentum L (N·m·s, world axes about the CoM)."""
        return self.data.hg.angular

    # -- frames ----------------------------------------------------------------------------------------------
    def frame_classical_drift(self, frame_id: int) -> np.ndarray:
        """(6,) classical acceleration of a frame at v̇ = 0, world axes at the frame origin (LOCAL_WORLD_ALIGNED):
        linear (m/s², the origin's p̈ drift) then angular (rad/s²)."""
        return pin.getFrameClassicalAcceleration(
            self.model, self.data, frame_id, pin.LOCAL_WORLD_ALIGNED
        ).vector
