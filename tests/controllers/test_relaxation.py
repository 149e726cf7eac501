"""The relaxation ladder's selection of the joints whose return rate it scales (``outside_limits``), against the
robot model's own limits (closed form: which joints were moved out, and which way)."""

from __future__ import annotations

import numpy as np

from wbc.configuration import Configuration
from wbc.constraints import JointPositionLimit
from wbc.controllers.relaxation import outside_limits


def test_joints_moved_out_of_their_range_are_found_by_side(robots):
    robot = robots("talos")
    model = robot.model
    limit = JointPositionLimit(robot)
    idx_q, idx_v = np.asarray(limit.idx_q), np.asarray(limit.indices)
    q = robot.q_ref.copy()
    below, above, quiet = 3, 7, 11  # positions in the limit's joint list
    q[idx_q[below]] = model.lowerPositionLimit[idx_q[below]] - 0.05
    q[idx_q[above]] = model.upperPositionLimit[idx_q[above]] + 0.05
    q[idx_q[quiet]] = model.lowerPositionLimit[idx_q[quiet]] - 0.05  # out, but its box asks no return
    config = Configuration(robot, q)
    lb, ub = -np.ones(model.nv), np.ones(model.nv)
    lb[idx_v[below]] = 0.5  # the box asks a return up ...
    ub[idx_v[above]] = -0.5  # ... and down
    low, high = outside_limits(config, [limit], lb, ub)
    assert low.tolist() == [idx_v[below]] and high.tolist() == [idx_v[above]]
    none = outside_limits(Configuration(robot, robot.q_ref.copy()), [limit], lb, ub)
    assert none[0].size == 0 and none[1].size == 0
    empty = outside_limits(config, [], lb, ub)
    assert empty[0].size == 0 and empty[1].size == 0
