"""A task's PD reference at the acceleration level (wbc.formulations.reference): r = ä_ff − Kp e − Kd J v − J̇v
for a CoM task, with e, J and J̇v = c̈(v̇ = 0) from Pinocchio on a data of their own; Kd defaults to 2√Kp; typed
errors of bad gains and feed-forward."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from conftest import random_configuration
from wbc.exceptions import InvalidInputError, InvalidTargetError
from wbc.formulations.reference import AccelerationReference
from wbc.state import DynamicsState
from wbc.tasks import ComTask


def test_com_reference_is_the_pd_law_on_pinocchios_quantities(robots):
    robot = robots("talos")
    model, data = robot.model, robot.model.createData()
    rng = np.random.default_rng(13)
    q, v = random_configuration(robot, rng), rng.normal(scale=0.4, size=robot.nv)
    target, a_ff = rng.uniform(-0.1, 0.1, 3), rng.uniform(-1.0, 1.0, 3)
    ref = AccelerationReference(ComTask(), kp=90.0)
    assert ref.kd == pytest.approx(2.0 * math.sqrt(90.0))
    ref.set_target(target)
    ref.set_feedforward_acceleration(a_ff)
    J, r = ref.compute(DynamicsState(robot, q, v))
    pin.centerOfMass(model, data, q, v, np.zeros(robot.nv))
    com, drift = data.com[0].copy(), data.acom[0].copy()
    Jc = pin.jacobianCenterOfMass(model, data, q)
    np.testing.assert_allclose(J, Jc, atol=1e-12)
    expected = a_ff - 90.0 * (com - target) - ref.kd * (Jc @ v) - drift
    np.testing.assert_allclose(r, expected, atol=1e-9 * max(1.0, np.abs(expected).max()))


def test_typed_errors():
    ref = AccelerationReference(ComTask(), kp=10.0, kd=1.0)
    for name, bad in (("kp", -1.0), ("kd", math.nan)):
        with pytest.raises(InvalidInputError):
            setattr(ref, name, bad)
    assert (ref.kp, ref.kd) == (10.0, 1.0)  # left unchanged
    with pytest.raises(InvalidTargetError):
        ref.set_feedforward_acceleration([0.0, 1.0])
    with pytest.raises(InvalidInputError):
        ref.weight = -1.0
