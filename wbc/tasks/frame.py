"""Frame pose task: drive a frame's world placement ``oMf`` to a target pose.

Error (6,): position p − p* in world axes (m), then orientation log₃(R*ᵀ R) in the target's axes (rad).
Jacobian: [R J_lin^LOCAL ; Jlog₃(R*ᵀR) J_ang^LOCAL], exact derivative of that error (Jlog₃ is the inverse of
the right Jacobian of SO(3), ``pin.Jlog3``).
Drift J̇v (acceleration level, ë = J v̇ + J̇ v), exact: position rows, the classical acceleration of the frame origin
at v̇ = 0 (``pin.getFrameClassicalAcceleration``, LOCAL_WORLD_ALIGNED); orientation rows, with ė = Jlog₃(rel) ω
(rel = R*ᵀR, ω the LOCAL angular velocity, rel̇ = rel [ω]×),

    ë = Jlog₃(rel) ω̇ + (d/dt Jlog₃(rel)) ω   ⇒   J̇v = Jlog₃(rel) α₀ + Hlog₃(rel, ω) ω

with α₀ the LOCAL angular acceleration at v̇ = 0 (``pin.getFrameAcceleration``) and ``pin.Hlog3(rel, ω)`` the
derivative of Jlog₃ along ω (checked against finite differences of J v in ``tests/tasks/test_tasks.py``).
Position-only and orientation-only forms keep only those rows.

:meth:`FrameTask.compute_with_drift_into` (the inverse-dynamics assembly's call) evaluates the same formulas in one
compiled pass on Pinocchio's frame placement, LOCAL Jacobian, LOCAL velocity and acceleration: log₃, Jlog₃ and
Hlog₃ as Pinocchio writes them (``pinocchio/spatial/log.hxx``, ``explog.hpp``) and the classical acceleration
R (a + ω × v); within Pinocchio's tolerance of a half turn it calls Pinocchio's functions instead
(``tests/tasks/test_tasks.py`` compares both with :meth:`FrameTask.compute_into` and :meth:`FrameTask.drift`).
"""

from __future__ import annotations

import numba as nb
import numpy as np
import pinocchio as pin

from wbc.compiled import NO_NRT, once_per_process
from wbc.configuration import LOCAL, Configuration
from wbc.exceptions import InvalidTargetError
from wbc.geometry import as_se3
from wbc.tasks.base import Task, as_weight

__all__ = ["FrameTask", "PositionTask", "OrientationTask", "frame_error_and_jacobian", "pose_error_and_jacobian",
           "orientation_drift", "as_se3", "log3_into", "jlog3_into", "placement_log6_into"]


def pose_error_and_jacobian(placement: pin.SE3, j_local: np.ndarray, target: pin.SE3) -> tuple[np.ndarray, np.ndarray]:
    """(6,) error and (6, nv) Jacobian of a pose M = ``placement`` w.r.t. ``target`` (module docstring), given
    the (6, nv) body Jacobian ``j_local`` of M (M⁻¹ dM/dt = j_local v, rows linear then angular, M's axes)."""
    rot = placement.rotation
    rel = target.rotation.T @ rot
    error = np.empty(6)
    error[:3] = placement.translation - target.translation
    error[3:] = pin.log3(rel)
    jac = np.empty((6, j_local.shape[1]))
    np.matmul(rot, j_local[:3], out=jac[:3])
    np.matmul(pin.Jlog3(rel), j_local[3:], out=jac[3:])
    return error, jac


#: |θ| (rad) below which :func:`orientation_drift` uses the small-angle form of (d/dt Jlog₃) ω.
SMALL_ANGLE = 1e-3


