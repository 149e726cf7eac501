"""End-to-end walks of every catalog robot, with the main job's acceptance criteria as assertions."""

from __future__ import annotations

import json

import numpy as np
import pytest

import wbc
from conftest import CATALOG
from wbc.cli import main
from wbc.configuration import Configuration
from wbc.exceptions import RobotFileNotFoundError, UnknownRobotError
from wbc.scenarios.acceptance import WALK_CRITERIA
from wbc.scenarios.walk import WalkController, plan_default_walk, run_walk, walk_summary


@pytest.mark.parametrize("name", CATALOG)
def test_default_walk_meets_acceptance(robots, name):
    robot = robots(name)
    plan = plan_default_walk(robot)  # 8 steps, the robot's default step length
    summary = walk_summary(robot, plan, run_walk(robot, plan))
    failed = [desc for _, desc, ok in WALK_CRITERIA if not ok(summary)]
    assert not failed, (failed, summary)
    assert summary["planned_distance_m"] == pytest.approx(7 * robot.gait["step_length"])


def test_turning_walk(robots):
    robot = robots("talos")
    plan = plan_default_walk(robot, n_steps=6, step_length=0.1, turn=0.15)
    run = run_walk(robot, plan)
    summary = walk_summary(robot, plan, run)
    failed = [desc for _, desc, ok in WALK_CRITERIA if not ok(summary)]
    assert not failed, (failed, summary)
    yaw = np.arctan2(run.left_sole[-1, 1, 0], run.left_sole[-1, 0, 0])
    assert yaw == pytest.approx(5 * 0.15, abs=2e-3)  # the closing step keeps the last heading


@pytest.mark.parametrize("name", ["talos", "humanoid15"])
def test_hard_constraints_hold_every_tick(robots, name):
    """Stance contacts and joint bounds hold to 1e-6 on the command of every solved tick.

    Rows the controller drops as linearly dependent (humanoid15: two flat feet both fix the base yaw) are implied
    by the kept ones up to drift; they are held to the controller's documented ``dependent_row_tolerance``.
    """
    robot = robots(name)
    plan = plan_default_walk(robot, n_steps=3)
    config = Configuration(robot)
    walker = WalkController(robot, config)
    ctrl = walker.controller
    worst_kept = worst_dropped = worst_box = 0.0
    dropped_any = False
    for k in range(0, len(plan.t)):
        walker.set_references(plan, k, config)
        H, g, A, b, C, l, u, lb, ub = (x.copy() for x in ctrl.assemble(config, plan.dt))
        result = ctrl.solve(config, plan.dt)
        assert result.ok, result.message
        residual = np.abs(A @ result.v - b)
        kept = np.zeros(len(b), dtype=bool)
        kept[ctrl._eq_rows] = True
        dropped_any |= not kept.all()
        worst_kept = max(worst_kept, float(residual[kept].max(initial=0.0)))
        worst_dropped = max(worst_dropped, float(residual[~kept].max(initial=0.0)))
        worst_box = max(worst_box, float(max((lb - result.v).max(), (result.v - ub).max())))
        config.update(config.integrate(result.v, plan.dt))
    assert worst_kept <= 1e-6
    assert worst_dropped <= ctrl.dependent_row_tolerance
    assert worst_box <= 0.0
    assert dropped_any == (name == "humanoid15")  # only the gimbal-locked legs have dependent contact rows


def test_cli_walk_writes_summary_and_log(tmp_path, capsys):
    js, log = tmp_path / "s.json", tmp_path / "w.npz"
    code = main(["walk", "--robot", "humanoid15", "--steps", "3", "--json", str(js), "--log", str(log)])
    out = capsys.readouterr().out
    assert code == 0, out
    summary = json.loads(js.read_text())
    assert summary["passed"] and summary["robot"] == "humanoid15" and summary["ticks"] > 0
    data = np.load(log)
    n, robot = summary["ticks"], wbc.load_robot("humanoid15")
    assert data["t"].shape == (n,) and np.allclose(np.diff(data["t"]), 0.002)
    assert data["q"].shape == (n, robot.nq) and data["v"].shape == (n, robot.nv)
    for key in ("com", "com_ref"):
        assert data[key].shape == (n, 3)
    assert data["zmp_ref"].shape == (n, 2)
    assert data["left_sole"].shape == (n, 4, 4) and data["right_sole"].shape == (n, 4, 4)
    assert set(np.unique(data["support"])) == {0, 1, 2}
    assert list(data["joint_names"]) == robot.joint_names and str(data["robot"]) == "humanoid15"


def test_bad_robot_inputs_raise_typed_errors(tmp_path, capsys):
    with pytest.raises(UnknownRobotError, match=r"\['g1', 'humanoid15', 'talos'\]"):
        wbc.load_robot("atlas")
    with pytest.raises(RobotFileNotFoundError, match="nowhere.urdf"):
        wbc.load_robot(tmp_path / "nowhere.urdf", left_sole="a", right_sole="b", torso="c")
    assert main(["walk", "--robot", "atlas"]) == 2
    assert "catalog" in capsys.readouterr().err


def test_any_urdf_loads_with_explicit_frames(robots):
    talos = robots("talos")
    robot = wbc.load_robot(talos.urdf_path, srdf=talos.srdf_path, reference="half_sitting",
                           left_sole="left_sole_link", right_sole="right_sole_link", torso="torso_2_link",
                           sole_length=0.21, sole_width=0.13)
    assert robot.nv == talos.nv
    np.testing.assert_allclose(robot.q_ref, talos.q_ref)
