""":class:`wbc.tasks.frame.FrameTask` rows against the same formulas written here with Pinocchio's ``log3``, ``Jlog3``,
``Hlog3`` and ``getFrameClassicalAcceleration``, through every entry point (``compute``, ``compute_into``,
``drift``, ``compute_with_drift_into``), from targets at the frame to targets a half turn away."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from conftest import CATALOG, random_configuration
from wbc.configuration import Configuration
from wbc.constraints import ContactConstraint
from wbc.exceptions import InvalidTargetError
from wbc.tasks import ComTask, FrameTask, OrientationTask, PositionTask

#: agreement with the Pinocchio-written rows, relative to max(1, the block's largest entry): the same formulas, the
#: last bits may differ with the order of the sums
RTOL = 1e-12


def _reference_rows(task, state):
    """(error, Jacobian, drift) of ``task`` with Pinocchio's functions (the module docstring's formulas)."""
    model, data, fid = state.model, state.data, task.frame_id
    oMf = data.oMf[fid]
    rel = task.target.rotation.T @ oMf.rotation
    j_local = pin.getFrameJacobian(model, data, fid, pin.LOCAL)
    omega = pin.getFrameVelocity(model, data, fid, pin.LOCAL).angular
    alpha = pin.getFrameAcceleration(model, data, fid, pin.LOCAL).angular
    error = np.concatenate([oMf.translation - task.target.translation, pin.log3(rel)])
    jac = np.vstack([oMf.rotation @ j_local[:3], pin.Jlog3(rel) @ j_local[3:]])
    drift = np.concatenate([pin.getFrameClassicalAcceleration(model, data, fid, pin.LOCAL_WORLD_ALIGNED).linear,
                            pin.Jlog3(rel) @ alpha + pin.Hlog3(rel, omega) @ omega])
    return error[task.rows], jac[task.rows], drift[task.rows]


def _close(got, ref, rtol=RTOL) -> bool:
    return bool(np.all(np.isfinite(got))) and np.abs(got - ref).max() <= rtol * max(1.0, np.abs(ref).max())


@pytest.mark.parametrize("name", ["talos", "g1"])
def test_frame_rows_are_one_computation_equal_to_pinocchios(robots, name):
    """Every entry point gives the same numbers (bitwise: one computation), equal to Pinocchio's rows to 1e-12
    (the drift to 1e-12 + 4 ε/θ²: Pinocchio's Hlog3 forms (1 − θ sin θ / (2 (1 − cos θ))) / θ², relative error
    ≈ ε/θ²); angles from 2e-3 rad to π − 1e-3 (the half turn itself: tests/test_lie.py)."""
    from wbc.state import DynamicsState

    robot = robots(name)
    rng = np.random.default_rng(9)
    for _ in range(6):
        state = DynamicsState(robot, random_configuration(robot, rng), rng.normal(scale=0.7, size=robot.nv))
        for angle in (2e-3, 0.5, 2.0, 3.0, np.pi - 1e-3):
            for cls in (FrameTask, OrientationTask, PositionTask):
                task = cls(robot, robot.left_sole)
                axis = rng.normal(size=3)
                task.set_target(state.data.oMf[task.frame_id]
                                * pin.SE3(pin.exp3(angle * axis / np.linalg.norm(axis)), rng.normal(scale=0.1, size=3)))
                k, nv = task.dim, robot.nv
                e1, j1 = task.compute(state)
                e2, j2 = np.full(k, np.nan), np.full((k, nv), np.nan)
                task.compute_into(state, e2, j2)
                d1 = task.drift(state)
                e3, j3, d3 = np.full(k, np.nan), np.full((k, nv), np.nan), np.full(k, np.nan)
                task.compute_with_drift_into(state, e3, j3, d3)
                for a, b in ((e1, e2), (e1, e3), (j1, j2), (j1, j3), (d1, d3)):
                    assert np.array_equal(a, b), task.name
                e_ref, j_ref, d_ref = _reference_rows(task, state)
                assert _close(e1, e_ref) and _close(j1, j_ref), (task.name, angle)
                assert _close(d1, d_ref, RTOL + 4 * np.finfo(float).eps / angle**2), (task.name, angle)


def test_frame_rows_at_a_half_turn_are_finite_and_consistent(robots):
    """At exactly a half turn from the target (where Pinocchio's log3 has its singular branch) the rows are finite,
    the error is a rotation vector of length π and exp₃ of it is the relative rotation."""
    from wbc.state import DynamicsState

    robot = robots("talos")
    rng = np.random.default_rng(2)
    state = DynamicsState(robot, random_configuration(robot, rng), rng.normal(scale=0.7, size=robot.nv))
    task = OrientationTask(robot, robot.torso)
    oMf = state.data.oMf[task.frame_id]
    task.set_target(oMf * pin.SE3(pin.exp3(np.array([0.0, np.pi, 0.0])), np.zeros(3)))
    e, j = task.compute(state)
    assert abs(np.linalg.norm(e) - np.pi) <= 1e-9
    assert np.abs(pin.exp3(e) - task.target.rotation.T @ oMf.rotation).max() <= 1e-9
    assert np.all(np.isfinite(j)) and np.all(np.isfinite(task.drift(state)))


@pytest.mark.parametrize("name", CATALOG)
def test_task_errors_against_independent_values(robots, name):
    """Errors vanish at the current placement and equal the independent geometric difference elsewhere."""
    robot = robots(name)
    config = Configuration(robot, random_configuration(robot, np.random.default_rng(3)))
    task = FrameTask(robot, robot.right_sole)
    task.set_target_from_configuration(config)
    np.testing.assert_allclose(task.compute_error(config), 0, atol=1e-12)
    M = config.frame_placement(task.frame_id)
    shifted = pin.SE3(M.rotation @ pin.exp3(np.array([0.0, 0.0, 0.2])), M.translation + [0.1, 0, 0])
    task.set_target(shifted)
    np.testing.assert_allclose(task.compute_error(config), [-0.1, 0, 0, 0, 0, -0.2], atol=1e-12)
    com = ComTask()
    com.set_target(config.com + [0, 0.05, 0])
    np.testing.assert_allclose(com.compute_error(config), [0, -0.05, 0], atol=1e-12)
    contact = ContactConstraint(robot, robot.left_sole)
    contact.set_placement_from_configuration(config)
    np.testing.assert_allclose(contact.compute_error(config), 0, atol=1e-12)


def test_position_task_accepts_a_point(robots):
    robot = robots("humanoid15")
    config = Configuration(robot)
    task = PositionTask(robot, robot.right_hand)
    p = config.frame_placement(task.frame_id).translation + [0.1, 0, 0]
    task.set_target(p, velocity=[0.2, 0, 0])
    np.testing.assert_allclose(task.compute_error(config), [-0.1, 0, 0], atol=1e-12)
    np.testing.assert_allclose(task.feedforward(), [0.2, 0, 0])
    with pytest.raises(InvalidTargetError):
        task.set_target([0.0, np.nan, 0.0])
