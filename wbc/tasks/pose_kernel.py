"""Compiled (numba) pose error and Jacobian of a frame task (:mod:`wbc.tasks.frame`), one call per task and tick.

Same formulas as :func:`wbc.tasks.frame.pose_error_and_jacobian`: position error p − p* (world), orientation error
log₃(R*ᵀ R), Jacobian [R J_lin ; Jlog₃(R*ᵀR) J_ang] with J the frame's LOCAL Jacobian. SO(3) log and its Jacobian
(the inverse of the right Jacobian of SO(3); Barfoot, *State Estimation for Robotics*, 2017, eq. 7.77a/7.79;
Pinocchio's ``log3``/``Jlog3``):

    θ = atan2(‖w‖/2, (tr R − 1)/2),  w = (R₃₂ − R₂₃, R₁₃ − R₃₁, R₂₁ − R₁₂),  log₃ R = θ/(2 sin θ) w
    Jlog₃ = I + ½[r]× + (1/θ² − (1 + cos θ)/(2θ sin θ)) [r]×²,   r = log₃ R

with series expansions below θ = 1e-4. Beyond θ = 3 rad (close to π, where w loses the axis) the kernels return
None-equivalents (a flag) and the caller uses Pinocchio's ``log3``/``Jlog3``.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

__all__ = ["orientation_error_jacobian", "pose_error_jacobian", "THETA_MAX"]

#: rotation angle (rad) above which the caller falls back to Pinocchio (axis ill-conditioned near π)
THETA_MAX = 3.0


@nb.njit(cache=True, nogil=True)
def _log3_jlog3(rel, r, jlog):
    """r ← log₃(rel), jlog ← Jlog₃(rel); returns θ (or −1 when θ > THETA_MAX: outputs not written)."""
    w0 = rel[2, 1] - rel[1, 2]
    w1 = rel[0, 2] - rel[2, 0]
    w2 = rel[1, 0] - rel[0, 1]
    c = 0.5 * (rel[0, 0] + rel[1, 1] + rel[2, 2] - 1.0)
    s = 0.5 * math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
    theta = math.atan2(s, c)
    if theta > THETA_MAX:
        return -1.0
    t2 = theta * theta
    if theta < 1e-4:
        f = 0.5 * (1.0 + t2 / 6.0 + 7.0 * t2 * t2 / 360.0)  # θ / (2 sin θ)
        a = 1.0 / 12.0 + t2 / 720.0 + t2 * t2 / 30240.0  # 1/θ² − (1 + cos θ) / (2θ sin θ)
    else:
        f = theta / (2.0 * s)
        a = 1.0 / t2 - (1.0 + c) / (2.0 * theta * s)
    r[0] = f * w0
    r[1] = f * w1
    r[2] = f * w2
    # [r]× and [r]×² = r rᵀ − ‖r‖² I
    rr = r[0] * r[0] + r[1] * r[1] + r[2] * r[2]
    for i in range(3):
        for j in range(3):
            jlog[i, j] = a * r[i] * r[j]
        jlog[i, i] += 1.0 - a * rr
    jlog[0, 1] -= 0.5 * r[2]
    jlog[0, 2] += 0.5 * r[1]
    jlog[1, 0] += 0.5 * r[2]
    jlog[1, 2] -= 0.5 * r[0]
    jlog[2, 0] -= 0.5 * r[1]
    jlog[2, 1] += 0.5 * r[0]
    return theta


@nb.njit(cache=True, nogil=True)
def _relative(target_rot, rot):
    rel = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            rel[i, j] = target_rot[0, i] * rot[0, j] + target_rot[1, i] * rot[1, j] + target_rot[2, i] * rot[2, j]
    return rel


@nb.njit(cache=True, nogil=True)
def pose_error_jacobian(rot, trans, target_rot, target_trans, j_local):
    """(ok, error (6,), jacobian (6, nv)) of a frame at (rot, trans) w.r.t. (target_rot, target_trans), with
    ``j_local`` its (6, nv) LOCAL Jacobian (module docstring); ok False (outputs unset) beyond THETA_MAX."""
    nv = j_local.shape[1]
    error = np.empty(6)
    jac = np.empty((6, nv))
    jlog = np.empty((3, 3))
    rel = _relative(target_rot, rot)
    if _log3_jlog3(rel, error[3:], jlog) < 0.0:
        return False, error, jac
    for i in range(3):
        error[i] = trans[i] - target_trans[i]
    for c in range(nv):
        a0, a1, a2 = j_local[0, c], j_local[1, c], j_local[2, c]
        b0, b1, b2 = j_local[3, c], j_local[4, c], j_local[5, c]
        for i in range(3):
            jac[i, c] = rot[i, 0] * a0 + rot[i, 1] * a1 + rot[i, 2] * a2
            jac[3 + i, c] = jlog[i, 0] * b0 + jlog[i, 1] * b1 + jlog[i, 2] * b2
    return True, error, jac


@nb.njit(cache=True, nogil=True)
def orientation_error_jacobian(rot, target_rot, j_local):
    """(ok, error (3,), jacobian (3, nv)): the orientation rows of :func:`pose_error_jacobian`."""
    nv = j_local.shape[1]
    error = np.empty(3)
    jac = np.empty((3, nv))
    jlog = np.empty((3, 3))
    rel = _relative(target_rot, rot)
    if _log3_jlog3(rel, error, jlog) < 0.0:
        return False, error, jac
    for c in range(nv):
        b0, b1, b2 = j_local[3, c], j_local[4, c], j_local[5, c]
        for i in range(3):
            jac[i, c] = jlog[i, 0] * b0 + jlog[i, 1] * b1 + jlog[i, 2] * b2
    return True, error, jac


_WARM = False


def ensure_compiled() -> None:
    """Compile (or load from the on-disk cache) the kernels once per process, with the array layouts Pinocchio
    hands out (F-ordered rotations, C-ordered Jacobians), so that no control tick pays for it."""
    global _WARM
    if _WARM:
        return
    _WARM = True
    rot = np.asfortranarray(np.eye(3))
    for j_local in (np.zeros((6, 1)), np.asfortranarray(np.zeros((6, 1)))):
        pose_error_jacobian(rot, np.zeros(3), np.eye(3), np.zeros(3), j_local)
        orientation_error_jacobian(rot, np.eye(3), j_local)
