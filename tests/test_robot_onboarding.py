"""Robot onboarding: load_robot refuses robots that cannot be right, derives the sole rectangle from the feet's
collision geometry, scales the default gait; `wbc robots` and `wbc walk --robot my.urdf --left-sole ...`."""

from __future__ import annotations

import math

import numpy as np

import pytest

import wbc
from wbc.cli import main
from wbc.exceptions import RobotDescriptionError
from wbc.robot import example_robot_data_dir

ERD = example_robot_data_dir() / "example-robot-data" / "robots"


@pytest.fixture(scope="module")
def talos():
    return wbc.load_robot("talos")


def _talos_path(talos, **kw):
    args = dict(srdf=talos.srdf_path, reference="half_sitting", left_sole="left_sole_link",
                right_sole="right_sole_link", torso="torso_2_link")
    args.update(kw)
    return wbc.load_robot(talos.urdf_path, **args)


def test_sole_rectangle_from_collision_geometry(talos):
    """Talos's foot collision mesh gives nearly the catalog's hand-measured 0.21 x 0.13 m sole."""
    robot = _talos_path(talos)
    assert robot.sole_length == pytest.approx(0.21, abs=0.015)
    assert robot.sole_width == pytest.approx(0.13, abs=0.015)
    given = _talos_path(talos, sole_length=0.2, sole_width=0.1)
    assert (given.sole_length, given.sole_width) == (0.2, 0.1)


def test_default_gait_scaled_to_leg_length(talos):
    """Talos (leg 1.019 m) keeps its gait; a robot with half the leg gets half the step and √½ the timing."""
    from wbc.robot import scaled_gait

    g = scaled_gait(talos)
    assert g["step_length"] == pytest.approx(0.15, abs=1e-3) and g["t_ss"] == pytest.approx(0.8, abs=1e-3)
    small = wbc.load_robot("talos")
    small.q_ref = small.q_ref.copy()
    small.q_ref[2] = 1.019 / 2
    g2 = scaled_gait(small)
    assert g2["step_length"] == pytest.approx(0.075, abs=1e-3)
    assert g2["step_height"] == pytest.approx(0.025, abs=1e-3)
    assert g2["t_ss"] == pytest.approx(0.8 / math.sqrt(2), abs=1e-3)
    assert g2["t_ds"] == pytest.approx(0.3 / math.sqrt(2), abs=1e-3)
    small.sole_length = 0.08  # the step is capped at 0.75 x the sole length
    assert scaled_gait(small)["step_length"] == pytest.approx(0.06, abs=1e-3)


def test_same_sole_refused(talos):
    with pytest.raises(RobotDescriptionError, match="same frame 'left_sole_link'"):
        _talos_path(talos, right_sole="left_sole_link")


def test_soles_on_one_leg_refused(talos):
    with pytest.raises(RobotDescriptionError, match="same kinematic chain"):
        _talos_path(talos, right_sole="leg_left_4_link")


def test_hands_as_soles_refused(talos):
    with pytest.raises(RobotDescriptionError, match=r"'arm_left_\d_joint', 0\.\d+ m above the floating base link "
                                                    r"'base_link'.*legless"):
        _talos_path(talos, left_sole="gripper_left_base_link", right_sole="gripper_right_base_link",
                    sole_length=0.1, sole_width=0.1)


def test_tilted_soles_refused(talos):
    """Half-sitting with both ankle pitches at 0 (from about -0.4 rad): the soles point 20-odd degrees off flat."""
    with pytest.raises(RobotDescriptionError, match=r"left sole frame 'left_sole_link' is tilted 2\d\.\d° from flat"):
        _talos_path(talos, reference_joints={"leg_left_5_joint": 0.0, "leg_right_5_joint": 0.0},
                    sole_length=0.2, sole_width=0.1)


def test_posture_outside_limits_refused(talos):
    knee = "leg_left_4_joint"
    hi = talos.model.upperPositionLimit[talos.model.joints[talos.model.getJointId(knee)].idx_q]
    with pytest.raises(RobotDescriptionError, match=rf"{knee} = {hi + 0.42:.3f} rad not in"):
        wbc.load_robot(talos.urdf_path, left_sole="left_sole_link", right_sole="right_sole_link",
                       torso="torso_2_link", reference_joints={knee: hi + 0.42, "leg_right_4_joint": hi + 0.42})


_MASSLESS = """<robot name="massless">
  <link name="base"/>
  <link name="lfoot"><collision><geometry><box size="0.2 0.1 0.02"/></geometry></collision></link>
  <link name="rfoot"><collision><geometry><box size="0.2 0.1 0.02"/></geometry></collision></link>
  <joint name="lhip" type="revolute"><parent link="base"/><child link="lfoot"/><origin xyz="0 0.1 -0.6"/>
    <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="10" velocity="1"/></joint>
  <joint name="rhip" type="revolute"><parent link="base"/><child link="rfoot"/><origin xyz="0 -0.1 -0.6"/>
    <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="10" velocity="1"/></joint>
</robot>"""


