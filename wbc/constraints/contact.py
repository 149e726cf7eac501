"""Contact constraint: a frame in rigid contact does not move.

Hard equality on its 6-D body velocity (``LOCAL``: linear and angular velocity in the contact frame's axes),
with drift correction towards the placement P recorded at contact:

    J v = −K e,   e = log₆(P⁻¹ oMf)   (m, rad; contact frame axes)

J v = 0 is exactly "the frame does not move"; the correction term (first order in e) only removes integration
drift.
"""

from __future__ import annotations

import numba as nb
import numpy as np
import pinocchio as pin

from wbc.compiled import CHECK_TYPES, NO_NRT, once_per_process, specialise
from wbc.configuration import LOCAL, Configuration, frame_jacobian_columns, local_jacobian_into
from wbc.constraints.base import EqualityConstraint, KinematicContext
from wbc.exceptions import InvalidInputError
from wbc.geometry import as_se3
from wbc.lie import placement_log6_into
from wbc.tasks.base import ValidatedAttribute

__all__ = ["ContactConstraint"]


@nb.njit(cache=True, nogil=True)
def _write_rows(jac, error, scale, A_out, b_out):
    """A_out = jac, b_out = scale · error (one compiled call instead of two numpy ones)."""
    for i in range(jac.shape[0]):
        b_out[i] = scale * error[i]
        for j in range(jac.shape[1]):
            A_out[i, j] = jac[i, j]


@nb.njit(cache=True, nogil=True, **NO_NRT)
def _write_contact_rows(frame, pose, scale, A_out, b_out):
    """A_out = the frame's LOCAL Jacobian, b_out = scale · log₆(P⁻¹ M) (:func:`~wbc.lie.placement_log6_into`: P =
    ``pose`` (4, 3), M = its placement) in one compiled call, no array allocated; ``frame`` = (rotation, position:
    its placed ``data.oMf``; ``data.J``; its Jacobian's columns), the Jacobian formed by
    :func:`~wbc.configuration.local_jacobian_into` (``pin.getFrameJacobian``'s numbers). Returns False (nothing
    written) near a half-turn error."""
    rot, pos, joint_jacobians, columns = frame
    if not placement_log6_into(pose, rot, pos, b_out):
        return False
    for i in range(6):
        b_out[i] = scale * b_out[i]
        for j in range(A_out.shape[1]):
            A_out[i, j] = 0.0
    local_jacobian_into(joint_jacobians, rot, pos, columns, A_out)
    return True


@nb.njit(cache=True, **NO_NRT)  # GIL kept: releasing it costs more than this call's work
def _write_contact_pair_rows(first, second, A, b, ra, rb):
    """:func:`_write_contact_rows` of two contacts in one compiled call, into the rows ``ra`` … ``ra + 6`` and ``rb``
    … ``rb + 6`` of A (m, nv) and b (m,); ``first``, ``second``: each contact's operands (frame, pose, scale) of
    :func:`_write_contact_rows` (plain tuples, built per call: cheaper than namedtuples). Returns False near a
    half-turn error of either (the second's rows then not written)."""
    frame, pose, scale = first
    if not _write_contact_rows(frame, pose, scale, A[ra:ra + 6], b[ra:ra + 6]):
        return False
    frame, pose, scale = second
    return _write_contact_rows(frame, pose, scale, A[rb:rb + 6], b[rb:rb + 6])


def _as_contact_gain(value) -> float:
    """A contact's drift-correction gain K (1/s) as a float.

    Raises:
        InvalidInputError: not a finite number > 0.
    """
    try:
        ok = not isinstance(value, bool) and bool(np.isfinite(value) and value > 0)
    except TypeError:
        ok = False
    if not ok:
        raise InvalidInputError(f"contact gain must be a finite number > 0 (1/s; 0 lets drift accumulate, "
                                f"e.g. 100), got {value!r}")
    return float(value)


@once_per_process
def _warm_up() -> None:
    """Load :func:`_write_rows`, :func:`_write_contact_rows` and :func:`_write_contact_pair_rows` (on-disk cache) once
    per process, at construction,
    for Pinocchio's array types (F-ordered rotation)."""
    _write_rows(np.zeros((6, 1)), np.zeros(6), 1.0, np.zeros((6, 1)), np.zeros(6))
    frame = (np.asfortranarray(np.eye(3)), np.zeros(3), np.zeros((6, 2), order="F"), np.arange(2))  # data.J: F
    _write_contact_rows(frame, np.eye(4, 3), 1.0, np.zeros((6, 2)), np.zeros(6))
    frame = (frame, np.eye(4, 3), 1.0)
    _write_contact_pair_rows(frame, frame, np.zeros((12, 2)), np.zeros(12), 0, 6)
    _write_contact_pair_rows(frame, frame, *_strided_rows(2), 0, 6)  # write_pair's specialisation


