"""The kinematic controller's clock guard: the tick's CPU time counted as work cuts the stages of a tick (the
strict cascade, the contact correction), and with the class's weight a tick under budget is bitwise the unguarded
one."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import hand_over_posture

DT = 0.002


def test_kinematic_clock_guard_cuts_the_stages_of_a_tick_by_its_cpu_time(robots):
    """Strict levels (a hand target at level 0, the posture at level 1) with a budget of 1 s (4000 counted solves:
    never reached). Without the clock guard the tick solves every level (path 'levels'). With it, and the CPU
    time weighted so that any time at all exceeds the budget (``CLOCK_WEIGHT`` = 1e12), the cascade starts no
    level after the first and no contact correction, and the weighted form of the levels answers (one QP; its
    command checked against quadprog in tests/formulations/test_velocity_weighted_levels.py): ok,
    'levels+budget+weighted', over_budget. Oracles: the soles move ≤ 0.05 mm over the tick by forward kinematics; the
    command is not the cascade's. With the class's weight the 1 s budget is not reached: bitwise the unguarded tick."""
    import pinocchio as pin

    from wbc.exceptions import InvalidInputError

    robot, config, ctrl, (hand, _) = hand_over_posture(robots, budget=1.0)
    assert ctrl.clock_guard is False  # the default: nothing decided by a clock
    full = ctrl.solve(config, DT)
    assert full.ok and full.path == "levels" and not full.over_budget
    _, _, guarded, _ = hand_over_posture(robots, budget=1.0, clock_guard=True)
    same = guarded.solve(config, DT)
    assert same.ok and same.path == "levels" and not same.over_budget
    assert same.v.tobytes() == full.v.tobytes()
    _, _, cutting, _ = hand_over_posture(robots, budget=1.0, clock_guard=True, CLOCK_WEIGHT=1e12)
    cut = cutting.solve(config, DT)
    assert cut.ok and cut.over_budget and cut.path == "levels+budget+weighted", (cut.path, cut.message)
    assert "priority levels after the first 1 of 3 (their weighted form's command)" in cut.message
    assert np.linalg.norm(cut.v - full.v) > 1e-6  # not the cascade's command
    model, data = robot.model, robot.model.createData()
    pin.framesForwardKinematics(model, data, pin.integrate(model, config.q, cut.v * DT))
    for frame in (robot.left_sole, robot.right_sole):
        fid = model.getFrameId(frame)
        assert np.linalg.norm(data.oMf[fid].translation - config.frame_placement(fid).translation) <= 5e-5
    for bad in ("yes", 1, None):
        with pytest.raises(InvalidInputError, match="clock_guard"):
            ctrl.clock_guard = bad
