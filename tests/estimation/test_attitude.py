"""The complementary attitude filter (wbc.estimation.attitude): convergence to the gravity-aligned orientation,
gyro bias on the tilt axes, heading corrections of yaw and its bias only, typed errors of bad gains."""

import math

import numpy as np
import pinocchio as pin
import pytest

from wbc.estimation import ComplementaryAttitudeFilter
from wbc.exceptions import InvalidInputError


DT = 0.002


G = 9.81


def _tilt_deg(Ra, Rb):
    return math.degrees(math.acos(min(1.0, float(Ra[2] @ Rb[2]))))


def test_static_imu_converges_to_the_gravity_aligned_orientation():
    # True orientation: roll 10 deg, pitch −5 deg, yaw 30 deg; the filter starts level with yaw 30 deg.
    R = pin.rpy.rpyToMatrix(math.radians(10), math.radians(-5), math.radians(30))
    accel = R.T @ np.array([0.0, 0.0, G])  # specific force at rest: +g up, IMU axes
    f = ComplementaryAttitudeFilter(DT, k_p=1.0, k_i=0.0)
    f.reset(pin.rpy.rpyToMatrix(0, 0, math.radians(30)))
    for _ in range(int(10.0 / DT)):
        f.update(np.zeros(3), accel)
    assert _tilt_deg(f.rotation, R) < 0.01
    # zero angular velocity: the estimated rate is zero
    assert np.abs(f.omega).max() == 0.0
    assert np.allclose(f.rotation.T @ f.rotation, np.eye(3), atol=1e-12)


def test_gyro_bias_is_estimated_on_the_tilt_axes():
    rng = np.random.default_rng(1)
    bias = np.array([0.01, -0.02, 0.005])  # rad/s
    R = np.eye(3)
    f = ComplementaryAttitudeFilter(DT, k_p=1.0, k_i=0.3)
    f.reset(R)
    for _ in range(int(60.0 / DT)):
        f.update(bias + rng.normal(0, 1e-3, 3), np.array([0.0, 0.0, G]) + rng.normal(0, 1e-2, 3))
    # roll/pitch bias observable from gravity: estimated; tilt stays small
    assert np.abs(f.bias[:2] - bias[:2]).max() < 1e-3
    assert _tilt_deg(f.rotation, R) < 0.1
    # without the integral term the bias leaves a steady tilt error ≈ |b| / k_p
    g = ComplementaryAttitudeFilter(DT, k_p=1.0, k_i=0.0)
    g.reset(R)
    for _ in range(int(20.0 / DT)):
        g.update(bias, np.array([0.0, 0.0, G]))
    assert _tilt_deg(g.rotation, R) == pytest.approx(math.degrees(np.linalg.norm(bias[:2]) / 1.0), rel=0.05)


def test_heading_directions_correct_yaw_and_its_bias_only():
    """A static IMU, level, gyro biased by b about every axis, and one heading direction (world x seen as the IMU's
    x) that is pitched by 2° — a sole forward axis that disagrees with gravity on tilt. Closed form of the yaw loop
    (k_H, k_IH): the yaw bias is learnt (b̂_z → b_z) and the yaw error → 0; the heading's pitch disagreement
    moves nothing: the tilt follows gravity alone, as with no heading at all."""
    b = np.array([0.004, -0.003, 0.0022])  # rad/s
    accel = np.array([0.0, 0.0, G])
    pitched = pin.rpy.rpyToMatrix(0.0, math.radians(2.0), 0.0)[:, 0]  # x pitched 2° (IMU axes)
    ref = np.array([1.0, 0.0, 0.0])
    f = ComplementaryAttitudeFilter(DT, k_p=1.0, k_i=0.3, k_heading=1.0, k_heading_bias=0.25)
    g = ComplementaryAttitudeFilter(DT, k_p=1.0, k_i=0.3, k_heading=0.0, k_heading_bias=0.0)
    for filt in (f, g):
        filt.reset(np.eye(3))
    yaw_peak = 0.0
    for _ in range(int(60.0 / DT)):
        f.update(b, accel, heading=[(ref, pitched, 1.0)])
        g.update(b, accel)
        yaw_peak = max(yaw_peak, abs(math.atan2(f.rotation[1, 0], f.rotation[0, 0])))
    yaw = math.atan2(f.rotation[1, 0], f.rotation[0, 0])
    assert abs(yaw) < 1e-4  # rad, after 60 s (critically damped yaw loop, corner 0.5 rad/s)
    assert yaw_peak < 1.2 * b[2] / 1.0  # never more than the proportional equilibrium b_z / k_H
    assert f.bias[2] == pytest.approx(b[2], abs=2e-5)
    assert _tilt_deg(f.rotation, np.eye(3)) < 0.02  # the 2° pitch of the heading axis is not followed
    assert np.abs(f.bias[:2] - g.bias[:2]).max() < 1e-6  # tilt and its biases as with no heading
    # without the heading, yaw integrates the bias: b_z t
    assert math.atan2(g.rotation[1, 0], g.rotation[0, 0]) == pytest.approx(b[2] * 60.0, rel=1e-3)
    with pytest.raises(InvalidInputError, match="k_heading"):
        f.k_heading = -0.5


def test_attitude_filter_rejects_bad_gains():
    with pytest.raises(InvalidInputError, match="k_p"):
        ComplementaryAttitudeFilter(DT, k_p=-1.0)
    f = ComplementaryAttitudeFilter(DT)
    with pytest.raises(InvalidInputError, match="dt"):
        f.dt = 0.0
    with pytest.raises(InvalidInputError, match="rotation"):
        f.reset(np.ones((3, 3)))
