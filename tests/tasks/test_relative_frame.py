"""The relative-frame task: its error is the pose of one frame in another minus the target, checked against
the relative placement computed independently."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from conftest import CATALOG, random_configuration
from wbc.configuration import Configuration
from wbc.tasks import RelativeFrameTask


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
