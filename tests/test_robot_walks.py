"""A humanoid outside the catalog end to end from its URDF: `wbc robot init` → `wbc robot check` → a 2-step
kinematic walk (with the joint-acceleration bound checked on the logged q: no chattering) → a 2-step physics walk
in MuJoCo on the robot's own feet (``[mujoco] foot = "urdf"``: its visual foot meshes, it has no collision geometry).
Robot: example-robot-data's Alexander (lower body, no collision geometry, Wavefront meshes)."""

from __future__ import annotations

import json

import numpy as np
import pinocchio as pin
import pytest

from wbc.cli import main
from wbc.robot import example_robot_data_dir, load_robot

URDF = example_robot_data_dir() / "example-robot-data" / "robots" / "alexander_description" / "urdf" / \
    "alexander_v1.lowerBodyOnly.urdf"
#: The walk's joint-acceleration bound (rad/s², WalkController's default) and the slack allowed on logged q.
A_MAX = 50.0
SLACK = 1.05


def joint_accelerations(model: pin.Model, q: np.ndarray, dt: float) -> np.ndarray:
    """(N − 2, nv − 6) joint accelerations from logged configurations: v_k = (q_{k+1} ⊖ q_k) / dt, a = Δv / dt."""
    v = np.array([pin.difference(model, q[k], q[k + 1]) / dt for k in range(len(q) - 1)])
    return (np.diff(v, axis=0) / dt)[:, 6:]


def chattering(acc: np.ndarray, bound: float) -> int:
    """Number of (tick, joint) pairs where the acceleration exceeds ``bound`` on two consecutive ticks with
    opposite signs."""
    big = np.abs(acc) > bound
    return int(np.sum(big[1:] & big[:-1] & (np.sign(acc[1:]) != np.sign(acc[:-1]))))


def test_chattering_detector_fails_on_chattering():
    model = pin.buildSampleModelHumanoid()
    q = np.tile(pin.neutral(model), (50, 1))
    idx = model.joints[model.getJointId("lleg_knee_joint") if model.existJointName("lleg_knee_joint")
                        else 2].idx_q
    dt = 0.002
    q[:, idx] += 0.5 * 80.0 * dt**2 * (np.arange(50) % 2)  # ±80 rad/s² alternating each tick
    acc = joint_accelerations(model, q, dt)
    assert chattering(acc, A_MAX) > 40
    assert chattering(joint_accelerations(model, np.tile(pin.neutral(model), (50, 1)), dt), A_MAX) == 0


@pytest.fixture(scope="module")
def robot_file(tmp_path_factory):
    out = tmp_path_factory.mktemp("alexander") / "alexander.toml"
    assert main(["robot", "init", str(URDF), "-o", str(out)]) == 0
    return out


def test_init_and_check(robot_file, capsys):
    text = robot_file.read_text()
    assert 'urdf = "erd:alexander_description/urdf/alexander_v1.lowerBodyOnly.urdf"' in text
    # the gait bounded by the legs and the assumed drives are said in the file
    assert "# - gait: nominal step (" in text and "armature = 0.01" in text
    # the plant's feet are the robot's own (visual: it has no collision geometry), not boxes of the sole
    assert 'foot = "urdf"' in text
    assert main(["robot", "check", str(robot_file)]) == 0
    out = capsys.readouterr().out
    assert "mass_kg" in out and "legs" in out
    robot = load_robot(str(robot_file))
    # the inferred soles are flat, at the feet's bottom, the CoM between them
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, robot.q_ref)
    for f in (robot.left_sole, robot.right_sole):
        oMf = data.oMf[robot.model.getFrameId(f)]
        assert abs(oMf.translation[2]) < 1e-9 and oMf.rotation[2, 2] > np.cos(np.radians(5))
    assert data.oMf[robot.model.getFrameId(robot.left_sole)].translation[1] > 0.05  # left is +y


