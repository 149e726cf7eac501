"""The kinematic controller keeps its constraint and task layouts per list of constraints and tasks (a support switch
that comes back to an earlier set reuses them) and remembers the objects it checked against its robot: none of
this may be stale. Each tick of a random sequence of changes (contacts removed and added back in another order, a
swing task added and removed, a hard task, a joint limit removed and restored, task weights and gains assigned or
edited in place) is compared with the tick of a controller built fresh on the same tasks and constraints, in the
same order, at the same configuration."""

from __future__ import annotations

import numpy as np
import pytest

from wbc import KinematicController
from wbc.configuration import Configuration
from wbc.constraints import ContactConstraint, JointPositionLimit, JointVelocityLimit
from wbc.constraints.task import TaskConstraint
from wbc.exceptions import InvalidInputError
from wbc.tasks import ComTask, FrameTask, OrientationTask, PostureTask

DT = 0.002


def _fresh(robot, ctrl: KinematicController) -> KinematicController:
    """A controller built from nothing on ``ctrl``'s tasks and constraints (hard tasks in their places)."""
    fresh = KinematicController(robot, list(ctrl.tasks))
    for c in ctrl.constraints:
        if isinstance(c, TaskConstraint):
            fresh.add_task(c.task, hard=True)
        else:
            fresh.add_constraint(c)
    return fresh


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_cached_layouts_solve_as_a_fresh_controller(robots, seed):
    robot = robots("talos")
    rng = np.random.default_rng(seed)
    config = Configuration(robot)
    com = ComTask(weight=10.0, gain=50.0)
    com.set_target(config.com + np.array([0.01, 0.0, -0.01]))
    torso = OrientationTask(robot, robot.torso, weight=1.0, gain=20.0, name="torso")
    torso.set_target_from_configuration(config)
    posture = PostureTask(robot, weight=1e-2, gain=5.0)
    posture.set_target(config.q)
    frames = {"left": robot.left_sole, "right": robot.right_sole}
    contact = {s: ContactConstraint(robot, f, gain=100.0) for s, f in frames.items()}
    swing = {s: FrameTask(robot, f, position_weight=10.0, orientation_weight=10.0, gain=50.0, name=f"swing:{s}")
             for s, f in frames.items()}
    for c in contact.values():
        c.set_placement_from_configuration(config)
    position, velocity = JointPositionLimit(robot), JointVelocityLimit(robot)
    ctrl = KinematicController(robot, [com, torso, posture], [contact["left"], contact["right"], position, velocity])
    hard = OrientationTask(robot, robot.torso, weight=1.0, gain=10.0, name="torso:hard")
    hard.set_target_from_configuration(config)

    def lift(side):
        if contact[side] in ctrl.constraints and len([c for c in contact.values() if c in ctrl.constraints]) == 2:
            ctrl.remove_constraint(contact[side])
            swing[side].set_target_from_configuration(config)
            target = swing[side].target.copy()
            target.translation[2] += 0.01
            swing[side].set_target(target)
            ctrl.add_task(swing[side])

    def land(side):
        if contact[side] not in ctrl.constraints:
            ctrl.remove_task(swing[side])
            contact[side].set_placement_from_configuration(config)
            ctrl.add_constraint(contact[side])

    def toggle_hard():
        if hard in ctrl.hard_tasks:
            ctrl.remove_task(hard)
        else:
            hard.set_target_from_configuration(config)
            ctrl.add_task(hard, hard=True)

    def toggle_limit():
        if velocity in ctrl.constraints:
            ctrl.remove_constraint(velocity)
        else:
            ctrl.add_constraint(velocity)

    def weights():
        com.weight = float(rng.uniform(1.0, 20.0))  # assigned: a new array
        torso.weight[:] = rng.uniform(0.5, 2.0, torso.dim)  # edited in place (the controller's stacked rows)
        for s in swing:
            swing[s].gain = float(rng.uniform(20.0, 80.0))

    ops = [lambda: lift("left"), lambda: lift("right"), lambda: land("left"), lambda: land("right"), toggle_hard,
           toggle_limit, weights, lambda: None]
    layouts = set()
    for _ in range(80):
        ops[rng.integers(len(ops))]()
        layouts.add(tuple(map(id, ctrl.constraints)) + (None,) + tuple(map(id, ctrl.tasks)))
        v = ctrl.solve(config, DT).v.copy()
        ref = _fresh(robot, ctrl).solve(config, DT).v
        # the same optimum from another warm start (the active-set solver's last solve on the same active set)
        np.testing.assert_allclose(v, ref, rtol=0, atol=1e-12 * max(1.0, float(np.abs(ref).max())))
        config.step(v, DT)
    assert len(layouts) >= 4  # the sequence came back to earlier layouts and met new ones


def test_a_foreign_object_is_refused_after_its_twin_was_checked(robots):
    """The objects remembered as checked are these very objects: a constraint of another robot is refused even when
    one of this robot (same class, same frame name) was added and removed before."""
    talos, g1 = robots("talos"), robots("g1")
    ctrl = KinematicController(talos)
    own = ContactConstraint(talos, talos.left_sole)
    ctrl.add_constraint(own)
    ctrl.remove_constraint(own)
    ctrl.add_constraint(own)
    with pytest.raises(InvalidInputError):
        ctrl.add_constraint(ContactConstraint(g1, g1.left_sole))
    with pytest.raises(InvalidInputError):
        ctrl.add_task(PostureTask(g1))