def orientation_drift(rel: np.ndarray, omega: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """(3,) J̇v of the orientation error log₃(rel) (module docstring): Jlog₃(rel) α₀ + Hlog₃(rel, ω) ω, for
    rel (3, 3) = R*ᵀR, ω (3,) the LOCAL angular velocity (rad/s) and α₀ (3,) the LOCAL angular acceleration at
    v̇ = 0 (rad/s²)."""
    return _orientation_drift(rel, pin.log3(rel), pin.Jlog3(rel), omega, alpha)


def _orientation_drift(rel: np.ndarray, theta: np.ndarray, jlog: np.ndarray, omega: np.ndarray,
                       alpha: np.ndarray) -> np.ndarray:
    """:func:`orientation_drift` given θ = log₃(rel) (3,) and Jlog₃(rel) (3, 3)."""
    if theta @ theta < SMALL_ANGLE**2:
        # pin.Hlog3 is NaN at rel = I and loses digits below ~1e-3 rad (measured: 4e-6 error at 1e-4 rad); there
        # (d/dt Jlog₃) ω = −(1/6) ω × (θ × ω) + O(|θ|² |ω|²), from Jlog₃ = I + ½[θ]× + (1/12)[θ]×² + O(|θ|³)
        # and θ̇ = Jlog₃ ω (checked against pin.Hlog3 at 1e-2 rad and finite differences in tests/tasks/test_tasks.py)
        t0, t1, t2 = theta.tolist()
        w0, w1, w2 = omega.tolist()
        c0, c1, c2 = t1 * w2 - t2 * w1, t2 * w0 - t0 * w2, t0 * w1 - t1 * w0  # θ × ω (scalars: np.cross costs ~10 µs)
        return jlog @ alpha - np.array([w1 * c2 - w2 * c1, w2 * c0 - w0 * c2, w0 * c1 - w1 * c0]) / 6.0
    return jlog @ alpha + pin.Hlog3(rel, omega) @ omega


@nb.njit(cache=True, nogil=True)
def _frame_rows(rot, jlog, j_local, pos, target_pos, log, rows, error_out, jac_out):
    """The selected rows of error [p − p*; log] and Jacobian [rot J_lin; jlog J_ang] (module docstring), written
    into error_out (k,) and jac_out (k, nv): a compiled 3×3 by 3×nv product of matrices given by Pinocchio
    (``oMf.rotation``, ``pin.Jlog3``, ``getFrameJacobian``) and of the log ``pin.log3``, no kinematics."""
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


#: Pinocchio's Taylor-expansion thresholds ε^(1/3) and ε^(1/4) (``TaylorSeriesExpansion::precision<2>``, ``<3>``) of
#: log₃, Jlog₃ (:func:`_frame_rows_drift` follows ``pinocchio/spatial/log.hxx`` and ``explog.hpp``).
_PREC2 = float(np.finfo(float).eps ** (1.0 / 3.0))
_PREC3 = float(np.finfo(float).eps ** (1.0 / 4.0))
_EPS = float(np.finfo(float).eps)


@nb.njit(cache=True, nogil=True)
def log3_into(rel, log):
    """log (3,) ← log₃(rel) for a rotation matrix rel (3, 3), as Pinocchio's ``log3`` computes it
    (``pinocchio/spatial/log.hxx``: the renormalized rotation, θ from its trace, θ / sin θ times its antisymmetric
    part, the series below ε^(1/3)); compiled, SO(3) algebra only.

    Returns:
        θ ∈ [0, π) (rad); −1 when rel is within Pinocchio's tolerance of a half turn (its singular branch, not done
        here: ``log`` untouched, call ``pin.log3``).
    """
    return _log3_columns(rel[0, 0], rel[1, 0], rel[2, 0], rel[0, 1], rel[1, 1], rel[2, 1], log)


@nb.njit(cache=True, nogil=True)
def _log3_columns(r00, r10, r20, r01, r11, r21, log):
    """:func:`log3_into` given the first two columns of rel (its third is rebuilt from them): scalars, so that a
    caller that forms rel entry by entry needs no (3, 3) array (no allocation)."""
    n0 = np.sqrt(r00 * r00 + r10 * r10 + r20 * r20)
    n1 = np.sqrt(r01 * r01 + r11 * r11 + r21 * r21)
    c0x, c0y, c0z = r00 / n0, r10 / n0, r20 / n0
    c1x, c1y, c1z = r01 / n1, r11 / n1, r21 / n1
    c2x, c2y, c2z = c0y * c1z - c0z * c1y, c0z * c1x - c0x * c1z, c0x * c1y - c0y * c1x
    c0x, c0y, c0z = c1y * c2z - c1z * c2y, c1z * c2x - c1x * c2z, c1x * c2y - c1y * c2x
    tr = c0x + c1y + c2z
    cos_value = (tr - 1.0) / 2.0
    if not cos_value >= -1.0 + _PREC2:
        return -1.0
    acos_expansion = np.sqrt(2.0 * (1.0 - cos_value) + _EPS * _EPS)
    if tr <= 3.0 - _PREC2:
        theta = np.arccos(cos_value) if tr >= -1.0 + _PREC2 else np.pi - acos_expansion
    else:
        theta = acos_expansion
    u0 = 0.5 * (c1z - c2y)
    u1 = 0.5 * (c2x - c0z)
    u2 = 0.5 * (c0y - c1x)
    nu2 = u0 * u0 + u1 * u1 + u2 * u2
    if theta >= _PREC2:
        t = theta / np.sin(theta)
    else:
        t = 1.0 + nu2 / 6.0 + nu2 * nu2 * 3.0 / 40.0
    log[0], log[1], log[2] = t * u0, t * u1, t * u2
    return theta


@nb.njit(cache=True, nogil=True)
def jlog3_into(theta, log, jlog):
    """jlog (3, 3) ← Jlog₃ at log = log₃(R) (3,), θ = ‖log‖ (rad), as Pinocchio's ``Jlog3`` computes it (its series
    below ε^(1/4)); compiled. Returns (sin θ, cos θ)."""
    st, ct = np.sin(theta), np.cos(theta)
    if theta < _PREC3:
        alpha_j = 1.0 / 12.0 + theta * theta / 720.0
        diag = 0.5 * (2.0 - theta * theta / 6.0)
    else:
        st_1mct = st / (1.0 - ct)
        alpha_j = 1.0 / (theta * theta) - st_1mct / (2.0 * theta)
        diag = 0.5 * (theta * st_1mct)
    for i in range(3):
        for j in range(3):
            jlog[i, j] = alpha_j * log[i] * log[j]
        jlog[i, i] += diag
    jlog[0, 1] -= 0.5 * log[2]
    jlog[0, 2] += 0.5 * log[1]
    jlog[1, 0] += 0.5 * log[2]
    jlog[1, 2] -= 0.5 * log[0]
    jlog[2, 0] -= 0.5 * log[1]
    jlog[2, 1] += 0.5 * log[0]
    return st, ct


@nb.njit(cache=True, nogil=True, inline="always")
def _col_dot(a, i, b, j):
    """(aᵀ b)[i, j] = a[0, i] b[0, j] + a[1, i] b[1, j] + a[2, i] b[2, j] (3 rows of a and b; in this order)."""
    return a[0, i] * b[0, j] + a[1, i] * b[1, j] + a[2, i] * b[2, j]


@nb.njit(cache=True, nogil=True, inline="always")
def _row_dot(a, i, b, j):
    """(a b)[i, j] = a[i, 0] b[0, j] + a[i, 1] b[1, j] + a[i, 2] b[2, j] (a 3-column, b 3-row; in this order)."""
    return a[i, 0] * b[0, j] + a[i, 1] * b[1, j] + a[i, 2] * b[2, j]


@nb.njit(cache=True, nogil=True, **NO_NRT)
def placement_log6_into(pose, rot, pos, out):
    """out (6,) ← log₆(P⁻¹ M) = (linear, angular) of a placement M (``rot`` (3, 3), ``pos`` (3,), world) relative to
    P given as ``pose`` (4, 3) = [R_P; p_Pᵀ] (world): what ``pin.log6(P.actInv(M)).vector`` returns, computed
    with Pinocchio's formulas (``SE3.actInv``; ``log6`` of ``pinocchio/spatial/log.hxx``) in one compiled call
    (m, rad; P's axes).

    Returns:
        False when P⁻¹M's rotation is within Pinocchio's tolerance of a half turn (``out`` then not fully written:
        call ``pin.log6``), else True.
    """
    # rel = R_Pᵀ R entry by entry (scalars: no (3, 3) array allocated)
    r00, r01, r02 = _col_dot(pose, 0, rot, 0), _col_dot(pose, 0, rot, 1), _col_dot(pose, 0, rot, 2)
    r10, r11, r12 = _col_dot(pose, 1, rot, 0), _col_dot(pose, 1, rot, 1), _col_dot(pose, 1, rot, 2)
    r20, r21, r22 = _col_dot(pose, 2, rot, 0), _col_dot(pose, 2, rot, 1), _col_dot(pose, 2, rot, 2)
    d0, d1, d2 = pos[0] - pose[3, 0], pos[1] - pose[3, 1], pos[2] - pose[3, 2]
    p0 = pose[0, 0] * d0 + pose[1, 0] * d1 + pose[2, 0] * d2
    p1 = pose[0, 1] * d0 + pose[1, 1] * d1 + pose[2, 1] * d2
    p2 = pose[0, 2] * d0 + pose[1, 2] * d1 + pose[2, 2] * d2
    a0 = 0.5 * (r21 - r12)
    a1 = 0.5 * (r02 - r20)
    a2 = 0.5 * (r10 - r01)
    t2 = a0 * a0 + a1 * a1 + a2 * a2
    tr = r00 + r11 + r22
    theta = _log3_columns(r00, r10, r20, r01, r11, r21, out[3:])
    if theta < 0.0:
        return False
    st, ct = np.sin(theta), np.cos(theta)
    if tr >= 3.0 - _PREC2:
        alpha = 1.0 - t2 / 12.0 - t2 * t2 / 720.0
        beta = 1.0 / 12.0 + t2 / 720.0
    else:
        alpha = theta * st / (2.0 * (1.0 - ct))
        beta = 1.0 / (theta * theta) - st / (2.0 * theta * (1.0 - ct))
    w0, w1, w2 = out[3], out[4], out[5]
    bd = beta * (w0 * p0 + w1 * p1 + w2 * p2)
    out[0] = alpha * p0 - 0.5 * (w1 * p2 - w2 * p1) + bd * w0
    out[1] = alpha * p1 - 0.5 * (w2 * p0 - w0 * p2) + bd * w1
    out[2] = alpha * p2 - 0.5 * (w0 * p1 - w1 * p0) + bd * w2
    return True


@nb.njit(cache=True, **NO_NRT)  # GIL kept: releasing it costs more than this call's work
def _frame_rows_log(rot, target_rot_t, j_local, pos, target_pos, rows, error_out, jac_out, scratch):
    """:func:`_frame_rows` with log₃(R*ᵀR) and Jlog₃ computed here (:func:`log3_into`, :func:`jlog3_into`, into
    ``scratch`` (12,) float64, overwritten) instead of by three calls into Pinocchio's bindings. Returns 1 (nothing
    written) within Pinocchio's tolerance of a half turn, else 0."""
    # the first two columns of rel = R*ᵀ R (what log₃ reads; scalars: no (3, 3) array allocated)
    t = target_rot_t
    r00, r10, r20 = _row_dot(t, 0, rot, 0), _row_dot(t, 1, rot, 0), _row_dot(t, 2, rot, 0)
    r01, r11, r21 = _row_dot(t, 0, rot, 1), _row_dot(t, 1, rot, 1), _row_dot(t, 2, rot, 1)
    log, jlog = scratch[:3], scratch[3:].reshape((3, 3))
    theta = _log3_columns(r00, r10, r20, r01, r11, r21, log)
    if theta < 0.0:
        return 1
    jlog3_into(theta, log, jlog)
    _frame_rows(rot, jlog, j_local, pos, target_pos, log, rows, error_out, jac_out)
    return 0


@nb.njit(cache=True, nogil=True)
def _frame_rows_drift(rot, target_rot_t, pos, target_pos, j_local, vel, acc, rows, error_out, jac_out, drift_out):
    """:meth:`FrameTask.compute_with_drift_into` in one compiled pass (module docstring): the selected rows of the
    error, Jacobian and drift J̇v into error_out (k,), jac_out (k, nv), drift_out (k,), from Pinocchio's frame
    rotation ``rot`` (3, 3) and position ``pos`` (3,) (world), LOCAL Jacobian ``j_local`` (6, nv), LOCAL velocity
    ``vel`` and acceleration at v̇ = 0 ``acc`` (6,) (linear then angular), and the target (R*ᵀ (3, 3), p* (3,)).

    Only SO(3) algebra is done here: log₃, Jlog₃ and the derivative of Jlog₃ along ω (Pinocchio's ``log3``,
    ``Jlog3``, ``Hlog3`` formulas, or the small-angle form of :func:`_orientation_drift`), and the classical
    acceleration of the origin R (a + ω × v) (what ``pin.getFrameClassicalAcceleration`` returns in
    LOCAL_WORLD_ALIGNED).

    Returns:
        0; 1 when R*ᵀR is within Pinocchio's tolerance of a half turn (log₃'s singular branch, not done here):
        nothing written.
    """
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
        if theta < 0.0:
            return 1
        st, ct = jlog3_into(theta, log, jlog)
        # drift: Jlog3 α₀ + (d/dt Jlog3) ω (_orientation_drift)
        w0, w1, w2 = vel[3], vel[4], vel[5]
        for i in range(3):
            d6[3 + i] = jlog[i, 0] * acc[3] + jlog[i, 1] * acc[4] + jlog[i, 2] * acc[5]
        t0, t1, t2 = log[0], log[1], log[2]
        if t0 * t0 + t1 * t1 + t2 * t2 < SMALL_ANGLE ** 2:
            c0, c1, c2 = t1 * w2 - t2 * w1, t2 * w0 - t0 * w2, t0 * w1 - t1 * w0
            d6[3] -= (w1 * c2 - w2 * c1) / 6.0
            d6[4] -= (w2 * c0 - w0 * c2) / 6.0
            d6[5] -= (w0 * c1 - w1 * c0) / 6.0
        else:  # pinocchio Hlog3(θ, log, ω), then times ω
            denom = 0.5 / (1.0 - ct)
            a_h = theta * st * denom
            da_dt = (st - theta) * denom
            b_h = (1.0 - a_h) / (theta * theta)
            db_dt = -(2.0 / theta - (theta + st) * denom) / (theta * theta)
            lw = t0 * w0 + t1 * w1 + t2 * w2
            dl0 = a_h * w0 + 0.5 * (t1 * w2 - t2 * w1) + b_h * t0 * lw
            dl1 = a_h * w1 + 0.5 * (t2 * w0 - t0 * w2) + b_h * t1 * lw
            dl2 = a_h * w2 + 0.5 * (t0 * w1 - t1 * w0) + b_h * t2 * lw
            dt_dv_v = (t0 * dl0 + t1 * dl1 + t2 * dl2) / theta
            s = db_dt * dt_dv_v
            # H ω = s log (log·ω) + b dl (log·ω) + b log (dl·ω) + ½ dl × ω + da_dt dt_dv_v ω
            dlw = dl0 * w0 + dl1 * w1 + dl2 * w2
            k_log = s * lw + b_h * dlw
            k_dl = b_h * lw
            k_w = da_dt * dt_dv_v
            d6[3] += k_log * t0 + k_dl * dl0 + 0.5 * (dl1 * w2 - dl2 * w1) + k_w * w0
            d6[4] += k_log * t1 + k_dl * dl1 + 0.5 * (dl2 * w0 - dl0 * w2) + k_w * w1
            d6[5] += k_log * t2 + k_dl * dl2 + 0.5 * (dl0 * w1 - dl1 * w0) + k_w * w2
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
    return 0


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
    # the rows of compute_with_drift_into: a C-ordered target R*ᵀ, Pinocchio's (6,) motion vectors
    _frame_rows_drift(rot, np.eye(3), np.zeros(3), np.zeros(3), jac, np.zeros(6), np.zeros(6), rows, e, j, np.empty(6))


def frame_error_and_jacobian(config: Configuration, frame_id: int, target: pin.SE3) -> tuple[np.ndarray, np.ndarray]:
    """(6,) error and (6, nv) Jacobian of frame ``frame_id`` w.r.t. ``target`` (see module docstring)."""
    return pose_error_and_jacobian(config.data.oMf[frame_id], config.frame_jacobian(frame_id, LOCAL), target)


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
        self._drift6 = np.empty(6)
        self._log_scratch = np.empty(12)  # log₃ and Jlog₃ of compute_into (_frame_rows_log)
        self._ff: np.ndarray | None = None
        self._oMf_views: tuple | None = None  # (data, oMf, its rotation, its translation): compute_into
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
        oMf = config.data.oMf[self.frame_id]
        j_local = pin.getFrameJacobian(config.model, config.data, self.frame_id, LOCAL)
        rot = oMf.rotation
        if self._all_rows:
            return pose_error_and_jacobian(oMf, j_local, self.target)
        # only the blocks that have rows (same formulas as pose_error_and_jacobian)
        if not self._has_rot:
            return (oMf.translation - self.target.translation)[self.rows], (rot @ j_local[:3])[self.rows]
        rel = self._target_rot_t @ rot
        if not self._has_pos:
            if self._rot_rows.size == 3:
                return pin.log3(rel), pin.Jlog3(rel) @ j_local[3:]
            rows = self._rot_rows
            return pin.log3(rel)[rows], (pin.Jlog3(rel) @ j_local[3:])[rows]
        error, jac = pose_error_and_jacobian(oMf, j_local, self.target)
        return error[self.rows], jac[self.rows]

    def _views(self, data) -> tuple:
        """(data, oMf, its rotation, its translation) of this task's frame: data.oMf[frame] is a reference into
        Pinocchio's data and its rotation/translation are views of it (eigenpy): kept per Data object (with the
        objects that own them), they follow every update."""
        views = self._oMf_views
        if views is None or views[0] is not data:
            other = self._oMf_other  # the other Data of a configuration that alternates two (Configuration.lookahead)
            if other is not None and other[0] is data:
                self._oMf_other, views = views, other
            else:
                oMf = data.oMf[self.frame_id]
                self._oMf_other, views = views, (data, oMf, oMf.rotation, oMf.translation)
            self._oMf_views = views
        return views

    def compute_into(self, config: Configuration, error_out: np.ndarray, jac_out: np.ndarray) -> None:
        if type(self).compute is not FrameTask.compute:  # a subclass with its own error (e.g. relative frames)
            Task.compute_into(self, config, error_out, jac_out)
            return
        data = config.kinematics_data  # its frame placed by getFrameJacobian below
        views = self._views(data)
        rot = views[2]
        j_local = pin.getFrameJacobian(config.model, data, self.frame_id, LOCAL)
        if self._has_rot:
            if not _frame_rows_log(rot, self._target_rot_t, j_local, views[3], self._target_pos, self.rows,
                                   error_out, jac_out, self._log_scratch):
                return
            rel = self._target_rot_t.dot(rot)  # within Pinocchio's tolerance of a half turn: its log₃
            log, jlog = pin.log3(rel), pin.Jlog3(rel)
        else:
            log, jlog = self._target_pos, rot  # unused (no orientation row): any (3,) and (3, 3) arrays
        _frame_rows(rot, jlog, j_local, views[3], self._target_pos, log, self.rows, error_out, jac_out)

    def compute_with_drift_into(self, state, error_out: np.ndarray, jac_out: np.ndarray,
                                drift_out: np.ndarray) -> None:
        """:meth:`compute_into` and :meth:`drift` (into drift_out (dim,)) in one compiled pass
        (:func:`_frame_rows_drift`) on Pinocchio's placement, LOCAL Jacobian, velocity and acceleration of the
        frame; near a half-turn orientation error, :meth:`_compute_with_drift_pinocchio`."""
        cls = type(self)
        if cls.compute is not FrameTask.compute or cls.drift is not FrameTask.drift:
            Task.compute_with_drift_into(self, state, error_out, jac_out, drift_out)
            return
        model, data, fid = state.model, state.kinematics_data, self.frame_id  # its frame placed by getFrameJacobian
        views = self._views(data)
        if _frame_rows_drift(views[2], self._target_rot_t, views[3], self._target_pos,
                             pin.getFrameJacobian(model, data, fid, LOCAL),
                             pin.getFrameVelocity(model, data, fid, LOCAL).vector,
                             pin.getFrameAcceleration(model, data, fid, LOCAL).vector, self.rows, error_out, jac_out,
                             drift_out):
            self._compute_with_drift_pinocchio(state, error_out, jac_out, drift_out)

    def _compute_with_drift_pinocchio(self, state, error_out: np.ndarray, jac_out: np.ndarray,
                                      drift_out: np.ndarray) -> None:
        """:meth:`compute_with_drift_into` with Pinocchio's log₃, Jlog₃ and Hlog₃ (any orientation error)."""
        model, data, fid = state.model, state.data, self.frame_id
        views = self._views(data)
        rot = views[2]
        j_local = pin.getFrameJacobian(model, data, fid, LOCAL)
        # the drift rows straight into drift_out when they are whole blocks (all rows; the 3 orientation rows)
        whole = self._all_rows or (not self._has_pos and self.dim == 3)
        d = drift_out if self._all_rows else self._drift6
        if self._has_pos:
            d[:3] = pin.getFrameClassicalAcceleration(model, data, fid, pin.LOCAL_WORLD_ALIGNED).linear
        if self._has_rot:
            rel = self._target_rot_t @ rot
            log, jlog = pin.log3(rel), pin.Jlog3(rel)
            od = _orientation_drift(rel, log, jlog, pin.getFrameVelocity(model, data, fid, LOCAL).angular,
                                    pin.getFrameAcceleration(model, data, fid, LOCAL).angular)
            if whole:
                drift_out[-3:] = od
            else:
                d[3:] = od
        else:
            log, jlog = self._target_pos, rot  # unused (no orientation row): any (3,) and (3, 3) arrays
        _frame_rows(rot, jlog, j_local, views[3], self._target_pos, log, self.rows, error_out, jac_out)
        if not whole:
            drift_out[:] = d[self.rows]

    def feedforward(self) -> np.ndarray | None:
        return self._ff

    def drift(self, state) -> np.ndarray:
        """(dim,) J̇ v (module docstring): m/s² (position rows, world), rad/s² (orientation rows, target axes)."""
        fid = self.frame_id
        model, data = state.model, state.data
        d = self._drift6
        if self._has_pos:
            d[:3] = pin.getFrameClassicalAcceleration(model, data, fid, pin.LOCAL_WORLD_ALIGNED).linear
        if self._has_rot:
            rel = self._target_rot_t @ data.oMf[fid].rotation
            d[3:] = orientation_drift(rel, pin.getFrameVelocity(model, data, fid, LOCAL).angular,
                                      pin.getFrameAcceleration(model, data, fid, LOCAL).angular)
        return d if self._all_rows else d[self.rows]


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
