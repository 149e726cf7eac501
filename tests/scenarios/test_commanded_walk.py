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
