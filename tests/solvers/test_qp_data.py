"""QPData (wbc.solvers.qp_data): the field order solvers take, and a formulation's assembly handing its own buffers
(no copies) that a backend solves as they are."""

from __future__ import annotations

import numpy as np

from wbc.configuration import Configuration
from wbc.constraints import JointVelocityLimit
from wbc.controllers.kinematic import KinematicController
from wbc.solvers import DaqpBackend
from wbc.solvers.qp_data import QPData
from wbc.tasks import ComTask, PostureTask


def test_fields_are_in_the_solvers_argument_order():
    assert QPData._fields == ("H", "g", "A", "b", "C", "l", "u", "lb", "ub")


def test_velocity_assembly_hands_its_buffers_and_a_backend_solves_them(robots):
    robot = robots("talos")
    config = Configuration(robot)
    com = ComTask(weight=10.0)
    com.set_target(config.com + np.array([0.01, 0.0, -0.01]))
    ctrl = KinematicController(robot, [com, PostureTask(robot, weight=1e-2)], [JointVelocityLimit(robot)],
                               solver="daqp")
    qp = ctrl.assemble(config, 0.002)
    assert isinstance(qp, QPData)
    again = ctrl.assemble(config, 0.002)
    assert all(a is b for a, b in zip(qp, again))  # the same buffers, not copies
    assert np.array_equal(qp.H, qp.H.T)
    v = DaqpBackend().solve(*qp)
    assert np.all(v >= qp.lb - 1e-9) and np.all(v <= qp.ub + 1e-9)
    result = ctrl.solve(config, 0.002)
    assert result.ok
    np.testing.assert_allclose(result.v, v, atol=1e-9)  # the controller's tick solves that QP
