"""Swing-foot trajectories: sole poses and spatial velocities on the sample grid, vectorised.

A swing of duration ``T`` goes from pose ``(p_0, R_0)`` to ``(p_1, R_1)`` with phase ``s = τ / T ∈ [0, 1]``:

* blend ``b(s) = 10 s³ − 15 s⁴ + 6 s⁵`` (minimum jerk: ``b' = b'' = 0`` at both ends);
* position ``p = p_0 + b (p_1 − p_0) + (0, 0, h · 64 s³ (1 − s)³)`` — the bump peaks at ``h`` for ``s = ½`` and has
  zero velocity and acceleration at both ends;
* orientation along the geodesic ``R = R_0 Exp(b θ u)`` with ``θ u = Log(R_0ᵀ R_1)`` (for flat soles: the yaw
  blended by ``b``), so the world angular velocity is ``ḃ θ R_0 u``.

Velocities are analytic: ``ṗ = ḃ (p_1 − p_0) + (0, 0, 192 h s² (1 − s)² (1 − 2s) / T)``, ``ḃ = 30 s² (1 − s)² / T``.
The pose at lift-off (``s = 0``), at touch-down (``s = 1``) and in between swings is a copy of the rest pose
(no rounding), so a foot at rest holds a bit-exact constant pose and its velocity is exactly zero.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import pinocchio as pin

from wbc.profiles import min_jerk

__all__ = ["min_jerk", "sample_feet"]


@lru_cache(maxsize=32)
def _swing_profile(n_swing: int, dt: float, height: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Shared per-swing functions of ``s = 0, 1/n, ..., (n-1)/n`` (cached, read-only): blend ``b`` (n,),
    clearance bump ``h·64 s³(1−s)³`` (n,), and the velocity basis (2, n): ``ḃ`` and the bump's time derivative."""
    T = n_swing * dt
    s = np.arange(n_swing) / n_swing
    b, db, _ = min_jerk(s)
    sm = s * (1.0 - s)
    bump = height * 64.0 * sm**3
    vbasis = np.stack((db / T, height * 192.0 * sm**2 * (1.0 - 2.0 * s) / T))
    for a in (b, bump, vbasis):
        a.flags.writeable = False
    return b, bump, vbasis


