"""Frame pose task: drive a frame's world placement ``oMf`` to a target pose.

Error (6,): position p − p* in world axes (m), then orientation log₃(R*ᵀ R) in the target's axes (rad).
Jacobian: [R J_lin^LOCAL ; Jlog₃(R*ᵀR) J_ang^LOCAL], exact derivative of that error (Jlog₃ is the inverse of
the right Jacobian of SO(3), ``pin.Jlog3``).
Drift J̇v (acceleration level, ë = J v̇ + J̇ v), exact: position rows, the classical acceleration of the frame origin
at v̇ = 0 (``pin.getFrameClassicalAcceleration``, LOCAL_WORLD_ALIGNED); orientation rows, with ė = Jlog₃(rel) ω
(rel = R*ᵀR, ω the LOCAL angular velocity, rel̇ = rel [ω]×),

    ë = Jlog₃(rel) ω̇ + (d/dt Jlog₃(rel)) ω   ⇒   J̇v = Jlog₃(rel) α₀ + Hlog₃(rel, ω) ω

with α₀ the LOCAL angular acceleration at v̇ = 0 (``pin.getFrameAcceleration``) and ``pin.Hlog3(rel, ω)`` the
derivative of Jlog₃ along ω (checked against finite differences of J v in ``tests/tasks/test_tasks_base.py``).
Position-only and orientation-only forms keep only those rows.

The rows are computed one way, whatever the entry point (:meth:`FrameTask.compute`, ``compute_into``, ``drift``,
``compute_with_drift_into``): compiled kernels on Pinocchio's frame placement, LOCAL Jacobian, velocity and
acceleration, with log₃, Jlog₃ and Hlog₃ from :mod:`wbc.lie` (Pinocchio's formulas, any angle up to a half turn)
and the classical acceleration R (a + ω × v). Pinocchio's own ``log3``, ``Jlog3``, ``Hlog3`` are the oracle of
``tests/test_lie.py`` and ``tests/tasks/test_frame.py``.
"""

from __future__ import annotations

import numba as nb
import numpy as np
import pinocchio as pin

from wbc.compiled import CHECK_TYPES, NO_NRT, once_per_process, specialise
from wbc.configuration import LOCAL, Configuration, frame_jacobian_columns, local_jacobian_into
from wbc.exceptions import InvalidTargetError
from wbc.geometry import as_se3
from wbc.lie import jlog3_into, log3_columns, log3_into, log3_rate_into, placement_log6_into
from wbc.tasks.base import Task, as_weight

__all__ = ["FrameTask", "PositionTask", "OrientationTask", "frame_drift", "pose_error_and_jacobian"]


def pose_error_and_jacobian(placement: pin.SE3, j_local: np.ndarray, target: pin.SE3) -> tuple[np.ndarray, np.ndarray]:
    """(6,) error and (6, nv) Jacobian of a pose M = ``placement`` w.r.t. ``target`` (module docstring), given
    the (6, nv) body Jacobian ``j_local`` of M (M⁻¹ dM/dt = j_local v, rows linear then angular, M's axes)."""
    error, jac = np.empty(6), np.empty((6, j_local.shape[1]))
    _frame_rows_log(placement.rotation, target.rotation.T.copy(), np.ascontiguousarray(j_local),
                    placement.translation, target.translation, _ALL_ROWS, error, jac, np.empty(12))
    return error, jac


_ALL_ROWS = np.arange(6)


@nb.njit(cache=True, nogil=True)
def _frame_rows(rot, jlog, j_local, pos, target_pos, log, rows, error_out, jac_out):
    """The selected rows of error [p − p*; log] and Jacobian [rot J_lin; jlog J_ang] (module docstring), written
    into error_out (k,) and jac_out (k, nv): a compiled 3×3 by 3×nv product of the frame rotation, Jlog₃ and the
    LOCAL Jacobian (``oMf.rotation``, :func:`wbc.lie.jlog3_into`, ``getFrameJacobian``), no kinematics."""
    nv = j_local.shape[1]
    for a in range(rows.shape[0]):
        r = rows[a]
        if r < 3:
            error_out[a] = pos[r] - target_pos[r]
            m0, m1, m2, off = rot[r, 0], rot[r, 1], rot[r, 2], 0
        else:
            error_out[a] = log[r - 3]
            m0, m1, m2, off = jlog[r - 3, 0], jlog[r - 3, 1], jlog[r - 3, 2], 3
        for j in range(nv):
            jac_out[a, j] = m0 * j_local[off, j] + m1 * j_local[off + 1, j] + m2 * j_local[off + 2, j]


