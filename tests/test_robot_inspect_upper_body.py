"""``wbc robot init``'s upper body (wbc.robot_inspect.upper_body_link): the link above the waist joints, found from
the kinematic tree, against the torso each catalog robot's hand-written robot file names, and on small trees built
here (a waist chain with unhelpful link names, arms on the pelvis)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from wbc.robot_inspect import upper_body_link


@pytest.mark.parametrize("name", ["talos", "g1", "humanoid15"])
def test_catalog_robots_upper_body_is_their_files_torso(robots, name):
    robot = robots(name)
    feet = [robot.model.frames[robot.frame_id(f)].parentJoint for f in (robot.left_sole, robot.right_sole)]
    assert upper_body_link(robot.model, feet) == robot.torso


def _tree(links: list[tuple[str, str]]) -> tuple[pin.Model, dict]:
    """A free-flyer model of revolute joints: (link, parent link) pairs, the root named PELVIS_S."""
    model = pin.Model()
    ids = {"PELVIS_S": model.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "root")}
    model.addJointFrame(ids["PELVIS_S"])
    model.addBodyFrame("PELVIS_S", ids["PELVIS_S"], pin.SE3.Identity(), -1)
    inertia = pin.Inertia(1.0, np.zeros(3), np.eye(3) * 0.01)
    for link, parent in links:
        j = model.addJoint(ids[parent], pin.JointModelRY(), pin.SE3(np.eye(3), np.array([0, 0, 0.1])), link + "_J")
        model.appendBodyToJoint(j, inertia, pin.SE3.Identity())
        model.addJointFrame(j)
        model.addBodyFrame(link, j, pin.SE3.Identity(), -1)
        ids[link] = j
    return model, ids


LEGS = [("R_HIP", "PELVIS_S"), ("R_KNEE", "R_HIP"), ("R_ANKLE", "R_KNEE"),
        ("L_HIP", "PELVIS_S"), ("L_KNEE", "L_HIP"), ("L_ANKLE", "L_KNEE")]


def test_a_waist_chain_with_no_torso_name_ends_at_the_branching_link():
    # JVRC-1's shape: PELVIS → WAIST_Y → WAIST_P → WAIST_R, where the arms and the neck branch
    model, ids = _tree(LEGS + [("WAIST_Y_S", "PELVIS_S"), ("WAIST_P_S", "WAIST_Y_S"), ("WAIST_R_S", "WAIST_P_S"),
                               ("R_SHOULDER", "WAIST_R_S"), ("L_SHOULDER", "WAIST_R_S"), ("NECK", "WAIST_R_S")])
    assert upper_body_link(model, [ids["L_ANKLE"], ids["R_ANKLE"]]) == "WAIST_R_S"


def test_arms_on_the_pelvis_means_no_waist_the_root_is_the_upper_body():
    model, ids = _tree(LEGS + [("R_SHOULDER", "PELVIS_S"), ("L_SHOULDER", "PELVIS_S")])
    assert upper_body_link(model, [ids["L_ANKLE"], ids["R_ANKLE"]]) == "PELVIS_S"
