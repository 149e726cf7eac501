"""CI: a 4-step Talos walk (0.24 m steps, 0.6 s/step) on the realistic plant (URDF joint damping and dry friction,
SRDF rotor armature, torque–speed envelope; wbc.sim.actuators) with the controller's compensation, the operator's
criteria as assertions. Ground-truth state (the estimator is not part of this test).

Independent references: tilt from Pinocchio on the logged MuJoCo state, joint speeds from the logged MuJoCo qvel
against the URDF limits, walked distance from MuJoCo's sole positions. No wall-clock assertion.
"""

import math

import numpy as np
import pinocchio as pin

from wbc.robot import load_robot
from wbc.sim.actuators import actuator_model, compensation_options
from wbc.sim.mujoco_model import build_mujoco_model
from wbc.sim.physics_scenarios import walk_options_for
from wbc.sim.scenarios import make_controller, run_scenario
from wbc.sim.walk import WalkScenario


def test_talos_four_step_walk_on_the_realistic_plant():
    robot = load_robot("talos")
    sim = build_mujoco_model(robot, plant="realistic")
    options = {**walk_options_for(robot), **compensation_options(robot, actuator_model(robot))}
    controller = make_controller(robot, "id", dt=sim.timestep, **options)
    run, s = run_scenario(sim, controller, WalkScenario(4, 0.24, 0.6))
    assert s["passed"], s["failed_criteria"]
    assert not s["fell"] and s["completed"] and s["touchdowns"] == 4
    # no fall by tilt: pelvis (root) and torso within 30° of their initial up axis (Pinocchio on the logged q)
    m, d = robot.model, robot.model.createData()
    up = {}
    worst = 0.0
    for i in range(0, len(run.t), 10):
        pin.framesForwardKinematics(m, d, run.q[i])
        for f in ("base_link", robot.torso):
            R = d.oMf[m.getFrameId(f)].rotation
            if f not in up:
                up[f] = R.T @ [0.0, 0.0, 1.0]
            worst = max(worst, math.degrees(math.acos(min(1.0, (R @ up[f])[2]))))
    assert worst <= 30.0
    # base height never 0.2 m below its start
    assert run.q[:, 2].min() >= run.q[0, 2] - 0.2
    # joint speeds (MuJoCo qvel, logged) within the URDF limits at every tick
    vlim = m.velocityLimit[6:]
    assert np.all(np.abs(run.v[:, 6:]) <= vlim)
    assert s["joint_speed_exceedances"] == 0
    # landing slide ≤ 10 mm, stance slip ≤ 5 mm
    assert s["max_landing_slide_m"] <= 0.010
    assert max(s["stance_slip_m"]) <= 0.005
    mid = run.sole_pos[:, :, :2].mean(axis=1)
    assert abs(float(np.linalg.norm(mid[-1] - mid[0])) - 0.72) <= 0.05 * 0.72
