"""Kinematic state of a robot: a configuration q and every Pinocchio quantity derived from it.

:class:`Configuration` runs Pinocchio once per control tick (joint Jacobians, CoM and its Jacobian; the frame
placements on the first read of ``data`` after it) and then answers frame placement / Jacobian / CoM queries from that
cache. Nothing here re-derives kinematics: every number comes from Pinocchio (:func:`local_jacobian_into` is Pinocchio's
change of axes of its joint Jacobians into a frame's, the same numbers as ``pin.getFrameJacobian``).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
import pinocchio as pin

from wbc.compiled import NO_NRT, once_per_process, specialise
from wbc.exceptions import ConfigurationError
from wbc.geometry import FLOAT64, ReadOnly, check_vector
from wbc.robot import Robot

__all__ = ["Configuration", "check_vector", "frame_jacobian_columns", "local_jacobian_into"]

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


@nb.njit(cache=True, **NO_NRT)  # GIL kept: releasing it costs more than this call's work
def _scaled_matches(v, dt, q, steps):
    """:func:`_scaled_if_finite` into out = steps[:nv] (0: v not finite, out untouched; else out = v dt) that also
    says whether out and q equal, bit for bit, the v·dt and q of a lookahead (ahead = steps[nv:] = [v·dt (nv,),
    q (nq,)]): 2 when they do, else 1. One array for both (one argument fewer)."""
    n = v.shape[0]
    out, ahead = steps[:n], steps[n:]
    if not _scaled_if_finite(v, dt, out):
        return 0
    for i in range(n):
        if out[i] != ahead[i]:
            return 1
    for i in range(q.shape[0]):
        if q[i] != ahead[n + i]:
            return 1
    return 2


@nb.njit(cache=True, **NO_NRT)  # GIL kept: releasing it costs more than this call's work
def _record_ahead(vdt, q, steps):
    """steps[nv:] = [vdt, q] (the ahead part of :func:`_scaled_matches`' array) and True when every entry of vdt
    is finite, else False with steps untouched (compiled: one call for the check and both copies)."""
    n = vdt.shape[0]
    for i in range(n):
        if not np.isfinite(vdt[i]):
            return False
    for i in range(n):
        steps[n + i] = vdt[i]
    for i in range(q.shape[0]):
        steps[2 * n + i] = q[i]
    return True


def frame_jacobian_columns(model: pin.Model, frame_id: int) -> np.ndarray:
    """(k,) int64 velocity indices of the joints supporting a frame (its parent joint and every ancestor): the
    columns of its frame Jacobian that can be nonzero (:func:`local_jacobian_into`)."""
    joints = model.joints
    return np.array([i for j in model.supports[model.frames[frame_id].parentJoint][1:]
                     for i in range(joints[j].idx_v, joints[j].idx_v + joints[j].nv)], np.int64)


@nb.njit(cache=True, nogil=True)
def local_jacobian_into(joint_jacobians, rot, pos, columns, out):
    """out[:, columns] ← the LOCAL frame Jacobian (``pin.getFrameJacobian(model, data, frame, LOCAL)``) of a frame
    placed at ``rot`` (3, 3), ``pos`` (3,) (its ``data.oMf``, world), from Pinocchio's joint Jacobians ``data.J``
    (6, nv, world): each column (v; ω) of ``columns`` (:func:`frame_jacobian_columns`) becomes (Rᵀ (v − p × ω); Rᵀ ω),
    Pinocchio's formula in its order of operations (the same numbers: ``tests/test_configuration.py``). The other
    columns of out are not written (zeros of the caller's buffer)."""
    for j in columns:
        w0, w1, w2 = joint_jacobians[3, j], joint_jacobians[4, j], joint_jacobians[5, j]
        l0 = joint_jacobians[0, j] - (pos[1] * w2 - pos[2] * w1)
        l1 = joint_jacobians[1, j] - (pos[2] * w0 - pos[0] * w2)
        l2 = joint_jacobians[2, j] - (pos[0] * w1 - pos[1] * w0)
        for i in range(3):
            out[i, j] = rot[0, i] * l0 + rot[1, i] * l1 + rot[2, i] * l2
            out[3 + i, j] = rot[0, i] * w0 + rot[1, i] * w1 + rot[2, i] * w2


# _scaled_matches and _record_ahead specialised (wbc.compiled.specialise) to their one argument type, contiguous
# float64 vectors (a Configuration's q and steps; v and vdt checked by the caller), by _warm_up
_scaled_matches_fixed, _record_ahead_fixed = _scaled_matches, _record_ahead


@once_per_process
def _warm_up() -> None:
    """Load :func:`_scaled_if_finite`, :func:`_scaled_matches` and :func:`_record_ahead` (on-disk cache) once per
    process, at construction, and specialise the last two."""
    global _scaled_matches_fixed, _record_ahead_fixed
    _scaled_if_finite(np.zeros(1), 0.002, np.zeros(1))
    _scaled_matches_fixed = specialise(_scaled_matches, np.zeros(1), 0.002, np.zeros(2), np.zeros(4))
    _record_ahead_fixed = specialise(_record_ahead, np.zeros(1), np.zeros(2), np.zeros(4))


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
        self._v_shape = (self._nv,)
        self._keep_ag = False
        self._ag = None
        # lookahead: a second Data computed at q ⊕ v·dt, adopted by a step with that v·dt (swapped with _data), made
        # here (not inside the first tick that looks ahead; none for a subclass with its own update, which does not);
        # [v·dt, q] it was computed from (_steps[nv:]), _ahead_out = (Data, its data.com[0], q ⊕ v·dt, CoM Jacobian, Ag)
        self._spare = None
        if type(self).update is Configuration.update:
            spare = robot.model.createData()
            self._spare = (spare, spare.com[0])
        # one array [v·dt of step (nv,), ahead (nv + nq,)]: a single argument of the step's compiled check
        self._steps = np.full(2 * self._nv + robot.model.nq, np.nan)
        self._steps[:self._nv] = 0.0
        self._ahead_out = None
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
            # a read-only or strided q is copied: the compiled tick (wbc.formulations.velocity_kernel) and this
            # module's kernels read q, and such an array is another argument type for them (one more compilation;
            # their specialised versions, wbc.compiled.specialise, take a writeable contiguous q)
            self.q = q if q.flags.writeable and q.flags.c_contiguous else q.copy()
        self._ahead_out = None
        self._com_jacobian, self._ag = self._kinematics(self._data, self.q)
        self._frames_stale = True  # data.oMf: every frame placed on the next read of data

    def _kinematics(self, data: pin.Data, q: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """Pinocchio's pass of :meth:`update` into ``data`` at q: (CoM Jacobian, Ag or None)."""
        if self._keep_ag:  # the joint placements and Jacobians of computeJointJacobians (the same numbers), and Ag
            ag = pin.computeCentroidalMap(self.model, data, q)
            return pin.jacobianCenterOfMass(self.model, data, False), ag
        # forward kinematics, then the joint Jacobians data.J, the CoM and its Jacobian in one backward pass
        return pin.jacobianCenterOfMass(self.model, data, q, False), None

    def lookahead(self, vdt: np.ndarray) -> pin.Data | None:
        """Pinocchio Data at q ⊕ vdt (``pin.integrate``), computed as :meth:`update` computes :attr:`kinematics_data`
        (joint placements and Jacobians, CoM and its Jacobian; no frame placed: ``pin.updateFramePlacement`` a frame
        before reading its ``oMf``), without changing this configuration. The next :meth:`step` whose v·dt equals
        ``vdt`` bit for bit, from the same q, adopts it instead of computing it again (the two Data objects are
        swapped: a Data read before that step then holds the lookahead's numbers no longer).

        Args:
            vdt: (nv,) float array, the displacement v·dt (rad, m).

        Returns:
            the Data, owned by this configuration (overwritten by the next lookahead); None for a subclass with its
            own :meth:`update` (nothing computed).

        Raises:
            ConfigurationError: vdt has the wrong size or is not finite.
        """
        if type(self).update is not Configuration.update:
            return None
        self._ahead_out = None  # until this lookahead's Data is computed
        q = self.q
        if not (type(vdt) is np.ndarray and vdt.shape == self._v_shape and vdt.dtype is FLOAT64
                and vdt.flags.c_contiguous and _record_ahead_fixed(vdt, q, self._steps)):  # ahead = [vdt, q] when vdt is finite
            vdt = check_vector(vdt, self._nv, "displacement vdt")  # raises with the details, else a finite array
            self._steps[self._nv:2 * self._nv] = vdt
            self._steps[2 * self._nv:] = q
        spare = self._spare
        q_next = pin.integrate(self.model, q, vdt)
        jcom, ag = self._kinematics(spare[0], q_next)
        self._ahead_out = (spare, q_next, jcom, ag)
        return spare[0]

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
        ahead = self._ahead_out
        match = 0
        if type(v) is np.ndarray and v.shape == self._v_shape and v.dtype is FLOAT64:
            if ahead is None:
                match = int(_scaled_if_finite(v, float(dt), self._steps[:self._nv]))
            elif v.flags.c_contiguous:
                match = _scaled_matches_fixed(v, float(dt), self.q, self._steps)
            else:
                match = _scaled_matches(v, float(dt), self.q, self._steps)
        if match == 2:  # the lookahead's v·dt from this q: its Data becomes this configuration's (swapped)
            spare, self.q, self._com_jacobian, self._ag = ahead
            self._spare = (self._data, self._com)
            self._data, self._com = spare
            self._ahead_out = None
            self._frames_stale = True
            return
        vdt = self._steps[:self._nv]  # v dt, written by the check above when v passed it
        if not match:
            v = check_vector(v, self._nv, "velocity v")  # raises with the details, else a finite float array
            np.multiply(v, dt, out=vdt)
        self.q = pin.integrate(self.model, self.q, vdt)
        self.update()

    def integrate(self, v: np.ndarray, dt: float) -> np.ndarray:
        """(nq,) configuration reached by applying velocity v (nv,) for dt seconds, on the manifold
        (``pin.integrate``)."""
        return pin.integrate(self.model, self.q, v * dt)
