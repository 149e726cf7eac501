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


def test_the_ladder_keeps_the_largest_return_rate_an_lp_finds_feasible(robots):
    """Talos standing on both soles with hip-roll, knee and ankle-roll of both legs 50 mrad past their upper limits:
    returning at the full rate is infeasible. The tick's relaxed return rate α is the largest of the ladder's scales
    (1/2, 1/10, 1/100, 1/1000, 0) whose hard set HiGHS finds feasible (an independent LP on the assembled rows)."""
    import math

    from conftest import highs_feasible, standing_controller
    from wbc.constraints.limits import bounded_joints

    robot = robots("talos")
    model = robot.model
    config = Configuration(robot)
    q = config.q.copy()
    names = {model.joints[j].idx_q: model.names[j] for j in range(1, model.njoints)}
    past = [i for i in bounded_joints(model)[0]
            if names[i] in {f"leg_{s}_{j}_joint" for s in ("left", "right") for j in (2, 4, 6)}]
    assert len(past) == 6
    q[past] = model.upperPositionLimit[past] + 0.05
    config.update(q)
    ctrl, _ = standing_controller(robot, config)
    ctrl.budget = math.inf  # the whole ladder, independent of the machine's load
    limit = next(c for c in ctrl.constraints if isinstance(c, JointPositionLimit))
    _, _, A, b, C, l, u, lb, ub = (x.copy() for x in ctrl.assemble(config, 0.002))
    low, high = outside_limits(config, [limit], lb, ub)
    assert high.size >= 6  # the six (and any joint the reference posture has past its limit margin)

    def feasible(alpha):
        ua = ub.copy()
        ua[high] = alpha * ub[high]
        return highs_feasible(A, b, C, l, u, lb, ua)

    assert not feasible(1.0)
    expected = max(a for a in (0.5, 0.1, 0.01, 0.001, 0.0) if feasible(a))
    res = ctrl.solve(config, 0.002)
    assert res.ok, res.message
    assert res.relaxed == [f"joint_position_limit return rate × {expected:g}"], (res.relaxed, expected)
