""":mod:`wbc.lie` against Pinocchio (``log3``, ``Jlog3``, ``Hlog3``, ``log6``, ``exp3``, ``exp6``): random rotations,
rotations within 1e-9 rad of the identity and within 1e-9 rad of a half turn (the Taylor and singular branches)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from wbc.lie import (exp3_into, exp6_translation, jlog3_into, log3_into, log3_rate_into, placement_log6_into,
                     quaternion_exp3, rotation_gap, translation_gap)

#: agreement with Pinocchio away from a half turn, relative to max(1, |reference|): the same formulas, the last bits
#: may differ with the order of the sums
RTOL = 1e-12


def _close(a, b, tol=RTOL) -> bool:
    return np.abs(np.asarray(a) - np.asarray(b)).max() <= tol * max(1.0, np.abs(b).max())


def _axis(rng):
    a = rng.standard_normal(3)
    return a / np.linalg.norm(a)


def _angles(rng, n):
    """n angles: uniform in [0, π), log-uniform in [1e-12, 1], and within 1e-9 of 0 and of π."""
    fixed = [0.0, 1e-12, 1e-9, 3e-5, 1e-3, np.pi - 1e-3, np.pi - 1e-6, np.pi - 1e-9, np.pi]
    return fixed + list(rng.uniform(0.0, np.pi, n // 2)) + list(10.0 ** rng.uniform(-12, 0, n // 2))


def _near_half_turn(angle: float) -> bool:
    return angle > np.pi - 1e-3


def test_log3_and_jlog3_are_pinocchios_at_every_angle():
    rng = np.random.default_rng(7)
    log, jlog = np.empty(3), np.empty((3, 3))
    for angle in _angles(rng, 400):
        w = angle * _axis(rng)
        R = pin.exp3(w)
        theta = log3_into(R, log)
        ref = pin.log3(R)
        if _near_half_turn(angle):
            # log₃ at π is defined up to the sign of the axis; at π − δ, exp₃ rounds R to ~1e-16, which moves the
            # axis by ~1e-16/δ (Pinocchio and this module each recover it from R): compare rotations and angles
            assert abs(theta - np.linalg.norm(ref)) <= 1e-9
            assert np.abs(pin.exp3(log) - R).max() <= 1e-9
            continue
        assert _close(log, ref), angle
        # the returned θ below ~2.5e-3 rad is √(2 (1 − cos θ)) = 2 sin(θ/2) (as in Pinocchio: log itself uses the
        # series): θ³/24 short, plus ε/θ of rounding, and θ under √ε ≈ 1.5e-8 rad is not resolved at all
        eps = np.finfo(float).eps
        slack = angle**3 / 24 + min(1.5e-8, 4 * eps / max(angle, 1e-300)) if angle < 3e-3 else 0.0
        assert abs(theta - np.linalg.norm(ref)) <= RTOL * max(1.0, angle) + slack
        jlog3_into(theta, log, jlog)
        assert _close(jlog, pin.Jlog3(R)), angle


def test_log3_of_a_half_turn_is_a_rotation_vector_of_length_pi():
    log = np.empty(3)
    for axis in (np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]), np.array([0.0, 0.0, 1.0]),
                 np.array([1.0, -2.0, 0.5]) / np.linalg.norm([1.0, -2.0, 0.5])):
        R = pin.exp3(np.pi * axis)
        theta = log3_into(R, log)
        assert abs(theta - np.pi) <= 1e-12
        assert abs(abs(log @ axis) - np.pi) <= 1e-9  # ±π axis
        assert np.abs(pin.exp3(log) - R).max() <= 1e-12


def test_log3_rate_is_pinocchios_hlog3_and_a_finite_difference():
    """Jlog₃ α + Hlog₃(R, ω) ω: Pinocchio's Hlog3 above the small-angle threshold (1e-3 rad), a central second
    difference of log₃(R exp(t ω + ½ t² α)) at every angle (including 0, where Hlog3 is NaN)."""
    rng = np.random.default_rng(5)
    log, jlog, out = np.empty(3), np.empty((3, 3)), np.empty(3)
    h = 1e-4
    for angle in (0.0, 1e-6, 5e-4, 2e-3, 0.3, 1.5, 2.5, 3.0):
        R = pin.exp3(angle * _axis(rng))
        omega, alpha = rng.standard_normal(3), rng.standard_normal(3)
        theta = log3_into(R, log)
        st, ct = jlog3_into(theta, log, jlog)
        log3_rate_into(theta, st, ct, log, jlog, omega, alpha, out)
        assert np.all(np.isfinite(out))
        if angle >= 1e-3:
            ref = pin.Jlog3(R) @ alpha + pin.Hlog3(R, omega) @ omega
            assert _close(out, ref, 1e-12 + 4 * np.finfo(float).eps / angle**2), angle  # Hlog3's ε/θ² (see below)

        def err(t, R=R, omega=omega, alpha=alpha):
            return pin.log3(R @ pin.exp3(omega * t + 0.5 * alpha * t * t))

        num = (err(h) - 2 * err(0.0) + err(-h)) / h**2
        assert _close(out, num, 2e-5), angle


def test_placement_log6_is_pinocchios_log6_of_act_inv():
    rng = np.random.default_rng(8)
    out = np.empty(6)
    for angle in _angles(rng, 400):
        P = pin.SE3(pin.exp3(rng.standard_normal(3)), rng.uniform(-1, 1, 3))
        M = P * pin.SE3(pin.exp3(angle * _axis(rng)), rng.standard_normal(3) * 10.0 ** rng.uniform(-12, 0))
        pose = np.vstack([P.rotation, P.translation])
        assert placement_log6_into(pose, np.asfortranarray(M.rotation), M.translation.copy(), out)
        ref = pin.log6(P.actInv(M)).vector
        if _near_half_turn(angle):  # see test_log3_and_jlog3_are_pinocchios_at_every_angle
            assert np.abs(pin.exp6(out).homogeneous - P.actInv(M).homogeneous).max() <= 1e-8
            continue
        assert _close(out, ref), angle


def test_exp3_is_pinocchios():
    rng = np.random.default_rng(9)
    out = np.empty((3, 3))
    for angle in _angles(rng, 200):
        w = angle * _axis(rng)
        exp3_into(w[0], w[1], w[2], out)
        assert _close(out, pin.exp3(w)), angle


@pytest.mark.parametrize("scale", [1e-9, 1e-4, 0.3, 2.5])
def test_exp6_translation_quaternion_and_gaps_against_pinocchio(scale):
    """The origin of exp₆(s ξ), the quaternion of exp₃(ω), and the distance and angle between two frames given by
    their twists, against Pinocchio's exp6, exp3 and log3 (small rotations: the series branches)."""
    rng = np.random.default_rng(3)
    for _ in range(50):
        xa, xb = rng.normal(size=6), rng.normal(size=6)
        xa[3:] *= scale
        xb[3:] *= scale
        sa, sb = rng.uniform(-1.0, 1.0, 2)
        Ma, Mb = pin.exp6(sa * xa), pin.exp6(sb * xb)
        # (1 − cos θ)/θ² and (θ − sin θ)/θ³ in closed form above θ = 1e-6 rad lose ε/θ² relative: measured 2e-12 m
        # at θ ~ 1e-4 rad for |ν| ~ 1 (within 1e-12 elsewhere)
        assert _close(exp6_translation(xa, sa), Ma.translation, 1e-11)
        w, x, y, z = quaternion_exp3(*(sa * xa[3:]))
        assert _close(pin.Quaternion(w, x, y, z).toRotationMatrix(), Ma.rotation)
        ref = np.linalg.norm(Ma.translation - Mb.translation)
        assert abs(translation_gap(xa, sa, xb, sb) - ref) <= 1e-12 * max(1.0, ref)
        ref = np.linalg.norm(pin.log3(Ma.rotation.T @ Mb.rotation))
        assert abs(rotation_gap(xa, sa, xb, sb) - ref) <= 1e-12 * max(1.0, ref)
