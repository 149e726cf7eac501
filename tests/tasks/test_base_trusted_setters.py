"""Trusted internal paths: targets validated once where they enter the public API, not on every tick of the
controller's own loop. The trusted setters must give exactly the task the validated setters give."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from wbc.configuration import Configuration
from wbc.tasks import ComTask, FrameTask, OrientationTask


def test_trusted_setters_equal_the_validated_ones(robots):
    robot = robots("talos")
    config = Configuration(robot)
    rng = np.random.default_rng(3)
    M = pin.SE3(pin.rpy.rpyToMatrix(*rng.uniform(-0.3, 0.3, 3)), rng.uniform(-0.5, 0.5, 3))
    vel = rng.normal(size=6)
    for cls in (FrameTask, OrientationTask):
        a, b = cls(robot, robot.left_sole), cls(robot, robot.left_sole)
        a.set_target(M.homogeneous, vel)
        b.set_target_trusted(M.homogeneous, vel)
        for x, y in zip(a.compute(config), b.compute(config)):
            np.testing.assert_array_equal(x, y)
        np.testing.assert_array_equal(a.feedforward(), b.feedforward())
        np.testing.assert_array_equal(a.target.homogeneous, b.target.homogeneous)  # the SE3 built on first read
        b.set_target_trusted(M.homogeneous)
        assert b.feedforward() is None
    c, d = ComTask(), ComTask()
    target, cvel = config.com + 0.01, np.array([0.1, 0.0, -0.2])
    c.set_target(target, cvel)
    d.set_target_trusted(target, cvel)
    np.testing.assert_array_equal(c.compute(config)[0], d.compute(config)[0])
    np.testing.assert_array_equal(c.feedforward(), d.feedforward())


def test_the_walk_tick_uses_the_trusted_setters(robots, monkeypatch):
    """WalkController.set_references calls the validating setters only at a lift-off (the swing task starts at the
    sole's measured placement), never for the plan's rows."""
    from wbc.scenarios.walk import WalkController, plan_default_walk

    robot = robots("talos")
    config = Configuration(robot)
    plan = plan_default_walk(robot, config, n_steps=2)
    walker = WalkController(robot, config)
    calls = []
    for cls in (ComTask, FrameTask):
        monkeypatch.setattr(cls, "set_target", lambda self, *a, **k: calls.append(type(self).__name__))
    for k in range(0, len(plan.t), 25):
        walker.set_references(plan, k, config)
    lift_offs = sum(1 for ph in plan.phases if ph.support != 0)
    assert len(calls) <= lift_offs and set(calls) <= {"FrameTask"}
    assert np.array_equal(walker.com.target, plan.com[len(plan.t) - 1 - (len(plan.t) - 1) % 25])


def test_walk_references_reject_a_bad_sample_index(robots):
    """The per-tick walk path skips validation of the plan's rows, not of the index it is given."""
    import pytest

    from wbc.exceptions import InvalidInputError, InvalidTargetError
    from wbc.scenarios.walk import WalkController, plan_default_walk

    robot = robots("talos")
    config = Configuration(robot)
    plan = plan_default_walk(robot, config, n_steps=1)
    walker = WalkController(robot, config)
    for k in (-1, len(plan.t), 1.0, True, "3"):
        with pytest.raises(InvalidInputError, match="sample index"):
            walker.set_references(plan, k, config)
    walker.set_references(plan, np.int64(len(plan.t) - 1), config)
    with pytest.raises(InvalidTargetError, match="WalkPlan"):
        walker.set_plan("not a plan")
