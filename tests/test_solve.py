"""wbc.solve_ik, the stateless one-call entry point, against the stateful controller and a closed form."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import wbc
from wbc.configuration import Configuration
from wbc.constraints import ContactConstraint, JointPositionLimit, JointVelocityLimit
from wbc.controllers.kinematic import KinematicController
from wbc.exceptions import ConfigurationError, InfeasibleProblemError
from wbc.tasks import ComTask, OrientationTask, PostureTask

DT = 0.002


def _standing(robot, config):
    contacts = [ContactConstraint(robot, f) for f in (robot.left_sole, robot.right_sole)]
    for c in contacts:
        c.set_placement_from_configuration(config)
    com = ComTask(weight=10.0)
    com.set_target(config.com + np.array([0.01, -0.02, -0.01]))
    torso = OrientationTask(robot, robot.torso, name="torso")
    torso.set_target_from_configuration(config)
    tasks = [com, torso, PostureTask(robot, weight=1e-2)]
    return tasks, [*contacts, JointPositionLimit(robot), JointVelocityLimit(robot)]


@pytest.mark.parametrize("name", ["talos", "g1"])
def test_solve_ik_equals_the_stateful_controller(robots, name):
    robot = robots(name)
    config = Configuration(robot)
    tasks, constraints = _standing(robot, config)
    v = wbc.solve_ik(robot, robot.q_ref, tasks, DT, constraints, solver="daqp")
    ctrl = KinematicController(robot, tasks, constraints, solver="daqp")
    result = ctrl.solve(config, DT)
    assert result.ok
    assert v.shape == (robot.model.nv,)
    np.testing.assert_allclose(v, result.v, atol=1e-12)
    # the contacts hold over the tick (second order, wbc.formulations.velocity's contact correction): the soles at
    # q ⊕ v dt (Pinocchio FK) are within 1 µm of where they were set (measured 0.02–0.48 µm at |v| up to 9.7 rad/s)
    q1 = pin.integrate(robot.model, robot.q_ref, v * DT)
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, q1)
    for frame in (robot.left_sole, robot.right_sole):
        fid = robot.frame_id(frame)
        assert np.linalg.norm(data.oMf[fid].translation - config.data.oMf[fid].translation) < 1e-6


def test_solve_ik_matches_the_closed_form_without_constraints(robots):
    """One CoM task, no constraints: v = (w JᵀJ + εI)⁻¹ w Jᵀ v*, with J the CoM Jacobian from Pinocchio and
    v* = −K (c − c*)."""
    robot = robots("talos")
    q = robot.q_ref.copy()
    target = pin.centerOfMass(robot.model, robot.model.createData(), q) + np.array([0.02, 0.01, -0.03])
    com = ComTask(weight=3.0, gain=50.0)
    com.set_target(target)
    eps = 1e-4
    v = wbc.solve_ik(robot, q, [com], DT, damping=eps, solver="daqp")
    data = robot.model.createData()
    J = pin.jacobianCenterOfMass(robot.model, data, q)
    v_star = -50.0 * (data.com[0] - target)
    expected = np.linalg.solve(3.0 * J.T @ J + eps * np.eye(robot.model.nv), 3.0 * J.T @ v_star)
    np.testing.assert_allclose(v, expected, atol=1e-7)


def test_solve_ik_names_the_conflict_or_returns_the_safe_command(robots):
    robot = robots("talos")
    config = Configuration(robot)
    # the same sole held at two placements 5 cm apart: the contacts contradict each other
    a, b = ContactConstraint(robot, robot.left_sole, name="left_here"), ContactConstraint(
        robot, robot.left_sole, name="left_there")
    a.set_placement_from_configuration(config)
    moved = config.frame_placement(robot.frame_id(robot.left_sole)).copy()
    moved.translation[0] += 0.05
    b.set_placement(moved)
    com = ComTask()
    com.set_target(config.com)
    # the contradicting contacts are named (whether the core fails on the rows or on the drift left after
    # making the dependent rows consistent)
    with pytest.raises(InfeasibleProblemError, match="left_here.*left_there|left_there.*left_here") as info:
        wbc.solve_ik(robot, robot.q_ref, [com], DT, [a, b])
    assert {"left_here", "left_there"} <= {name for name, _ in info.value.conflicts}
    assert all(violation > 0 for _, violation in info.value.conflicts)
    v = wbc.solve_ik(robot, robot.q_ref, [com], DT, [a, b], safe_fallback=True)
    assert v.shape == (robot.model.nv,) and np.all(np.isfinite(v))


def test_solve_ik_rejects_a_bad_configuration(robots):
    robot = robots("talos")
    with pytest.raises(ConfigurationError):
        wbc.solve_ik(robot, robot.q_ref[:-1], [ComTask()], DT)
