"""Floating-base state estimation from joint encoders, a base IMU and ankle force/torque sensors.

Per sample (period Δt), :meth:`FloatingBaseEstimator.update`:

1. **Joint velocities** (:class:`JointStateFilter`): a backward difference low-passed at f_c by default, or a
   fading-memory polynomial filter of degree 2
   (Morrison 1969, "Introduction to Sequential Smoothing and Prediction", McGraw-Hill; the critically damped
   g-h-k filter of Brookner 1998, "Tracking and Kalman Filtering Made Easy", Wiley, Ch. 1) on the encoder angles,
   with a state (q, q̇, q̈) per joint:
   predict q⁻ = q + q̇ Δt + ½ q̈ Δt², q̇⁻ = q̇ + q̈ Δt; with r = qₖ − q⁻: q = q⁻ + g r, q̇ = q̇⁻ + (h/Δt) r,
   q̈ = q̈ + (2k/Δt²) r, where g = 1 − θ³, h = 1.5 (1 − θ)² (1 + θ), k = 0.5 (1 − θ)³ for the memory θ ∈ [0, 1)
   (``velocity_memory``). Its velocity has no steady-state lag while a joint accelerates at a constant rate; a
   backward difference low-passed at f_c (``velocity_memory=None``, the default: v ← v + α ((qₖ − qₖ₋₁)/Δt − v),
   α = Δt / (Δt + 1/(2π f_c))) lags it by (½ Δt + 1/(2π f_c)) q̈. ``wbc sim jump`` uses θ = 0.5 (its take-off and
   landing need the lag-free velocity); the other scenarios the low-pass (the blind swing over rough ground lands
   2-5× farther from its foothold with θ = 0.5).
2. **Orientation**: :class:`~wbc.estimation.attitude.ComplementaryAttitudeFilter` (Mahony et al. 2008, eq. 32) on the
   gyro and on the accelerometer's specific force minus the base acceleration measured by the leg kinematics (the
   leg-odometry velocity of step 3, differenced and low-passed at ``accel_cutoff_hz``; without it the walking
   accelerations, ~1 m/s², tilt the estimated vertical) and, as a second reference direction of eq. 32, the forward
   axis of each sole in contact: its world direction v₀ is stored when the sole is anchored (step 3) and held while
   it stays in contact, its base-frame direction v comes from the leg kinematics, weighted by the sole's share of the
   normal force times ``heading_weight``, corrected with k_P about every axis and, as a heading direction of the
   filter, once more about the vertical with its own gains ``k_heading``, ``k_heading_bias`` (yaw has no other
   reference than the soles, and the gyro's yaw bias is learnt from them) — the sole does not turn while it carries
   load, which makes yaw and the gyro's yaw bias observable (leg odometry of the heading; on flat ground a sole that
   touches down while the other is anchored takes its v₀ from that sole's v₀ through the leg kinematics (on uneven
   ground its heading only, the tilt staying R̂'s), on every
   sample while both are in contact (it still turns as it settles, up to a few tenths of a degree in the first 0.1 s,
   while the other stays loaded and flat until it lifts off), so the heading passes from foot to foot without the yaw
   error of R̂, ``heading_handover``, ``handover_end_share``). A sole that turns on the ground with no still sole to
   hand over from — its world yaw rate, R̂ (ω + the leg kinematics' rate) low-passed at ``turn_cutoff_hz``, above
   ``turn_rate``, e.g. both feet pivoting under a jump's landing impact — is re-anchored from R̂ on every sample
   until it stops turning: its heading then follows the gyro instead of pulling R̂ back to the heading it had at
   touch-down. The base angular velocity is the bias-corrected gyro.
3. **Leg kinematics** (Pinocchio, base at the origin with orientation R̂): for each sole i its position rᵢ relative
   to the base (world axes), its orientation, and the velocity it would have if the base did not translate,
   uᵢ = ω × rᵢ + R̂ Jᵢ(q) q̇ (``getFrameVelocity``, ``LOCAL_WORLD_ALIGNED``). The F/T reading gives the foot's
   ground reaction (:class:`~wbc.estimation.contact.FootForceSensor`) and its normal force; a
   :class:`~wbc.estimation.contact.ContactDetector` (hysteresis) decides contact. A foot that becomes a contact is
   anchored: aᵢ = p̂ + rᵢ (its world position, held while it stays in contact), its height set to the ground's
   when the ground is flat and of known height (``ground_height``).
4. **Base position and velocity** (world), a Kalman filter per axis on x = (p, ṗ) with the IMU acceleration as
   input and the leg odometry as measurement — the estimator of Flayols, Del Prete, Wensing, Mifsud, Benallegue,
   Mansard 2017, "Experimental evaluation of simple estimators for humanoid robots", IEEE-RAS Humanoids (Sec.
   III-C: IMU-driven prediction corrected by the kinematics of the feet in contact; a linear Kalman filter whose
   steady state is a complementary filter):

       prediction   a = R̂ aʸ + g,   p ← p + ṗ Δt + ½ a Δt²,   ṗ ← ṗ + a Δt,   P ← A P Aᵀ + Q
       measurement  z_p = Σᵢ wᵢ (aᵢ − rᵢ),   z_v = −Σᵢ wᵢ uᵢ   (the feet in contact do not move),
                    wᵢ = f_z,ᵢ / Σ f_z (normal-force weights)
       update       K = P (P + R)⁻¹,   x ← x + K (z − x),   P ← (I − K) P

   with A = [[1, Δt], [0, 1]], Q = σ_a² [[Δt⁴/4, Δt³/2], [Δt³/2, Δt²]], R = diag(σ_p², σ_v²), the same 2 × 2
   covariance for the three axes (isotropic noises). Without a foot in contact (a flight phase) only the
   prediction runs.

The estimated configuration is q = (p̂, quaternion of R̂ (x, y, z, w), encoder angles) and
v = (R̂ᵀ ṗ̂ (base frame, Pinocchio's convention), Ωʸ − b̂, filtered joint velocities). Every array is preallocated;
one update costs one ``forwardKinematics`` with velocities and a few 3-vectors.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numba as nb
import numpy as np
import pinocchio as pin

from wbc.compiled import CHECK_TYPES, specialise
from wbc.constants import SIDES
from wbc.estimation.attitude import ComplementaryAttitudeFilter
from wbc.estimation.contact import GRAVITY_VECTOR, ContactDetector, FootForceSensor
from wbc.exceptions import InvalidInputError
from wbc.geometry import check_flag, check_scalar
from wbc.lie import exp3_into

__all__ = ["JointStateFilter", "BaseKalmanFilter", "FloatingBaseEstimator"]

# Indices of the estimator's compiled state (``FloatingBaseEstimator.state``) and parameters (``_prm``).
_ST_ACC, _ST_ZV, _ST_HAVE_ZV, _ST_YAW, _ST_FZ, _ST_CONTACT, _ST_TURNING, _ST_FROM, _ST_ACCEL_USED = (
    0, 3, 6, 7, 9, 11, 13, 15, 17)
_ST_SIZE = 18
_PRM_SIZE = 38
#: [update's compiled call] once loaded in this process (wbc.compiled.specialise for the types of update's arguments,
#: the sensors' inputs and Kalman covariance of any strides; with kernel type checks on, the dispatcher)
_FUSE: list = []
#: the estimator's own arrays that :func:`_fuse_kernel` reads and updates in place (built once)
_FuseState = namedtuple("_FuseState", "st anchor axis arot wrench sole_rot sole_pos prm q v")


@nb.njit(cache=True)
def _fuse_kernel(ft, accel, gyro, legs, filters, state):
    """:meth:`FloatingBaseEstimator.update` after the leg kinematics ``legs`` (module docstring, steps 2-4, in its
    order): updates in place the attitude (``R``, ``bias``, ``omega``) and the Kalman filter (``kf_p``, ``kf_v``,
    ``kf_P``) of ``filters`` and, of ``state`` (:data:`_FuseState`), ``st`` (``_ST_*`` slots), the anchors, the
    wrenches, the soles' world placements and ``q[0:3]``, ``v[0:6]``. ``legs``, ``filters``: plain tuples of the
    names below (built per sample: cheaper than namedtuples)."""
    rot0, pos0, rot1, pos1, vel0, vel1 = legs
    R, gains, bias, omega, kf_p, kf_v, kf_P = filters
    st, anchor, axis, arot, wrench, sole_rot, sole_pos, prm, q, v = state
    dt, beta, alpha_turn, turn_rate, heading_weight = prm[0], prm[1], prm[2], prm[3], prm[4]
    has_ground, ground_height, handover, end_share = prm[5] != 0.0, prm[6], prm[7] != 0.0, prm[8]
    g_z = prm[19]
    Rp = np.empty((3, 3))  # R̂ of the last sample
    Rp[:, :] = R
    u = np.empty((2, 3))
    fz_total = 0.0
    zv0 = zv1 = zv2 = 0.0
    nf = st[_ST_FZ:_ST_FZ + 2]
    for j in range(2):
        rot = rot0 if j == 0 else rot1
        vel = vel0 if j == 0 else vel1
        f = ft[j]
        # the sole's world orientation Rw = R̂_prev rot; the sensor's ground wrench (FootForceSensor.ground_wrench)
        Rw = np.empty((3, 3))
        for a in range(3):
            for b in range(3):
                Rw[a, b] = (Rp[a, 0] * rot[0, b] + Rp[a, 1] * rot[1, b]) + Rp[a, 2] * rot[2, b]
        o = 20 + 7 * j
        mass = prm[o]
        p0, p1, p2 = prm[o + 1], prm[o + 2], prm[o + 3]
        d0, d1, d2 = prm[o + 4] - p0, prm[o + 5] - p1, prm[o + 6] - p2
        m0, m1, m2 = mass * (Rw[2, 0] * g_z), mass * (Rw[2, 1] * g_z), mass * (Rw[2, 2] * g_z)
        f0, f1, f2, t0, t1, t2 = f[0], f[1], f[2], f[3], f[4], f[5]
        w = wrench[j]
        w[0], w[1], w[2] = -f0 - m0, -f1 - m1, -f2 - m2
        w[3] = -t0 + (p1 * f2 - p2 * f1) - (d1 * m2 - d2 * m1)
        w[4] = -t1 + (p2 * f0 - p0 * f2) - (d2 * m0 - d0 * m2)
        w[5] = -t2 + (p0 * f1 - p1 * f0) - (d0 * m1 - d1 * m0)
        fz = (Rw[2, 0] * w[0] + Rw[2, 1] * w[1]) + Rw[2, 2] * w[2]
        nf[j] = fz
        u[j, 0], u[j, 1], u[j, 2] = vel[0], vel[1], vel[2]
        wz = (Rp[2, 0] * vel[3] + Rp[2, 1] * vel[4]) + Rp[2, 2] * vel[5]  # world yaw rate of the sole
        y = st[_ST_YAW + j]
        y += alpha_turn * (wz - y)
        st[_ST_YAW + j] = y
        st[_ST_TURNING + j] = 1.0 if abs(y) > turn_rate else 0.0
        if st[_ST_CONTACT + j] != 0.0 and fz > 0:
            zv0, zv1, zv2 = zv0 - fz * u[j, 0], zv1 - fz * u[j, 1], zv2 - fz * u[j, 2]
            fz_total += fz
    # base acceleration from the leg kinematics, low-passed
    acc = st[_ST_ACC:_ST_ACC + 3]
    if fz_total > 0:
        zv0, zv1, zv2 = zv0 / fz_total, zv1 / fz_total, zv2 / fz_total
        for a in range(3):
            z = (Rp[a, 0] * zv0 + Rp[a, 1] * zv1) + Rp[a, 2] * zv2
            if st[_ST_HAVE_ZV] != 0.0:
                acc[a] = acc[a] + beta * ((z - st[_ST_ZV + a]) / dt - acc[a])
            st[_ST_ZV + a] = z
        st[_ST_HAVE_ZV] = 1.0
    else:
        st[_ST_HAVE_ZV] = 0.0
        for a in range(3):
            acc[a] *= 1.0 - beta
    fg = np.empty(3)  # accel − R̂_prevᵀ acc_kin
    for a in range(3):
        fg[a] = accel[a] - ((Rp[0, a] * acc[0] + Rp[1, a] * acc[1]) + Rp[2, a] * acc[2])
    # attitude filter (ComplementaryAttitudeFilter.update with the soles' forward axes as directions and heading)
    att_dt, k_p, k_i, k_heading, k_hb, accel_gate, bias_gate, bias_max = (
        gains[0], gains[1], gains[2], gains[3], gains[4], gains[5], gains[6], gains[7])
    a0, a1, a2 = fg[0], fg[1], fg[2]
    n = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
    used = n > 0 and abs(n - gains[8]) <= accel_gate
    st[_ST_ACCEL_USED] = 1.0 if used else 0.0
    m0 = m1 = m2 = 0.0
    if used:
        a0, a1, a2 = a0 / n, a1 / n, a2 / n
        u0, u1, u2 = Rp[2, 0], Rp[2, 1], Rp[2, 2]
        m0, m1, m2 = a1 * u2 - a2 * u1, a2 * u0 - a0 * u2, a0 * u1 - a1 * u0
    h0 = h1 = h2 = 0.0
    if heading_weight > 0 and fz_total > 0:
        for j in range(2):
            fz = nf[j]
            if st[_ST_CONTACT + j] != 0.0 and fz > 0:
                k = heading_weight * fz / fz_total
                rot = rot0 if j == 0 else rot1
                x0, x1, x2 = rot[0, 0], rot[1, 0], rot[2, 0]  # the sole's forward axis, base frame
                v0 = axis[j]
                e0 = (Rp[0, 0] * v0[0] + Rp[1, 0] * v0[1]) + Rp[2, 0] * v0[2]  # R̂ᵀ v₀
                e1 = (Rp[0, 1] * v0[0] + Rp[1, 1] * v0[1]) + Rp[2, 1] * v0[2]
                e2 = (Rp[0, 2] * v0[0] + Rp[1, 2] * v0[1]) + Rp[2, 2] * v0[2]
                c0, c1, c2 = x1 * e2 - x2 * e1, x2 * e0 - x0 * e2, x0 * e1 - x1 * e0
                m0, m1, m2 = m0 + k * c0, m1 + k * c1, m2 + k * c2
                h0, h1, h2 = h0 + k * c0, h1 + k * c1, h2 + k * c2
    up0, up1, up2 = Rp[2, 0], Rp[2, 1], Rp[2, 2]
    hu = (h0 * up0 + h1 * up1) + h2 * up2
    h0, h1, h2 = hu * up0, hu * up1, hu * up2
    for a in range(3):
        omega[a] = gyro[a] - bias[a]
    w0 = ((m0 * k_p + omega[0]) + k_heading * h0) * att_dt
    w1 = ((m1 * k_p + omega[1]) + k_heading * h1) * att_dt
    w2 = ((m2 * k_p + omega[2]) + k_heading * h2) * att_dt
    E = np.empty((3, 3))
    exp3_into(w0, w1, w2, E)
    for a in range(3):
        for b in range(3):
            R[a, b] = (Rp[a, 0] * E[0, b] + Rp[a, 1] * E[1, b]) + Rp[a, 2] * E[2, b]
    gate = bias_gate * bias_gate
    if k_i != 0.0 and used and (m0 * m0 + m1 * m1) + m2 * m2 <= gate:
        c = k_i * att_dt
        bias[0], bias[1], bias[2] = bias[0] - c * m0, bias[1] - c * m1, bias[2] - c * m2
    if k_hb != 0.0 and (h0 * h0 + h1 * h1) + h2 * h2 <= gate:
        c = k_hb * att_dt
        bias[0], bias[1], bias[2] = bias[0] - c * h0, bias[1] - c * h1, bias[2] - c * h2
    for a in range(3):
        bias[a] = min(max(bias[a], -bias_max), bias_max)
    # Kalman prediction with the IMU acceleration
    h, half_h2 = prm[9], prm[10]
    for a in range(3):
        acc_w = ((R[a, 0] * accel[0] + R[a, 1] * accel[1]) + R[a, 2] * accel[2]) + (g_z if a == 2 else 0.0)
        kf_p[a] += kf_v[a] * h + half_h2 * acc_w
        kf_v[a] += acc_w * h
    P00, P01, P10, P11 = kf_P[0, 0], kf_P[0, 1], kf_P[1, 0], kf_P[1, 1]
    A00, A01, A10, A11 = P00 + h * P10, P01 + h * P11, P10, P11  # A P
    kf_P[0, 0] = (A00 + A01 * h) + prm[11]
    kf_P[0, 1] = A01 + prm[12]
    kf_P[1, 0] = (A10 + A11 * h) + prm[13]
    kf_P[1, 1] = A11 + prm[14]
    # contacts and leg odometry
    r_world = np.empty((2, 3))
    newly0 = newly1 = False
    zp0 = zp1 = zp2 = zw0 = zw1 = zw2 = 0.0
    total = 0.0
    for j in range(2):
        fz = nf[j]
        was = st[_ST_CONTACT + j] != 0.0
        if was:
            now = fz >= prm[35 + 2 * j]
        else:
            now = fz > prm[34 + 2 * j]
        st[_ST_CONTACT + j] = 1.0 if now else 0.0
        pos = pos0 if j == 0 else pos1
        for a in range(3):
            r_world[j, a] = (R[a, 0] * pos[0] + R[a, 1] * pos[1]) + R[a, 2] * pos[2]
        if now and not was:
            if j == 0:
                newly0 = True
            else:
                newly1 = True
        if now and was:
            wgt = max(fz, 0.0)
            zp0 += wgt * (anchor[j, 0] - r_world[j, 0])
            zp1 += wgt * (anchor[j, 1] - r_world[j, 1])
            zp2 += wgt * (anchor[j, 2] - r_world[j, 2])
            uw0 = (R[0, 0] * u[j, 0] + R[0, 1] * u[j, 1]) + R[0, 2] * u[j, 2]
            uw1 = (R[1, 0] * u[j, 0] + R[1, 1] * u[j, 1]) + R[1, 2] * u[j, 2]
            uw2 = (R[2, 0] * u[j, 0] + R[2, 1] * u[j, 1]) + R[2, 2] * u[j, 2]
            zw0 -= wgt * uw0
            zw1 -= wgt * uw1
            zw2 -= wgt * uw2
            total += wgt
    if total > 0:
        zp = (zp0 / total, zp1 / total, zp2 / total)
        zw = (zw0 / total, zw1 / total, zw2 / total)
        s00, s01, s10, s11 = kf_P[0, 0] + prm[15], kf_P[0, 1], kf_P[1, 0], kf_P[1, 1] + prm[16]
        det = s00 * s11 - s01 * s10
        i00, i01, i10, i11 = s11 / det, -s01 / det, -s10 / det, s00 / det
        P00, P01, P10, P11 = kf_P[0, 0], kf_P[0, 1], kf_P[1, 0], kf_P[1, 1]
        k00, k01 = P00 * i00 + P01 * i10, P00 * i01 + P01 * i11  # K = P S⁻¹
        k10, k11 = P10 * i00 + P11 * i10, P10 * i01 + P11 * i11
        for a in range(3):
            ep = zp[a] - kf_p[a]
            ev = zw[a] - kf_v[a]
            kf_p[a] += k00 * ep + k01 * ev
            kf_v[a] += k10 * ep + k11 * ev
        kf_P[0, 0] = (1.0 - k00) * P00 + (-k01) * P10  # (I − K) P
        kf_P[0, 1] = (1.0 - k00) * P01 + (-k01) * P11
        kf_P[1, 0] = (-k10) * P00 + (1.0 - k11) * P10
        kf_P[1, 1] = (-k10) * P01 + (1.0 - k11) * P11
    # new contacts: anchored at p̂ + r, forward axis from R̂ (or handed over, below)
    for j in range(2):
        if not (newly0 if j == 0 else newly1):
            continue
        rot = rot0 if j == 0 else rot1
        for a in range(3):
            anchor[j, a] = kf_p[a] + r_world[j, a]
        st[_ST_FROM + j] = -1.0
        for a in range(3):
            axis[j, a] = (R[a, 0] * rot[0, 0] + R[a, 1] * rot[1, 0]) + R[a, 2] * rot[2, 0]
        if has_ground:
            anchor[j, 2] = ground_height
            axis[j, 2] = 0.0
        else:
            for a in range(3):
                for b in range(3):
                    arot[j, a, b] = (R[a, 0] * rot[0, b] + R[a, 1] * rot[1, b]) + R[a, 2] * rot[2, b]
        if handover and st[_ST_CONTACT + 1 - j] != 0.0 and st[_ST_FROM + 1 - j] < 0.0:
            st[_ST_FROM + j] = 1.0 - j
        nrm = math.sqrt((axis[j, 0] * axis[j, 0] + axis[j, 1] * axis[j, 1]) + axis[j, 2] * axis[j, 2])
        axis[j, 0], axis[j, 1], axis[j, 2] = axis[j, 0] / nrm, axis[j, 1] / nrm, axis[j, 2] / nrm
    # a sole turning on the ground with no hand-over: re-anchored from R̂
    for j in range(2):
        if st[_ST_CONTACT + j] != 0.0 and st[_ST_TURNING + j] != 0.0 and st[_ST_FROM + j] < 0.0:
            rot = rot0 if j == 0 else rot1
            for a in range(3):
                axis[j, a] = (R[a, 0] * rot[0, 0] + R[a, 1] * rot[1, 0]) + R[a, 2] * rot[2, 0]
            if has_ground:
                axis[j, 2] = 0.0
            else:
                for a in range(3):
                    for b in range(3):
                        arot[j, a, b] = (R[a, 0] * rot[0, b] + R[a, 1] * rot[1, b]) + R[a, 2] * rot[2, b]
            nrm = math.sqrt((axis[j, 0] * axis[j, 0] + axis[j, 1] * axis[j, 1]) + axis[j, 2] * axis[j, 2])
            axis[j, 0], axis[j, 1], axis[j, 2] = axis[j, 0] / nrm, axis[j, 1] / nrm, axis[j, 2] / nrm
    # heading handed over from the other anchored sole through the leg kinematics
    for j in range(2):
        if st[_ST_FROM + j] < 0.0:
            continue
        o = 1 - j
        if not (st[_ST_CONTACT + j] != 0.0 and st[_ST_CONTACT + o] != 0.0):
            st[_ST_FROM + j] = -1.0
            continue
        Xs = rot0 if j == 0 else rot1
        Xo = rot1 if j == 0 else rot0
        r0 = (Xo[0, 0] * Xs[0, 0] + Xo[1, 0] * Xs[1, 0]) + Xo[2, 0] * Xs[2, 0]  # Xoᵀ (Xs e_x)
        r1 = (Xo[0, 1] * Xs[0, 0] + Xo[1, 1] * Xs[1, 0]) + Xo[2, 1] * Xs[2, 0]
        r2 = (Xo[0, 2] * Xs[0, 0] + Xo[1, 2] * Xs[1, 0]) + Xo[2, 2] * Xs[2, 0]
        if has_ground:
            ca, sa = axis[o, 0], axis[o, 1]
            axis[j, 0], axis[j, 1], axis[j, 2] = ca * r0 - sa * r1, sa * r0 + ca * r1, 0.0
        else:
            ch0 = (arot[o, 0, 0] * r0 + arot[o, 0, 1] * r1) + arot[o, 0, 2] * r2
            ch1 = (arot[o, 1, 0] * r0 + arot[o, 1, 1] * r1) + arot[o, 1, 2] * r2
            for a in range(3):
                for b in range(3):
                    arot[j, a, b] = (R[a, 0] * Xs[0, b] + R[a, 1] * Xs[1, b]) + R[a, 2] * Xs[2, b]
            turn = math.atan2(ch1, ch0) - math.atan2(arot[j, 1, 0], arot[j, 0, 0])
            c, sn = math.cos(turn), math.sin(turn)
            for b in range(3):
                x, y = arot[j, 0, b], arot[j, 1, b]
                arot[j, 0, b], arot[j, 1, b] = c * x - sn * y, sn * x + c * y
            axis[j, 0], axis[j, 1], axis[j, 2] = arot[j, 0, 0], arot[j, 1, 0], arot[j, 2, 0]
        nrm = math.sqrt((axis[j, 0] * axis[j, 0] + axis[j, 1] * axis[j, 1]) + axis[j, 2] * axis[j, 2])
        axis[j, 0], axis[j, 1], axis[j, 2] = axis[j, 0] / nrm, axis[j, 1] / nrm, axis[j, 2] / nrm
        fs, fo = max(nf[j], 0.0), max(nf[o], 0.0)
        if fo <= end_share * (fs + fo):
            st[_ST_FROM + j] = -1.0
    # the soles' world placements and the outputs
    for j in range(2):
        rot = rot0 if j == 0 else rot1
        for a in range(3):
            for b in range(3):
                sole_rot[j, a, b] = (R[a, 0] * rot[0, b] + R[a, 1] * rot[1, b]) + R[a, 2] * rot[2, b]
            sole_pos[j, a] = r_world[j, a] + kf_p[a]
    for a in range(3):
        q[a] = kf_p[a]
        v[a] = (R[0, a] * kf_v[0] + R[1, a] * kf_v[1]) + R[2, a] * kf_v[2]
        v[3 + a] = omega[a]



@nb.njit(cache=True)
def _lowpass_kernel(angles, prev, velocity, alpha, dt):
    """:class:`JointStateFilter`'s low-pass step, element by element: v ← v + α ((angles − prev)/Δt − v), then
    prev ← angles (all (n,))."""
    for i in range(angles.size):
        raw = (angles[i] - prev[i]) / dt
        velocity[i] += alpha * (raw - velocity[i])
        prev[i] = angles[i]


def _nonneg(value, what: str, positive: bool = False) -> float:
    """``value`` as a float, finite and ≥ 0 (> 0 with ``positive``) (:func:`wbc.geometry.check_scalar`)."""
    return check_scalar(value, what, "SI units, see the docstring", strict=positive)


class JointStateFilter:
    """Joint velocities from encoder angles (module docstring, step 1): a degree-2 fading-memory (g-h-k) filter
    of memory ``memory``, or with ``memory=None`` a backward difference then a first-order low-pass of corner
    ``cutoff_hz``.

    Args:
        n: number of joints. dt: sample period (s). cutoff_hz: corner frequency f_c (Hz, > 0) of the low-pass
            (used with ``memory=None``). memory: θ in [0, 1) of the g-h-k filter (None: the low-pass).

    Attributes:
        velocity: (n,) filtered velocity (rad/s).

    Raises:
        InvalidInputError: bad numbers.
    """

    def __init__(self, n: int, dt: float, cutoff_hz: float = 80.0, memory: float | None = None):
        self.dt = _nonneg(dt, "dt", positive=True)
        self.cutoff_hz = _nonneg(cutoff_hz, "cutoff_hz", positive=True)
        self.alpha = self.dt / (self.dt + 1.0 / (2.0 * math.pi * self.cutoff_hz))
        if memory is not None:
            memory = _nonneg(memory, "memory")
            if memory >= 1.0:
                raise InvalidInputError(f"memory must be in [0, 1), got {memory!r}")
        self.memory = memory
        th = 0.0 if memory is None else memory
        self._g, self._h, self._k = 1.0 - th**3, 1.5 * (1.0 - th) ** 2 * (1.0 + th), 0.5 * (1.0 - th) ** 3
        self.velocity = np.zeros(int(n))
        self._prev = np.zeros(int(n))  # low-pass: last angles; g-h-k: filtered angles
        self._raw = np.zeros(int(n))
        self._acc = np.zeros(int(n))
        self._started = False

    def reset(self, angles=None, velocity=None) -> None:
        """Start from ``angles`` (n,) rad (default: the next sample) and ``velocity`` (n,) rad/s (default 0), at
        zero acceleration."""
        self.velocity[:] = 0.0 if velocity is None else velocity
        self._acc[:] = 0.0
        self._started = angles is not None
        if angles is not None:
            self._prev[:] = angles

    def update(self, angles: np.ndarray) -> np.ndarray:
        """One sample of encoder angles (n,) rad → filtered velocities (n,) rad/s (the :attr:`velocity` array)."""
        if not self._started:
            self._prev[:] = angles
            self._started = True
            return self.velocity
        dt = self.dt
        if self.memory is None:
            _lowpass_kernel(angles, self._prev, self.velocity, self.alpha, dt)
            return self.velocity
        x, v, a, r = self._prev, self.velocity, self._acc, self._raw
        x += v * dt + (0.5 * dt * dt) * a  # prediction
        v += a * dt
        np.subtract(angles, x, out=r)  # residual
        x += self._g * r
        v += (self._h / dt) * r
        a += (2.0 * self._k / (dt * dt)) * r
        return self.velocity


class BaseKalmanFilter:
    """Linear Kalman filter of the base position p and velocity ṗ (world, m and m/s), one (p, ṗ) pair per axis,
    driven by the IMU acceleration and corrected by the leg odometry (module docstring, step 4).

    Args:
        dt: period (s). sigma_acc: input noise σ_a (m/s²). sigma_pos: σ_p (m). sigma_vel: σ_v (m/s).

    Attributes:
        p: (3,) position. velocity: (3,) ṗ. P: (2, 2) covariance of (p, ṗ) of each axis. Q: (2, 2) process noise
            covariance (σ_a² [[Δt⁴/4, Δt³/2], [Δt³/2, Δt²]]). R: (2, 2) measurement noise covariance diag(σ_p², σ_v²).

    Raises:
        InvalidInputError: bad numbers.
    """

    def __init__(self, dt: float, sigma_acc: float = 0.5, sigma_pos: float = 0.002, sigma_vel: float = 0.02):
        h = _nonneg(dt, "dt", positive=True)
        for val, what in ((sigma_acc, "sigma_acc"), (sigma_pos, "sigma_pos"), (sigma_vel, "sigma_vel")):
            _nonneg(val, what, positive=True)
        self.dt = h
        self.Q = sigma_acc**2 * np.array([[h**4 / 4, h**3 / 2], [h**3 / 2, h**2]])
        self.R = np.diag([sigma_pos**2, sigma_vel**2])
        self._A = np.array([[1.0, h], [0.0, 1.0]])
        self._I = np.eye(2)
        self._Sinv = np.zeros((2, 2))
        self._half_h2 = 0.5 * h * h
        self.p, self.velocity = np.zeros(3), np.zeros(3)
        self.P = np.diag([1e-6, 1e-4])

    def reset(self, p, velocity, P=None) -> None:
        """Start at p (3,) m, ṗ (3,) m/s with covariance P (2, 2) (default diag(1e-6 m², 1e-4 m²/s²))."""
        self.p[:] = p
        self.velocity[:] = velocity
        self.P = np.diag([1e-6, 1e-4]) if P is None else np.array(P, dtype=float)

    def predict(self, a: np.ndarray) -> None:
        """Propagate over dt with the world acceleration a (3,) m/s²."""
        h = self.dt
        self.p += self.velocity * h + self._half_h2 * a
        self.velocity += a * h
        A = self._A
        self.P = A @ self.P @ A.T + self.Q

    def correct(self, z_p: np.ndarray, z_v: np.ndarray) -> None:
        """Update with a measured position z_p (3,) m and velocity z_v (3,) m/s."""
        (s00, s01), (s10, s11) = (self.P + self.R).tolist()
        det = s00 * s11 - s01 * s10
        Si = self._Sinv
        Si[:] = ((s11 / det, -s01 / det), (-s10 / det, s00 / det))
        K = self.P @ Si  # P S⁻¹ (2 × 2)
        (k00, k01), (k10, k11) = K.tolist()
        ep = z_p - self.p
        ev = z_v - self.velocity
        self.p += k00 * ep + k01 * ev
        self.velocity += k10 * ep + k11 * ev
        self.P = (self._I - K) @ self.P


def _sole_chains(model: pin.Model, frame_ids: tuple[int, int]) -> tuple | None:
    """The model of the joints that carry the two sole frames (``pin.buildReducedModel``, every other joint locked
    at its neutral position: the soles' placements and velocities in the base frame are those of the whole model,
    the same arithmetic over fewer joints) with its Data, the soles' frame ids in it, the slice of the encoder vector
    (v[6:] order) its joints take, and its (q, v) buffers with their base angular velocity and joint views. None
    when those joints are not one contiguous block of the encoder vector in the same order, or are all the joints."""
    keep = set()
    for f in frame_ids:
        j = model.frames[f].parentJoint
        while j > 1:
            keep.add(j)
            j = model.parents[j]
    kept = sorted(keep)
    cols = [model.joints[j].idx_v - 6 for j in kept]
    if not kept or len(kept) == model.njoints - 2 or cols != list(range(cols[0], cols[0] + len(cols))):
        return None
    chains = pin.buildReducedModel(model, [j for j in range(2, model.njoints) if j not in keep], pin.neutral(model))
    if [chains.names[j] for j in range(2, chains.njoints)] != [model.names[j] for j in kept]:
        return None
    frames = tuple(chains.getFrameId(model.frames[f].name, model.frames[f].type) for f in frame_ids)
    q, v = pin.neutral(chains), np.zeros(chains.nv)
    return chains, chains.createData(), frames, slice(cols[0], cols[0] + len(cols)), q, v, v[3:6], q[7:], v[6:]


class FloatingBaseEstimator:
    """Base pose and velocity of a humanoid from its encoders, IMU and ankle F/T sensors (module docstring).

    Args:
        robot: the :class:`~wbc.robot.Robot` (Pinocchio model, sole frames).
        dt: sample period (s).
        velocity_memory: memory θ in [0, 1) of the joint-velocity g-h-k filter (module docstring, step 1; None:
            the low-pass of corner ``velocity_cutoff_hz``, the default).
        velocity_cutoff_hz: joint-velocity low-pass corner (Hz), used with ``velocity_memory=None``.
        k_p, k_i, accel_gate: attitude filter gains (:class:`~wbc.estimation.attitude.ComplementaryAttitudeFilter`).
        contact_on, contact_off: contact hysteresis thresholds as fractions of the robot's weight
            (0 ≤ off < on).
        sigma_acc: IMU acceleration input noise σ_a (m/s², includes the tilt error of R̂ g).
        sigma_pos: leg-odometry position noise σ_p (m). sigma_vel: leg-odometry velocity noise σ_v (m/s).
        accel_cutoff_hz: corner (Hz) of the low-pass on the differenced leg-odometry velocity, the base
            acceleration removed from the accelerometer before the tilt correction.
        heading_weight: weight k of the anchored soles' forward axes in the attitude filter, as reference
            directions and as heading (yaw-only) directions there (≥ 0; 0: gravity alone, yaw then follows the gyro).
        k_heading, k_heading_bias: the attitude filter's yaw gains for those axes (rad/s and 1/s², ≥ 0;
            :class:`~wbc.estimation.attitude.ComplementaryAttitudeFilter`).
        heading_handover: a sole touching down while the other is anchored takes its heading (v₀) from that
            sole's through the leg kinematics while both are in contact (True), or from R̂ when it touches down
            (False: R̂'s yaw error, the integral of the gyro's yaw bias, is then locked into each new anchor). On
            flat ground (``ground_height`` not None) the soles' forward axes are horizontal and the hand-over
            turns the other sole's axis about the vertical. On uneven ground (None) the new sole's orientation is
            R̂'s (world ← sole: its tilt) turned about the vertical to the heading that the other sole's anchored
            orientation gives it through the two soles' relative orientation from the leg kinematics: the heading
            passes from sole to sole, the tilt does not (a sole rocking on a bump would pass its tilt on).
            ``wbc sim walk --blind`` turns it off (blind over rough ground the soles land on unknown bumps; the
            blind walks in benchmarks/README.md).
        handover_end_share: the hand-over also ends once the sole it comes from carries at most this share of the
            two soles' normal force (in [0, 1); default 0: it runs until that sole's contact ends. A sole that
            lands fast takes the larger share in its first sample, and ending there locked the yaw it still turned
            while settling, about 0.1° per step on Talos, into every later anchor).
        turn_rate: world yaw rate (rad/s, > 0) above which a sole in contact counts as turning on the ground and
            takes its heading from R̂ (module docstring, step 2).
        turn_cutoff_hz: corner (Hz, > 0) of the low-pass on that yaw rate (encoder differencing noise).
        ground_height: height (m, world) of flat ground: a sole becoming a contact is anchored at that height
            (its x, y come from the odometry). None: the anchor's height is odometry too (uneven ground) — it then
            drifts by the contact's compression under load at every step (≈ 1 mm per step on MuJoCo's soft
            contacts, Talos), as x and y do by the feet's rolling.

    Attributes (after :meth:`update`):
        q: (nq,) estimated configuration. v: (nv,) estimated velocity (Pinocchio conventions).
        contact: {side: bool}. turning: {side: bool}, the sole turns on the ground (``turn_rate``).
        sole_yaw_rate: (2,) low-passed world yaw rate of the (left, right) sole (rad/s).
        wrench: (2, 6) ground reaction per foot (sole frame, sole axes).
        sole: {side: pin.SE3} world placements, set when read from sole_rotation (2, 3, 3) and sole_position (2, 3).
        velocity_world: (3,) ṗ̂ (m/s, world).

    Raises:
        InvalidInputError: bad numbers (here and on :meth:`reset`).
    """

    def __init__(self, robot, dt: float, *, velocity_memory: float | None = None,
                 velocity_cutoff_hz: float = 80.0, k_p: float = 0.2, k_i: float = 0.01,
                 accel_gate: float = 2.0, contact_on: float = 0.2, contact_off: float = 0.08,
                 sigma_acc: float = 0.5, sigma_pos: float = 0.002, sigma_vel: float = 0.02,
                 accel_cutoff_hz: float = 10.0, ground_height: float | None = 0.0, heading_weight: float = 1.0,
                 heading_handover: bool = True, k_heading: float = 0.5, k_heading_bias: float = 0.1,
                 handover_end_share: float = 0.0, turn_rate: float = 0.05, turn_cutoff_hz: float = 10.0):
        self.robot = robot
        model = robot.model
        self.model, self.data = model, model.createData()
        self.dt = _nonneg(dt, "dt", positive=True)
        nj = model.nv - 6
        self.joints = JointStateFilter(nj, self.dt, velocity_cutoff_hz, velocity_memory)
        self.attitude = ComplementaryAttitudeFilter(self.dt, k_p=k_p, k_i=k_i, accel_gate=accel_gate,
                                                    k_heading=k_heading, k_heading_bias=k_heading_bias)
        weight = robot.mass * robot.gravity
        self.detectors = {s: ContactDetector(contact_on * weight, contact_off * weight) for s in SIDES}
        self.ft = {s: FootForceSensor(robot, getattr(robot, f"{s}_sole")) for s in SIDES}
        if ground_height is not None:
            ground_height = _nonneg(abs(ground_height), "ground_height") * np.sign(ground_height)
        self.ground_height = ground_height
        self.kf = BaseKalmanFilter(self.dt, sigma_acc, sigma_pos, sigma_vel)
        # joint angle → q maps (1-DoF joints; continuous joints as (cos, sin))
        one, cs_q, cs_j = [], [], []
        for i in range(2, model.njoints):
            jm = model.joints[i]
            if jm.nv != 1:
                raise InvalidInputError(f"joint {model.names[i]!r} has {jm.nv} DoF; the estimator needs 1-DoF joints")
            (one if jm.nq == 1 else cs_q).append(jm.idx_q)
            if jm.nq == 2:
                cs_j.append(jm.idx_v - 6)
        self._q_one = np.array(one, dtype=int)
        self._j_one = np.array([model.joints[i].idx_v - 6 for i in range(2, model.njoints)
                                if model.joints[i].nq == 1], dtype=int)
        self._q_cs, self._j_cs = np.array(cs_q, dtype=int), np.array(cs_j, dtype=int)
        self.q = pin.neutral(model)
        self.v = np.zeros(model.nv)
        self._qk = pin.neutral(model)  # kinematic configuration: base at the origin, identity orientation
        self._vk = np.zeros(model.nv)
        self.p = self.kf.p
        self.velocity_world = self.kf.velocity
        # the compiled update's state (``_ST_*`` slots) and the anchors, of which the dicts below hold views
        self._st = np.zeros(_ST_SIZE)
        self._st[_ST_FROM:_ST_FROM + 2] = -1.0  # no hand-over
        self._anchor, self._axis = np.zeros((2, 3)), np.tile([1.0, 0.0, 0.0], (2, 1))
        self._arot = np.tile(np.eye(3), (2, 1, 1))
        self.anchor = {s: self._anchor[j] for j, s in enumerate(SIDES)}
        self.anchor_axis = {s: self._axis[j] for j, s in enumerate(SIDES)}
        self._anchor_rotation = {s: self._arot[j] for j, s in enumerate(SIDES)}  # uneven ground: world ← sole
        self.heading_weight = _nonneg(heading_weight, "heading_weight")
        self.heading_handover = check_flag(heading_handover, "heading_handover")
        self.handover_end_share = _nonneg(handover_end_share, "handover_end_share")
        if self.handover_end_share >= 1.0:
            raise InvalidInputError(f"handover_end_share must be in [0, 1), got {handover_end_share!r}")
        self.turn_rate = _nonneg(turn_rate, "turn_rate", positive=True)
        self._alpha_turn = self.dt / (self.dt + 1.0 / (2.0 * math.pi * _nonneg(turn_cutoff_hz, "turn_cutoff_hz", True)))
        # low-passed world yaw rate of each sole (rad/s), gyro + leg kinematics
        self.sole_yaw_rate = self._st[_ST_YAW:_ST_YAW + 2]
        self.turning = {s: False for s in SIDES}
        self.contact = {s: False for s in SIDES}
        self.normal_force = {s: 0.0 for s in SIDES}
        self.wrench = np.zeros((2, 6))
        self._sole = {s: pin.SE3.Identity() for s in SIDES}
        self._X = pin.SE3.Identity()  # the estimated base rotation, for its quaternion (update)
        self.acc_kin = self._st[_ST_ACC:_ST_ACC + 3]
        self._beta = self.dt / (self.dt + 1.0 / (2.0 * math.pi * _nonneg(accel_cutoff_hz, "accel_cutoff_hz", True)))
        # per-sample work arrays (update)
        self._has_cs = len(self._q_cs) > 0
        # encoder angles → q[7:] as one slice when every joint has nq = 1 in v order (Talos, G1)
        self._q_slice = not self._has_cs and np.array_equal(self._q_one, np.arange(7, model.nq)) \
            and np.array_equal(self._j_one, np.arange(nj))
        self._vk_base, self._vk_joints = self._vk[3:6], self._vk[6:]
        self._frame_ids = tuple(self.ft[s].frame_id for s in SIDES)
        self._chains = _sole_chains(model, self._frame_ids) if self._q_slice else None
        self._soles_placed = None  # [(data.oMf[sole], its rotation and translation views)] (update)
        self.sole_rotation, self.sole_position = np.tile(np.eye(3), (2, 1, 1)), np.zeros((2, 3))
        self._prm = np.zeros(_PRM_SIZE)
        self._state = _FuseState(self._st, self._anchor, self._axis, self._arot, self.wrench, self.sole_rotation,
                                 self.sole_position, self._prm, self.q, self.v)
        self._pack()
        self._warm_up()

    _PACKED = ("dt", "_beta", "_alpha_turn", "turn_rate", "heading_weight", "ground_height", "heading_handover",
               "handover_end_share")  #: attributes copied into the compiled update's parameters

    def __setattr__(self, name, value):
        object.__setattr__(self, name, value)
        if name in self._PACKED and "_prm" in self.__dict__:
            self._pack()

    def _pack(self) -> None:
        """Copy the estimator's numbers into :func:`_fuse_kernel`'s ``prm`` (layout in its code)."""
        prm, kf = self._prm, self.kf
        gh = self.ground_height
        prm[0:11] = (self.dt, self._beta, self._alpha_turn, self.turn_rate, self.heading_weight,
                     0.0 if gh is None else 1.0, 0.0 if gh is None else gh, float(self.heading_handover),
                     self.handover_end_share, kf.dt, 0.5 * kf.dt * kf.dt)
        prm[11:15] = kf.Q.ravel()
        prm[15], prm[16] = kf.R[0, 0], kf.R[1, 1]
        prm[19] = GRAVITY_VECTOR[2]
        for j, s in enumerate(SIDES):
            sensor, det = self.ft[s], self.detectors[s]
            prm[20 + 7 * j] = sensor.mass
            prm[21 + 7 * j:24 + 7 * j] = sensor.sole_in_sensor
            prm[24 + 7 * j:27 + 7 * j] = sensor.com_in_sensor
            prm[34 + 2 * j], prm[35 + 2 * j] = det.on, det.off

    @property
    def sole(self) -> dict:
        """{side: pin.SE3} the soles' world placements (class docstring; the same SE3 objects at every read)."""
        for j, side in enumerate(SIDES):
            self._sole[side].rotation, self._sole[side].translation = self.sole_rotation[j], self.sole_position[j]
        return self._sole

    def _warm_up(self) -> None:
        """Load :func:`_fuse_kernel` (on-disk cache) for the argument types of :meth:`update`, on copies."""
        if _FUSE:
            return
        model, data = self.model, self.model.createData()
        pin.forwardKinematics(model, data, self._qk, self._vk)
        X = [pin.updateFramePlacement(model, data, f) for f in self._frame_ids]
        vel = [pin.getFrameVelocity(model, data, f, pin.LOCAL_WORLD_ALIGNED).vector for f in self._frame_ids]
        legs = (X[0].rotation, X[0].translation, X[1].rotation, X[1].translation, vel[0], vel[1])
        state = _FuseState(*(a.copy() for a in self._state))
        for k in (1, 2):  # contiguous sensor inputs and covariance, then strided ones
            ft, accel, gyro = np.zeros((2, 6 * k))[:, ::k], np.zeros(3 * k)[::k], np.zeros(3 * k)[::k]
            filters = (np.eye(3), self.attitude.gains.copy(), *np.zeros((4, 3)), np.eye(2, 2 * k)[:, ::k])
            _fuse_kernel(ft, accel, gyro, legs, filters, state)
        _lowpass_kernel(np.zeros(1), np.zeros(1), np.zeros(1), 0.5, 1.0)
        _FUSE.append(_fuse_kernel if CHECK_TYPES else specialise(_fuse_kernel, ft, accel, gyro, legs, filters, state))

    def reset(self, q0, v0=None) -> None:
        """Start at configuration ``q0`` (nq,) (it defines the world frame of the odometry: its base position and
        orientation are taken as known) and velocity ``v0`` (nv,) (default at rest); contacts start open and are
        detected from the first F/T sample.

        Raises:
            InvalidInputError: wrong shapes or non-finite values.
        """
        model = self.model
        q0 = np.asarray(q0, dtype=float)
        if q0.shape != (model.nq,) or not np.all(np.isfinite(q0)):
            raise InvalidInputError(f"q0 must be a finite ({model.nq},) configuration, got shape {q0.shape}")
        v0 = np.zeros(model.nv) if v0 is None else np.asarray(v0, dtype=float)
        if v0.shape != (model.nv,) or not np.all(np.isfinite(v0)):
            raise InvalidInputError(f"v0 must be a finite ({model.nv},) velocity, got shape {v0.shape}")
        quat = q0[3:7] / np.linalg.norm(q0[3:7])
        R = pin.Quaternion(quat[3], quat[0], quat[1], quat[2]).toRotationMatrix()
        self.attitude.reset(R)
        self.kf.reset(q0[0:3], R @ v0[0:3])
        self.q[:] = q0
        self.v[:] = v0
        angles = np.empty(model.nv - 6)
        angles[self._j_one] = q0[self._q_one]
        if len(self._q_cs):
            angles[self._j_cs] = np.arctan2(q0[self._q_cs + 1], q0[self._q_cs])
        self.joints.reset(angles, v0[6:])
        st = self._st
        st[_ST_HAVE_ZV] = 0.0
        self.acc_kin[:] = 0.0
        for j, s in enumerate(SIDES):
            self.detectors[s].active = False
            st[_ST_FROM + j] = -1.0
            st[_ST_CONTACT + j] = st[_ST_TURNING + j] = 0.0
            self.contact[s] = False
            self.turning[s] = False
        self.sole_yaw_rate[:] = 0.0

    def update(self, joint_q: np.ndarray, gyro: np.ndarray, accel: np.ndarray, ft: np.ndarray):
        """One sample of the sensors → ``(q, v)`` (the :attr:`q`, :attr:`v` arrays, overwritten next call).

        Args:
            joint_q: (nv − 6,) encoder angles (rad), Pinocchio's ``v[6:]`` order.
            gyro: (3,) rad/s and accel: (3,) m/s² (specific force), base axes.
            ft: (2, 6) (left, right) ankle F/T readings (:mod:`wbc.estimation.contact` convention).
        """
        model, data = self.model, self.data
        vj = self.joints.update(joint_q)
        att, kf, st = self.attitude, self.kf, self._st
        # Leg kinematics in the base frame (base at the origin, identity orientation, angular velocity ω of the
        # last sample, no base translation); world axes are R̂ times these.
        qk = self._qk
        if self._q_slice:
            qk[7:] = joint_q
        else:
            qk[self._q_one] = joint_q[self._j_one]
            if self._has_cs:
                qk[self._q_cs] = np.cos(joint_q[self._j_cs])
                qk[self._q_cs + 1] = np.sin(joint_q[self._j_cs])
        chains = self._chains
        if chains is None:
            np.subtract(gyro, att.bias, out=self._vk_base)
            self._vk_joints[:] = vj
            pin.forwardKinematics(model, data, qk, self._vk)
            fl, fr = self._frame_ids
        else:  # the same pass on the soles' chains alone (the other joints do not move the soles)
            model, data, (fl, fr), cols, qc, vc, vc_base, qc_joints, vc_joints = chains
            qc_joints[:] = joint_q[cols]
            np.subtract(gyro, att.bias, out=vc_base)
            vc_joints[:] = vj[cols]
            pin.forwardKinematics(model, data, qc, vc)
        pin.updateFramePlacement(model, data, fl)
        pin.updateFramePlacement(model, data, fr)
        if self._soles_placed is None:  # (views of this estimator's data.oMf (eigenpy), kept with their SE3s)
            self._soles_placed = [(M, M.rotation, M.translation) for M in (data.oMf[fl], data.oMf[fr])]
        (_, rl, pl), (_, rr, pr) = self._soles_placed
        vl = pin.getFrameVelocity(model, data, fl, pin.LOCAL_WORLD_ALIGNED).vector
        vr = pin.getFrameVelocity(model, data, fr, pin.LOCAL_WORLD_ALIGNED).vector
        q, v = self.q, self.v
        # numbers a caller may change between samples without an attribute of this object (the detectors'
        # thresholds, the Kalman filter's noise covariances): read every sample, not only at construction
        prm, dl, dr = self._prm, self.detectors["left"], self.detectors["right"]
        prm[34], prm[35], prm[36], prm[37] = dl.on, dl.off, dr.on, dr.off
        prm[11:15] = kf.Q.ravel()
        prm[15], prm[16] = kf.R[0, 0], kf.R[1, 1]
        # steps 2-4 (attitude, contacts, anchors, Kalman filter) and the outputs but the quaternion, compiled
        legs = (rl, pl, rr, pr, vl, vr)
        filters = (att.rotation, att.gains, att.bias, att.omega, kf.p, kf.velocity, kf.P)
        _FUSE[0](ft, accel, gyro, legs, filters, self._state)
        s = st.tolist()
        object.__setattr__(att, "accel_used", s[_ST_ACCEL_USED] != 0.0)  # (not a gain: no check)
        contact, turning, normal_force, detectors = self.contact, self.turning, self.normal_force, self.detectors
        for j, side in enumerate(SIDES):
            contact[side] = detectors[side].active = s[_ST_CONTACT + j] != 0.0
            turning[side] = s[_ST_TURNING + j] != 0.0
            normal_force[side] = s[_ST_FZ + j]
        # (pin.Quaternion(R), built from a matrix, leaks 80 B of C heap per call with eigenpy 3.12: 2.4 MB per
        # minute at 500 Hz; SE3ToXYZQUAT gives the same (x, y, z, w) without it)
        self._X.rotation = att.rotation
        q[3:7] = pin.SE3ToXYZQUAT(self._X)[3:]
        q[7:] = qk[7:]
        v[6:] = vj
        return q, v