def _geodesic_coefficients(R0: np.ndarray, R1: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """For ``R(ψ) = R0 Exp(ψ u) = R0 + sin ψ · R0[u]× + (1 − cos ψ) · R0[u]×²`` with ``θ u = Log(R0ᵀ R1)``.

    Returns ``(A1, A2, w_axis, theta)``: (m, 3, 3) ``R0[u]×`` and ``R0[u]×²``, (m, 3) world axis times angle
    ``θ R0 u``, (m,) angle ``θ`` (rad). Zero rotations give zero coefficients.
    """
    m = R0.shape[0]
    phi = np.array([pin.log3(r) for r in np.matmul(R0.transpose(0, 2, 1), R1)]).reshape(m, 3)
    theta = np.sqrt(np.einsum("ij,ij->i", phi, phi))
    u = phi / np.where(theta > 1e-12, theta, np.inf)[:, None]
    K = np.zeros((m, 3, 3))
    K[:, 0, 1], K[:, 0, 2], K[:, 1, 2] = -u[:, 2], u[:, 1], -u[:, 0]
    K[:, 1, 0], K[:, 2, 0], K[:, 2, 1] = u[:, 2], -u[:, 1], u[:, 0]
    A1 = np.matmul(R0, K)
    return A1, np.matmul(A1, K), np.matmul(R0, phi[:, :, None])[:, :, 0], theta


def sample_feet(n_samples: int, initial: np.ndarray, targets: np.ndarray, foot: np.ndarray, lift_off: np.ndarray,
                n_swing, dt: float, height: float) -> tuple[np.ndarray, np.ndarray]:
    """World poses and velocities of several soles over a walk, vectorised over all swings.

    Foot ``f`` stays at ``initial[f]`` until its first lift-off. Swing ``i`` moves foot ``foot[i]`` from its
    latest pose to ``targets[i]`` from sample ``lift_off[i]`` (``s = 0``) to the touch-down sample
    ``lift_off[i] + n_swing[i]`` (``s = 1``); the foot then stays there until its next lift-off.

    Args:
        n_samples: number of samples N.
        initial: (F, 4, 4) world poses of the soles at sample 0.
        targets: (m, 4, 4) world landing poses, in swing order (m may be 0).
        foot: (m,) int in ``[0, F)``, which sole each swing moves.
        lift_off: (m,) int, lift-off samples; a foot's swings must not overlap and every touch-down must be
            ``< n_samples``.
        n_swing: samples per swing (int >= 1, swing duration ``n_swing * dt``), or (m,) ints, one per swing.
        dt: sample period (s).
        height: swing clearance ``h`` (m) added to z at mid-swing.

    Returns:
        ``(poses, vel)``: (F, N, 4, 4) world poses; (F, N, 6) velocity of each sole-frame origin, linear (m/s)
        then angular (rad/s), both in world axes (Pinocchio's LOCAL_WORLD_ALIGNED).
    """
    initial = np.asarray(initial, dtype=float)
    n_feet, m = initial.shape[0], len(lift_off)
    targets = np.asarray(targets, dtype=float).reshape(m, 4, 4)
    poses = np.empty((n_feet, n_samples, 4, 4))
    vel = np.zeros((n_feet, n_samples, 6))
    foot_l = [int(f) for f in foot]
    lift_l = [int(k) for k in lift_off]
    # Pose each swing starts from: the foot's previous target, or its initial pose.
    latest = list(initial)
    start_list = []
    for f, tgt in zip(foot_l, targets):
        start_list.append(latest[f])
        latest[f] = tgt
    if m:
        P0 = np.array(start_list)
        A1, A2, w_axis, theta = _geodesic_coefficients(P0[:, :3, :3], targets[:, :3, :3])
        dp = targets[:, :3, 3] - P0[:, :3, 3]
        # Each swing sample is a linear combination of 5 basis functions of s with per-swing (5, 16)
        # coefficients (pose entries, row-major), and of 2 functions with (2, 6) coefficients (velocity): one
        # matmul per swing, written straight into the (samples, 4, 4) output. Swing samples are s = 0, 1/n, ...,
        # (n-1)/n; the touch-down sample (s = 1) starts the next rest interval. At s = 0 every basis function
        # except the constant is exactly 0, so the lift-off pose equals the rest pose bit for bit.
        counts = [int(n_swing)] * m if isinstance(n_swing, (int, np.integer)) else [int(c) for c in n_swing]
        groups: dict[int, list[int]] = {}
        for i, c in enumerate(counts):
            groups.setdefault(c, []).append(i)
        basis_of, vbasis_of = [None] * m, [None] * m
        for c, idx in groups.items():  # swings of the same length share their basis functions
            b, bump, vbasis = _swing_profile(c, float(dt), float(height))
            psi = theta[idx, None] * b[None, :]
            basis = np.empty((len(idx), 5, c))  # rows: 1, sin psi, 1 - cos psi, b, bump
            basis[:, 0] = 1.0
            np.sin(psi, out=basis[:, 1])
            np.cos(psi, out=basis[:, 2])
            np.subtract(1.0, basis[:, 2], out=basis[:, 2])
            basis[:, 3] = b
            basis[:, 4] = bump
            for j, i in enumerate(idx):
                basis_of[i], vbasis_of[i] = basis[j], vbasis
        coef = np.zeros((m, 5, 4, 4))
        coef[:, 0] = P0
        coef[:, 1, :3, :3] = A1
        coef[:, 2, :3, :3] = A2
        coef[:, 3, :3, 3] = dp
        coef[:, 4, 2, 3] = 1.0
        coef = coef.reshape(m, 5, 16)
        vcoef = np.zeros((m, 2, 6))
        vcoef[:, 0, :3] = dp
        vcoef[:, 0, 3:] = w_axis
        vcoef[:, 1, 2] = 1.0

    rest_from = [0] * n_feet  # first sample of each foot's current rest interval
    flat = poses.reshape(n_feet, n_samples, 16)
    for i, (f, lo) in enumerate(zip(foot_l, lift_l)):
        poses[f, rest_from[f]:lo] = start_list[i]
        n_i = counts[i]
        np.matmul(basis_of[i].T, coef[i], out=flat[f, lo:lo + n_i])
        np.matmul(vbasis_of[i].T, vcoef[i], out=vel[f, lo:lo + n_i])
        rest_from[f] = lo + n_i
    for f in range(n_feet):
        poses[f, rest_from[f]:] = latest[f]
    return poses, vel
