"""Estimator building blocks against closed-form cases (no physics): the attitude filter on a static IMU (with and
without gyro bias), the base Kalman filter on a constant-velocity base, encoder differencing, contact hysteresis,
the static F/T compensation and the ZMP of known wrenches. Thresholds are written here."""

import math

import numpy as np
import pinocchio as pin
import pytest

from wbc.estimation import (BaseKalmanFilter, ComplementaryAttitudeFilter, ContactDetector, FootForceSensor,
                            JointStateFilter, zmp_from_wrenches)
from wbc.exceptions import InvalidInputError
from wbc.robot import load_robot

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


def test_attitude_filter_rejects_bad_gains():
    with pytest.raises(InvalidInputError, match="k_p"):
        ComplementaryAttitudeFilter(DT, k_p=-1.0)
    f = ComplementaryAttitudeFilter(DT)
    with pytest.raises(InvalidInputError, match="dt"):
        f.dt = 0.0
    with pytest.raises(InvalidInputError, match="rotation"):
        f.reset(np.ones((3, 3)))


def test_constant_velocity_base_converges():
    # Base moving at 0.4 m/s along x, 0.1 m/s along y: IMU input zero acceleration (noisy), leg odometry measures
    # position and velocity (noisy); the filter starts at rest.
    rng = np.random.default_rng(2)
    vel = np.array([0.4, 0.1, 0.0])
    kf = BaseKalmanFilter(DT, sigma_acc=0.5, sigma_pos=0.002, sigma_vel=0.02)
    kf.reset(np.zeros(3), np.zeros(3))
    n = int(3.0 / DT)
    for k in range(1, n + 1):
        kf.predict(rng.normal(0, 0.1, 3))
        kf.correct(vel * k * DT + rng.normal(0, 0.001, 3), vel + rng.normal(0, 0.01, 3))
    assert np.abs(kf.velocity - vel).max() < 0.01
    assert np.abs(kf.p - vel * n * DT).max() < 0.002
    # Prediction alone (flight): a constant velocity is kept exactly with a zero acceleration input.
    kf.reset(np.zeros(3), vel)
    for _ in range(100):
        kf.predict(np.zeros(3))
    assert np.allclose(kf.velocity, vel) and np.allclose(kf.p, vel * 100 * DT)


def test_encoder_differencing_gives_the_joint_rate():
    res = 2 * math.pi / 2**19
    w = np.array([1.0, -0.5, 0.0])
    f = JointStateFilter(3, DT, cutoff_hz=80.0)
    f.reset()
    for k in range(500):
        f.update(np.round(w * k * DT / res) * res)
    # quantisation error of a difference ≤ 2 res / dt (≈ 0.012 rad/s), attenuated by the filter
    assert np.abs(f.velocity - w).max() < 2 * res / DT


def test_contact_hysteresis():
    c = ContactDetector(on=100.0, off=40.0)
    seq = [0, 90, 101, 60, 41, 39, 99, 100.5]
    assert [c.update(x) for x in seq] == [False, False, True, True, True, False, False, True]
    with pytest.raises(InvalidInputError):
        ContactDetector(on=10.0, off=20.0)


def test_ft_static_compensation_and_zmp():
    robot = load_robot("talos")
    s = FootForceSensor(robot, robot.left_sole)
    # A foot at rest, level, with a 500 N vertical ground reaction at CoP (0.02, −0.01) in the sole frame: the
    # sensor reads F_s = −f − m g, τ_s = −τ_p + p × F_s − (c − p) × m g (module docstring of wbc.estimation.contact).
    Rw = np.eye(3)
    mg = s.mass * np.array([0.0, 0.0, -G])
    f = np.array([0.0, 0.0, 500.0])
    cop = np.array([0.02, -0.01, 0.0])
    tau_p = np.cross(cop, f)
    Fs = -f - mg
    ts = -tau_p + np.cross(s.sole_in_sensor, Fs) - np.cross(s.com_in_sensor - s.sole_in_sensor, mg)
    w = s.ground_wrench(np.r_[Fs, ts], Rw)
    assert np.allclose(w[:3], f) and np.allclose(w[3:], tau_p, atol=1e-12)
    X = pin.SE3(Rw, np.array([0.3, 0.1, 0.0]))
    z = zmp_from_wrenches(w[None], [X])
    assert np.allclose(z, [0.32, 0.09])
    assert zmp_from_wrenches(np.zeros((1, 6)), [X]) is None
