"""``wbc sim walk --terrain``: Talos climbs 3 stairs of 10 cm rise and 30 cm tread in MuJoCo, one foot per tread.

The operator's criteria are assertions here: no fall (base drop > 0.2 m, pelvis/torso tilt > 30°, or any
non-sole body touching the ground — the step boxes count as ground, so a toe or heel hitting a step edge is a
fall), every landed sole wholly on one tread (checked against the stairs' tread intervals from the plant's logged
state), the swing soles above the step edges, 0 solver failures, both feet on the top tread at the end (MuJoCo's
sole positions). No wall-clock assertion.
"""

import math

import numpy as np
import pinocchio as pin
import pytest

from wbc.robot import load_robot
from wbc.sim.actuators import SPEED_MARGIN, actuator_model, apply_actuators, compensation_options
from wbc.sim.mujoco_model import build_mujoco_model
from wbc.sim.physics_scenarios import walk_options_for
from wbc.sim.scenarios import make_controller, run_scenario
from wbc.sim.walk import WalkScenario
from wbc.terrain import parse_terrain


def test_talos_climbs_three_10cm_stairs():
    rise, tread, n = 0.10, 0.30, 3
    terrain = parse_terrain(f"stairs:{rise}:{tread}:{n}:up")
    robot = load_robot("talos")
    # the plant and controller of `wbc sim walk`: realistic drives, the controller's compensation of them (joint
    # speed limits with a 5 % margin included)
    sim = build_mujoco_model(robot, terrain=terrain)
    drives = actuator_model(robot, "realistic")
    apply_actuators(sim, drives)
    options = walk_options_for(robot)
    options.update(compensation_options(robot, drives, SPEED_MARGIN))
    controller = make_controller(robot, "id", dt=sim.timestep, mu=0.7, **options)
    steps = 5  # 3 treads, the landing, the closing step
    scenario = WalkScenario(steps, tread, 0.8, terrain=terrain)
    run, s = run_scenario(sim, controller, scenario)
    # step timing: the stair swings (two treads forward and a rise) last longer than the 0.64 s of a level step,
    # and the run covers the lengthened plan (completed below)
    swings = [ph.duration for ph in scenario.plan.phases if ph.step >= 0]
    assert max(swings) > 0.64 + 0.05
    assert not s["fell"], s.get("fall_reason")
    assert s["completed"] and s["touchdowns"] == steps
    assert s["solver_failures"] == 0
    assert s["joint_speed_exceedances"] == 0  # no joint past its URDF speed limit in the plant
    # Every landed sole wholly on one tread (plant's state through Pinocchio; tread intervals of the stairs).
    model, data = robot.model, robot.model.createData()
    fid = {side: robot.frame_id(getattr(robot, f"{side}_sole")) for side in ("left", "right")}
    L = robot.sole_length
    treads = terrain.treads
    dt = run.dt
    for ph in scenario.plan.phases:
        if ph.step < 0:
            continue
        side = scenario.plan.footsteps[ph.step].side
        k = min(ph.end + int(0.2 / dt), len(run.t) - 1)  # 0.2 s after the planned touch-down: landed
        pin.framesForwardKinematics(model, data, run.q[k])
        M = data.oMf[fid[side]]
        yaw = math.atan2(M.rotation[1, 0], M.rotation[0, 0])
        half = 0.5 * L * abs(math.cos(yaw)) + 0.5 * robot.sole_width * abs(math.sin(yaw))
        lo, hi = M.translation[0] - half, M.translation[0] + half
        on = [tr for tr in treads if tr[0] <= lo and hi <= tr[1]]
        assert len(on) == 1, f"step {ph.step + 1}: sole x in [{lo:.3f}, {hi:.3f}] m is not on one tread"
        assert abs(M.translation[2] - on[0][2]) <= 0.005
    assert s["max_sole_support_gap_m"] <= 0.005
    # Swing soles above the terrain away from their footholds (step edges) by at least 5 mm.
    assert s["min_swing_clearance_m"] >= 0.005
    # On top at the end: both soles at the top tread's height (MuJoCo's sole positions), the walk's distance.
    assert np.allclose(run.sole_pos[-1, :, 2], n * rise, atol=0.005)
    mid = run.sole_pos[:, :, :2].mean(axis=1)
    walked = float(np.linalg.norm(mid[-1] - mid[0]))
    assert walked == pytest.approx(s["commanded_distance_m"], rel=0.05)
    assert s["commanded_distance_m"] >= n * tread  # the feet end beyond the last riser
