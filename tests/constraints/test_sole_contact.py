"""The validated parameters of SoleContact and AccelerationReference (kp, kd, mu): a value that is not a finite
number ≥ 0 (> 0 for mu; a bool included) is refused with InvalidInputError and leaves the attribute unchanged."""

import math

import numpy as np
import pytest

import wbc
from wbc.constraints.sole_contact import SoleContact
from wbc.exceptions import InvalidInputError
from wbc.formulations.reference import AccelerationReference
from wbc.tasks import ComTask

BAD = [-1.0, math.nan, math.inf, "stiff", None, True]


@pytest.fixture(scope="module")
def robot():
    return wbc.load_robot("talos")


@pytest.mark.parametrize("bad", BAD)
def test_bad_gains_refused_and_kept(robot, bad):
    contact = SoleContact(robot, robot.left_sole, kp=5.0, kd=20.0)
    ref = AccelerationReference(ComTask(), kp=100.0, kd=20.0, name="com")
    for obj, attr, before, prefix in ((contact, "kp", 5.0, "contact kp"), (contact, "kd", 20.0, "contact kd"),
                                      (ref, "kp", 100.0, "com kp"), (ref, "kd", 20.0, "com kd")):
        with pytest.raises(InvalidInputError, match=prefix):
            setattr(obj, attr, bad)
        assert getattr(obj, attr) == before


def test_gains_accept_numbers_as_floats(robot):
    contact = SoleContact(robot, robot.left_sole)
    contact.kp, contact.kd = 0, np.float32(3.5)
    assert (contact.kp, contact.kd) == (0.0, 3.5) and type(contact.kp) is float and type(contact.kd) is float
    ref = AccelerationReference(ComTask(), kp=16.0)
    assert ref.kd == 8.0  # default 2 √Kp


@pytest.mark.parametrize("bad", [0.0, *BAD])
def test_bad_mu_refused_and_friction_rows_kept(robot, bad):
    contact = SoleContact(robot, robot.left_sole, mu=0.8)
    F = contact.friction_matrix.copy()
    with pytest.raises(InvalidInputError, match="friction coefficient mu"):
        contact.mu = bad
    assert contact.mu == 0.8
    np.testing.assert_array_equal(contact.friction_matrix, F)


def test_mu_rewrites_friction_rows(robot):
    contact = SoleContact(robot, robot.left_sole, mu=0.8)
    contact.mu = 0.5
    # row 0: corner 0, +f_x − μ/√2 f_z ≤ 0 (inscribed pyramid)
    assert contact.friction_matrix[0, 0] == 1.0 and contact.friction_matrix[0, 2] == pytest.approx(-0.5 / math.sqrt(2))
