"""``wbc walk``'s refusals name the robot's own range (exact lines a user sees, exit 2, before any run), and a walk
that ends before crossing its terrain fails with the shortfall printed."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

import wbc
from wbc.cli.walk import leg_rise, terrain_crossing
from wbc.terrain import parse_terrain

#: Each case: the command line, then the exact line on stderr (exit 2, nothing on stdout).
REFUSED_TEXT = """\
walk --step-length nan
wbc walk: error: --step-length nan is not a finite number (valid: 0 <= step length <= 0.631 m, talos's leg reach)
walk --vx nan
wbc walk: error: --vx nan is not a finite number (valid: 0 <= vx <= 0.574 m/s: talos's leg reach 0.631 m \
per 1.1 s step)
walk --wz nan
wbc walk: error: --wz nan is not a finite number (valid: |wz| < 81.82 deg/s: 90 deg per 1.1 s step)
walk --step-length -0.1
wbc walk: error: --step-length -0.1 m: walking backwards is not planned (valid: 0 <= step length <= 0.631 m, talos's \
leg reach)
walk --terrain stairs:0.5:0.1:3
wbc walk: error: --terrain stairs:0.5:0.1:3:up: a 0.1 m tread is shorter than talos's 0.21 m sole (valid: TREAD >= \
0.21 m: the whole sole stands on each tread)
walk --terrain stairs:0.5:0.3:3
wbc walk: error: --terrain stairs:0.5:0.3:3:up: a 0.5 m rise is beyond the reach of talos's legs (valid: RISE <= \
0.494 m: hip height above the sole minus the leg folded to its shortest at the knee's limit)
"""
REFUSED = list(zip(*[iter(REFUSED_TEXT.splitlines())] * 2))


@pytest.mark.parametrize("command, line", REFUSED, ids=[c for c, _ in REFUSED])
def test_refused_with_the_robots_range(command, line, cli):
    assert cli(command.split()) == (2, line, "")


def test_leg_rise_is_the_hip_height_minus_the_knee_folded_to_its_limit():
    """Independent of the chain walk: Talos's knee (leg_left_4_joint) at its upper limit, the hip joint
    (leg_left_1_joint) to sole distance from Pinocchio."""
    robot = wbc.load_robot("talos")
    model, data = robot.model, robot.model.createData()
    hip, sole = model.getJointId("leg_left_1_joint"), robot.frame_id(robot.left_sole)
    pin.framesForwardKinematics(model, data, robot.q_ref)
    height = data.oMi[hip].translation[2] - data.oMf[sole].translation[2]
    q = robot.q_ref.copy()
    knee = model.joints[model.getJointId("leg_left_4_joint")].idx_q
    q[knee] = model.upperPositionLimit[knee]
    pin.framesForwardKinematics(model, data, q)
    folded = np.linalg.norm(data.oMi[hip].translation - data.oMf[sole].translation)
    assert leg_rise(robot) == pytest.approx(height - folded, abs=1e-12)
    assert 0.45 < leg_rise(robot) < 0.55  # m: a 0.75 m hip height, a 0.25 m folded leg


def test_terrain_crossing_shortfall():
    """updown stairs 3 × 0.3 m: the floor after the last step starts at x = 0.2 + 2 × 0.3 + 0.9 + 2 × 0.3 = 2.3 m;
    a 0.21 m sole whose frame is at x = 2.5 has its heel 0.005 m short of it."""
    terrain = parse_terrain("stairs:0.1:0.3:3:updown")
    got = terrain_crossing(terrain, 2.6, 2.4, 0.21)
    assert got["terrain_end_x_m"] == pytest.approx(2.3)
    assert got["terrain_shortfall_m"] == pytest.approx(2.3 - (2.4 - 0.105))
    assert terrain_crossing(terrain, 3.0, 3.0, 0.21)["terrain_shortfall_m"] < 0
    assert terrain_crossing(parse_terrain("flat"), 0.0, 0.0, 0.21) == {}


def test_a_walk_that_ends_before_crossing_its_terrain_fails(cli):
    """Two steps down 0.3 m treads: the feet end on the first tread, far from the floor below: exit 1, a note before
    the run and the failed criterion with its measurement."""
    code, _, out = cli(["walk", "--terrain", "stairs:0.1:0.3:3:down", "--steps", "2"])
    assert code == 1
    note = next(line for line in out.splitlines() if line.startswith("wbc walk: note:"))
    assert "before the end of stairs:0.1:0.3:3:down (x = 0.800 m): the walk will not cross it" in note
    failed = next(line for line in out.splitlines() if "failed_criteria" in line)
    shortfall = float(failed.split("terrain_shortfall_m): measured ")[1].split(" ")[0])
    assert 0.3 < shortfall < 0.8 and "(required <= 0)" in failed
    assert not math.isnan(shortfall)


def test_a_walk_without_steps_on_stairs_takes_the_steps_that_cross_them(cli):
    """No --steps on a terrain with an end: the count is the fewest that cross it (said in a note), and the walk
    crosses (terrain_shortfall_m <= 0, measured on the executed soles); one step fewer would not (the plan)."""
    from wbc.robot import load_robot
    from wbc.scenarios.terrain_walk import plan_default_terrain_walk

    code, _, out = cli(["walk", "--terrain", "stairs:0.1:0.3:3:down"])
    note = next(line for line in out.splitlines() if line.startswith("wbc walk: note: --steps not given"))
    n = int(note.split("given: ")[1].split(" ")[0])
    assert "the fewest that cross stairs:0.1:0.3:3:down (both heels past x = 0.800 m)" in note
    shortfall = float(next(line for line in out.splitlines() if line.strip().startswith("terrain_shortfall_m"))
                      .split()[-1])
    assert shortfall <= 0.0 and "the walk crosses its terrain" not in out.split("failed_criteria")[-1]
    robot = load_robot("talos")
    holds = plan_default_terrain_walk(robot, "stairs:0.1:0.3:3:down", n_steps=n - 1).footholds
    assert min(holds[-1][0, 3], holds[-2][0, 3]) - robot.sole_length / 2 < 0.8
