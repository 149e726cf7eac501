"""SO(3) and SE(3) in compiled form: the exponential and logarithm maps, the Jacobian of log₃ and its rate.

Conventions are Pinocchio's (``pinocchio/spatial/explog.hpp``, ``log.hxx``): a twist ξ (6,) is (ν linear, ω
angular); log₆ returns (linear, angular); Jlog₃ is the inverse of the right Jacobian of SO(3), so that
d/dt log₃(R) = Jlog₃(R) ω for Ṙ = R [ω]× (ω in the body axes). Quaternions are (w, x, y, z).

Every function is a numba kernel without allocation, callable from other kernels; Pinocchio is the oracle
(``tests/test_lie.py``: random samples, rotations within 1e-9 rad of the identity and of a half turn):

- :func:`log3_into`, :func:`log3_columns`: θ and log₃(R) for any rotation, Pinocchio's Taylor branches below
  ε^(1/3) and, within ε^(1/3) of a half turn, the axis from the largest diagonal entry (``log3`` near π).
- :func:`jlog3_into`: Jlog₃ at log₃(R) (Pinocchio's series below ε^(1/4)).
- :func:`log3_rate_into`: d/dt (Jlog₃(R)) ω = ``pin.Hlog3(R, ω) ω`` (a second-order series below 1e-3 rad, where
  Pinocchio's closed form loses digits).
- :func:`placement_log6_into`: log₆(P⁻¹ M) of two placements (``pin.log6(P.actInv(M))``).
- :func:`exp3_into`: exp₃(ω) (Pinocchio's ``exp3`` with its Taylor branches).
- :func:`exp6_translation`, :func:`quaternion_exp3`, :func:`translation_gap`, :func:`rotation_gap`: the origin of
  exp₆(s ξ), the quaternion of exp₃(ω), and the distance and angle between two frames given by their twists.

Sources: Pinocchio 3 (``explog.hpp``, ``log.hxx``); Lynch & Park, *Modern Robotics* (2017), eq. 3.88 (V(ω));
Solà, Deray & Atchuthan, *A micro Lie theory for state estimation in robotics* (2018), eq. 143–146 (Jr⁻¹).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from wbc.compiled import FASTMATH, NO_NRT

__all__ = ["PREC2", "PREC3", "EXP3_TAYLOR", "SMALL_ANGLE", "log3_into", "log3_columns", "jlog3_into",
           "log3_rate_into", "placement_log6_into", "exp3_into", "exp6_translation", "quaternion_exp3",
           "translation_gap", "rotation_gap"]

_EPS = float(np.finfo(float).eps)
_EPS2 = _EPS * _EPS
#: Pinocchio's Taylor-expansion thresholds ε^(1/3) and ε^(1/4) (``TaylorSeriesExpansion::precision<2>``, ``<3>``)
#: of log₃, log₆ and Jlog₃.
PREC2 = float(_EPS ** (1.0 / 3.0))
PREC3 = float(_EPS ** (1.0 / 4.0))
#: Taylor-branch threshold of Pinocchio's ``exp3`` (``TaylorSeriesExpansion<double>::precision<3>()``: ε^(1/4)).
EXP3_TAYLOR = _EPS ** 0.25
#: |θ| (rad) below which :func:`log3_rate_into` uses its small-angle series.
SMALL_ANGLE = 1e-3


@nb.njit(cache=True, nogil=True)
def log3_into(rel, log):
    """log (3,) ← log₃(rel) for a rotation matrix rel (3, 3) (``pin.log3``: the rotation renormalized from its
    first two columns, θ from its trace, θ / sin θ times its antisymmetric part, the series below ε^(1/3), the
    half-turn branch within ε^(1/3) of π). Returns θ ∈ [0, π] (rad)."""
    return log3_columns(rel[0, 0], rel[1, 0], rel[2, 0], rel[0, 1], rel[1, 1], rel[2, 1], log)


@nb.njit(cache=True, nogil=True)
def log3_columns(r00, r10, r20, r01, r11, r21, log):
    """:func:`log3_into` given the first two columns of rel (its third is rebuilt from them): scalars, so that a
    caller that forms rel entry by entry needs no (3, 3) array. Returns θ (rad)."""
    n0 = np.sqrt(r00 * r00 + r10 * r10 + r20 * r20)
    n1 = np.sqrt(r01 * r01 + r11 * r11 + r21 * r21)
    c0x, c0y, c0z = r00 / n0, r10 / n0, r20 / n0
    c1x, c1y, c1z = r01 / n1, r11 / n1, r21 / n1
    c2x, c2y, c2z = c0y * c1z - c0z * c1y, c0z * c1x - c0x * c1z, c0x * c1y - c0y * c1x
    c0x, c0y, c0z = c1y * c2z - c1z * c2y, c1z * c2x - c1x * c2z, c1x * c2y - c1y * c2x
    tr = c0x + c1y + c2z
    cos_value = (tr - 1.0) / 2.0
    if not cos_value >= -1.0 + PREC2:
        return _log3_half_turn(c0x, c0y, c0z, c1x, c1y, c1z, c2x, c2y, c2z, log)
    acos_expansion = np.sqrt(2.0 * (1.0 - cos_value) + _EPS * _EPS)
    if tr <= 3.0 - PREC2:
        theta = np.arccos(cos_value) if tr >= -1.0 + PREC2 else np.pi - acos_expansion
    else:
        theta = acos_expansion
    u0 = 0.5 * (c1z - c2y)
    u1 = 0.5 * (c2x - c0z)
    u2 = 0.5 * (c0y - c1x)
    nu2 = u0 * u0 + u1 * u1 + u2 * u2
    if theta >= PREC2:
        t = theta / np.sin(theta)
    else:
        t = 1.0 + nu2 / 6.0 + nu2 * nu2 * 3.0 / 40.0
    log[0], log[1], log[2] = t * u0, t * u1, t * u2
    return theta


@nb.njit(cache=True, nogil=True)
def _log3_half_turn(c0x, c0y, c0z, c1x, c1y, c1z, c2x, c2y, c2z, log):
    """log₃ of the rotation with columns c0, c1, c2 when its angle is within ε^(1/3) of π (trace near −1): the
    quaternion from the largest diagonal entry (Shepperd's method), θ = 2 atan2(‖v‖, w), log = θ v / ‖v‖.
    Returns θ (rad)."""
    # R[i, j] with R = [c0 c1 c2]
    d0, d1, d2 = c0x, c1y, c2z
    if d0 >= d1 and d0 >= d2:
        s = 2.0 * np.sqrt(max(1.0 + d0 - d1 - d2, 0.0))
        w, x, y, z = (c1z - c2y) / s, 0.25 * s, (c1x + c0y) / s, (c2x + c0z) / s
    elif d1 >= d2:
        s = 2.0 * np.sqrt(max(1.0 - d0 + d1 - d2, 0.0))
        w, x, y, z = (c2x - c0z) / s, (c1x + c0y) / s, 0.25 * s, (c2y + c1z) / s
    else:
        s = 2.0 * np.sqrt(max(1.0 - d0 - d1 + d2, 0.0))
        w, x, y, z = (c0y - c1x) / s, (c2x + c0z) / s, (c2y + c1z) / s, 0.25 * s
    if w < 0.0:  # the shorter arc: θ ≤ π
        w, x, y, z = -w, -x, -y, -z
    nv = np.sqrt(x * x + y * y + z * z)
    theta = 2.0 * np.arctan2(nv, w)
    k = theta / nv
    log[0], log[1], log[2] = k * x, k * y, k * z
    return theta


@nb.njit(cache=True, nogil=True)
def jlog3_into(theta, log, jlog):
    """jlog (3, 3) ← Jlog₃ at log = log₃(R) (3,), θ = ‖log‖ (rad), as Pinocchio's ``Jlog3`` computes it (its series
    below ε^(1/4)). Returns (sin θ, cos θ)."""
    st, ct = np.sin(theta), np.cos(theta)
    if theta < PREC3:
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


@nb.njit(cache=True, nogil=True)
def log3_rate_into(theta, st, ct, log, jlog, omega, alpha, out):
    """out (3,) ← Jlog₃ α + (d/dt Jlog₃) ω: the second derivative of log₃(R(t)) for Ṙ = R [ω]×, ω̇ = α (body axes;
    rad/s, rad/s²), given θ, sin θ, cos θ, log = log₃(R) (3,) and jlog = Jlog₃ (3, 3) (:func:`jlog3_into`).

    (d/dt Jlog₃) ω is ``pin.Hlog3(R, ω) ω`` (Pinocchio's formula) for θ ≥ :data:`SMALL_ANGLE`; below, where that
    formula loses digits (its terms cancel as θ → 0) and is NaN at R = I, −(1/6) ω × (θ × ω), from Jlog₃ = I + ½[θ]× +
    (1/12)[θ]×² + O(|θ|³) and θ̇ = Jlog₃ ω (error O(|θ|² |ω|²))."""
    w0, w1, w2 = omega[0], omega[1], omega[2]
    for i in range(3):
        out[i] = jlog[i, 0] * alpha[0] + jlog[i, 1] * alpha[1] + jlog[i, 2] * alpha[2]
    t0, t1, t2 = log[0], log[1], log[2]
    if t0 * t0 + t1 * t1 + t2 * t2 < SMALL_ANGLE ** 2:
        c0, c1, c2 = t1 * w2 - t2 * w1, t2 * w0 - t0 * w2, t0 * w1 - t1 * w0
        out[0] -= (w1 * c2 - w2 * c1) / 6.0
        out[1] -= (w2 * c0 - w0 * c2) / 6.0
        out[2] -= (w0 * c1 - w1 * c0) / 6.0
        return
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
    out[0] += k_log * t0 + k_dl * dl0 + 0.5 * (dl1 * w2 - dl2 * w1) + k_w * w0
    out[1] += k_log * t1 + k_dl * dl1 + 0.5 * (dl2 * w0 - dl0 * w2) + k_w * w1
    out[2] += k_log * t2 + k_dl * dl2 + 0.5 * (dl0 * w1 - dl1 * w0) + k_w * w2


@nb.njit(cache=True, nogil=True, inline="always")
def _col_dot(a, i, b, j):
    """(aᵀ b)[i, j] = a[0, i] b[0, j] + a[1, i] b[1, j] + a[2, i] b[2, j] (3 rows of a and b; in this order)."""
    return a[0, i] * b[0, j] + a[1, i] * b[1, j] + a[2, i] * b[2, j]


@nb.njit(cache=True, nogil=True, **NO_NRT)
def placement_log6_into(pose, rot, pos, out):
    """out (6,) ← log₆(P⁻¹ M) = (linear, angular) of a placement M (``rot`` (3, 3), ``pos`` (3,), world) relative to
    P given as ``pose`` (4, 3) = [R_P; p_Pᵀ] (world): ``pin.log6(P.actInv(M)).vector`` with Pinocchio's formulas
    (``SE3.actInv``; ``log6`` of ``log.hxx``) (m, rad; P's axes). Returns True (kept for its callers' checks)."""
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
    theta = log3_columns(r00, r10, r20, r01, r11, r21, out[3:])
    st, ct = np.sin(theta), np.cos(theta)
    if tr >= 3.0 - PREC2:
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


@nb.njit(cache=True)
def exp3_into(w0, w1, w2, out):
    """out (3, 3) ← exp₃(ω) for ω = (w0, w1, w2) (rad), Pinocchio's ``exp3`` (``explog.hpp``, its Taylor branches
    below ε^(1/4); θ² carries Pinocchio's ε² so that θ > 0)."""
    t2 = (w0 * w0 + w1 * w1) + w2 * w2 + _EPS2
    t = math.sqrt(t2)
    st, ct = math.sin(t), math.cos(t)
    if t > EXP3_TAYLOR:
        a_xx, a_x = (1.0 - ct) / t2, st / t
    else:
        a_xx, a_x = 0.5 - t2 / 24.0, 1.0 - t2 / 6.0
        ct = 1.0 - t2 / 2.0
    w = (w0, w1, w2)
    for i in range(3):
        for j in range(3):
            out[i, j] = a_xx * w[i] * w[j]
    out[0, 1] -= a_x * w2
    out[1, 0] += a_x * w2
    out[0, 2] += a_x * w1
    out[2, 0] -= a_x * w1
    out[1, 2] -= a_x * w0
    out[2, 1] += a_x * w0
    for i in range(3):
        out[i, i] += ct


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def exp6_translation(xi, s):
    """The translation (3 floats, m) of exp₆(s ξ) for a twist ξ = (ν, ω) (6,): V(sω) sν with
    V(ω) = I + (1 − cos θ)/θ² [ω]× + (θ − sin θ)/θ³ [ω]×², θ = ‖ω‖ (Lynch & Park, eq. 3.88)."""
    nx, ny, nz = s * xi[0], s * xi[1], s * xi[2]
    wx, wy, wz = s * xi[3], s * xi[4], s * xi[5]
    t2 = wx * wx + wy * wy + wz * wz
    if t2 < 1e-12:  # series: 1/2 − θ²/24, 1/6 − θ²/120
        a, c = 0.5 - t2 / 24.0, 1.0 / 6.0 - t2 / 120.0
    else:
        t = np.sqrt(t2)
        a, c = (1.0 - np.cos(t)) / t2, (t - np.sin(t)) / (t2 * t)
    # w × n and w × (w × n)
    cx, cy, cz = wy * nz - wz * ny, wz * nx - wx * nz, wx * ny - wy * nx
    dx, dy, dz = wy * cz - wz * cy, wz * cx - wx * cz, wx * cy - wy * cx
    return nx + a * cx + c * dx, ny + a * cy + c * dy, nz + a * cz + c * dz


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def translation_gap(xa, sa, xb, sb):
    """‖t(exp₆(sa ξa)) − t(exp₆(sb ξb))‖ (m): the distance between the origins of two frames given by their twists
    ξa, ξb (6,) from one reference frame (e.g. a contact's placement)."""
    pa = exp6_translation(xa, sa)
    pb = exp6_translation(xb, sb)
    return np.sqrt((pa[0] - pb[0]) ** 2 + (pa[1] - pb[1]) ** 2 + (pa[2] - pb[2]) ** 2)


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def quaternion_exp3(wx, wy, wz):
    """The unit quaternion (w, x, y, z) of exp₃(ω) for a rotation vector ω (rad): (cos(θ/2), sin(θ/2)/θ · ω),
    θ = ‖ω‖ (series below θ = 1e-6)."""
    t2 = wx * wx + wy * wy + wz * wz
    if t2 < 1e-12:  # series: 1 − θ²/8, 1/2 − θ²/48
        c, s = 1.0 - t2 / 8.0, 0.5 - t2 / 48.0
    else:
        t = np.sqrt(t2)
        c, s = np.cos(0.5 * t), np.sin(0.5 * t) / t
    return c, s * wx, s * wy, s * wz


@nb.njit(cache=True, fastmath=FASTMATH, nogil=True)
def rotation_gap(xa, sa, xb, sb):
    """The angle (rad, in [0, π]) of the rotation between the frames exp₆(sa ξa) and exp₆(sb ξb) given by their
    twists ξa, ξb (6,) from one reference frame: ‖log₃(R(sa ωa)ᵀ R(sb ωb))‖, from the quaternion q̄_a q_b = (w, v)
    as 2 atan2(‖v‖, |w|)."""
    aw, ax, ay, az = quaternion_exp3(sa * xa[3], sa * xa[4], sa * xa[5])
    bw, bx, by, bz = quaternion_exp3(sb * xb[3], sb * xb[4], sb * xb[5])
    w = aw * bw + ax * bx + ay * by + az * bz
    vx = aw * bx - bw * ax - (ay * bz - az * by)
    vy = aw * by - bw * ay - (az * bx - ax * bz)
    vz = aw * bz - bw * az - (ax * by - ay * bx)
    return 2.0 * np.arctan2(np.sqrt(vx * vx + vy * vy + vz * vz), abs(w))