@nb.njit(cache=True, nogil=True, inline="always")
def _row_dot(a, i, b, j):
    """(a b)[i, j] = a[i, 0] b[0, j] + a[i, 1] b[1, j] + a[i, 2] b[2, j] (a 3-column, b 3-row; in this order)."""
    return a[i, 0] * b[0, j] + a[i, 1] * b[1, j] + a[i, 2] * b[2, j]


@nb.njit(cache=True, **NO_NRT)  # GIL kept: releasing it costs more than this call's work
def _frame_rows_log(rot, target_rot_t, j_local, pos, target_pos, rows, error_out, jac_out, scratch):
    """:func:`_frame_rows` with log₃(R*ᵀR) and Jlog₃ computed here (:func:`wbc.lie.log3_columns`,
    :func:`wbc.lie.jlog3_into`, into ``scratch`` (12,) float64, overwritten)."""
    # the first two columns of rel = R*ᵀ R (what log₃ reads; scalars: no (3, 3) array allocated)
    t = target_rot_t
    r00, r10, r20 = _row_dot(t, 0, rot, 0), _row_dot(t, 1, rot, 0), _row_dot(t, 2, rot, 0)
    r01, r11, r21 = _row_dot(t, 0, rot, 1), _row_dot(t, 1, rot, 1), _row_dot(t, 2, rot, 1)
    log, jlog = scratch[:3], scratch[3:].reshape((3, 3))
    theta = log3_columns(r00, r10, r20, r01, r11, r21, log)
    jlog3_into(theta, log, jlog)
    _frame_rows(rot, jlog, j_local, pos, target_pos, log, rows, error_out, jac_out)


@nb.njit(cache=True, **NO_NRT)  # GIL kept: releasing it costs more than this call's work
def _frame_rows_at(frame, target, rows, error_out, jac_out, scratch, has_rot):
    """:func:`_frame_rows_log` (``has_rot``; else :func:`_frame_rows`, no orientation row) of a frame given as
    (rotation, position: its placed ``data.oMf``; ``data.J``; its Jacobian's columns; a (6, nv) buffer of zeros but
    in those columns) and a target (R*ᵀ, p*): the LOCAL Jacobian formed here (:func:`wbc.configuration.
    local_jacobian_into`) instead of by ``pin.getFrameJacobian``, the same numbers."""
    rot, pos, joint_jacobians, columns, j_local = frame
    target_rot_t, target_pos = target
    local_jacobian_into(joint_jacobians, rot, pos, columns, j_local)
    if has_rot:
        _frame_rows_log(rot, target_rot_t, j_local, pos, target_pos, rows, error_out, jac_out, scratch)
    else:  # log and Jlog₃ unused (no orientation row): any (3,) and (3, 3) arrays
        _frame_rows(rot, rot, j_local, pos, target_pos, target_pos, rows, error_out, jac_out)


