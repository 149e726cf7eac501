"""Dynamic state of a robot: (q, v) and every Pinocchio quantity the inverse-dynamics QP needs, computed once.

:class:`DynamicsState` extends :class:`wbc.configuration.Configuration` (so every kinematic task of
:mod:`wbc.tasks` evaluates its error e(q) and Jacobian J(q) on it unchanged) with the velocity v. Per tick
(:meth:`DynamicsState.update`), for a robot with a free-flyer root, Pinocchio's

* ``crba`` → M(q) (nv, nv), both triangles filled (Pinocchio 3.8, checked in the tests);
* ``nonLinearEffects`` → h(q, v) = C(q, v) v + g(q) (nv,);
* ``forwardKinematics(q, v, 0)`` → body velocities ``data.v`` and accelerations ``data.a`` **with v̇ = 0**, so
  ``pin.getFrameClassicalAcceleration`` / ``pin.getFrameAcceleration`` return the drift terms J̇ v of frames;
* ``computeJointJacobians`` (``data.J``, from the joint placements of that forward pass); the frames' placements
  ``data.oMf`` follow on the first read of :attr:`data` after an update (``updateFramePlacements``), as for a
  :class:`~wbc.configuration.Configuration`;

and the centroidal quantities follow from M's base rows, without another pass over the tree: with a free-flyer
root, M[0:6, :] v is the whole robot's spatial momentum (base axes, base origin; linear then angular), and its
base block M[3:6, 0:3] = m [c_b]× gives the CoM c_b in base axes (m = M[0, 0]). With (R, p) the base placement,

    com = p + R c_b,   Ag = blockdiag(R, R) [I 0; −[c_b]× I] M[0:6, :],   J_com = Ag[0:3] / m,   h_G = Ag v,
    dAg v = blockdiag(R, R) [I 0; −[c_b]× I] h[0:6] + (m g, 0)

(the centroidal momentum matrix of Orin, Goswami & Lee 2013, "Centroidal dynamics of a humanoid robot", Auton.
Robots 35:161–176, which they also obtain from the base rows of M; the last line is the Newton–Euler balance of
the whole robot at v̇ = 0: the base wrench h[0:6] and gravity are the only external wrenches).
``pin.computeAllTerms`` gives the same numbers (to ≈ 1e-14, checked in the tests) for 254k instructions per call
against 170k for the four calls above (callgrind, Talos): its Python binding copies the Model on every call. A
robot without a free-flyer root uses ``computeAllTerms``.
"""

from __future__ import annotations

from typing import NamedTuple

import numba as nb
import numpy as np
import pinocchio as pin

