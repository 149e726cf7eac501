"""WalkController.set_plan builds the layouts of the plan's support phases ahead of the ticks
(StanceController.prepare_supports → KinematicController.prepare_layouts): no tick of the walk builds a QP layout,
and every command is bit-identical to a controller that builds each phase's layout in its first tick."""

from __future__ import annotations

import numpy as np
import pytest

import wbc
import wbc.formulations.velocity as velocity
from wbc.configuration import Configuration
from wbc.scenarios.walk import WalkController, plan_default_walk


@pytest.fixture(scope="module")
def talos():
    return wbc.load_robot("talos")


def _walk(robot, plan, prepare: bool, builds: list | None = None) -> np.ndarray:
    config = Configuration(robot)
    walker = WalkController(robot, config, solver="fast")
    if prepare:
        walker.set_plan(plan)
    else:  # the plan's rows without the prepared layouts: the tick that first meets a phase builds it
        walker.prepare_supports = lambda *args: None
        walker.set_plan(plan)
    if builds is not None:
        builds.clear()
    V = np.empty((len(plan.t), robot.model.nv))
    for k in range(len(plan.t)):
        walker.set_references(plan, k, config)
        res = walker.solve(config, plan.dt)
        assert res.ok
        V[k] = res.v
        config.step(res.v, plan.dt)
    return V


def test_prepared_walk_builds_no_layout_in_its_ticks_and_answers_the_same(talos, monkeypatch):
    plan = plan_default_walk(talos, n_steps=2)
    assert {0, 1, 2} <= set(plan.support.tolist())  # double support and both single supports
    builds: list = []
    real_pack = velocity.kinematic_pack

    def counting_pack(*args):
        builds.append(args)
        return real_pack(*args)

    monkeypatch.setattr(velocity, "kinematic_pack", counting_pack)
    reference = _walk(talos, plan, prepare=False, builds=builds)
    assert len(builds) == 3  # one layout per support phase, each built in the phase's first tick
    prepared = _walk(talos, plan, prepare=True, builds=builds)
    assert builds == []  # every phase's layout was built at set_plan
    np.testing.assert_array_equal(prepared, reference)


def test_prepare_supports_leaves_the_controller_as_it_was(talos):
    config = Configuration(talos)
    walker = WalkController(talos, config, solver="fast")
    tasks, constraints = list(walker.controller.tasks), list(walker.controller.constraints)
    walker.prepare_supports([0, 1, 2], config, 0.002)
    assert walker.controller.tasks == tasks and walker.controller.constraints == constraints
    assert walker.support == 0 and walker.stance == {"left": True, "right": True}


def test_prepare_layouts_rejects_a_bad_period(talos):
    walker = WalkController(talos, Configuration(talos), solver="fast")
    with pytest.raises(wbc.exceptions.InvalidInputError):
        walker.controller.prepare_layouts([], Configuration(talos), float("nan"))


@pytest.mark.parametrize("codes, dt", [([0, 3], 0.002), ([1, -1], 0.002), ([0, 1.5], 0.002), ([0, 1], 0.0),
                                       ([2], float("nan"))])
def test_prepare_supports_rejects_unknown_support_codes_and_bad_dt(talos, codes, dt):
    """A code other than 0, 1, 2 (it would build a layout with no sole in contact) or a dt not finite and > 0 is a
    typed error naming what is valid; the controller's tasks and constraints stay as they were."""
    from wbc.exceptions import InvalidInputError

    config = Configuration(talos)
    walker = WalkController(talos, config, solver="fast")
    before = (list(walker.controller.tasks), list(walker.controller.constraints))
    with pytest.raises(InvalidInputError, match="support codes must be|dt must be"):
        walker.prepare_supports(codes, config, dt)
    assert (list(walker.controller.tasks), list(walker.controller.constraints)) == before
