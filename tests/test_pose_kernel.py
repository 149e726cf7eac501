"""The compiled frame-task error and Jacobian (wbc.tasks.pose_kernel) against Pinocchio's log3/Jlog3 and against
the closed-form series of Jlog3 near the identity (where Pinocchio's own Jlog3 is off by up to 2e-9, measured)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from wbc.tasks.pose_kernel import orientation_error_jacobian, pose_error_jacobian


@pytest.mark.parametrize("angle", [1e-9, 1e-6, 1e-2, 0.5, 1.5, 2.5, 2.99])
def test_pose_error_and_jacobian_match_pinocchio(angle):
    rng = np.random.default_rng(int(angle * 1e9) % 1000)
    for _ in range(50):
        axis = rng.standard_normal(3)
        axis /= np.linalg.norm(axis)
        target = pin.SE3.Random()
        frame = pin.SE3(target.rotation @ pin.exp3(axis * angle), target.translation + rng.standard_normal(3))
        j_local = rng.standard_normal((6, 9))
        ok, e, J = pose_error_jacobian(frame.rotation, frame.translation, np.array(target.rotation, order="C"),
                                       np.array(target.translation), j_local)
        rel = target.rotation.T @ frame.rotation
        assert ok
        assert np.abs(e[:3] - (frame.translation - target.translation)).max() < 1e-12
        assert np.abs(e[3:] - pin.log3(rel)).max() < 1e-12
        assert np.abs(J[:3] - frame.rotation @ j_local[:3]).max() < 1e-12
        assert np.abs(J[3:] - pin.Jlog3(rel) @ j_local[3:]).max() < 1e-12
        ok, e3, J3 = orientation_error_jacobian(frame.rotation, np.array(target.rotation, order="C"), j_local)
        assert ok and np.abs(e3 - e[3:]).max() == 0.0 and np.abs(J3 - J[3:]).max() == 0.0


@pytest.mark.parametrize("angle", [2e-4, 1e-3])
def test_jlog3_near_identity_matches_the_series(angle):
    """Jlog3 = I + ½[r]× + a [r]×², a = 1/12 + θ²/720 + θ⁴/30240 + O(θ⁶) (series of 1/θ² − (1+cos θ)/(2θ sin θ))."""
    rng = np.random.default_rng(7)
    axis = rng.standard_normal(3)
    axis /= np.linalg.norm(axis)
    R = pin.exp3(axis * angle)
    ok, r, J = orientation_error_jacobian(R, np.eye(3), np.vstack([np.zeros((3, 3)), np.eye(3)]))
    assert ok
    t = np.linalg.norm(r)
    K = pin.skew(r)
    series = np.eye(3) + 0.5 * K + (1 / 12 + t**2 / 720 + t**4 / 30240) * K @ K
    assert np.abs(J - series).max() < 1e-15
    assert abs(t - angle) < 1e-15


def test_beyond_three_radians_the_caller_falls_back():
    R = pin.exp3(np.array([0.0, 0.0, 3.1]))
    ok, _, _ = pose_error_jacobian(R, np.zeros(3), np.eye(3), np.zeros(3), np.zeros((6, 2)))
    assert not ok


def test_frame_task_near_pi_uses_pinocchio(robots):
    """A frame task 3.1 rad away from its target still returns Pinocchio's error (fallback path)."""
    from wbc.configuration import Configuration
    from wbc.tasks import FrameTask

    robot = robots("talos")
    config = Configuration(robot)
    task = FrameTask(robot, robot.torso)
    M = config.data.oMf[task.frame_id]
    task.set_target(pin.SE3(M.rotation @ pin.exp3(np.array([0.0, 0.0, 3.1])), M.translation))
    e, _ = task.compute(config)
    assert np.abs(e[3:] - pin.log3(task.target.rotation.T @ M.rotation)).max() < 1e-12
