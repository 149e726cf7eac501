"""Compiled (numba) kernels of the estimators of :mod:`wbc.estimation`: one call per sample instead of ~150 small
numpy operations on 3-vectors and 3 × 3 matrices.

The kernels do the arithmetic of :mod:`wbc.estimation.base`, :mod:`wbc.estimation.attitude` and
:mod:`wbc.estimation.contact` (their docstrings give the equations) on preallocated arrays; Pinocchio stays the
source of the leg kinematics (the callers pass the sole placements and velocities it computed). No validation here:
the classes validate at construction and on assignment.

Layouts (all float64 unless said otherwise):

* attitude state ``att`` (24,): R̂ (9, row-major, world ← IMU), b̂ (3), ω = Ωʸ − b̂ (3), ω_mes (3), ω_yaw (3), the
  rotation vector of the last sample (3).
* attitude parameters ``aprm`` (8,): Δt, k_P, k_I, accel_gate, bias_max, bias_gate, k_H, k_IH.
* direction rows ``dirs`` (k, 7): v₀ (3, world), v (3, IMU axes), weight.
* Kalman state ``kfs`` (10,): p (3), ṗ (3), P (4, row-major); parameters ``kprm`` (8,): Δt, ½ Δt², Q (4), σ_p²,
  σ_v².
* joint filter state ``js`` (4, n): previous (or filtered) angles, velocity, raw difference, acceleration;
  parameters ``jprm`` (6,): Δt, α, g, h, k, 1 for the g-h-k filter (0 for the low-pass).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
import pinocchio as pin

from wbc.compiled import once_per_process
from wbc.constants import GRAVITY
from wbc.exceptions import InvalidInputError

__all__ = ["check_storage", "exp3", "rotation_quaternion", "attitude_step", "kalman_predict", "kalman_correct",
           "joint_filter_step", "estimator_prepare", "estimator_step", "estimator_prepare_packed", "estimator_step_packed",
           "ESTIMATOR_PARAMS", "PACKED_BLOCKS", "warm_up"]


def check_storage(state: np.ndarray, params: np.ndarray, like_state: np.ndarray, like_params: np.ndarray) -> None:
    """Check that ``state`` and ``params`` can hold a filter's compiled state and parameters: writable float64
    arrays of the shapes of ``like_state`` and ``like_params``.

    Raises:
        InvalidInputError: another dtype or shape, or a read-only array.
    """
    for arr, like, what in ((state, like_state, "state"), (params, like_params, "params")):
        if not isinstance(arr, np.ndarray) or arr.dtype != np.float64 or arr.shape != like.shape \
                or not arr.flags.writeable:
            raise InvalidInputError(f"{what} must be a writable float64 array of shape {like.shape}, got "
                                    f"{getattr(arr, 'dtype', type(arr).__name__)} {getattr(arr, 'shape', '')}")

#: names of the entries of the estimator parameter vector ``prm`` of :func:`estimator_step`, in order
ESTIMATOR_PARAMS = ("dt", "beta", "alpha_turn", "turn_rate", "heading_weight", "handover_end_share",
                    "has_ground", "ground_height", "heading_handover", "on_left", "off_left", "on_right",
                    "off_right", "mass_left", "mass_right", "sole_left_x", "sole_left_y", "sole_left_z",
                    "sole_right_x", "sole_right_y", "sole_right_z", "com_left_x", "com_left_y", "com_left_z",
                    "com_right_x", "com_right_y", "com_right_z")

#: blocks of the packed float buffer of :func:`estimator_prepare_packed` / :func:`estimator_step_packed`, in order;
#: the int buffer holds their offsets (then nq, nv, nj), the joint filter's started flag, ``ist`` and ``idx``
PACKED_BLOCKS = ("att", "js", "jprm", "qk", "vk", "aprm", "kfs", "kprm", "prm", "ws", "wrench", "q", "v")
_NB = len(PACKED_BLOCKS)

_EPS3 = np.finfo(np.float64).eps ** (1.0 / 3.0)  # Pinocchio's TaylorSeriesExpansion<double>::precision<3>()
_G = -GRAVITY  # z of the gravity vector (world)


@nb.njit(cache=True)
def exp3(w, out):
    """out (3, 3) = exp([w]×) for w (3,) (rad), Pinocchio's ``exp3`` formula (Rodrigues; Taylor terms below
    ‖w‖ = ε^⅓)."""
    t2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2]
    t = math.sqrt(t2)
    st, ct = math.sin(t), math.cos(t)
    if t > _EPS3:
        a2, a1 = (1.0 - ct) / t2, st / t
    else:
        a2, a1 = 0.5 - t2 / 24.0, 1.0 - t2 / 6.0
    for i in range(3):
        for j in range(3):
            out[i, j] = a2 * w[i] * w[j]
    out[0, 1] -= a1 * w[2]
    out[1, 0] += a1 * w[2]
    out[0, 2] += a1 * w[1]
    out[2, 0] -= a1 * w[1]
    out[1, 2] -= a1 * w[0]
    out[2, 1] += a1 * w[0]
    for i in range(3):
        out[i, i] += ct


@nb.njit(cache=True)
def rotation_quaternion(m, out):
    """out (4,) = (x, y, z, w) of the rotation matrix m (3, 3) (Eigen's ``Quaternion(Matrix3)`` algorithm, as
    ``pin.SE3ToXYZQUAT``)."""
    t = m[0, 0] + m[1, 1] + m[2, 2]
    if t > 0.0:
        t = math.sqrt(t + 1.0)
        out[3] = 0.5 * t
        t = 0.5 / t
        out[0] = (m[2, 1] - m[1, 2]) * t
        out[1] = (m[0, 2] - m[2, 0]) * t
        out[2] = (m[1, 0] - m[0, 1]) * t
    else:
        i = 0
        if m[1, 1] > m[0, 0]:
            i = 1
        if m[2, 2] > m[i, i]:
            i = 2
        j = (i + 1) % 3
        k = (j + 1) % 3
        t = math.sqrt(m[i, i] - m[j, j] - m[k, k] + 1.0)
        out[i] = 0.5 * t
        t = 0.5 / t
        out[3] = (m[k, j] - m[j, k]) * t
        out[j] = (m[j, i] + m[i, j]) * t
        out[k] = (m[k, i] + m[i, k]) * t


@nb.njit(cache=True)
def _mm(A, B, out):
    """out (3, 3) = A B."""
    for i in range(3):
        for j in range(3):
            out[i, j] = A[i, 0] * B[0, j] + A[i, 1] * B[1, j] + A[i, 2] * B[2, j]


@nb.njit(cache=True)
def _mv(A, x, out):
    """out (3,) = A x."""
    for i in range(3):
        out[i] = A[i, 0] * x[0] + A[i, 1] * x[1] + A[i, 2] * x[2]


@nb.njit(cache=True)
def _mtv(A, x, out):
    """out (3,) = Aᵀ x."""
    for i in range(3):
        out[i] = A[0, i] * x[0] + A[1, i] * x[1] + A[2, i] * x[2]


@nb.njit(cache=True)
def _direction_error(R, dirs, out):
    """out (3,) += Σ k (v × R̂ᵀ v₀) over the rows of dirs (eq. 32c), in row order."""
    for r in range(dirs.shape[0]):
        h0 = R[0, 0] * dirs[r, 0] + R[1, 0] * dirs[r, 1] + R[2, 0] * dirs[r, 2]
        h1 = R[0, 1] * dirs[r, 0] + R[1, 1] * dirs[r, 1] + R[2, 1] * dirs[r, 2]
        h2 = R[0, 2] * dirs[r, 0] + R[1, 2] * dirs[r, 1] + R[2, 2] * dirs[r, 2]
        v0, v1, v2, k = dirs[r, 3], dirs[r, 4], dirs[r, 5], dirs[r, 6]
        out[0] += k * (v1 * h2 - v2 * h1)
        out[1] += k * (v2 * h0 - v0 * h2)
        out[2] += k * (v0 * h1 - v1 * h0)


@nb.njit(cache=True)
def attitude_step(att, aprm, gyro, accel, dirs, heading):
    """One sample of the complementary filter (:mod:`wbc.estimation.attitude`) on the state ``att`` (module
    docstring) → whether the accelerometer was used."""
    R = att[0:9].reshape(3, 3)
    bias, omega, wm, wh, w = att[9:12], att[12:15], att[15:18], att[18:21], att[21:24]
    dt, k_p, k_i, gate_a, bias_max, bias_gate, k_h, k_hb = (aprm[0], aprm[1], aprm[2], aprm[3], aprm[4], aprm[5],
                                                             aprm[6], aprm[7])
    a0, a1, a2 = accel[0], accel[1], accel[2]
    n = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
    used = n > 0 and abs(n - GRAVITY) <= gate_a
    wm[0] = wm[1] = wm[2] = 0.0
    if used:  # v × v̂ with v = a/‖a‖, v̂ = R̂ᵀ e_z (the third row of R̂), then the directions
        a0, a1, a2 = a0 / n, a1 / n, a2 / n
        u0, u1, u2 = R[2, 0], R[2, 1], R[2, 2]
        wm[0], wm[1], wm[2] = a1 * u2 - a2 * u1, a2 * u0 - a0 * u2, a0 * u1 - a1 * u0
    _direction_error(R, dirs, wm)
    wh[0] = wh[1] = wh[2] = 0.0
    _direction_error(R, heading, wh)
    s = wh[0] * R[2, 0] + wh[1] * R[2, 1] + wh[2] * R[2, 2]
    for i in range(3):
        wh[i] = s * R[2, i]  # projected on the vertical u = R̂ᵀ e_z
        omega[i] = gyro[i] - bias[i]
        w[i] = ((wm[i] * k_p + omega[i]) + k_h * wh[i]) * dt
    E, Rn = np.empty((3, 3)), np.empty((3, 3))
    exp3(w, E)
    _mm(R, E, Rn)
    R[:, :] = Rn
    gate = bias_gate * bias_gate
    if k_i and used and wm[0] * wm[0] + wm[1] * wm[1] + wm[2] * wm[2] <= gate:
        c = k_i * dt
        for i in range(3):
            bias[i] -= c * wm[i]
    if k_hb and wh[0] * wh[0] + wh[1] * wh[1] + wh[2] * wh[2] <= gate:
        c = k_hb * dt
        for i in range(3):
            bias[i] -= c * wh[i]
    for i in range(3):
        bias[i] = min(max(bias[i], -bias_max), bias_max)
    return used


@nb.njit(cache=True)
def kalman_predict(kfs, kprm, a):
    """Prediction of :class:`~wbc.estimation.base.BaseKalmanFilter` with the world acceleration a (3,)."""
    h, hh = kprm[0], kprm[1]
    for i in range(3):
        kfs[i] += kfs[3 + i] * h + hh * a[i]
        kfs[3 + i] += a[i] * h
    p00, p01, p10, p11 = kfs[6], kfs[7], kfs[8], kfs[9]
    b00, b01 = p00 + h * p10, p01 + h * p11  # A P
    kfs[6] = b00 + b01 * h + kprm[2]  # (A P) Aᵀ + Q
    kfs[7] = b01 + kprm[3]
    kfs[8] = p10 + p11 * h + kprm[4]
    kfs[9] = p11 + kprm[5]


@nb.njit(cache=True)
def kalman_correct(kfs, kprm, z_p, z_v):
    """Update of :class:`~wbc.estimation.base.BaseKalmanFilter` with z_p (3,) m and z_v (3,) m/s."""
    p00, p01, p10, p11 = kfs[6], kfs[7], kfs[8], kfs[9]
    s00, s01, s10, s11 = p00 + kprm[6], p01, p10, p11 + kprm[7]
    det = s00 * s11 - s01 * s10
    i00, i01, i10, i11 = s11 / det, -s01 / det, -s10 / det, s00 / det
    k00, k01 = p00 * i00 + p01 * i10, p00 * i01 + p01 * i11
    k10, k11 = p10 * i00 + p11 * i10, p10 * i01 + p11 * i11
    for i in range(3):
        ep = z_p[i] - kfs[i]
        ev = z_v[i] - kfs[3 + i]
        kfs[i] += k00 * ep + k01 * ev
        kfs[3 + i] += k10 * ep + k11 * ev
    kfs[6] = (1.0 - k00) * p00 - k01 * p10
    kfs[7] = (1.0 - k00) * p01 - k01 * p11
    kfs[8] = -k10 * p00 + (1.0 - k11) * p10
    kfs[9] = -k10 * p01 + (1.0 - k11) * p11


@nb.njit(cache=True)
def joint_filter_step(js, jprm, angles):
    """One started sample of :class:`~wbc.estimation.base.JointStateFilter` (state ``js``, module docstring)."""
    dt = jprm[0]
    x, v, r, a = js[0], js[1], js[2], js[3]
    if jprm[5] == 0.0:
        alpha = jprm[1]
        for i in range(angles.shape[0]):
            r[i] = (angles[i] - x[i]) / dt
            v[i] += alpha * (r[i] - v[i])
            x[i] = angles[i]
        return
    g, hd, kd, half = jprm[2], jprm[3] / dt, 2.0 * jprm[4] / (dt * dt), 0.5 * dt * dt
    for i in range(angles.shape[0]):
        x[i] += v[i] * dt + half * a[i]  # prediction
        v[i] += a[i] * dt
        r[i] = angles[i] - x[i]  # residual
        x[i] += g * r[i]
        v[i] += hd * r[i]
        a[i] += kd * r[i]


@nb.njit(cache=True)
def estimator_prepare(joint_q, gyro, att, js, jprm, started, qk, vk, idx):
    """Joint filter and the kinematic configuration of a sample of
    :meth:`~wbc.estimation.base.FloatingBaseEstimator.update`: ``qk`` (nq,) base at the origin and the encoder
    angles, ``vk`` (nv,) (0, ω of the last sample, joint velocities). ``idx``: (4, n) int rows q index of each
    1-DoF joint angle, its v index − 6, then for (cos, sin) joints their q index and v index − 6 (−1 padded)."""
    if started:
        joint_filter_step(js, jprm, joint_q)
    else:
        js[0, :] = joint_q
    for c in range(idx.shape[1]):
        if idx[0, c] >= 0:
            qk[idx[0, c]] = joint_q[idx[1, c]]
        if idx[2, c] >= 0:
            qk[idx[2, c]] = math.cos(joint_q[idx[3, c]])
            qk[idx[2, c] + 1] = math.sin(joint_q[idx[3, c]])
    for i in range(3):
        vk[3 + i] = gyro[i] - att[9 + i]
    vk[6:] = js[1]


@nb.njit(cache=True)
def _unit(x):
    n = math.sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2])
    x[0] /= n
    x[1] /= n
    x[2] /= n


@nb.njit(cache=True)
def estimator_step(accel, gyro, ft, H0, V0, H1, V1, att, aprm, kfs, kprm, prm, ws, ist, wrench, q, v, qk, js):
    """The rest of a sample of :meth:`~wbc.estimation.base.FloatingBaseEstimator.update` after Pinocchio's leg
    kinematics.

    Args:
        accel, gyro: (3,) IMU. ft: (2, 6) F/T readings. H0, V0, H1, V1: the (left, right) sole's placement (4, 4)
            (homogeneous matrix) and velocity (6,) (linear, angular; ``LOCAL_WORLD_ALIGNED``) in the base frame,
            from Pinocchio. att, aprm, kfs, kprm, js: module docstring. prm: :data:`ESTIMATOR_PARAMS`.
        ws: (64,) estimator state: base acceleration of the leg kinematics (3), last odometry velocity (3), sole yaw
            rates (2), normal forces (2), anchors (2 × 3), anchor axes (2 × 3), anchor rotations (2 × 9), sole
            world rotations (2 × 9), sole world positions (2 × 3) — written.
        ist: (9,) int state: contact (2), turning (2), hand-over source (2, −1 none), odometry velocity valid,
            accelerometer used, spare.
        wrench: (2, 6) ground reactions (written). q (nq,), v (nv,): the estimate (written); qk (nq,) the
            kinematic configuration (its joint part is copied).
    """
    dt, beta, alpha_turn, turn_rate = prm[0], prm[1], prm[2], prm[3]
    heading_weight, end_share, has_ground, ground_height = prm[4], prm[5], prm[6] != 0.0, prm[7]
    handover_on = prm[8] != 0.0
    acc_kin, zv_prev, yaw_rate, nf = ws[0:3], ws[3:6], ws[6:8], ws[8:10]
    anchor, axes = ws[10:16].reshape(2, 3), ws[16:22].reshape(2, 3)
    anchor_rot, sole_rot, sole_pos = ws[22:40].reshape(2, 3, 3), ws[40:58].reshape(2, 3, 3), ws[58:64].reshape(2, 3)
    R_prev = att[0:9].reshape(3, 3).copy()
    rot = np.empty((2, 3, 3))
    kin = np.empty((2, 6, 3))  # per sole: rotation, position, linear and angular velocity
    for j in range(2):
        H, V = (H0, V0) if j == 0 else (H1, V1)
        for i in range(3):
            for c in range(3):
                rot[j, i, c] = kin[j, i, c] = H[i, c]
            kin[j, 3, i] = H[i, 3]
            kin[j, 4, i] = V[i]
            kin[j, 5, i] = V[3 + i]
    fz_total = 0.0
    zv, x3, y3, Rw = np.zeros(3), np.empty(3), np.empty(3), np.empty((3, 3))
    for j in range(2):
        _mm(R_prev, rot[j], Rw)
        m = prm[13 + j]
        m0 = m * (Rw[0, 0] * 0.0 + Rw[1, 0] * 0.0 + Rw[2, 0] * _G)
        m1 = m * (Rw[0, 1] * 0.0 + Rw[1, 1] * 0.0 + Rw[2, 1] * _G)
        m2 = m * (Rw[0, 2] * 0.0 + Rw[1, 2] * 0.0 + Rw[2, 2] * _G)
        p0, p1, p2 = prm[15 + 3 * j], prm[16 + 3 * j], prm[17 + 3 * j]
        d0, d1, d2 = prm[21 + 3 * j] - p0, prm[22 + 3 * j] - p1, prm[23 + 3 * j] - p2
        f0, f1, f2, t0, t1, t2 = ft[j, 0], ft[j, 1], ft[j, 2], ft[j, 3], ft[j, 4], ft[j, 5]
        w = wrench[j]
        w[0], w[1], w[2] = -f0 - m0, -f1 - m1, -f2 - m2
        w[3] = -t0 + (p1 * f2 - p2 * f1) - (d1 * m2 - d2 * m1)
        w[4] = -t1 + (p2 * f0 - p0 * f2) - (d2 * m0 - d0 * m2)
        w[5] = -t2 + (p0 * f1 - p1 * f0) - (d0 * m1 - d1 * m0)
        fz = Rw[2, 0] * w[0] + Rw[2, 1] * w[1] + Rw[2, 2] * w[2]
        nf[j] = fz
        wz = R_prev[2, 0] * kin[j, 5, 0] + R_prev[2, 1] * kin[j, 5, 1] + R_prev[2, 2] * kin[j, 5, 2]
        y = yaw_rate[j]
        y += alpha_turn * (wz - y)
        yaw_rate[j] = y
        ist[2 + j] = abs(y) > turn_rate
        if ist[j] and fz > 0:
            for i in range(3):
                zv[i] -= fz * kin[j, 4, i]
            fz_total += fz
    # base acceleration from the leg kinematics (differenced, low-passed)
    if fz_total > 0:
        for i in range(3):
            zv[i] /= fz_total
        zw = np.empty(3)
        _mv(R_prev, zv, zw)
        if ist[6]:
            for i in range(3):
                acc_kin[i] = acc_kin[i] + beta * ((zw[i] - zv_prev[i]) / dt - acc_kin[i])
        zv_prev[:] = zw
        ist[6] = 1
    else:
        ist[6] = 0
        for i in range(3):
            acc_kin[i] *= 1.0 - beta
    _mtv(R_prev, acc_kin, x3)
    f_grav = np.empty(3)
    for i in range(3):
        f_grav[i] = accel[i] - x3[i]
    nd = 0
    dirs = np.empty((2, 7))
    if heading_weight > 0 and fz_total > 0:  # the anchored soles' forward axes (leg kinematics)
        for j in range(2):
            if ist[j] and nf[j] > 0:
                dirs[nd, 0:3] = axes[j]
                dirs[nd, 3:6] = rot[j][:, 0]
                dirs[nd, 6] = heading_weight * nf[j] / fz_total
                nd += 1
    ist[7] = attitude_step(att, aprm, gyro, f_grav, dirs[:nd], dirs[:nd])
    R = att[0:9].reshape(3, 3)
    # prediction with the IMU acceleration
    a = np.empty(3)
    _mv(R, accel, a)
    a[2] += _G
    kalman_predict(kfs, kprm, a)
    p, pd = kfs[0:3], kfs[3:6]
    # contacts and leg odometry
    zp = np.zeros(3)
    zvw = np.zeros(3)
    r_world = np.empty((2, 3))
    total = 0.0
    newly = np.zeros(2, dtype=np.bool_)
    for j in range(2):
        fz = nf[j]
        was = ist[j] != 0
        now = fz >= prm[10 + 2 * j] if was else fz > prm[9 + 2 * j]
        ist[j] = now
        _mv(R, kin[j, 3], r_world[j])
        if now and not was:
            newly[j] = True
        if now and was:
            wgt = max(fz, 0.0)
            _mv(R, kin[j, 4], x3)
            for i in range(3):
                zp[i] += wgt * (anchor[j, i] - r_world[j, i])
                zvw[i] -= wgt * x3[i]
            total += wgt
    if total > 0:
        for i in range(3):
            zp[i] /= total
            zvw[i] /= total
        kalman_correct(kfs, kprm, zp, zvw)
    for j in range(2):
        if not newly[j]:
            continue
        for i in range(3):
            anchor[j, i] = p[i] + r_world[j, i]
        ist[4 + j] = -1
        axis = np.empty(3)
        _mv(R, rot[j][:, 0], axis)
        if has_ground:
            anchor[j, 2] = ground_height
            axis[2] = 0.0  # a sole flat on flat ground: its forward axis is horizontal
        else:
            _mm(R, rot[j], anchor_rot[j])
        o = 1 - j
        if handover_on and ist[o] and ist[4 + o] == -1:
            ist[4 + j] = o
        _unit(axis)
        axes[j] = axis
    for j in range(2):
        if ist[j] and ist[2 + j] and ist[4 + j] == -1:  # a sole turning on the ground: re-anchored from R̂
            axis = np.empty(3)
            _mv(R, rot[j][:, 0], axis)
            if has_ground:
                axis[2] = 0.0
            else:
                _mm(R, rot[j], anchor_rot[j])
            _unit(axis)
            axes[j] = axis
    for j in range(2):
        o = ist[4 + j]
        if o == -1:
            continue
        if not (ist[j] and ist[o]):
            ist[4 + j] = -1
            continue
        axis = axes[j]
        Xo = rot[o]
        if has_ground:  # both soles level: the other's anchored axis turned about z
            rel = y3
            _mtv(Xo, rot[j][:, 0], rel)
            ca, sa = axes[o, 0], axes[o, 1]
            axis[0], axis[1], axis[2] = ca * rel[0] - sa * rel[1], sa * rel[0] + ca * rel[1], 0.0
        else:  # uneven ground: the tilt of R̂'s world ← sole j, turned about z to the heading through sole o
            _mtv(Xo, rot[j][:, 0], x3)
            chain = y3
            _mv(anchor_rot[o], x3, chain)
            Rs = anchor_rot[j]
            _mm(R, rot[j], Rs)
            turn = math.atan2(chain[1], chain[0]) - math.atan2(Rs[1, 0], Rs[0, 0])
            c, sn = math.cos(turn), math.sin(turn)
            for i in range(3):
                r0, r1 = Rs[0, i], Rs[1, i]
                Rs[0, i], Rs[1, i] = c * r0 - sn * r1, sn * r0 + c * r1
            axis[:] = Rs[:, 0]
        _unit(axis)
        fs, fo = max(nf[j], 0.0), max(nf[o], 0.0)
        if fo <= end_share * (fs + fo):
            ist[4 + j] = -1  # the old sole has handed over its load: the new heading is held
    for j in range(2):
        _mm(R, rot[j], sole_rot[j])
        for i in range(3):
            sole_pos[j, i] = r_world[j, i] + p[i]
    # outputs
    q[0:3] = p
    rotation_quaternion(R, q[3:7])
    q[7:] = qk[7:]
    _mtv(R, pd, x3)
    v[0:3] = x3
    v[3:6] = att[12:15]
    v[6:] = js[1]


@nb.njit(cache=True)
def estimator_prepare_packed(joint_q, gyro, buf, ib):
    """:func:`estimator_prepare` on the blocks of ``buf`` (:data:`PACKED_BLOCKS`; offsets, sizes and int state in
    ``ib``): one call with few arguments."""
    nq, nv, nj = ib[_NB], ib[_NB + 1], ib[_NB + 2]
    n = ib[_NB + 13]
    idx = ib[_NB + 14:_NB + 14 + 4 * n].reshape(4, n)
    estimator_prepare(joint_q, gyro, buf[ib[0]:ib[0] + 24], buf[ib[1]:ib[1] + 4 * nj].reshape(4, nj),
                      buf[ib[2]:ib[2] + 6], ib[_NB + 3] != 0, buf[ib[3]:ib[3] + nq], buf[ib[4]:ib[4] + nv], idx)
    ib[_NB + 3] = 1


@nb.njit(cache=True)
def estimator_step_packed(accel, gyro, ft, H0, V0, H1, V1, buf, ib):
    """:func:`estimator_step` on the blocks of ``buf`` (see :func:`estimator_prepare_packed`)."""
    nq, nv, nj = ib[_NB], ib[_NB + 1], ib[_NB + 2]
    estimator_step(accel, gyro, ft, H0, V0, H1, V1, buf[ib[0]:ib[0] + 24], buf[ib[5]:ib[5] + 8],
                   buf[ib[6]:ib[6] + 10], buf[ib[7]:ib[7] + 8], buf[ib[8]:ib[8] + len(ESTIMATOR_PARAMS)],
                   buf[ib[9]:ib[9] + 64], ib[_NB + 4:_NB + 13], buf[ib[10]:ib[10] + 12].reshape(2, 6),
                   buf[ib[11]:ib[11] + nq], buf[ib[12]:ib[12] + nv], buf[ib[3]:ib[3] + nq],
                   buf[ib[1]:ib[1] + 4 * nj].reshape(4, nj))


@once_per_process
def warm_up() -> None:
    """Load every kernel (on-disk cache) once per process on small example arrays of the real calls' types."""
    att = np.zeros(24)
    att[0:9] = np.eye(3).ravel()
    aprm = np.array([0.002, 0.2, 0.01, 2.0, 0.05, 0.02, 0.5, 0.1])
    g, a3, d = np.zeros(3), np.array([0.0, 0.0, GRAVITY]), np.zeros((0, 7))
    attitude_step(att.copy(), aprm, g, a3, d, d)
    js, jprm = np.zeros((4, 1)), np.array([0.002, 0.5, 1.0, 0.0, 0.0, 0.0])
    kfs, kprm = np.zeros(10), np.array([0.002, 2e-6, 1e-12, 1e-9, 1e-9, 1e-6, 4e-6, 4e-4])
    kfs[6], kfs[9] = 1e-6, 1e-4
    joint_filter_step(js, jprm, np.zeros(1))
    kalman_predict(kfs, kprm, g)
    kalman_correct(kfs, kprm, g, g)
    qk, vk, idx = np.zeros(8), np.zeros(7), -np.ones((4, 1), dtype=np.int64)
    estimator_prepare(np.zeros(1), g, att, js, jprm, True, qk, vk, idx)
    H, V = pin.SE3.Identity().homogeneous, pin.Motion.Zero().vector  # the array types Pinocchio returns
    prm = np.zeros(len(ESTIMATOR_PARAMS))
    prm[9:13] = (1.0, 0.5, 1.0, 0.5)
    estimator_step(a3, g, np.zeros((2, 6)), H, V, H, V, att, aprm, kfs, kprm, prm, np.zeros(64),
                   np.zeros(9, dtype=np.int64), np.zeros((2, 6)), np.zeros(8), np.zeros(7), qk, js)
    sizes = (24, 4, 6, 8, 7, 8, 10, 8, len(ESTIMATOR_PARAMS), 64, 12, 8, 7)
    offsets = np.cumsum((0,) + sizes[:-1])
    buf = np.zeros(sum(sizes))
    buf[0:9] = np.eye(3).ravel()
    buf[offsets[2]:offsets[2] + 6] = jprm
    buf[offsets[7]:offsets[7] + 8] = kprm
    ib = np.r_[offsets, 8, 7, 1, 1, np.zeros(9), 1, -np.ones(4)].astype(np.int64)
    estimator_prepare_packed(np.zeros(1), g, buf, ib)
    estimator_step_packed(a3, g, np.zeros((2, 6)), H, V, H, V, buf, ib)
    E, quat = np.empty((3, 3)), np.empty(4)
    exp3(g, E)
    rotation_quaternion(E, quat)