def test_massless_urdf_refused(tmp_path):
    path = tmp_path / "massless.urdf"
    path.write_text(_MASSLESS)
    with pytest.raises(RobotDescriptionError, match=r"total mass is 0\.00\d kg.*add masses"):
        wbc.load_robot(path, left_sole="lfoot", right_sole="rfoot", torso="base")


def test_box_feet_give_their_rectangle(tmp_path):
    """Collision boxes 0.2 x 0.1 x 0.02 m centred under the sole frames: the derived sole is 0.2 x 0.1 m (the
    sole frame is the box centre here, so the patch band covers the whole box)."""
    path = tmp_path / "boxfeet.urdf"
    path.write_text(_MASSLESS.replace("<link name=\"base\"/>", "<link name=\"base\"><inertial><mass value=\"5\"/>"
                                      "<inertia ixx=\"1\" iyy=\"1\" izz=\"1\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/>"
                                      "</inertial></link>"))
    robot = wbc.load_robot(path, left_sole="lfoot", right_sole="rfoot", torso="base")
    assert robot.sole_length == pytest.approx(0.2, abs=1e-9) and robot.sole_width == pytest.approx(0.1, abs=1e-9)
    assert robot.q_ref[2] == pytest.approx(0.6, abs=1e-9)  # soles on z = 0, base 0.6 m above
    assert robot.gait["step_length"] == pytest.approx(round(min(0.15 * 0.6 / 1.019, 0.15), 3))


@pytest.mark.skipif(not (ERD / "simple_humanoid_description").is_dir(), reason="example-robot-data absent")
def test_cli_refuses_simple_humanoid_posture(capsys):
    d = ERD / "simple_humanoid_description"
    code = main(["walk", "--robot", str(d / "urdf/simple_humanoid.urdf"), "--srdf",
                 str(d / "srdf/simple_humanoid.srdf"), "--reference", "half_sitting", "--left-sole", "l_ankle",
                 "--right-sole", "r_ankle", "--torso", "torso", "--sole-length", "0.2", "--sole-width", "0.1"])
    assert code == 2
    err = capsys.readouterr().err
    assert "outside the joint limits" in err and "LLEG_KNEE" in err and "fix the SRDF" in err


def test_cli_robots_lists_the_catalog(capsys):
    assert main(["robots"]) == 0
    out = capsys.readouterr().out
    for name in wbc.robot.catalog():
        assert f"| {name} |" in out
    talos_row = next(line for line in out.splitlines() if line.startswith("| talos |"))
    assert "0.210×0.130" in talos_row and "| 39 | 38 |" in talos_row


# -- humanoids of example-robot-data outside the catalog (issue 8 acceptance; full 8-step CLI walks in README) --
_HAS_ERD = pytest.mark.skipif(not (ERD / "romeo_description").is_dir(), reason="example-robot-data absent")


def _romeo():
    d = ERD / "romeo_description"
    return wbc.load_robot(d / "urdf/romeo.urdf", srdf=d / "srdf/romeo.srdf", reference="half_sitting",
                          left_sole="l_sole", right_sole="r_sole", torso="torso")


@_HAS_ERD
def test_romeo_zero_width_joints_locked_and_short_walk_passes():
    """Romeo's URDF has 24 hand joints with a zero speed limit (velocity="0"): they are loaded as fixed joints (no
    QP variable), no tick fails, and a 3-step walk meets the executed-motion criteria (thresholds written here)."""
    from wbc.scenarios.walk import plan_default_walk, run_walk, walk_summary

    robot = _romeo()
    assert 0.15 < robot.sole_length < 0.18 and 0.10 < robot.sole_width < 0.12  # from its foot mesh
    assert robot.gait["step_length"] < 0.15  # scaled to its 0.84 m leg
    assert len(robot.locked_joints) == 24 and "LHand" in robot.locked_joints
    assert not robot.model.existJointName("LHand") and not robot.model.existJointName("RThumb1")
    plan = plan_default_walk(robot, n_steps=3)
    run = run_walk(robot, plan)
    s = walk_summary(robot, plan, run)
    assert s["solver_failures"] == 0 and not s["nan"]
    assert abs(s["walked_distance_m"] - s["planned_distance_m"]) <= 0.05 * s["planned_distance_m"]
    assert s["min_zmp_margin_m"] >= 0.0 and s["max_stance_slip_m"] <= 1e-3 and s["max_com_error_m"] <= 5e-3
    assert s["joint_position_violations"] == 0 and s["joint_velocity_violations"] == 0
    assert s["relaxed_ticks"] == 0
    # joint accelerations stay within the walk's 50 rad/s² bound, also where the ankles reach their limits
    assert np.abs(np.diff(run.v[:, 6:], axis=0)).max() / run.dt <= 50.0 + 1e-6
    assert s["passed"], s["failed_criteria"]


