"""TickBudget (wbc.controllers.budget): its decisions against the counts written out by hand, and the controller
sharing its one TickWork with its backends."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wbc.controllers.budget import TickBudget
from wbc.exceptions import InvalidInputError


def _budget(seconds=2e-3, solve_cost=2.5e-4, stage_factor=1.75, stage_deadline=1.5) -> TickBudget:
    b = TickBudget()
    b.stage_factor, b.stage_deadline = stage_factor, stage_deadline
    b.start(seconds, solve_cost, clock_weight=1.4)
    return b


def test_start_sets_the_cap_from_the_budget_and_resets_the_tick_costs():
    b = _budget()
    b.resolve_work, b.resolve_cost, b.safe_cost, b.safe_fresh = 3.0, 1e-3, 2e-4, True
    b.start(2e-3, 2.5e-4, clock_weight=1.4)
    assert b.work.cap == 8  # ⌊2 ms / 0.25 ms⌋
    assert b.work.solves == 0 and b.seconds == 2e-3
    assert b.resolve_work == 0.0 and b.resolve_cost == 0.0 and not b.safe_fresh
    assert b.safe_cost == 2e-4  # the last tick's safe command time is kept until one is timed
    b.start(math.inf, 2.5e-4, clock_weight=1.4)
    assert b.work.cap == math.inf and b.may_start("retry") and b.may_start("stage")


def test_may_start_counts_the_largest_resolve_ahead():
    b = _budget()
    b.work.add(6)
    assert b.may_start("retry") and b.may_start("stage")
    b.resolve_work = 2.0  # 6 + 2 = 8: not past the cap of 8
    assert b.may_start("retry")
    b.resolve_work = 2.5  # 8.5 > 8: a failed tick's optional stage would end past one budget
    assert not b.may_start("retry")
    assert b.may_start("stage")  # 8.5 ≤ 1.75 × 8 = 14
    b.work.add(6)  # 12 + 2.5 = 14.5 > 14
    assert not b.may_start("stage")
    assert b.may_start("timed")  # bounded by the clock guard only, which is off


def test_may_start_with_a_cost_asks_the_clock_guard_only_when_it_is_on():
    b = _budget()
    assert b.may_start("retry", cost=10.0)  # no clock guard: a cost never stops a stage
    b.clock_guard = True
    b.start(2e-3, 2.5e-4, clock_weight=1.4)
    assert not b.may_start("timed", cost=10.0)  # 10 s > 1.5 × 2 ms
    assert not b.fits(0.0, deadline=-1.0)
    assert b.fits(-10.0)  # any CPU time so far minus 10 s is within 1.5 × 2 ms


def test_an_unknown_stage_is_a_typed_error_naming_the_valid_ones():
    with pytest.raises(InvalidInputError, match="retry, stage, timed"):
        _budget().may_start("level")


def test_level_stop_counts_the_largest_level():
    b = _budget()
    b.level_count = 0.0
    b.work.add(5)
    assert not b.level_stop()  # a level of 5: 5 + 5 = 10 ≤ 14
    assert b.level_work == 5 and b.level_count == 5
    b.work.add(4)  # a level of 4; the largest stays 5: 9 + 5 = 14 ≤ 14
    assert not b.level_stop()
    b.work.add(1)  # 10 + 5 = 15 > 14
    assert b.level_stop()


def test_cascade_fits_scales_the_weighted_ticks_count_by_the_levels():
    b = _budget()
    b.work.add(2)
    assert b.cascade_fits(levels=2, share=1.0)  # 3 × 2 = 6 ≤ 8
    b.work.add(1)
    assert not b.cascade_fits(levels=2, share=1.0)  # 3 × 3 = 9 > 8


def test_the_controller_shares_its_budget_work_with_its_backend(robots):
    from wbc.configuration import Configuration
    from wbc.constraints import JointVelocityLimit
    from wbc.controllers.kinematic import KinematicController
    from wbc.tasks import PostureTask

    robot = robots("talos")
    ctrl = KinematicController(robot, [PostureTask(robot, weight=1.0)], [JointVelocityLimit(robot)], solver="daqp",
                               budget=2e-3)
    res = ctrl.solve(Configuration(robot), 0.002)
    assert res.ok
    assert ctrl.backend.work is ctrl.tick_budget.work
    assert ctrl.tick_budget.work.cap == 8 and ctrl.tick_budget.seconds == 2e-3
    assert 1 <= ctrl.tick_budget.work.solves <= 8
    assert np.all(np.isfinite(res.v))
