"""The contact constraint's gain: a finite number > 0, checked at construction and on assignment."""

from __future__ import annotations

import pytest


def test_contact_gain_must_be_positive(robots):
    from wbc.constraints import ContactConstraint
    from wbc.exceptions import InvalidInputError

    robot = robots("humanoid15")
    for bad in (0.0, -1.0, float("nan")):
        with pytest.raises(InvalidInputError, match="gain"):
            ContactConstraint(robot, robot.left_sole, gain=bad)
    contact = ContactConstraint(robot, robot.left_sole)
    for bad in (0.0, -5.0, float("inf"), "100", None, True):  # also on assignment
        with pytest.raises(InvalidInputError, match=r"contact gain must be a finite number > 0"):
            contact.gain = bad
    assert contact.gain == 100.0
    contact.gain = 50
    assert contact.gain == 50.0
