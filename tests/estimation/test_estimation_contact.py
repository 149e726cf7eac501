"""Foot F/T sensors and contact detection (wbc.estimation.contact): hysteresis of the detector, static
compensation of the sensor and the ZMP of the wrenches."""


import numpy as np
import pinocchio as pin
import pytest

from wbc.estimation import ContactDetector, FootForceSensor, zmp_from_wrenches
from wbc.exceptions import InvalidInputError
from wbc.robot import load_robot

G = 9.81


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