def test_two_step_walk_without_chattering(robot_file, tmp_path, capsys):
    log = tmp_path / "walk.npz"
    code = main(["walk", "--robot", str(robot_file), "--steps", "2", "--quiet", "--log", str(log)])
    out = capsys.readouterr().out
    assert code == 0, out
    z = np.load(log)
    robot = load_robot(str(robot_file))
    acc = joint_accelerations(robot.model, z["q"], float(z["dt"]))
    ok = z["solver_ok"][1:-1] & ~z["relaxed"][1:-1]
    assert np.abs(acc[ok]).max() <= A_MAX * SLACK
    assert chattering(acc, A_MAX * SLACK) == 0


def test_two_step_physics_walk(robot_file, tmp_path, capsys):
    summary = tmp_path / "sim.json"
    code = main(["sim", "walk", "--robot", str(robot_file), "--steps", "2", "--quiet", "--json", str(summary)])
    out = capsys.readouterr().out
    s = json.loads(summary.read_text())
    assert code == 0, out
    step = load_robot(str(robot_file)).gait["step_length"]  # 2 steps: the second closes alongside the first
    assert step > 0.05
    assert s["passed"] and s["touchdowns"] == 2 and s["walked_distance_m"] > 0.9 * step
    assert s["joint_speed_exceedances"] == 0


def test_mujoco_resolves_package_uri_with_empty_authority(tmp_path):
    """talos_full_v2.urdf names a mesh ``package:///example-robot-data/...`` (three slashes): Pinocchio loads it, and
    so must the MuJoCo plant (it looked for /example-robot-data/... at the file-system root)."""
    from wbc.sim.mujoco_model import build_mujoco_model

    urdf = URDF.parents[2] / "talos_data" / "robots" / "talos_full_v2.urdf"
    assert "package:///" in urdf.read_text()
    out = tmp_path / "talos_full.toml"
    assert main(["robot", "init", str(urdf), "-o", str(out)]) == 0
    robot = load_robot(str(out))
    sim = build_mujoco_model(robot)
    assert sim.model.nmesh > 0
    assert abs(sim.model.body_mass.sum() - robot.mass) < 1e-6 * robot.mass


def test_one_leg_puts_the_swing_sole_back(robot_file, tmp_path, capsys):
    """Alexander's feet are 0.24 m apart: with the CoM over the stance sole at the start height its outer leg is
    stretched (knee 0.02 rad), so the swing sole held at that height could not come back to the floor (it stopped
    3.8 mm above it). The single support now holds the CoM height reached at lift-off."""
    summary = tmp_path / "one_leg.json"
    code = main(["balance", "one-leg", "--robot", str(robot_file), "--quiet", "--json", str(summary)])
    out = capsys.readouterr().out
    s = json.loads(summary.read_text())
    assert code == 0, out
    assert s["touchdown_error_m"] <= 0.002
    assert abs(s["lift_height_m"] - 0.10) <= 0.005 and s["lift_hold_s"] >= 3.0
    assert s["swing_joints_at_limit"] == "none"


def test_one_leg_names_the_joint_that_stops_the_lift(robot_file, tmp_path, capsys):
    """A lift the legs cannot reach (0.45 m with the sole level) fails on its criterion and names the swing leg's
    joint at its limit; --height applies to one-leg and jump only and must be a lift in (0, 0.5] m."""
    summary = tmp_path / "one_leg_high.json"
    code = main(["balance", "one-leg", "--robot", str(robot_file), "--height", "0.45", "--quiet",
                 "--json", str(summary)])
    capsys.readouterr()
    s = json.loads(summary.read_text())
    assert code == 1 and not s["passed"]
    assert s["lift_height_m"] < 0.445
    assert "limit" in s["swing_joints_at_limit"] and s["swing_joints_at_limit"].split(" at its ")[0].startswith("RIGHT_")
    for bad in (["one-leg", "--height", "nan"], ["one-leg", "--height", "-0.1"], ["shift", "--height", "0.1"]):
        assert main(["balance", *bad, "--robot", str(robot_file)]) == 2
        assert "--height" in capsys.readouterr().err
