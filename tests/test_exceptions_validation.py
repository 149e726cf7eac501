"""Bad input at the public API edge raises a typed ``wbc.exceptions`` error naming what is wrong and what is valid."""

from __future__ import annotations

import math

import numpy as np
import pytest

import wbc
from wbc.configuration import Configuration
from wbc.constraints.limits import JointPositionLimit, JointVelocityLimit
from wbc.exceptions import ConfigurationError, InvalidInputError, InvalidTargetError, RobotDescriptionError, WbcError
from wbc.tasks import ComTask, FrameTask, PostureTask


@pytest.fixture(scope="module")
def talos():
    return wbc.load_robot("talos")


@pytest.mark.parametrize("bad", [-50.0, math.nan, math.inf, "fast", None, True])
def test_task_gain_validated_on_assignment(talos, bad):
    for task in (ComTask(), PostureTask(talos), FrameTask(talos, talos.left_sole)):
        before = task.gain
        with pytest.raises(InvalidInputError, match=r"gain must be a finite number ≥ 0"):
            task.gain = bad
        assert task.gain == before  # unchanged
    with pytest.raises(InvalidInputError, match="gain"):
        ComTask(gain=bad)


def test_task_gain_accepts_valid_values(talos):
    task = ComTask()
    task.gain = 0
    assert task.gain == 0.0
    task.gain = np.float64(25.0)
    assert task.gain == 25.0 and isinstance(task.gain, float)


@pytest.mark.parametrize("bad", [-1.0, math.nan, np.array([1.0, -1.0, 1.0]), np.ones(4)])
def test_task_weight_validated_on_assignment(bad):
    task = ComTask()
    with pytest.raises(InvalidInputError, match="weight must be a non-negative finite"):
        task.weight = bad


def test_task_target_validated_on_assignment(talos):
    com = ComTask()
    for bad in (np.array([0.0, math.nan, 1.0]), np.zeros(2), "up"):
        with pytest.raises(InvalidTargetError, match="CoM target"):
            com.target = bad
    com.target = [0.1, 0.0, 0.9]
    np.testing.assert_array_equal(com.target, [0.1, 0.0, 0.9])
    posture = PostureTask(talos)
    with pytest.raises(InvalidTargetError, match="posture target"):
        posture.target = np.full(talos.nq, math.nan)
    with pytest.raises(InvalidTargetError, match="posture target"):
        posture.target = np.zeros(talos.nq - 1)
    frame = FrameTask(talos, talos.left_sole)
    bad_rot = np.eye(4)
    bad_rot[0, 0] = 2.0
    for bad in (np.full((4, 4), math.nan), bad_rot, np.eye(3)):
        with pytest.raises(InvalidTargetError, match="target of"):
            frame.target = bad
    frame.target = np.eye(4)
    np.testing.assert_array_equal(frame.target.homogeneous, np.eye(4))


@pytest.mark.parametrize("bad", [-1.0, 0.0, math.nan, math.inf])
def test_velocity_limit_scale_must_be_positive(talos, bad):
    with pytest.raises(InvalidInputError, match=r"scale must be a finite number > 0"):
        JointVelocityLimit(talos, scale=bad)


def test_velocity_limit_scale_scales(talos):
    half = JointVelocityLimit(talos, scale=0.5)
    full = JointVelocityLimit(talos)
    finite = np.isfinite(full.v_max)
    np.testing.assert_allclose(half.v_max[finite], 0.5 * full.v_max[finite])


@pytest.mark.parametrize("bad", [-0.1, math.nan, math.inf])
def test_position_limit_margin_must_be_non_negative(talos, bad):
    with pytest.raises(InvalidInputError, match=r"margin must be a finite number ≥ 0"):
        JointPositionLimit(talos, margin=bad)
    lim = JointPositionLimit(talos, margin=0.1)
    assert np.all(lim.q_min == talos.model.lowerPositionLimit[lim.idx_q] + 0.1)


@pytest.mark.parametrize("bad_dt", [math.nan, math.inf, -0.002, 0.0, "0.002", None])
def test_configuration_step_rejects_bad_dt(talos, bad_dt):
    config = Configuration(talos)
    q0 = config.q.copy()
    with pytest.raises(ConfigurationError, match=r"dt must be a finite number > 0"):
        config.step(np.zeros(talos.nv), bad_dt)
    np.testing.assert_array_equal(config.q, q0)  # state untouched