from wbc.compiled import CHECK_TYPES, specialise
from wbc.configuration import Configuration, check_vector
from wbc.geometry import ReadOnly
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
        nv = robot.model.nv
        self._dAg_v = np.zeros(6)
        self._com_drift = np.zeros(3)
        self._zero_a = np.zeros(nv)
        #: free-flyer root: the centroidal quantities from M's base rows (module docstring), else computeAllTerms
        self._free_flyer = robot.model.njoints > 1 and robot.model.joints[1].shortname() == "JointModelFreeFlyer"
        self._Ag, self._Jcom, self._hg, self._com_buf = np.zeros((6, nv)), np.zeros((3, nv)), np.zeros(6), np.zeros(3)
        self._gravity = np.array(robot.model.gravity.linear, dtype=float)
        self._centroidal_out = _Centroidal(self._Ag, self._Jcom, self._hg, self._com_buf, self._dAg_v, self._com_drift)
        self._views: tuple | None = None
        super().__init__(robot, q)
        self._com = self._com_buf  # com: this array, rewritten by update with the centroidal quantities
        self._nq, self._nv = robot.model.nq, nv  # (ints: not read through the Model's bindings every tick)
        # update's input check, for the contiguous float vectors it tests for first (wbc.compiled.specialise; with
        # kernel type checks on, the dispatcher), loaded here, not inside the first tick
        self._inputs_ok = _state_inputs_ok if CHECK_TYPES else specialise(_state_inputs_ok, self.q, self.v, 7, 6)

    def update(self, q: np.ndarray | None = None, v: np.ndarray | None = None) -> None:  # type: ignore[override]
        """Set (q, v) when given and recompute every quantity (module docstring).

        Raises:
            ConfigurationError: see the class docstring.
        """
        if type(q) is np.ndarray and type(v) is np.ndarray and q.dtype == _F64 and v.dtype == _F64 \
                and q.ndim == 1 and v.ndim == 1 and q.flags.c_contiguous and v.flags.c_contiguous \
                and self._inputs_ok(q, v, self._nq, self._nv):
            self.q = q  # float (nq,) and (nv,) arrays, finite, unit base quaternion: the checks below, in one call
            self.v = v
        else:
            if q is not None:
                q = check_vector(q, self.model.nq, "configuration q")
                quat_norm = float(np.dot(q[3:7], q[3:7]))
                if abs(quat_norm - 1.0) > 1e-6:
                    raise ConfigurationError(f"base quaternion q[3:7] must have unit norm, got norm² {quat_norm:.6g}")
                self.q = q
            if v is not None:
                self.v = check_vector(v, self.model.nv, "velocity v")
        model, data, q, v = self.model, self.kinematics_data, self.q, self.v
        if not self._free_flyer:
            self._update_all_terms()
            return
        pin.crba(model, data, q)
        pin.nonLinearEffects(model, data, q, v)
        pin.forwardKinematics(model, data, q, v, self._zero_a)  # data.v, data.a (v̇ = 0): the frame drifts
        pin.computeJointJacobians(model, data)  # data.J from the placements forwardKinematics just computed
        self._frames_stale = True  # data.oMf: every frame placed on the next read of data (Configuration.data)
        views = self._views
        if views is None:
            # numpy views of Data's fixed-size storage, which Pinocchio overwrites in place: fetched once (each
            # attribute access through the bindings costs ≈ 1.5 µs)
            root = data.oMi[1]
            views = self._views = (data.M, data.nle, root, root.rotation, root.translation)
            self._com_jacobian = self._Jcom
            # the compiled call on these views and this object's arrays, of fixed types, for a v of any strides
            # (wbc.compiled.specialise; with kernel type checks on, the dispatcher)
            self._centroidal = _centroidal_from_base_rows if CHECK_TYPES else specialise(
                _centroidal_from_base_rows, views[0], views[1], views[3], views[4], np.zeros(2 * model.nv)[::2],
                self._gravity, self._centroidal_out)
        self._centroidal(views[0], views[1], views[3], views[4], v, self._gravity, self._centroidal_out)

    def _update_all_terms(self) -> None:
        """Every quantity from ``pin.computeAllTerms`` (a robot without a free-flyer root)."""
        model, data = self.model, self.kinematics_data
        pin.computeAllTerms(model, data, self.q, self.v)
        pin.updateFramePlacements(model, data)
        if self._views is None:
            self._views = (data.M, data.nle)
        self._Ag[:] = data.Ag
        self._Jcom[:] = data.Jcom
        self._com_jacobian = self._Jcom
        np.matmul(data.dAg, self.v, out=self._dAg_v)
        np.multiply(self._dAg_v[0:3], 1.0 / self.mass, out=self._com_drift)
        self._com_buf[:] = data.com[0]
        self._hg[:] = data.hg.vector

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
        """(3,) CoM velocity in world (m/s): ``Ag[0:3] v / m``."""
        return self._hg[0:3] / self.mass

    com_drift = ReadOnly("(3,) CoM acceleration at v̇ = 0 (m/s²): ``(dAg v)[0:3] / m`` (an array rewritten by "
                         ":meth:`update`).")
    centroidal_momentum_matrix = ReadOnly("(6, nv) Ag: ``[m ċ ; L] = Ag v`` (linear N·s, angular N·m·s about the "
                                          "CoM, world axes).", "_Ag")
    centroidal_drift = ReadOnly("(6,) dAg v: centroidal momentum rate at v̇ = 0 (N, N·m).", "_dAg_v")

    @property
    def angular_momentum(self) -> np.ndarray:
        """(3,) centroidal angular momentum L (N·m·s, world axes about the CoM)."""
        return self._hg[3:6]

    # -- frames ----------------------------------------------------------------------------------------------
    def frame_classical_drift(self, frame_id: int) -> np.ndarray:
        """(6,) classical acceleration of a frame at v̇ = 0, world axes at the frame origin (LOCAL_WORLD_ALIGNED):
        linear (m/s², the origin's p̈ drift) then angular (rad/s²)."""
        return pin.getFrameClassicalAcceleration(
            self.model, self.data, frame_id, pin.LOCAL_WORLD_ALIGNED
        ).vector


