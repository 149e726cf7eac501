"""The recovery of a failed kinematic tick (:mod:`wbc.controllers.recovery`): infeasible hard constraints give no
exception, no NaN, a safe command ('constraints_only', 'contacts_held' or 'hold') and a report naming the conflict;
the diagnosis agrees with an independent feasibility oracle (HiGHS's LP); a run of failures does not latch."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from conftest import CATALOG, highs_feasible
from wbc.configuration import Configuration
from wbc.constraints import ContactConstraint, EqualityConstraint, JointPositionLimit, JointVelocityLimit
from wbc.controllers.kinematic import KinematicController
from wbc.exceptions import InvalidInputError
from wbc.tasks import ComTask, FrameTask, PostureTask
from wbc.tasks.base import Task

DT = 0.002


def standing(robot, config, *tasks):
    contacts = [ContactConstraint(robot, f) for f in (robot.left_sole, robot.right_sole)]
    for c in contacts:
        c.set_placement_from_configuration(config)
    com = ComTask()
    com.set_target(config.com)
    # no tick budget: these tests check the diagnosis, which a budget spent under the machine's load would skip
    ctrl = KinematicController(robot, [com, PostureTask(robot), *tasks],
                               [*contacts, JointPositionLimit(robot), JointVelocityLimit(robot)], budget=math.inf)
    return ctrl, contacts


def add_far_foot(robot, config, ctrl, name: str = "left_foot_target", frame: str | None = None, offset=(1.0, 0.0, 0.0)):
    """Add to ``ctrl`` a hard task sending the sole ``frame`` (default the left one) ``offset`` (m, world) away
    from where it is at ``config``, against its contact; returns the task."""
    foot = FrameTask(robot, frame or robot.left_sole, gain=10.0, name=name)
    target = config.frame_placement(foot.frame_id).copy()
    target.translation += offset
    foot.set_target(target)
    ctrl.add_task(foot, hard=True)
    return foot


@pytest.mark.parametrize("name", CATALOG)
def test_hard_foot_target_against_fixed_feet(robots, name):
    """Both feet are contacts and a hard task asks the left foot to go 1 m forward: every tick returns a finite
    command without raising, flagged (ok False), naming both the contact and the hard task with their violation
    (m/s, rad/s); the command is the constraints-only fallback: the contacts and limits hold."""
    robot = robots(name)
    config = Configuration(robot)
    ctrl, contacts = standing(robot, config)
    foot = add_far_foot(robot, config, ctrl)
    for _ in range(20):
        res = ctrl.solve(config, DT)
        assert not res.ok and np.isfinite(res.v).all()
        names = [n for n, _ in res.conflicts]
        assert "left_foot_target" in names and f"contact:{robot.left_sole}" in names, res.conflicts
        assert all(viol > 1.0 for n, viol in res.conflicts if n in ("left_foot_target", f"contact:{robot.left_sole}"))
        assert [v for _, v in res.conflicts] == sorted((v for _, v in res.conflicts), reverse=True)
        assert res.fallback == "constraints_only"
        for c in contacts:
            J, b = c.compute(config, DT)
            assert np.max(np.abs(J @ res.v - b)) < 1e-3
        config.update(config.integrate(res.v, DT))
    print(f"\n{name}: {res.message}")
    # the conflict gone, the next tick is ok again
    ctrl.remove_task(foot)
    assert ctrl.solve(config, DT).ok


def test_conflicting_constraints_keep_the_contacts_where_they_are(robots):
    """A contact placed 1 m away from its sole (100 m/s asked) against the joint velocity limits: the constraint
    objects themselves conflict, and the report names both. The safe command is then the soft level under the
    constraints without the contacts' drift correction ('contacts_held'): both soles stay where they are to first
    order (J_c v = 0; forward kinematics after the tick: moved ≤ 10 µm, measured 2.4 µm), the joint velocity limits
    hold, and the command is not v = 0."""
    robot = robots("talos")
    config = Configuration(robot)
    ctrl, contacts = standing(robot, config)
    moved = config.frame_placement(contacts[0].frame_id).copy()
    moved.translation += [1.0, 0.0, 0.0]
    contacts[0].set_placement(moved)
    ctrl.tasks[0].set_target(config.com + np.array([0.02, 0.0, 0.0]))  # the soft level asks for motion
    soles = [config.frame_placement(c.frame_id).copy() for c in contacts]
    res = ctrl.solve(config, DT)
    assert not res.ok and res.fallback == "contacts_held"
    assert np.abs(res.v).max() > 1e-6
    assert np.all(np.abs(res.v[6:]) <= robot.model.velocityLimit[6:] + 1e-9)
    after = Configuration(robot, config.integrate(res.v, DT))
    for c, before in zip(contacts, soles):
        assert np.linalg.norm(pin.log6(before.actInv(after.frame_placement(c.frame_id))).vector) < 1e-5
    names = [n for n, _ in res.conflicts]
    assert f"contact:{robot.left_sole}" in names and "joint_velocity_limit" in names, res.conflicts
    print(f"\n{res.message}")


class NanTask(Task):
    dim = 1
    name = "nan_task"

    def __init__(self):
        super().__init__(gain=1.0, weight=1.0)

    def compute(self, config):
        return np.array([np.nan]), np.ones((1, config.model.nv))


class BrokenConstraint(EqualityConstraint):
    name = "broken"
    dim = 1

    def compute(self, config, dt):
        raise RuntimeError("sensor unplugged")


def test_nan_task_and_raising_constraint_do_not_escape(robots):
    robot = robots("humanoid15")
    config = Configuration(robot)
    ctrl, _ = standing(robot, config, NanTask())
    res = ctrl.solve(config, DT)
    assert not res.ok and np.isfinite(res.v).all() and res.fallback == "hold"
    assert ("nan_task" in [n for n, _ in res.conflicts]), res.conflicts
    ctrl2, _ = standing(robot, config)
    ctrl2.add_constraint(BrokenConstraint())
    res = ctrl2.solve(config, DT)
    assert not res.ok and np.array_equal(res.v, np.zeros(robot.nv)) and "sensor unplugged" in res.message
    with pytest.raises(InvalidInputError):
        ctrl2.solve(config, float("nan"))


def test_infeasible_hard_set_under_a_hierarchy(robots):
    """With strict levels the same conflict is reported and the fallback drops the levels and the hard task."""
    robot = robots("talos")
    config = Configuration(robot)
    ctrl, _ = standing(robot, config)
    hand = FrameTask(robot, robot.right_hand, gain=5.0)
    hand.set_target_from_configuration(config)
    ctrl.add_task(hand, level=0)
    add_far_foot(robot, config, ctrl, "right_foot_target", robot.right_sole, (0.0, 0.0, 1.0))
    res = ctrl.solve(config, DT)
    assert not res.ok and res.fallback == "constraints_only" and np.isfinite(res.v).all()
    assert {"right_foot_target", f"contact:{robot.right_sole}"} <= {n for n, _ in res.conflicts}


def test_diagnosis_agrees_with_an_lp_feasibility_oracle(robots):
    """``diagnose`` at a feasible stance names nothing; with a hard foot target 1 m forward it names the hard task,
    and HiGHS's LP finds the assembled hard set empty with the task and non-empty without it."""
    robot = robots("humanoid15")
    config = Configuration(robot)
    ctrl, _ = standing(robot, config)
    assert ctrl.diagnose(config, DT) == []
    assert highs_feasible(*ctrl.assemble(config, DT)[2:])
    foot = add_far_foot(robot, config, ctrl)
    assert not highs_feasible(*ctrl.assemble(config, DT)[2:])
    names = [n for n, _ in ctrl.diagnose(config, DT)]
    assert "left_foot_target" in names, names
    ctrl.remove_task(foot)
    assert highs_feasible(*ctrl.assemble(config, DT)[2:])


