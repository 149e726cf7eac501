"""CommandedWalk.clock_guard: set on the kinematic controller at once and kept over reset (a new controller)."""

from __future__ import annotations

from wbc.scenarios.commanded_walk import CommandedWalk


def test_the_clock_guard_reaches_the_controller_and_survives_a_reset(robots):
    walk = CommandedWalk(robots("talos"))
    assert walk.clock_guard is False and walk.walker.controller.clock_guard is False  # off by default
    walk.clock_guard = True
    assert walk.walker.controller.clock_guard is True
    before = walk.walker
    walk.reset()
    assert walk.walker is not before  # reset builds a new controller ...
    assert walk.clock_guard is True and walk.walker.controller.clock_guard is True  # ... with the guard still on
    walk.clock_guard = False
    assert walk.walker.controller.clock_guard is False


def _streamed_walk(robot, ticks, early):
    """q per tick of a CommandedWalk under a streamed command that changes every 1.5 s (forward, turn, side,
    stop), with ``plan_ahead`` = ``early``."""
    import numpy as np

    walk = CommandedWalk(robot)
    walk.plan_ahead = early
    pattern = [(0.2, 0.0, 0.0), (0.1, 0.0, 0.3), (0.0, 0.05, 0.0), (0.0, 0.0, 0.0)]
    qs = []
    for _ in range(ticks):
        walk.set_velocity(*pattern[int(walk.t / 1.5) % 4])
        walk.tick()
        qs.append(walk.q.copy())
    return np.array(qs), walk


def test_touchdown_replan_planned_ahead_gives_the_same_walk(robots):
    """The re-plan computed three ticks before a touch-down (CommandedWalk module docstring) is the plan the
    touch-down tick would have made: the same joint trajectory, bit for bit, as re-planning in that tick."""
    import numpy as np

    robot = robots("g1")
    ahead, walk = _streamed_walk(robot, 3000, early=True)
    assert walk.touchdowns >= 4 and walk.replans >= 4, (walk.touchdowns, walk.replans)
    assert walk.early_replans >= 2, walk.early_replans  # the planned-ahead path was taken
    in_tick, walk = _streamed_walk(robot, 3000, early=False)
    assert walk.early_replans == 0
    assert np.array_equal(ahead, in_tick), float(np.abs(ahead - in_tick).max())


def test_plan_ahead_refuses_a_non_bool(robots):
    import pytest

    from wbc.exceptions import InvalidInputError

    walk = CommandedWalk(robots("humanoid15"))
    assert walk.plan_ahead is True
    for bad in (1, "no", None):
        with pytest.raises(InvalidInputError, match="plan_ahead must be True or False"):
            walk.plan_ahead = bad
    walk.plan_ahead = False
    assert walk.plan_ahead is False
