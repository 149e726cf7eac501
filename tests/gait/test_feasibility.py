"""Gait defaults bounded by the legs: the nominal walk replayed on the robot's own model (wbc.gait.feasibility)."""

from __future__ import annotations

from wbc.gait.feasibility import feasible_gait, nominal_step_demand
from wbc.robot import load_robot

#: Acceptance written here, not imported: nominal peak speed ≤ 0.35 × the URDF limit, acceleration ≤ 30 rad/s²,
#: soles reached within 3 mm.
SPEED, ACC, REACH = 0.35, 30.0, 0.003


def test_catalog_gait_fits_and_slower_gait_asks_less():
    robot = load_robot("humanoid15")
    d = nominal_step_demand(robot, robot.gait)
    assert d.reach_error < 1e-4 and 0.0 < d.speed_ratio < SPEED and 0.0 < d.acceleration
    slow = {**robot.gait, "t_ss": 2 * robot.gait["t_ss"], "t_ds": 2 * robot.gait["t_ds"]}
    assert nominal_step_demand(robot, slow).speed_ratio < d.speed_ratio


def test_step_beyond_the_leg_is_unreachable_and_shortened():
    robot = load_robot("humanoid15")
    far = {**robot.gait, "step_length": 0.45}
    assert nominal_step_demand(robot, far).reach_error > REACH
    gait, d, notes = feasible_gait(robot, far)
    assert gait["step_length"] < 0.45 and d.reach_error <= REACH
    assert any("miss their targets" in n for n in notes)


def test_slow_joints_stretch_the_durations():
    robot = load_robot("humanoid15")
    model = robot.model
    knees = [model.joints[model.getJointId(n)].idx_v for n in ("left_knee", "right_knee")]
    model.velocityLimit[knees] = 1.5  # rad/s (URDF: 10)
    d0 = nominal_step_demand(robot, robot.gait)
    assert d0.speed_ratio > SPEED and "knee" in d0.speed_joint
    gait, d, notes = feasible_gait(robot, robot.gait)
    assert gait["t_ss"] > robot.gait["t_ss"] and d.speed_ratio <= SPEED and d.acceleration <= ACC
    assert any("speed limit" in n for n in notes)