_F64 = np.dtype(np.float64)


@nb.njit(cache=True, nogil=True)
def _state_inputs_ok(q, v, nq, nv):
    """True when q is (nq,) and v (nv,), every entry finite, and the base quaternion q[3:7] has |‖q[3:7]‖² − 1| ≤
    1e-6 (the checks of :meth:`DynamicsState.update`, whose full checks name what fails)."""
    if q.shape[0] != nq or v.shape[0] != nv or nq < 7:
        return False
    for i in range(nq):
        if not np.isfinite(q[i]):
            return False
    for i in range(nv):
        if not np.isfinite(v[i]):
            return False
    s = 0.0
    for i in range(3, 7):
        s += q[i] * q[i]
    return abs(s - 1.0) <= 1e-6


class _Centroidal(NamedTuple):
    """The outputs of :func:`_centroidal_from_base_rows` (a :class:`DynamicsState`'s arrays, built once)."""

    Ag: np.ndarray         #: (6, nv) the centroidal momentum matrix
    Jcom: np.ndarray       #: (3, nv) the CoM Jacobian Ag[0:3] / m
    hg: np.ndarray         #: (6,) the centroidal momentum Ag v
    com: np.ndarray        #: (3,) the CoM (m, world)
    dhg: np.ndarray        #: (6,) dAg v
    com_drift: np.ndarray  #: (3,) dhg[0:3] / m


@nb.njit(cache=True, nogil=True)
def _centroidal_from_base_rows(M, nle, R, p, v, gravity, out):
    """Centroidal quantities of a free-flyer robot from its base rows (module docstring): M (nv, nv), nle (nv,),
    the base placement (R (3, 3), p (3,)), v (nv,), gravity (3,) (m/s², world); written into ``out``
    (:class:`_Centroidal`): Ag (6, nv), the CoM Jacobian Jcom = Ag[0:3] / m (3, nv), hg = Ag v (6,), com (3,),
    dhg = dAg v (6,), com_drift = dhg[0:3] / m."""
    Ag, Jcom, hg, com, dhg, com_drift = out
    nv = M.shape[0]
    m = M[0, 0]
    # c_b: CoM in base axes, from the base block M[3:6, 0:3] = m [c_b]× of the composite spatial inertia
    cb0 = -M[4, 2] / m
    cb1 = -M[5, 0] / m
    cb2 = -M[3, 1] / m
    for i in range(3):
        com[i] = p[i] + R[i, 0] * cb0 + R[i, 1] * cb1 + R[i, 2] * cb2
    for j in range(nv):
        l0, l1, l2 = M[0, j], M[1, j], M[2, j]
        # angular momentum about the CoM, base axes: k_b − c_b × p_b
        a0 = M[3, j] - (cb1 * l2 - cb2 * l1)
        a1 = M[4, j] - (cb2 * l0 - cb0 * l2)
        a2 = M[5, j] - (cb0 * l1 - cb1 * l0)
        for i in range(3):
            Ag[i, j] = R[i, 0] * l0 + R[i, 1] * l1 + R[i, 2] * l2
            Ag[3 + i, j] = R[i, 0] * a0 + R[i, 1] * a1 + R[i, 2] * a2
    for i in range(6):
        s = 0.0
        for j in range(nv):
            s += Ag[i, j] * v[j]
        hg[i] = s
    # momentum rate at v̇ = 0: the base wrench nle[0:6] (base axes, base origin) moved to the CoM in world axes,
    # plus gravity m g
    f0, f1, f2 = nle[0], nle[1], nle[2]
    n0 = nle[3] - (cb1 * f2 - cb2 * f1)
    n1 = nle[4] - (cb2 * f0 - cb0 * f2)
    n2 = nle[5] - (cb0 * f1 - cb1 * f0)
    for i in range(3):
        dhg[i] = R[i, 0] * f0 + R[i, 1] * f1 + R[i, 2] * f2 + m * gravity[i]
        dhg[3 + i] = R[i, 0] * n0 + R[i, 1] * n1 + R[i, 2] * n2
        com_drift[i] = dhg[i] / m
    for i in range(3):
        for j in range(nv):
            Jcom[i, j] = Ag[i, j] / m
