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


def test_may_start_with_a_cost_asks_the_clock_guard_only_when_it_is_on():
    b = _budget()
    assert b.may_start("retry", cost=10.0)  # no clock guard: a cost never stops a stage
    b.clock_guard = True
    b.start(2e-3, 2.5e-4, clock_weight=1.4)
    assert not b.may_start("stage", cost=10.0)  # 10 s > 1.5 × 2 ms
    assert not b.fits(0.0, deadline=-1.0)
    assert b.fits(-10.0)  # any CPU time so far minus 10 s is within 1.5 × 2 ms


def test_an_unknown_stage_is_a_typed_error_naming_the_valid_ones():
    with pytest.raises(InvalidInputError, match="retry, stage"):
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


def test_a_stage_of_given_work_counts_it_beside_the_work_done_and_the_reserve():
    """A cascade's runs of 2 levels at LEVEL_WORK 0.5 count at least 2 × 1.5 = 3 solves each (``_plan_levels``); they
    may start as a 'stage' while they end within 1.75 × 8 = 14 with the weighted form's reserve (0.75 × 8 = 6) counted
    as done."""
    b = _budget()
    b.work.reserve = 6.0
    assert b.may_start("stage", work=2 * 2 * 1.5)  # a steady tick: 0 + 6 + 2 × 3 = 12 ≤ 14
    b.work.add(4)  # a new layout's LAYOUT_WORK
    assert not b.may_start("stage", work=2 * 2 * 1.5)  # 4 + 6 + 6 = 16 > 14: its contact correction cannot fit
    assert b.may_start("stage", work=2 * 1.5)  # without a correction: 4 + 6 + 3 = 13 ≤ 14
    assert not b.may_start("stage", work=3 * 1.5)  # 4 + 6 + 4.5 = 14.5 > 14
    b.start(math.inf, 2.5e-4, clock_weight=1.4)
    b.work.add(1e6)
    assert b.may_start("stage", work=2 * 50 * 1.5)  # no cap


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


class FakeClock:
    """A CPU clock for the budget (``TickBudget(timer=...)``): reads ``t``."""

    def __init__(self):
        self.t = 0.0

    def __call__(self) -> float:
        return self.t


def _clocked(clock_guard: bool) -> tuple[TickBudget, FakeClock]:
    clock = FakeClock()
    b = TickBudget(timer=clock)
    b.clock_guard = clock_guard
    b.stage_factor = 1.75
    b.start(2e-3, 2.5e-4, clock_weight=1.4)  # cap 8; clock guard: 2 ms / (1.4 × 8) of CPU time per solve
    return b, clock


def test_the_clock_guard_stops_a_stage_when_the_time_is_spent_not_before():
    b, clock = _clocked(clock_guard=True)
    assert b.work.solves == 0 and b.may_start("retry") and b.may_start("stage")
    clock.t = 1.8e-3  # 1.8 ms / (2 ms / 11.2) = 10.08 solves: past one cap (8), within 1.75 caps (14)
    assert b.work.solves == pytest.approx(10.08)
    assert not b.may_start("retry") and b.may_start("stage")
    clock.t = 2.6e-3  # 14.56 solves > 14
    assert not b.may_start("stage")
    # no solve was counted: the clock alone stopped them; without the guard the same clock stops nothing
    free, free_clock = _clocked(clock_guard=False)
    free_clock.t = 2.6e-3
    assert free.work.solves == 0 and free.may_start("retry") and free.may_start("stage")


def test_the_first_solve_gets_an_iteration_cap_from_the_time_left():
    b, clock = _clocked(clock_guard=True)
    assert b.iteration_cap(100) == 100  # no cost per iteration measured yet: the solver's own cap
    b.note_first_solve(10, 1e-4)  # 10 µs per iteration
    assert b.iteration_cost == pytest.approx(1e-5)
    clock.t = 0.5e-3  # 1.5 ms left of one budget: 150 iterations, the solver's own 100 is smaller
    assert b.iteration_cap(100) == 100
    clock.t = 1.9e-3  # 0.1 ms left: 10 iterations
    assert b.iteration_cap(100) == 10
    clock.t = 2.5e-3  # past the budget: one iteration (the kernel gives up, its rescue is bounded by the count)
    assert b.iteration_cap(100) == 1
    b.note_first_solve(10, 1e-5)  # a faster sample: the cost decays by 0.9 per tick, not at once
    assert b.iteration_cost == pytest.approx(0.9e-5)
    off, off_clock = _clocked(clock_guard=False)
    off.note_first_solve(10, 1e-4)
    off_clock.t = 1.9e-3
    assert off.iteration_cap(100) == 100  # without the clock guard a count: reproducible


def _posture_controller(robots, **options):
    from wbc.constraints import JointVelocityLimit
    from wbc.controllers.kinematic import KinematicController
    from wbc.tasks import PostureTask

    robot = robots("talos")
    task = PostureTask(robot, weight=1.0, gain=1e3)  # (a target far away, at a high gain)
    ctrl = KinematicController(robot, [task], [JointVelocityLimit(robot)], solver="fast", budget=2e-3, **options)
    target = robot.q_ref.copy()
    target[7:] += 0.5  # far: many joints at their speed limits (many active bounds)
    task.set_target(target)
    return robot, ctrl


def test_the_first_solve_of_a_clock_guarded_tick_stops_at_its_iteration_cap(robots):
    from wbc.configuration import Configuration

    robot, free = _posture_controller(robots)
    res = free.solve(Configuration(robot), 0.002)
    assert res.ok and res.path.route == "compiled"
    assert free.backend.last_kernel_iterations > 3  # cold: the compiled solve needs more than the cap below
    for cost, route in ((2e-3 / 3.5, "general"), (1e-12, "compiled")):
        robot, ctrl = _posture_controller(robots, clock_guard=True)
        ctrl.tick_budget.work.timer = FakeClock()  # CPU time 0: the cost sets the cap
        ctrl.tick_budget.iteration_cost = cost  # 2 ms / 3.5: one budget holds 3 iterations
        res = ctrl.solve(Configuration(robot), 0.002)
        # capped at 3, the compiled solve gives up and the general path answers; at a negligible cost it runs to
        # its own cap (100) and answers as without the guard
        assert res.ok and res.path.route == route and np.all(np.isfinite(res.v))
