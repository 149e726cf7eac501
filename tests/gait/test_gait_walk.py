"""The walk plan (wbc.gait.walk): its structure and immutability, replanning from a measured state, typed errors of bad arguments."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from wbc.exceptions import GaitError, InvalidInputError
from wbc.gait import DOUBLE_SUPPORT, plan_walk
from gait_plans import DT, Z_COM, lifted, pose, rot_fd, straight_plan, talos_size_walk


def test_replan_without_perturbation_reproduces_plan():
    plan = talos_size_walk(n_steps=6)
    for k in (0, 1, plan.index(1.0), plan.index(1.5), plan.index(2.95), plan.n_samples - 2):
        r = plan.replan(k, plan.com[k], plan.com_vel[k])
        assert r.n_samples == plan.n_samples - k and r.t_offset == pytest.approx(k * DT)
        np.testing.assert_allclose(r.com, plan.com[k:], atol=1e-9)
        np.testing.assert_allclose(r.com_vel, plan.com_vel[k:], atol=1e-9)
        np.testing.assert_allclose(r.zmp, plan.zmp[k:], atol=1e-8)
        assert np.array_equal(r.left_sole, plan.left_sole[k:]) and np.array_equal(r.support, plan.support[k:])
        assert r.footsteps == plan.footsteps[len(plan.footsteps) - len(r.footsteps):]


def test_replan_with_perturbed_velocity_starts_at_state():
    plan = talos_size_walk(n_steps=6)
    k = plan.index(3.0)
    v = plan.com_vel[k] + np.array([0.04, -0.05, 0.0])
    r = plan.replan(k, plan.com[k], v)
    np.testing.assert_allclose(r.com[0, :2], plan.com[k, :2], atol=1e-12)
    np.testing.assert_allclose(r.com_vel[0, :2], v[:2], atol=1e-12)
    assert r.t[0] == 0.0 and r.duration == pytest.approx(plan.duration - k * DT)
    assert r.zmp_margin().min() >= 0.0
    # The reference is unchanged after the current segment.
    seg_end = r.segments.first[1]
    np.testing.assert_allclose(r.zmp[seg_end:], plan.zmp[k + seg_end:], atol=1e-12)
    # Replanning twice composes.
    r2 = r.replan(10, r.com[10], r.com_vel[10])
    assert r2.t_offset == pytest.approx((k + 10) * DT)
    np.testing.assert_allclose(r2.com, r.com[10:], atol=1e-9)


def test_replan_rejects_uncapturable_state_and_bad_input():
    plan = talos_size_walk(n_steps=4)
    k = plan.index(2.0)
    with pytest.raises(GaitError, match="outside the current support polygon"):
        plan.replan(k, plan.com[k], plan.com_vel[k] + np.array([0.0, 1.0, 0.0]))
    for bad_k in (-1, plan.n_samples - 1, 1.5, True):
        with pytest.raises(GaitError):
            plan.replan(bad_k, plan.com[0], plan.com_vel[0])
    with pytest.raises(GaitError):
        plan.replan(k, np.array([0.0, np.nan, Z_COM]), plan.com_vel[k])
    with pytest.raises(GaitError):
        plan.replan(k, plan.com[k], np.zeros(2))


def test_plan_structure_and_immutability():
    plan = straight_plan()
    n = plan.n_samples
    assert plan.t.shape == (n,) and plan.t[1] == DT and plan.duration == pytest.approx(plan.t[-1])
    assert plan.duration == pytest.approx(1.0 + 8 * 0.8 + 7 * 0.3 + 1.2)
    for name, shape in [("com", (n, 3)), ("com_vel", (n, 3)), ("com_acc", (n, 3)), ("zmp", (n, 2)),
                        ("dcm", (n, 2)), ("left_sole", (n, 4, 4)), ("right_sole", (n, 4, 4)),
                        ("left_sole_vel", (n, 6)), ("right_sole_vel", (n, 6)), ("support", (n,))]:
        arr = getattr(plan, name)
        assert arr.shape == shape, name
        with pytest.raises(ValueError):
            arr[0] = 0
    assert plan.support.dtype == np.int8 and plan.support[0] == DOUBLE_SUPPORT and plan.support[-1] == 0
    assert set(np.unique(plan.support).tolist()) == {0, 1, 2}
    assert sum(ph.count for ph in plan.phases) == n - 1
    assert plan.index(0.0) == 0 and plan.index(1.0) == 500 and plan.index(1e9) == n - 1 and plan.index(-3) == 0
    with pytest.raises(GaitError):
        plan.index(float("nan"))
    poly = plan.support_polygon_at(plan.phases[1].first + 3)
    assert poly.shape == (4, 2)
    assert plan.support_polygon_at(0).shape[0] >= 4


def test_talos_robot_feet():
    """Real Talos soles (0.0017 rad roll in the reference posture) and CoM."""
    from wbc import load_robot

    robot = load_robot("talos")
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, robot.q_ref)
    L0 = data.oMf[robot.frame_id(robot.left_sole)]
    R0 = data.oMf[robot.frame_id(robot.right_sole)]
    com = pin.centerOfMass(robot.model, data, robot.q_ref)
    plan = plan_walk(L0, R0, com, n_steps=6, sole_length=robot.sole_length, sole_width=robot.sole_width)
    assert np.array_equal(plan.left_sole[0], L0.homogeneous) and np.array_equal(plan.right_sole[0], R0.homogeneous)
    assert plan.zmp_margin().min() >= 0.0
    assert plan.planned_distance == pytest.approx(5 * 0.15, abs=1e-9)
    # The first swing of each foot also levels the sole: velocities stay consistent with the poses.
    w = rot_fd(plan.left_sole[:, :3, :3], plan.dt)
    assert np.abs(w - plan.left_sole_vel[1:-1, 3:]).max() < 2e-4
    assert np.allclose(plan.left_sole[-1, :3, :3] @ [0, 0, 1], [0, 0, 1])


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(n_steps=0), "n_steps"),
        (dict(n_steps=2.0), "n_steps"),
        (dict(n_steps=True), "n_steps"),
        (dict(t_ss=-0.8), "t_ss"),
        (dict(t_ds=0.0), "t_ds"),
        (dict(t_init=float("nan")), "t_init"),
        (dict(t_final=0.001), "t_final"),
        (dict(dt=0.0), "dt"),
        (dict(step_height=-0.01), "step_height"),
        (dict(step_width=0.1), "step_width"),
        (dict(step_length=float("inf")), "step_length"),
        (dict(turn=2.0), "turn"),
        (dict(sole_length=0.0), "sole_length"),
        (dict(first_side="middle"), "first_side"),
        (dict(com_velocity=np.zeros(2)), "com_velocity"),
        (dict(com_velocity=np.array([0.0, 2.0, 0.0])), "outside the current support polygon"),
    ],
)
def test_bad_arguments_raise_gait_error(kwargs, match):
    with pytest.raises(GaitError, match=match):
        talos_size_walk(**kwargs)


@pytest.mark.parametrize(
    "left, right, com, match",
    [
        (pose(0, 0.085), pose(0, -0.085), np.array([0.0, np.nan, Z_COM]), "com"),
        (pose(0, 0.085), pose(0, -0.085), np.zeros(2), "com"),
        (pose(0, 0.085), pose(0, -0.085), np.array([0.0, 0.0, -0.1]), "com"),
        (np.eye(3), pose(0, -0.085), np.array([0.0, 0.0, Z_COM]), "left_sole"),
        (pose(0, 0.085), "foot", np.array([0.0, 0.0, Z_COM]), "right_sole"),
        (pose(0, -0.085), pose(0, 0.085), np.array([0.0, 0.0, Z_COM]), "left of"),
        (pose(0, 0.05), pose(0, -0.05), np.array([0.0, 0.0, Z_COM]), "overlap"),
        (lifted(pose(0, 0.085), 0.2), pose(0, -0.085), np.array([0.0, 0.0, Z_COM]), "flat"),
        (pin.SE3(pin.rpy.rpyToMatrix(0.3, 0, 0), np.array([0, 0.085, 0])), pose(0, -0.085),
         np.array([0.0, 0.0, Z_COM]), "flat"),
        (pose(0, 0.085) @ np.diag([1.0, 1.0, 2.0, 1.0]), pose(0, -0.085), np.array([0.0, 0.0, Z_COM]), "rigid"),
    ],
)
def test_bad_feet_or_com_raise_gait_error(left, right, com, match):
    with pytest.raises(GaitError, match=match):
        plan_walk(left, right, com)


def test_gait_error_is_invalid_input():
    assert issubclass(GaitError, InvalidInputError) and issubclass(GaitError, ValueError)
