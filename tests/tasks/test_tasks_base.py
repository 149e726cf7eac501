"""The task protocol (:class:`wbc.tasks.base.Task`), checked on every task type: its Jacobian against finite
differences (of the error along the configuration manifold; of the task's velocity-level quantity, computed by
Pinocchio or closed form, along v for the tasks with no configuration error), its drift, its inputs, its weights."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import wbc.tasks
from conftest import CATALOG, EPS, fd_jacobian, make_tasks, random_configuration, standing_controller
from wbc.configuration import Configuration
from wbc.tasks.base import Task
from wbc.exceptions import InvalidInputError, InvalidTargetError, UnknownFrameError, UnknownJointError
from wbc.tasks import (AngularMomentumTask, ComTask, DampingTask, FrameTask, OrientationTask, PostureTask,
                       RelativeFrameTask)

#: every task type wbc.tasks exports (a new one joins the finite-difference test below or fails it)
TASK_TYPES = sorted(n for n in wbc.tasks.__all__ if isinstance(getattr(wbc.tasks, n), type)
                    and issubclass(getattr(wbc.tasks, n), Task) and getattr(wbc.tasks, n) is not Task)


def _velocity_level(robot, name):
    """(task, quantity(q, v)) of a task type with no configuration error: the quantity its rows J v stand for,
    computed independently of the task."""
    model, data = robot.model, robot.model.createData()
    if name == "AngularMomentumTask":
        return AngularMomentumTask(robot), lambda q, v: pin.computeCentroidalMomentum(model, data, q, v).angular.copy()
    if name == "DampingTask":
        return DampingTask(robot, actuated_only=True), lambda q, v: v[6:].copy()
    raise AssertionError(f"{name}: no finite-difference check; add it to make_tasks (conftest) or here")


@pytest.mark.parametrize("seed", [2, 12])
@pytest.mark.parametrize("name", CATALOG)
@pytest.mark.parametrize("task_type", TASK_TYPES)
def test_jacobian_matches_finite_differences(robots, task_type, name, seed):
    """Every exported task type's Jacobian at random configurations: against central differences of its error
    along pin.integrate (the types make_tasks builds, every instance of the type), or, velocity-level, against
    central differences of its quantity along v."""
    robot = robots(name)
    rng = np.random.default_rng(seed)
    q = random_configuration(robot, rng)
    config = Configuration(robot, q)
    tasks = [t for t in make_tasks(robot, rng) if type(t).__name__ == task_type]
    for task in tasks:
        error, J = task.compute(config)
        assert error.shape == (task.dim,) and J.shape == (task.dim, robot.nv)
        np.testing.assert_allclose(J, fd_jacobian(task, robot, q), atol=2e-6, err_msg=task.name)
    if tasks:
        return
    task, quantity = _velocity_level(robot, task_type)
    error, J = task.compute(config)
    assert J.shape == (task.dim, robot.nv) and not error.any()
    v = rng.standard_normal(robot.nv)
    fd = np.empty((task.dim, robot.nv))
    for i in range(robot.nv):
        dv = np.zeros(robot.nv)
        dv[i] = EPS
        fd[:, i] = (quantity(q, v + dv) - quantity(q, v - dv)) / (2 * EPS)
    np.testing.assert_allclose(J, fd, atol=2e-6, err_msg=task.name)


def test_bad_task_inputs_raise_typed_errors(robots):
    robot = robots("talos")
    with pytest.raises(UnknownFrameError, match="left_sole_link"):
        FrameTask(robot, "left_sole")
    with pytest.raises(UnknownJointError):
        PostureTask(robot, joints=["no_such_joint"])
    task = FrameTask(robot, robot.left_sole)
    with pytest.raises(InvalidTargetError, match="4, 4"):
        task.set_target(np.eye(3))
    bad = np.eye(4)
    bad[0, 3] = np.nan
    with pytest.raises(InvalidTargetError, match="NaN"):
        task.set_target(bad)
    com = ComTask()
    with pytest.raises(InvalidTargetError):
        com.set_target([0.0, np.nan, 0.8])
    with pytest.raises(InvalidTargetError, match=r"\(3,\)"):
        com.set_target([0.0, 0.8])


def test_share_weight_keeps_the_weights_in_the_given_rows():
    """``share_weight`` copies the weights into the rows and makes them the task's weight array: in-place edits
    reach the rows; an assignment gives a new validated array again; rows of the wrong shape or type, a read-only
    array or a list raise InvalidInputError."""
    task = ComTask(weight=[1.0, 2.0, 3.0])
    buffer = np.zeros(5)
    task.share_weight(buffer[1:4])
    assert np.array_equal(buffer, [0.0, 1.0, 2.0, 3.0, 0.0]) and np.shares_memory(task.weight, buffer)
    task.weight[0] = 7.0
    assert buffer[1] == 7.0
    task.weight = 2.0
    assert not np.shares_memory(task.weight, buffer)
    assert np.array_equal(task.weight, [2.0, 2.0, 2.0]) and buffer[1] == 7.0
    read_only = np.zeros(3)
    read_only.flags.writeable = False
    for bad in (np.zeros(4), np.zeros(3, dtype=int), read_only, [0.0, 0.0, 0.0]):
        with pytest.raises(InvalidInputError, match="weight rows"):
            task.share_weight(bad)


def test_a_weight_edited_in_place_reaches_the_compiled_tick(robots):
    """The compiled tick keeps each task's weights in its stacked rows (``share_weight``): after a first tick, an
    in-place edit of ``com.weight`` gives the same next command, bit for bit, as assigning the same weights, and a
    different one from leaving them unchanged."""
    robot = robots("talos")
    config = Configuration(robot)
    ticks = {}
    for edit in ("in place", "assigned", "unchanged"):
        ctrl, com = standing_controller(robot, config)
        com.set_target(config.com + np.array([0.002, 0.001, -0.001]))
        assert ctrl.solve(config, 0.002).path == "compiled"
        if edit == "in place":
            com.weight[:] = [1.0, 100.0, 0.1]
        elif edit == "assigned":
            com.weight = [1.0, 100.0, 0.1]
        ticks[edit] = ctrl.solve(config, 0.002)
    assert all(t.ok and t.path == "compiled" for t in ticks.values())
    assert np.array_equal(ticks["in place"].v, ticks["assigned"].v)
    assert np.abs(ticks["in place"].v - ticks["unchanged"].v).max() > 1e-3


def test_new_task_inputs_raise_typed_errors(robots):
    robot = robots("talos")
    with pytest.raises(UnknownFrameError):
        RelativeFrameTask(robot, robot.right_hand, "no_such_frame")
    with pytest.raises(InvalidInputError):
        DampingTask(robot, weight=-1.0)
    with pytest.raises(InvalidInputError):
        AngularMomentumTask(robot, weight=[1.0, 2.0])
    with pytest.raises(InvalidTargetError):
        AngularMomentumTask(robot).set_target([0.0, np.inf, 0.0])


def fd_drift(task, robot, q, v, eps=1e-6):
    """d/dt (J(q(t)) v) at t = 0 along q(t) = q ⊕ t v (constant v, i.e. v̇ = 0), central differences."""
    jp = task.compute_jacobian(Configuration(robot, pin.integrate(robot.model, q, v * eps))) @ v
    jm = task.compute_jacobian(Configuration(robot, pin.integrate(robot.model, q, -v * eps))) @ v
    return (jp - jm) / (2 * eps)


@pytest.mark.parametrize("name", CATALOG)
def test_task_drifts_match_finite_differences(robots, name):
    """J̇v of every task (the acceleration-level term of the same object) = d/dt (J v) at v̇ = 0 by finite differences
    of the task's own Jacobian along the motion; the targets are far from the current pose (orientation errors up
    to ~1 rad), where the second-order terms of the orientation rows matter."""
    from wbc.state import DynamicsState

    robot = robots(name)
    rng = np.random.default_rng(3)
    q = random_configuration(robot, rng)
    v = rng.normal(scale=0.7, size=robot.nv)
    state = DynamicsState(robot, q, v)
    tasks = make_tasks(robot, rng) + [AngularMomentumTask(robot), DampingTask(robot)]
    for task in tasks:
        drift = task.drift(state)
        assert drift.shape == (task.dim,), task.name
        num = fd_drift(task, robot, q, v)
        np.testing.assert_allclose(drift, num, atol=1e-5 * max(1.0, np.abs(num).max()), err_msg=task.name)


@pytest.mark.parametrize("name", CATALOG)
def test_compute_with_drift_into_is_compute_into_then_drift(robots, name):
    """The one-pass error, Jacobian and drift of every task (the inverse-dynamics assembly's call) are the numbers of
    its separate ``compute_into`` and ``drift``: frame tasks (all rows, partial rows, position only, orientation
    only, a relative frame, whose drift comes from Pinocchio's frame velocities of the two frames) far from their
    targets, at their targets, just above the small-angle threshold and near a half turn, the CoM and posture tasks.
    Frame tasks' rows against Pinocchio's log3, Jlog3, Hlog3: tests/tasks/test_frame.py. Equal to 1e-12 times each
    block's largest entry (at least 1), the drift rows to 1e-12 + 4 ε/θ² (the Hlog₃ form's relative error ≈ ε/θ²)."""
    from wbc.state import DynamicsState

    robot = robots(name)
    rng = np.random.default_rng(7)
    q = random_configuration(robot, rng)
    v = rng.normal(scale=0.7, size=robot.nv)
    state = DynamicsState(robot, q, v)
    tasks = make_tasks(robot, rng)
    at_target = FrameTask(robot, robot.left_sole)
    at_target.set_target(state.data.oMf[at_target.frame_id])
    small = OrientationTask(robot, robot.torso)
    small.set_target(state.data.oMf[small.frame_id] * pin.SE3(pin.exp3(np.array([2e-4, -1e-4, 3e-4])), np.zeros(3)))
    tasks += [at_target, small]
    for angle in (1.2e-3, 3e-3, 3.0, np.pi - 1e-8):
        for cls in (FrameTask, OrientationTask):
            task = cls(robot, robot.right_sole)
            axis = rng.normal(size=3)
            task.set_target(state.data.oMf[task.frame_id]
                            * pin.SE3(pin.exp3(angle * axis / np.linalg.norm(axis)), rng.normal(scale=0.1, size=3)))
            tasks.append(task)
    eps = np.finfo(float).eps
    for task in tasks:
        k, nv = task.dim, robot.nv
        e1, j1 = np.full(k, np.nan), np.full((k, nv), np.nan)
        task.compute_into(state, e1, j1)
        d1 = np.array(task.drift(state))
        e2, j2, d2 = np.full(k, np.nan), np.full((k, nv), np.nan), np.full(k, np.nan)
        task.compute_with_drift_into(state, e2, j2, d2)
        theta = 1.0
        if isinstance(task, FrameTask) and task.dim > 0:
            rel = task.target.rotation.T @ state.data.oMf[task.frame_id].rotation
            theta = max(float(np.linalg.norm(pin.log3(rel))), 1e-3)
        for got, ref, rtol in ((e2, e1, 1e-12), (j2, j1, 1e-12), (d2, d1, 1e-12 + 4 * eps / theta**2)):
            assert np.all(np.isfinite(got)), task.name
            np.testing.assert_allclose(got, ref, rtol=0, atol=rtol * max(np.abs(ref).max(), 1.0),
                                       err_msg=task.name)
