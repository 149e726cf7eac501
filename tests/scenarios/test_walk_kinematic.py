"""End-to-end walks of every catalog robot, with the main job's acceptance criteria as assertions."""

from __future__ import annotations

import json

import numpy as np
import pytest

import wbc
from conftest import CATALOG, centroidal_oracle
from wbc.cli import main
from wbc.configuration import Configuration
from wbc.exceptions import RobotFileNotFoundError, UnknownRobotError
from wbc.scenarios.walk import WalkController, plan_default_walk, run_walk, walk_summary


def _failed_walk_criteria(s: dict) -> list[str]:
    """The main job's walk criteria, thresholds written here (not imported from wbc.scenarios.acceptance)."""
    checks = {
        "walked distance within 5% of planned":
            abs(s["walked_distance_m"] - s["planned_distance_m"]) <= 0.05 * max(s["planned_distance_m"], 1e-9),
        "stance-foot slip <= 1 mm": s["max_stance_slip_m"] <= 1e-3,
        "CoM tracking error <= 5 mm": s["max_com_error_m"] <= 5e-3,
        "executed ZMP inside the support polygon": s["min_zmp_margin_m"] >= 0.0,
        "no joint position limit violation": s["joint_position_violations"] == 0,
        "no joint velocity limit violation": s["joint_velocity_violations"] == 0,
        "no solver failure": s["solver_failures"] == 0,
        "no NaN": not s["nan"],
    }
    failed = [desc for desc, ok in checks.items() if not ok]
    assert s["passed"] == (not failed), (s["passed"], failed)  # the summary's verdict agrees with the test's
    return failed


@pytest.mark.parametrize("name", CATALOG)
def test_default_walk_meets_acceptance(robots, name):
    robot = robots(name)
    plan = plan_default_walk(robot)  # 8 steps, the robot's default step length
    run = run_walk(robot, plan)
    summary = walk_summary(robot, plan, run)
    failed = _failed_walk_criteria(summary)
    assert not failed, (failed, summary)
    assert summary["planned_distance_m"] == pytest.approx(7 * robot.gait["step_length"])
    # joint accelerations |v_k − v_{k−1}|/dt within 50 rad/s² (the walk's bound) on every tick
    assert summary["relaxed_ticks"] == 0
    assert np.abs(np.diff(run.v[:, 6:], axis=0)).max() / run.dt <= 50.0 + 1e-6


def test_turning_walk(robots):
    robot = robots("talos")
    plan = plan_default_walk(robot, n_steps=6, step_length=0.1, turn=0.15)
    run = run_walk(robot, plan)
    summary = walk_summary(robot, plan, run)
    failed = _failed_walk_criteria(summary)
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


def _rectangle_hull_margin(point, soles, length, width):
    """Signed distance (m, > 0 inside) of a 2-D point to the convex hull of sole rectangles, with scipy: exact
    when inside; when outside, only its sign is meaningful (the largest facet violation, a lower bound)."""
    from scipy.spatial import ConvexHull

    corners = np.array([[sx * length / 2, sy * width / 2, 0.0, 1.0] for sx in (-1, 1) for sy in (-1, 1)])
    pts = np.vstack([(pose @ corners.T).T[:, :2] for pose in soles])
    hull = ConvexHull(pts)
    return float(-np.max(hull.equations[:, :2] @ point + hull.equations[:, 2]))


@pytest.mark.parametrize("name", ["talos", "g1"])
def test_summary_zmp_is_the_executed_motion_zmp(robots, name):
    """Independent oracle of the multi-body ZMP of the executed motion: CoM from the logged q with Pinocchio's
    centerOfMass, c̈ by np.diff twice, centroidal angular momentum from the logged (q, v) with Pinocchio's
    computeCentroidalMomentum and L̇ by np.diff, Newton-Euler about the CoM with the ground wrench at the ZMP on
    the stance sole plane, distance to the sole rectangles with scipy's ConvexHull."""

    robot = robots(name)
    plan = plan_default_walk(robot)
    run = run_walk(robot, plan)
    s = walk_summary(robot, plan, run)
    mass, com, acc, ldot = centroidal_oracle(robot.model, run.q, run.v, run.dt)
    margins, margins_com = [], []
    for k in range(len(com)):
        soles = [p[k] for code, p in ((1, run.left_sole), (2, run.right_sole)) if run.support[k] in (0, code)]
        h = com[k, 2] - np.mean([p[2, 3] for p in soles])
        fz = mass * (acc[k, 2] + 9.81)
        fx, fy = mass * acc[k, 0], mass * acc[k, 1]
        zmp = np.array([com[k, 0] - (h * fx + ldot[k, 1]) / fz, com[k, 1] - (h * fy - ldot[k, 0]) / fz])
        zmp_com = com[k, :2] - h * acc[k, :2] / (acc[k, 2] + 9.81)
        margins.append(_rectangle_hull_margin(zmp, soles, robot.sole_length, robot.sole_width))
        margins_com.append(_rectangle_hull_margin(zmp_com, soles, robot.sole_length, robot.sole_width))
    margins, margins_com = np.array(margins), np.array(margins_com)
    assert set(np.unique(run.support)) == {0, 1, 2}  # codes: 0 double, 1 left, 2 right stance
    assert margins.min() >= 0.0  # the walk's executed multi-body ZMP stays inside the soles
    assert s["min_zmp_margin_m"] == pytest.approx(margins.min(), abs=1e-6)  # c̈ amplifies CoM round-off by 1/dt²
    if margins_com.min() >= 0:
        assert s["min_zmp_margin_com_only_m"] == pytest.approx(margins_com.min(), abs=1e-6)
    else:  # outside, the scipy distance is only a lower bound: the sign must agree
        assert s["min_zmp_margin_com_only_m"] < 0
    # the executed ZMP differs from the plan's: the plan margin is reported beside it
    assert s["min_zmp_margin_plan_m"] != s["min_zmp_margin_m"]


@pytest.mark.parametrize("defect", ["reflection", "scaled", "sheared", "nan"])
def test_set_plan_refuses_a_sole_block_that_is_not_a_rotation(robots, defect):
    """WalkController.set_plan validates every sample's sole rotation once: a reflection (det −1), a column
    scaled by 1 + 1e-5, a sheared block, a NaN — each refused with InvalidTargetError; the untouched plan is
    accepted. (Checked against the definition: RᵀR = I within 1e-6 and det R = +1 by numpy.linalg.)"""
    from dataclasses import replace

    from wbc.exceptions import InvalidTargetError

    robot = robots("humanoid15")
    plan = plan_default_walk(robot)
    walker = WalkController(robot, Configuration(robot))
    walker.set_plan(plan)  # the planner's plan passes
    left = plan.left_sole.copy()
    k = len(left) // 2
    block = left[k, :3, :3]
    if defect == "reflection":
        block[:, 0] *= -1.0
    elif defect == "scaled":
        block[:, 1] *= 1.0 + 1e-5
    elif defect == "sheared":
        block[:, 2] += 1e-3 * block[:, 0]
    else:
        block[0, 0] = np.nan
    if defect != "nan":  # the defect is real by numpy's definition of a rotation
        assert (np.abs(block.T @ block - np.eye(3)).max() > 1e-6) or np.linalg.det(block) < 0
    with pytest.raises(InvalidTargetError, match="left_sole"):
        walker.set_plan(replace(plan, left_sole=left))