def test_configuration_step_rejects_bad_v(talos):
    config = Configuration(talos)
    q0 = config.q.copy()
    v = np.zeros(talos.nv)
    v[7] = math.nan
    with pytest.raises(ConfigurationError, match="velocity v"):
        config.step(v, 0.002)
    with pytest.raises(ConfigurationError, match="velocity v"):
        config.step(np.zeros(talos.nv + 1), 0.002)
    np.testing.assert_array_equal(config.q, q0)
    v[:] = 0.0
    v[0] = 1.0
    config.step(v, 0.002)  # a valid step still moves the base 2 mm forward (world x, base not rotated)
    assert config.q[0] - q0[0] == pytest.approx(0.002, abs=1e-6)


def test_reference_joints_nan_rejected(talos):
    joint = talos.joint_names[0]
    with pytest.raises(RobotDescriptionError, match=rf"reference_joints.*{joint}.*must be a finite"):
        wbc.load_robot(talos.urdf_path, left_sole=talos.left_sole, right_sole=talos.right_sole, torso=talos.torso,
                       reference_joints={joint: math.nan})


def test_malformed_urdf_raises_typed_error_with_reason(tmp_path, talos):
    bad = tmp_path / "broken.urdf"
    bad.write_text('<robot name="x"><link name="a"/><joint name="j" type="revolute"><parent link="a"/></joint>'
                   '</robot>')
    with pytest.raises(RobotDescriptionError, match="cannot parse URDF") as info:
        wbc.load_robot(bad, left_sole="a", right_sole="a", torso="a")
    assert isinstance(info.value, WbcError) and isinstance(info.value, ValueError)
    assert str(info.value.__cause__) in str(info.value)  # urdfdom's reason is carried in the message
    truncated = tmp_path / "truncated.urdf"
    truncated.write_text('<robot name="x"><link name="a">')
    with pytest.raises(RobotDescriptionError, match=r"truncated\.urdf:1:\d+: malformed XML"):  # file:line:column
        wbc.load_robot(truncated, left_sole="a", right_sole="a", torso="a")


def test_task_or_constraint_of_another_robot_rejected(talos):
    """Each object built for G1 and added to a Talos controller raises InvalidInputError naming the object, the
    other robot's mismatch and this robot (before the fix it became a silent freeze or wrong rows)."""
    from wbc.constraints import ComPolygonConstraint, ContactConstraint, JointAccelerationLimit
    from wbc.controllers.kinematic import KinematicController
    from wbc.tasks import DampingTask

    g1 = wbc.load_robot("g1")
    tasks = [FrameTask(g1, g1.left_sole), PostureTask(g1), DampingTask(g1)]
    constraints = [ContactConstraint(g1, g1.left_sole), JointPositionLimit(g1), JointVelocityLimit(g1),
                   JointAccelerationLimit(g1), ComPolygonConstraint(g1)]
    ctrl = KinematicController(talos)
    for obj in tasks:
        with pytest.raises(InvalidInputError, match=rf"task '{obj.name}' was built for another robot.*'talos' "
                                                    rf"\(nq 39, nv 38\)"):
            ctrl.add_task(obj)
        with pytest.raises(InvalidInputError, match="built for another robot"):
            ctrl.add_task(obj, hard=True)
    for obj in constraints:
        with pytest.raises(InvalidInputError, match=rf"constraint '{obj.name}' was built for another robot"):
            ctrl.add_constraint(obj)
    assert ctrl.tasks == [] and ctrl.constraints == [] and ctrl.levels == {}
    # the same objects built for Talos (also from a second load of the same robot: an equal model) are accepted
    talos2 = wbc.load_robot("talos")
    for robot in (talos, talos2):
        KinematicController(talos, [FrameTask(robot, robot.left_sole), PostureTask(robot), DampingTask(robot)],
                            [ContactConstraint(robot, robot.left_sole), JointPositionLimit(robot),
                             JointVelocityLimit(robot), JointAccelerationLimit(robot), ComPolygonConstraint(robot)])