@_HAS_ERD
def test_icub_refused_sole_frame_off_its_foot():
    d = ERD / "icub_description"
    with pytest.raises(RobotDescriptionError, match=r"'l_sole' is off the centre of its foot's contact patch.*"
                                                    r"x must point along the foot"):
        wbc.load_robot(d / "robots/icub.urdf", srdf=d / "srdf/icub.srdf", reference="half_sitting",
                       left_sole="l_sole", right_sole="r_sole", torso="chest")


@_HAS_ERD
def test_legless_upper_body_refused():
    """Alex (example-robot-data) is an upper body on a pelvis: its hands named as soles are refused, whether the
    sole size is derived or given."""
    d = ERD / "alex_description"
    for size in ({}, {"sole_length": 0.05, "sole_width": 0.05}):
        with pytest.raises(RobotDescriptionError, match=r"'LeftShoulder\w+', 0\.\d+ m above the floating base "
                                                        r"link 'Pelvis'.*legless"):
            wbc.load_robot(d / "urdf/alex_nub_hands.urdf", srdf=d / "srdf/alex_nub_hands.srdf", reference="default",
                           left_sole="leftNub", right_sole="rightNub", torso="Torso", **size)


@_HAS_ERD
def test_cli_refuses_a_legless_robot(capsys):
    d = ERD / "alex_description"
    code = main(["walk", "--robot", str(d / "urdf/alex_nub_hands.urdf"), "--srdf", str(d / "srdf/alex_nub_hands.srdf"),
                 "--reference", "default", "--left-sole", "leftNub", "--right-sole", "rightNub", "--torso", "Torso"])
    assert code == 2
    assert "legless" in capsys.readouterr().err


_ALEXANDER = ERD / "alexander_description"
#: Sole links added at the bottom of Alexander's feet: its Foot.obj spans x in [-0.055, 0.157], y in
#: [-0.048, 0.048] m and reaches 0.072 m below the LEFT_FOOT/RIGHT_FOOT (ankle) frames.
_SOLE_LINKS = """
  <link name="{side}_sole"/>
  <joint name="{side}_sole_fixed" type="fixed"><parent link="{foot}"/><child link="{side}_sole"/>
    <origin xyz="0.05 0 -0.072" rpy="0 0 0"/></joint>
"""


@pytest.mark.skipif(not _ALEXANDER.is_dir(), reason="example-robot-data absent")
def test_alexander_ankle_frames_refused_then_sole_frames_walk(tmp_path):
    """Alexander's lower body: its foot frames are the ankles, 7.2 cm above the sole (visual mesh; it has no
    collision geometry): refused with the fix. With sole links added as the message says, it loads and a 3-step
    walk meets the executed-motion criteria."""
    from wbc.scenarios.walk import plan_default_walk, run_walk, walk_summary

    urdf = _ALEXANDER / "urdf/alexander_v1.lowerBodyOnly.urdf"
    common = dict(srdf=_ALEXANDER / "srdf/alexander.srdf", reference="default", torso="TORSO_LINK",
                  sole_length=0.2, sole_width=0.09)
    with pytest.raises(RobotDescriptionError, match=r"'LEFT_FOOT' is 0\.07\d m above the bottom of its foot's "
                                                    r"visual geometry.*add one to the URDF"):
        wbc.load_robot(urdf, left_sole="LEFT_FOOT", right_sole="RIGHT_FOOT", **common)
    text = urdf.read_text()
    extra = "".join(_SOLE_LINKS.format(side=s, foot=f) for s, f in (("left", "LEFT_FOOT"), ("right", "RIGHT_FOOT")))
    fixed = tmp_path / "alexander_soles.urdf"
    fixed.write_text(text.replace("</robot>", extra + "</robot>"))
    robot = wbc.load_robot(fixed, left_sole="left_sole", right_sole="right_sole", **common)
    plan = plan_default_walk(robot, n_steps=3)
    s = walk_summary(robot, plan, run_walk(robot, plan))
    assert s["solver_failures"] == 0 and not s["nan"]
    assert abs(s["walked_distance_m"] - s["planned_distance_m"]) <= 0.05 * s["planned_distance_m"]
    assert s["min_zmp_margin_m"] >= 0.0 and s["max_stance_slip_m"] <= 1e-3 and s["max_com_error_m"] <= 5e-3
    assert s["joint_position_violations"] == 0 and s["joint_velocity_violations"] == 0
    assert s["passed"], s["failed_criteria"]