@nb.njit(cache=True, nogil=True)
def _frame_rows_drift(rot, pos, target, j_local, vel, acc, rows, error_out, jac_out, drift_out):
    """:meth:`FrameTask.compute_with_drift_into` in one compiled pass (module docstring): the selected rows of the
    error, Jacobian and drift J̇v into error_out (k,), jac_out (k, nv), drift_out (k,), from Pinocchio's frame
    rotation ``rot`` (3, 3) and position ``pos`` (3,) (world), LOCAL Jacobian ``j_local`` (6, nv), LOCAL velocity
    ``vel`` and acceleration at v̇ = 0 ``acc`` (6,) (linear then angular), and the ``target`` (R*ᵀ (3, 3), p* (3,))
    (a plain tuple, built per call: cheaper than a namedtuple).

    Only SO(3) algebra is done here: log₃, Jlog₃ and the derivative of Jlog₃ along ω (Pinocchio's ``log3``,
    ``Jlog3``, ``Hlog3`` formulas, :func:`wbc.lie.log3_rate_into`), and the classical
    acceleration of the origin R (a + ω × v) (what ``pin.getFrameClassicalAcceleration`` returns in
    LOCAL_WORLD_ALIGNED).

    """
    target_rot_t, target_pos = target
    has_rot = False
    has_pos = False
    for a in range(rows.shape[0]):
        if rows[a] < 3:
            has_pos = True
        else:
            has_rot = True
    d6 = np.zeros(6)
    log = np.zeros(3)
    jlog = np.zeros((3, 3))
    if has_rot:
        rel = np.empty((3, 3))
        for i in range(3):
            for j in range(3):
                rel[i, j] = target_rot_t[i, 0] * rot[0, j] + target_rot_t[i, 1] * rot[1, j] \
                    + target_rot_t[i, 2] * rot[2, j]
        theta = log3_into(rel, log)
        st, ct = jlog3_into(theta, log, jlog)
        log3_rate_into(theta, st, ct, log, jlog, vel[3:], acc[3:], d6[3:])
    if has_pos:  # classical acceleration of the origin, world axes: R (a + ω × v)
        wx, wy, wz = vel[3], vel[4], vel[5]
        cx = acc[0] + wy * vel[2] - wz * vel[1]
        cy = acc[1] + wz * vel[0] - wx * vel[2]
        cz = acc[2] + wx * vel[1] - wy * vel[0]
        for i in range(3):
            d6[i] = rot[i, 0] * cx + rot[i, 1] * cy + rot[i, 2] * cz
    for a in range(rows.shape[0]):
        drift_out[a] = d6[rows[a]]
    _frame_rows(rot, jlog, j_local, pos, target_pos, log, rows, error_out, jac_out)


@once_per_process
def _warm_up() -> None:
    """Load :func:`_frame_rows` for the array types of a real call (Pinocchio's F-ordered rotation, C-ordered
    Jacobians), once per process: at task construction, not inside a controller's first tick."""
    rot, jac, rows = np.asfortranarray(np.eye(3)), np.zeros((6, 1)), np.arange(6)
    e, j = np.empty(6), np.empty((6, 1))
    _frame_rows(rot, np.eye(3), jac, np.zeros(3), np.zeros(3), np.zeros(3), rows, e, j)  # pose rows
    _frame_rows(rot, rot, jac, np.zeros(3), np.zeros(3), np.zeros(3), rows[:3], e[:3], j[:3])  # position only
    _frame_rows_log(rot, np.eye(3), jac, np.zeros(3), np.zeros(3), rows, e, j, np.empty(12))  # compiled log₃
    placement_log6_into(np.eye(4, 3), rot, np.zeros(3), np.empty(6))  # a contact's error (Pinocchio's views)
    # the rows of compute_with_drift_into: a C-ordered target R*ᵀ, Pinocchio's (6,) motion vectors; then the target
    # and outputs of any strides (FrameTask's specialised call)
    _frame_rows_drift(rot, np.zeros(3), (np.eye(3), np.zeros(3)), jac, np.zeros(6), np.zeros(6), rows, e, j,
                      np.empty(6))
    _frame_rows_drift(rot, np.zeros(3), *_strided_drift_arrays(1))
    specialise(_frame_rows_at, *_frame_rows_at_types(2))  # (6, 2) data.J: F-ordered only, as Pinocchio's
    frame, _, rows, *_ = _frame_rows_at_types(2)  # and the dispatcher's call (CHECK_TYPES): contiguous target, outputs
    specialise(_frame_rows_at, frame, (np.eye(3), np.zeros(3)), rows, np.zeros(6), np.zeros((6, 2)), np.empty(12), True)


def _frame_rows_at_types(nv: int) -> tuple:
    """Arguments of the types :class:`FrameTask` specialises :func:`_frame_rows_at` for, but ``has_rot``:
    Pinocchio's views and the task's own buffers, the target and outputs of any strides (numba layout 'A')."""
    rot, strided = np.asfortranarray(np.eye(3)), _strided_drift_arrays(nv)
    frame = (rot, np.zeros(3), np.zeros((6, nv), order="F"), np.arange(nv), np.zeros((6, nv)))
    return frame, strided[0], np.arange(6), *strided[5:7], np.empty(12), True


def _strided_drift_arrays(nv: int) -> tuple:
    """Zeros of the types of the last seven arguments of :func:`_frame_rows_drift` as :class:`FrameTask` calls it
    (its target and the caller's outputs strided: numba layout 'A', which reads arrays of any strides), for six rows
    of a Jacobian of nv columns."""
    j_local = np.zeros((6, nv))
    return ((np.eye(3, 6)[:, ::2], np.zeros(6)[::2]), j_local, np.zeros(6), np.zeros(6), np.arange(6),
            np.zeros(12)[::2], np.zeros((6, 2 * nv))[:, ::2], np.zeros(12)[::2])


