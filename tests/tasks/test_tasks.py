"""Each task's error and Jacobian against finite differences along the configuration manifold."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from conftest import CATALOG, EPS, fd_jacobian, make_tasks, random_configuration, standing_controller
from wbc.configuration import Configuration
from wbc.constraints import ContactConstraint
from wbc.tasks.base import Task
from wbc.exceptions import InvalidInputError, InvalidTargetError, UnknownFrameError, UnknownJointError
from wbc.tasks import (AngularMomentumTask, ComTask, DampingTask, FrameTask, OrientationTask, PositionTask,
                       PostureTask, RelativeFrameTask)

# Tasks with no position error (velocity-level): their Jacobian is checked against another oracle, named here.
VELOCITY_LEVEL_TASKS = {"AngularMomentumTask": "test_angular_momentum_matrix (Pinocchio and a sum over bodies)",
                        "DampingTask": "test_damping_task_adds_its_weights_to_the_diagonal"}


def test_every_task_type_has_its_jacobian_checked(robots):
    """A task type exported by wbc.tasks is either built by make_tasks (its Jacobian then checked by finite
    differences below) or named in VELOCITY_LEVEL_TASKS with the test that checks it."""
    import wbc.tasks

    exported = {n for n in wbc.tasks.__all__ if isinstance(getattr(wbc.tasks, n), type)
                and issubclass(getattr(wbc.tasks, n), Task) and getattr(wbc.tasks, n) is not Task}
    built = {type(t).__name__ for t in make_tasks(robots("talos"), np.random.default_rng(0))}
    assert exported - built == set(VELOCITY_LEVEL_TASKS), exported - built
    assert all(test.split()[0] in globals() for test in VELOCITY_LEVEL_TASKS.values())


@pytest.mark.parametrize("seed", [2, 12, 22])
@pytest.mark.parametrize("name", CATALOG)
def test_task_jacobians_match_finite_differences(robots, name, seed):
    """Every task's Jacobian against central differences of its error along pin.integrate, at random
    configurations (three per robot)."""
    robot = robots(name)
    rng = np.random.default_rng(seed)
    q = random_configuration(robot, rng)
    config = Configuration(robot, q)
    for task in make_tasks(robot, rng):
        error, J = task.compute(config)
        assert error.shape == (task.dim,) and J.shape == (task.dim, robot.nv)
        np.testing.assert_allclose(J, fd_jacobian(task, robot, q), atol=2e-6, err_msg=task.name)


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


@pytest.mark.parametrize("name", CATALOG)
def test_relative_frame_task_error_is_the_relative_pose(robots, name):
    """Independent geometry: rMf from the two world placements (homogeneous matrices), error = its translation
    minus the target's and the rotation vector of R*ᵀ R_rel (scipy), zero at the current relative placement."""
    from scipy.spatial.transform import Rotation

    robot = robots(name)
    config = Configuration(robot, random_configuration(robot, np.random.default_rng(5)))
    hand = robot.right_hand or robot.right_sole
    task = RelativeFrameTask(robot, hand, robot.torso)
    task.set_target_from_configuration(config)
    np.testing.assert_allclose(task.compute_error(config), 0, atol=1e-12)
    target = pin.SE3(pin.rpy.rpyToMatrix(0.1, -0.2, 0.3), np.array([0.2, -0.1, 0.05]))
    task.set_target(target.homogeneous)
    rel = np.linalg.inv(config.frame_placement(robot.frame_id(robot.torso)).homogeneous) @ \
        config.frame_placement(robot.frame_id(hand)).homogeneous
    expected = np.r_[rel[:3, 3] - target.translation,
                     Rotation.from_matrix(target.rotation.T @ rel[:3, :3]).as_rotvec()]
    np.testing.assert_allclose(task.compute_error(config), expected, atol=1e-12)


def test_damping_task_adds_its_weights_to_the_diagonal(robots):
    """Velocity-level task: e ≡ 0 and J = identity rows, so its cost is exactly Σ w_j v_j² (H += diag(w), g += 0)."""
    robot = robots("talos")
    config = Configuration(robot)
    for actuated_only, first in ((False, 0), (True, 6)):
        w = np.linspace(1.0, 2.0, robot.nv - first)
        task = DampingTask(robot, weight=w, actuated_only=actuated_only)
        error, J = task.compute(config)
        assert task.dim == robot.nv - first and np.all(error == 0)
        np.testing.assert_array_equal(J, np.eye(robot.nv)[first:])
        H, g = np.zeros((robot.nv, robot.nv)), np.zeros(robot.nv)
        task.add_cost(config, H, g)
        np.testing.assert_array_equal(H, np.diag(np.r_[np.zeros(first), w]))
        assert not g.any()
        H2, g2 = np.zeros((robot.nv, robot.nv)), np.zeros(robot.nv)
        Task.add_cost(task, config, H2, g2)  # the generic Jᵀ W J path gives the same
        np.testing.assert_allclose(H2, H, atol=0)


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


@pytest.mark.parametrize("name", CATALOG)
def test_angular_momentum_matrix(robots, name):
    """J v (J = rows 3:6 of A_g) equals Pinocchio's computeCentroidalMomentum(q, v).angular and an independent
    sum over bodies Σ (c_i − c) × m_i ċ_i + R_i I_i R_iᵀ ω_i (body velocities from pin.forwardKinematics);
    computing it leaves the configuration's cached kinematics unchanged."""
    robot = robots(name)
    model = robot.model
    rng = np.random.default_rng(7)
    q = random_configuration(robot, rng)
    config = Configuration(robot, q)
    before = (config.com_jacobian.copy(), config.frame_jacobian(robot.frame_id(robot.torso)).copy(),
              config.frame_placement(robot.frame_id(robot.left_sole)).homogeneous.copy())
    task = AngularMomentumTask(robot, weight=[1, 2, 3])
    error, J = task.compute(config)
    assert J.shape == (3, robot.nv) and not error.any()
    np.testing.assert_allclose(config.com_jacobian, before[0], atol=1e-14)
    np.testing.assert_allclose(config.frame_jacobian(robot.frame_id(robot.torso)), before[1], atol=1e-14)
    np.testing.assert_allclose(config.frame_placement(robot.frame_id(robot.left_sole)).homogeneous, before[2],
                               atol=1e-14)
    data = model.createData()
    for _ in range(3):
        v = rng.standard_normal(robot.nv)
        h = pin.computeCentroidalMomentum(model, data, q, v)
        np.testing.assert_allclose(J @ v, h.angular, atol=1e-10)
        pin.forwardKinematics(model, data, q, v)
        c = pin.centerOfMass(model, data, q)
        k = np.zeros(3)
        for i in range(1, model.njoints):
            inertia, M, vel = model.inertias[i], data.oMi[i], data.v[i]  # vel: body velocity in joint frame
            ci = M.act(inertia.lever)
            vi = M.rotation @ (vel.linear + np.cross(vel.angular, inertia.lever))
            wi = M.rotation @ vel.angular
            Iw = M.rotation @ inertia.inertia @ M.rotation.T  # rotational inertia about c_i, world axes
            k += np.cross(ci - c, inertia.mass * vi) + Iw @ wi
        np.testing.assert_allclose(J @ v, k, atol=1e-9 * max(1.0, np.abs(k).max()))
    task.set_target([0.0, 0.1, 0.0])
    np.testing.assert_array_equal(task.velocity_target(error), [0.0, 0.1, 0.0])


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