def _strided_rows(nv: int) -> tuple:
    """Zeros of the types of the stacked rows A (12, nv) and b (12,) as :meth:`ContactConstraint.write_pair` is
    specialised for them: strided (numba layout 'A', which reads arrays of any strides)."""
    return np.zeros((12, 2 * nv))[:, ::2], np.zeros(24)[::2]


class ContactConstraint(EqualityConstraint):
    """Keep a frame (e.g. a stance sole) fixed at its contact placement.

    Args:
        robot: the robot.
        frame: frame name (e.g. ``robot.left_sole``).
        gain: drift-correction gain K (1/s), 0 < K (capped at 1/dt).
        name: label in reports (default ``contact:<frame>``).

    Raises:
        UnknownFrameError: no such frame.
        InvalidInputError: gain not finite and > 0.
    """

    dim = 6

    _pair_kernel = None  # write_pair's compiled call, specialised at its first call

    def __init__(self, robot, frame: str, *, gain: float = 100.0, name: str | None = None):
        self.frame = frame
        self.frame_id = robot.frame_id(frame)
        self.gain = gain
        self.name = name or f"contact:{frame}"
        self.placement = pin.SE3.Identity()
        self._columns = frame_jacobian_columns(robot.model, self.frame_id)  # its Jacobian's (_write_contact_rows)
        self._oMf_views: dict[int, tuple] = {}  # per Data object: (data, oMf, rotation, translation, frame), _views
        self._recent_views = self._older_views = (None,)  # those of the last two Data objects read, looked at first
        _warm_up()

    gain = ValidatedAttribute(lambda contact, k: _as_contact_gain(k),
                              "Drift-correction gain K (1/s), finite and > 0; validated on assignment (raises "
                              "InvalidInputError: not a finite number > 0).")

    @property
    def placement(self) -> pin.SE3:
        """Contact placement (world) the frame must hold."""
        return self._placement

    @placement.setter
    def placement(self, pose: pin.SE3) -> None:
        self._placement = pose.copy()
        self._rot = pose.rotation.copy()
        self._rot_t = self._rot.T.copy()
        self._pos = pose.translation.copy()
        self._pose = np.vstack([self._rot, self._pos])  # (4, 3) [R; pᵀ]: placement_log6_into

    def set_placement(self, pose) -> None:
        """Contact placement (pin.SE3 or (4,4), world) the frame must hold.

        Raises:
            InvalidTargetError: malformed pose.
        """
        self.placement = as_se3(pose, f"placement of {self.name}")

    def set_placement_from_configuration(self, config: Configuration) -> None:
        """Contact placement = the frame's current placement."""
        self.placement = config.data.oMf[self.frame_id]

    def compute_error(self, config: Configuration) -> np.ndarray:
        """(6,) pose error log₆(P⁻¹ oMf) of the frame w.r.t. its contact placement (m, rad; contact axes), by the
        compiled formula that :meth:`write` and :meth:`error_into` use (so that their rows equal this bit for bit)."""
        out = np.empty(6)
        self.error_into(config.data, out)
        return out

    def compute(self, config: Configuration, dt: float) -> tuple[np.ndarray, np.ndarray]:
        b = self.compute_error(config)
        b *= -min(self._gain, 1.0 / dt)
        return pin.getFrameJacobian(config.model, config.data, self.frame_id, LOCAL), b

    def write(self, ctx: KinematicContext, A_out: np.ndarray, b_out: np.ndarray, hi=None) -> None:
        """Write the rows of :meth:`compute` in place into A_out (6, nv) and b_out (6,) (views of a controller's
        stacked buffers), at ``ctx.config`` and ``ctx.dt``; a subclass that overrides :meth:`compute` is written
        from it."""
        if type(self).compute is not ContactConstraint.compute:
            super().write(ctx, A_out, b_out, hi)
            return
        config = ctx.config
        data = config.kinematics_data  # its frame placed here
        views = self._views(data)
        pin.updateFramePlacement(config.model, data, self.frame_id)
        scale = -min(self._gain, 1.0 / ctx.dt)
        if not _write_contact_rows(views[4], self._pose, scale, A_out, b_out):
            _write_rows(pin.getFrameJacobian(config.model, data, self.frame_id, LOCAL),
                        pin.log6(self._placement.actInv(views[1])).vector, scale, A_out, b_out)

    def write_pair(self, other: ContactConstraint, ctx: KinematicContext, A: np.ndarray, b: np.ndarray, row: int,
                   other_row: int) -> None:
        """:meth:`write` of this contact and of ``other`` in one compiled call (the same numbers): this one's rows
        into A[row:row + 6] (6, nv) and b[row:row + 6], those of ``other`` at ``other_row``, at ``ctx.config`` and
        ``ctx.dt`` (a biped's two soles, written every tick). Each contact's rows are the module docstring's
        J v = −K e: A ← its frame Jacobian J (``LOCAL``: linear then angular velocity in the contact frame's axes,
        per unit of v), b ← −min(K, 1/dt) · log₆(P⁻¹ oMf) (m/s, then rad/s; contact frame axes). Near a half-turn
        pose error both are written by :meth:`write` (Pinocchio's ``log6``). Both contacts must be of class
        :class:`ContactConstraint` itself (not checked here, a per-tick call: the caller selects them; a subclass's
        own rows are written by its :meth:`write`).

        Args:
            other: the second contact.
            ctx: the tick's :class:`~wbc.constraints.base.KinematicContext` (``config`` with its kinematics computed
                at q, ``dt`` > 0 in s).
            A (m, nv), b (m,): the stacked equality rows (out, float64); only the two blocks of 6
                rows are written.
            row, other_row: where each contact's 6 rows start (0 ≤ row, other_row ≤ m − 6; the blocks disjoint).
        """
        config = ctx.config
        model, data = config.model, config.kinematics_data  # each frame placed here
        pin.updateFramePlacement(model, data, self.frame_id)
        pin.updateFramePlacement(model, data, other.frame_id)
        k, ka, kb = 1.0 / ctx.dt, self._gain, other.gain
        first = (self._views(data)[4], self._pose, -(k if k < ka else ka))  # −min(K, 1/dt)
        second = (other.frame_operands(data), other._pose, -(k if k < kb else kb))
        kernel = self._pair_kernel
        if kernel is None:  # the operands are Pinocchio's and the contacts' arrays, of fixed types; the stacked rows
            # specialised for any strides (wbc.compiled.specialise; with kernel type checks on, the dispatcher)
            kernel = self._pair_kernel = _write_contact_pair_rows if CHECK_TYPES else specialise(
                _write_contact_pair_rows, first, second, *_strided_rows(1), row, other_row)
        if not kernel(first, second, A, b, row, other_row):
            self.write(ctx, A[row:row + 6], b[row:row + 6])  # a half-turn error: Pinocchio's log6
            other.write(ctx, A[other_row:other_row + 6], b[other_row:other_row + 6])

    def frame_operands(self, data: pin.Data) -> tuple:
        """(R (3, 3), p (3,), ``data.J``, the columns of the frame's Jacobian): what :func:`_write_contact_rows` reads
        of the contact frame in ``data`` (views; the frame placed by the caller)."""
        return self._views(data)[4]

    def log_operands(self, data: pin.Data) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(P (4, 3) = [R_P; p_Pᵀ], R (3, 3), p (3,)): the placement and the contact frame's rotation and position
        (world; views of ``data.oMf``, placed by the caller) from which :meth:`error_into` computes log₆(P⁻¹ M) with
        :func:`~wbc.lie.placement_log6_into`. Read-only use: they are this constraint's and Pinocchio's."""
        views = self._views(data)
        return self._pose, views[2], views[3]

    def _views(self, data) -> tuple:
        """(data, oMf, its rotation, its translation, the frame argument of :func:`_write_contact_rows`) of the contact
        frame: data.oMf[frame] is a reference into Pinocchio's data and its rotation/translation, like ``data.J``, are
        views of it (eigenpy), kept per Data object (a few)."""
        views = self._recent_views
        if views[0] is data:
            return views
        views = self._older_views  # a tick reads two Data objects (its configuration's and the lookahead's)
        if views[0] is data:
            return views
        views = self._oMf_views.get(id(data))
        if views is None or views[0] is not data:
            if len(self._oMf_views) >= 4:  # a controller's configuration and drift data, kept; others replaced
                self._oMf_views.clear()
            oMf = data.oMf[self.frame_id]
            frame = (oMf.rotation, oMf.translation, data.J, self._columns)  # _write_contact_rows' frame
            views = self._oMf_views[id(data)] = (data, oMf, *frame[:2], frame)
        self._older_views, self._recent_views = self._recent_views, views
        return views

    def error_into(self, data: pin.Data, out: np.ndarray) -> None:
        """out (6,) ← log₆(P⁻¹ oMf), the error of :meth:`compute_error`, read from ``data.oMf`` of the contact frame
        (placed by the caller, e.g. ``pin.updateFramePlacement``), in one compiled call (Pinocchio's ``log6`` near
        a half-turn error)."""
        views = self._views(data)
        if not placement_log6_into(self._pose, views[2], views[3], out):
            out[:] = pin.log6(self._placement.actInv(views[1])).vector