def frame_drift(rot: np.ndarray, target_rot_t: np.ndarray, velocity: pin.Motion, acceleration: pin.Motion,
                rows: np.ndarray) -> np.ndarray:
    """(k,) the ``rows`` of J̇v (module docstring) of a frame of rotation ``rot`` (3, 3, world) with LOCAL spatial
    velocity ``velocity`` and acceleration at v̇ = 0 ``acceleration`` (pin.Motion), against a target of transposed
    rotation ``target_rot_t`` (3, 3): m/s² (position rows, world axes), rad/s² (orientation rows, target axes)."""
    out = np.empty(rows.shape[0])
    _frame_rows_drift(rot, _NO_POSITION, (target_rot_t, _NO_POSITION), _NO_COLUMNS, velocity.vector,
                      acceleration.vector, rows, np.empty(rows.shape[0]), np.empty((rows.shape[0], 0)), out)
    return out


_NO_COLUMNS = np.zeros((6, 0))  # a Jacobian without columns: frame_drift writes no Jacobian entry
_NO_POSITION = np.zeros(3)  # frame_drift's error rows are discarded


class FrameTask(Task):
    """Track a target placement of a frame, with per-axis weights.

    Args:
        config_or_robot: used only to resolve the frame name.
        frame: frame name.
        position_weight: scalar or (3,) weights of x, y, z position rows (world axes); 0 drops a row.
        orientation_weight: scalar or (3,) weights of the orientation rows (target axes); 0 drops a row.
        gain: K (1/s).
        name: label (default: the frame name).

    Raises:
        UnknownFrameError: no such frame.
        InvalidInputError: bad weights or gain; all weights zero.
    """

    _drift_kernel = None  # compute_with_drift_into's compiled call, specialised at its first call
    _rows_kernel = None  # compute_into's (_frame_rows_at), likewise

    def __init__(self, robot, frame: str, *, position_weight=1.0, orientation_weight=1.0, gain: float = 100.0,
                 name: str | None = None):
        self.frame = frame
        self.frame_id = robot.frame_id(frame)
        w6 = np.concatenate([as_weight(position_weight, 3, "position_weight"),
                             as_weight(orientation_weight, 3, "orientation_weight")])
        self.rows = np.flatnonzero(w6 > 0)
        if self.rows.size == 0:
            raise InvalidTargetError(f"frame task on {frame!r}: every weight is zero")
        self._all_rows = self.rows.size == 6
        self._has_pos = bool((self.rows < 3).any())
        self._has_rot = bool((self.rows >= 3).any())
        self._rot_rows = self.rows[self.rows >= 3] - 3
        self.dim = int(self.rows.size)
        super().__init__(gain=gain, weight=w6[self.rows], name=name or frame)
        self.target = pin.SE3.Identity()
        self._ff6 = np.zeros(6)
        self._log_scratch = np.empty(12)  # log₃ and Jlog₃ of compute_into (_frame_rows_log)
        self._ff: np.ndarray | None = None
        model = robot.model
        # its Jacobian's columns and a buffer of zeros but in them (_frame_rows_at)
        self._columns, self._j_local = frame_jacobian_columns(model, self.frame_id), np.zeros((6, model.nv))
        self._oMf_views: tuple | None = None  # (data, oMf, its rotation, its translation, _frame_rows_at's frame)
        self._oMf_other: tuple | None = None  # the same for the Data read before it
        _warm_up()

    def set_target(self, pose, velocity: np.ndarray | None = None) -> None:
        """Set the target placement (pin.SE3 or (4,4), world) and optionally its spatial velocity
        (6,) = (linear m/s, angular rad/s), both in world axes (LOCAL_WORLD_ALIGNED at the target).

        Raises:
            InvalidTargetError: malformed pose or velocity.
        """
        self.target = pose  # validated by the setter
        if velocity is None:
            self._ff = None
            return
        vel = np.asarray(velocity, dtype=float)
        if vel.shape != (6,) or not np.isfinite(vel).all():
            raise InvalidTargetError(f"velocity of {self.name} must be a finite (6,) array, got {vel!r}")
        self._set_feedforward(vel)

    def _set_feedforward(self, vel: np.ndarray) -> None:
        self._ff6[:3] = vel[:3]
        self._ff6[3:] = self._target_rot_t @ vel[3:]
        self._ff = self._ff6 if self._all_rows else self._ff6[self.rows]

    def set_target_trusted(self, pose: np.ndarray, velocity: np.ndarray | None = None) -> None:
        """:meth:`set_target` without validation, for a controller's own loop feeding targets it built and
        validated once (e.g. the rows of a :class:`~wbc.gait.WalkPlan`): ``pose`` a (4, 4) homogeneous matrix
        (world, m), ``velocity`` None or a finite (6,) float array (linear m/s, angular rad/s, world axes).
        Malformed input is not detected here."""
        rot_t = pose[:3, :3].T.copy()
        ff = None
        if velocity is not None:
            ff = np.empty(6)
            ff[:3] = velocity[:3]
            ff[3:] = rot_t @ velocity[3:]
        self.set_target_rows(rot_t, pose[:3, 3].copy(), ff)

    def set_target_rows(self, rotation_t: np.ndarray, position: np.ndarray,
                        feedforward: np.ndarray | None = None) -> None:
        """The cheapest trusted target path, for a controller that precomputed its targets once (e.g. a walk plan's
        rows, :class:`~wbc.scenarios.walk.WalkController`): no validation, no copy, no ``pin.SE3`` built.

        Args:
            rotation_t: (3, 3) C-contiguous float array, the TRANSPOSED target rotation R*ᵀ (world → target axes).
            position: (3,) contiguous float array, target position p* (m, world).
            feedforward: None or (6,) float array, the error rate ė* of all six rows: linear velocity (m/s, world)
                then R*ᵀ ω* (rad/s, target axes) — what :meth:`set_target` derives from a world velocity.

        The arrays are kept by reference until the next target is set (the caller must not modify them); the
        ``target`` SE3 is built only when read."""
        self._target = None
        self._target_rot_t = rotation_t
        self._target_pos = position
        self._ff = None if feedforward is None else (feedforward if self._all_rows else feedforward[self.rows])

    @property
    def target(self) -> pin.SE3:
        """Target placement (world)."""
        t = self._target
        if t is None:  # set through set_target_rows: built on first read (pin.SE3 copies its arguments)
            t = self._target = pin.SE3(self._target_rot_t.T, self._target_pos)
        return t

    @target.setter
    def target(self, pose) -> None:
        """Validated on assignment (pin.SE3 or (4, 4)); raises InvalidTargetError like :func:`as_se3`."""
        pose = as_se3(pose, f"target of {self.name}")
        self._target = pose
        self._target_rot_t = pose.rotation.T.copy()
        self._target_pos = np.array(pose.translation)

    def set_target_from_configuration(self, config: Configuration) -> None:
        """Target = the frame's current placement, zero velocity (Pinocchio's placement: nothing to validate)."""
        self.set_target_trusted(config.data.oMf[self.frame_id].homogeneous)

    def compute(self, config: Configuration) -> tuple[np.ndarray, np.ndarray]:
        error, jac = np.empty(self.dim), np.empty((self.dim, config.model.nv))
        FrameTask.compute_into(self, config, error, jac)
        return error, jac

    def _views(self, data) -> tuple:
        """(data, oMf, its rotation, its translation, the frame argument of :func:`_frame_rows_at`) of this task's
        frame: data.oMf[frame] is a reference into Pinocchio's data and its rotation/translation, like ``data.J``, are
        views of it (eigenpy): kept per Data object (with the objects that own them), they follow every update."""
        views = self._oMf_views
        if views is None or views[0] is not data:
            other = self._oMf_other  # the other Data of a configuration that alternates two (Configuration.lookahead)
            if other is not None and other[0] is data:
                self._oMf_other, views = views, other
            else:
                oMf = data.oMf[self.frame_id]
                frame = (oMf.rotation, oMf.translation, data.J, self._columns, self._j_local)
                self._oMf_other, views = views, (data, oMf, *frame[:2], frame)
            self._oMf_views = views
        return views

    def compute_into(self, config: Configuration, error_out: np.ndarray, jac_out: np.ndarray) -> None:
        """The rows of error and Jacobian (module docstring) of this task's frame at ``config`` (its placement updated
        here): the compiled kernels of :mod:`wbc.lie` on Pinocchio's placement and joint Jacobians."""
        if type(self).compute is not FrameTask.compute:  # a subclass with its own error (e.g. relative frames)
            Task.compute_into(self, config, error_out, jac_out)
            return
        model, data, views = config.model, config.kinematics_data, self._oMf_views
        frame = (views if views is not None and views[0] is data else self._views(data))[4]
        pin.updateFramePlacement(model, data, self.frame_id)
        kernel = self._rows_kernel
        if kernel is None:  # Pinocchio's views and the task's buffers: fixed types; the target and outputs: any strides
            kernel = self._rows_kernel = _frame_rows_at if CHECK_TYPES else specialise(
                _frame_rows_at, *_frame_rows_at_types(model.nv))
        kernel(frame, (self._target_rot_t, self._target_pos), self.rows, error_out, jac_out, self._log_scratch,
               self._has_rot)

    def compute_with_drift_into(self, state, error_out: np.ndarray, jac_out: np.ndarray,
                                drift_out: np.ndarray) -> None:
        """:meth:`compute_into` and :meth:`drift` (into drift_out (dim,)) in one compiled pass
        (:func:`_frame_rows_drift`) on Pinocchio's placement, LOCAL Jacobian, velocity and acceleration of the
        frame."""
        cls = type(self)
        if cls.compute is not FrameTask.compute or cls.drift is not FrameTask.drift:
            Task.compute_with_drift_into(self, state, error_out, jac_out, drift_out)
            return
        model, data, fid = state.model, state.kinematics_data, self.frame_id  # its frame placed by getFrameJacobian
        views = self._views(data)
        target = (self._target_rot_t, self._target_pos)
        jac = pin.getFrameJacobian(model, data, fid, LOCAL)
        vel = pin.getFrameVelocity(model, data, fid, LOCAL).vector
        acc = pin.getFrameAcceleration(model, data, fid, LOCAL).vector
        kernel = self._drift_kernel
        if kernel is None:  # Pinocchio's views and this task's rows are of fixed types, the target and the outputs
            # specialised for any strides (wbc.compiled.specialise; with kernel type checks on, the dispatcher)
            strided = _strided_drift_arrays(1)
            kernel = self._drift_kernel = _frame_rows_drift if CHECK_TYPES else specialise(
                _frame_rows_drift, views[2], views[3], strided[0], jac, vel, acc, self.rows, *strided[5:])
        kernel(views[2], views[3], target, jac, vel, acc, self.rows, error_out, jac_out, drift_out)

    def feedforward(self) -> np.ndarray | None:
        return self._ff

    def drift(self, state) -> np.ndarray:
        """(dim,) J̇ v (module docstring): m/s² (position rows, world), rad/s² (orientation rows, target axes)."""
        fid, model, data = self.frame_id, state.model, state.data
        return frame_drift(data.oMf[fid].rotation, self._target_rot_t, pin.getFrameVelocity(model, data, fid, LOCAL),
                           pin.getFrameAcceleration(model, data, fid, LOCAL), self.rows)


