"""A stance controller keeps one constraint order per support: a sole that touches down goes back to its place among
the contacts (first, left before right), so a support that comes back has the constraint list (hence the QP row
layout) it had before. ``KinematicController.add_constraint(index=...)`` is what places it."""

from __future__ import annotations

import numpy as np
import pytest

from wbc import KinematicController
from wbc.configuration import Configuration
from wbc.constraints import JointPositionLimit, JointVelocityLimit
from wbc.exceptions import InvalidInputError
from wbc.scenarios.stance import DOUBLE, LEFT_STANCE, RIGHT_STANCE, StanceController
from wbc.tasks import ComTask


def test_add_constraint_inserts_at_index_and_rejects_bad_indices(robots):
    robot = robots("talos")
    position, velocity = JointPositionLimit(robot), JointVelocityLimit(robot)
    ctrl = KinematicController(robot, [ComTask()], [position])
    ctrl.add_constraint(velocity, index=0)
    assert ctrl.constraints == [velocity, position]
    ctrl.remove_constraint(velocity)
    for bad in (-1, 2, True, 0.0, "0"):
        with pytest.raises(InvalidInputError):
            ctrl.add_constraint(velocity, index=bad)
    assert ctrl.constraints == [position]
    ctrl.add_constraint(velocity, index=1)
    assert ctrl.constraints == [position, velocity]


def test_each_support_keeps_one_constraint_order(robots):
    robot = robots("talos")
    config = Configuration(robot)
    stance = StanceController(robot, config, joint_acceleration=50.0)
    ctrl = stance.controller
    left, right = stance.contact["left"], stance.contact["right"]
    others = [c for c in ctrl.constraints if c is not left and c is not right]
    expected = {DOUBLE: [left, right, *others], LEFT_STANCE: [left, *others], RIGHT_STANCE: [right, *others]}
    assert ctrl.constraints == expected[DOUBLE]
    for support in (LEFT_STANCE, DOUBLE, RIGHT_STANCE, DOUBLE, LEFT_STANCE, RIGHT_STANCE, DOUBLE):
        stance.set_support(support, config)
        assert [c.name for c in ctrl.constraints] == [c.name for c in expected[support]]
        assert all(a is b for a, b in zip(ctrl.constraints, expected[support]))
        result = stance.solve(config, 0.002)
        assert result.ok and np.isfinite(result.v).all()