def test_a_run_of_failed_ticks_does_not_latch(robots):
    """Five ticks that fail (the hard foot target above) each answer a finite safe command that keeps the joint
    velocity limits (checked against the model's limits), counted 1..5; the tick after the conflict is removed is ok
    and its command, with a CoM target 2 cm forward, is the one a fresh controller gives at the same configuration
    (within 1e-9). (Moved here from test_kinematic_solve_core's test_failures_counted_and_never_latch, with the fresh
    controller added.)"""
    robot = robots("humanoid15")
    config = Configuration(robot)
    ctrl, _ = standing(robot, config)
    foot = add_far_foot(robot, config, ctrl)
    for k in range(1, 6):
        res = ctrl.solve(config, DT)
        assert not res.ok and res.consecutive_failures == k and np.isfinite(res.v).all()
        assert res.fallback in ("constraints_only", "contacts_held", "hold") and res.path == f"fallback:{res.fallback}"
        assert np.all(np.abs(res.v[6:]) <= robot.model.velocityLimit[6:] + 1e-9)
        config.update(config.integrate(res.v, DT))
    ctrl.remove_task(foot)
    fresh, fresh_contacts = standing(robot, config)
    for c, c0 in zip(fresh_contacts, (c for c in ctrl.constraints if isinstance(c, ContactConstraint))):
        c.set_placement(c0.placement)
    for controller in (ctrl, fresh):  # the CoM task asks for motion: the answer depends on the whole QP
        controller.tasks[0].set_target(config.com + np.array([0.02, 0.0, 0.0]))
    res, ref = ctrl.solve(config, DT), fresh.solve(config, DT)
    assert res.ok and ctrl.consecutive_failures == 0 and ref.ok
    assert np.abs(ref.v).max() > 1e-3
    assert np.abs(res.v - ref.v).max() < 1e-9, np.abs(res.v - ref.v).max()