class PositionTask(FrameTask):
    """Frame position only (3 rows, world axes). Same arguments as :class:`FrameTask` minus orientation.

    ``set_target`` also accepts a (3,) position (m, world); ``velocity`` may then be a (3,) linear velocity.
    """

    def __init__(self, robot, frame: str, *, weight=1.0, gain: float = 100.0, name: str | None = None):
        super().__init__(robot, frame, position_weight=weight, orientation_weight=0.0, gain=gain, name=name)

    def set_target(self, pose, velocity: np.ndarray | None = None) -> None:
        if not isinstance(pose, pin.SE3) and np.shape(pose) == (3,):
            pos = np.asarray(pose, dtype=float)
            if not np.isfinite(pos).all():
                raise InvalidTargetError(f"target of {self.name} contains NaN/inf")
            pose = pin.SE3(np.eye(3), pos.copy())
        if velocity is not None and np.shape(velocity) == (3,):
            velocity = np.concatenate([np.asarray(velocity, dtype=float), np.zeros(3)])
        super().set_target(pose, velocity)


class OrientationTask(FrameTask):
    """Frame orientation only (3 rows, target axes). Same arguments as :class:`FrameTask` minus position."""

    def __init__(self, robot, frame: str, *, weight=1.0, gain: float = 100.0, name: str | None = None):
        super().__init__(robot, frame, position_weight=0.0, orientation_weight=weight, gain=gain, name=name)
