"""Balance behaviours (shift, one-leg, wave, squat, reach) on every catalog robot, with the issue's acceptance
criteria as assertions: zero limit violations, CoM projection margin ≥ 0 at every tick (≥ 0.01 m over the stance
sole for one-leg), the behaviour's own target reached, no solver failure, no NaN."""

from __future__ import annotations

import json

import numpy as np
import pytest

import wbc
from conftest import CATALOG, centroidal_oracle
from wbc.cli import main
from wbc.configuration import Configuration
from wbc.exceptions import InvalidInputError
from wbc.profiles import min_jerk_ramp as min_jerk
from wbc.scenarios.balance import (
    BEHAVIOURS, COMMON_CRITERIA, DOUBLE, LEFT_STANCE, BalanceController, MinJerkPath, balance_summary,
    run_balance,
)
from wbc.geometry import support_polygon

CASES = [(b, r) for b in BEHAVIOURS for r in CATALOG]

ZMP_CRITERION = "ZMP of the executed motion inside the support polygon at every tick"


@pytest.fixture(scope="module")
def runs(robots):
    """(behaviour, robot) -> (robot, run, summary), each run once per module."""
    cache = {}

    def get(behaviour: str, name: str):
        if (behaviour, name) not in cache:
            robot = robots(name)
            run = run_balance(robot, behaviour)
            cache[behaviour, name] = robot, run, balance_summary(robot, run)
        return cache[behaviour, name]

    return get


@pytest.mark.parametrize("behaviour,name", CASES)
def test_behaviour_meets_acceptance(runs, behaviour, name):
    """Every criterion but the executed-motion ZMP (tested on its own below, with the known failures)."""
    robot, run, s = runs(behaviour, name)
    failed = {line.split(": measured ")[0] for line in s["failed_criteria"]}  # the requirement, before its measurement
    assert failed <= {ZMP_CRITERION}, (s["failed_criteria"], s)
    assert s["joint_position_violations"] == 0 and s["joint_velocity_violations"] == 0
    assert s["solver_failures"] == 0 and not s["nan"]
    assert np.all(run.com_margin >= 0.0) and s["min_com_margin_m"] >= 0.0
    assert s["max_stance_slip_m"] <= 1e-3
    assert set(s["max_task_error_rad"]) >= {"torso", "posture"}
    assert ("com" in s["max_task_error_m"]) == (behaviour != "reach")  # reach has no CoM target
    if behaviour == "shift":
        assert max(s["shift_target_error_m"].values()) <= 0.005
        # the CoM really went over each sole: its lateral excursion is half the feet distance
        half = 0.5 * abs(run.left_sole[0, 1, 3] - run.right_sole[0, 1, 3])
        assert s["shift_amplitude_m"] == pytest.approx(half, abs=0.005)
    elif behaviour == "one-leg":
        assert s["lift_height_m"] == pytest.approx(0.10, abs=0.005)
        assert s["lift_hold_s"] >= 3.0
        assert s["min_stance_margin_m"] >= 0.01
        phases = run.support[np.r_[True, np.diff(run.support) != 0]].tolist()
        assert phases == [DOUBLE, LEFT_STANCE, DOUBLE]
        assert s["touchdown_error_m"] <= 0.002
    elif behaviour == "wave":
        assert s["wave_time_s"] == 5.0 and s["wave_amplitude_ratio"] >= 0.95
        assert s["max_task_error_rad"]["arms"] <= 0.05
    elif behaviour == "squat":
        assert len(s["squat_depths_m"]) == 3
        assert all(d == pytest.approx(0.15, abs=0.005) for d in s["squat_depths_m"])
        assert s["final_height_error_m"] <= 0.005
    elif behaviour == "reach":
        assert s["reach_residual_m"] < s["reach_initial_distance_m"]
        assert s["reach_residual_m"] <= 0.005 or s["reach_limited_by"]
        # the forward lean is stopped by the CoM polygon constraint (margin 0.01 m), not by luck
        assert "balance" in s["reach_limited_by"]
        assert s["final_com_margin_m"] == pytest.approx(0.01, abs=1e-3)


def test_summary_keys_and_log_format(runs, tmp_path):
    robot, run, s = runs("one-leg", "humanoid15")
    for key in ("robot", "behaviour", "dt_s", "ticks", "tick_time_us", "min_com_margin_m", "max_task_error_m",
                "max_task_error_rad",
                "joint_position_violations", "joint_velocity_violations", "solver_failures", "nan", "passed",
                "failed_criteria"):
        assert key in s
    assert set(s["tick_time_us"]) == {"median", "p99", "max"}
    path = tmp_path / "b.npz"
    run.save(path)
    data = np.load(path)
    n = s["ticks"]
    assert data["t"].shape == (n,) and np.allclose(np.diff(data["t"]), 0.002)
    assert data["q"].shape == (n, robot.nq) and data["v"].shape == (n, robot.nv)
    assert data["com"].shape == (n, 3) and data["com_ref"].shape == (n, 3)
    assert data["left_sole"].shape == (n, 4, 4) and data["right_sole"].shape == (n, 4, 4)
    assert data["support"].shape == (n,) and data["com_margin"].shape == (n,)
    assert data["task_error"].shape == (n, len(data["task_names"]))
    names, units = list(data["task_names"]), list(data["task_units"])
    assert len(units) == len(names)
    # the swing sole's 6-D frame task: its position error (m) and orientation error (rad) in separate columns
    assert units[names.index("swing:right position")] == "m"
    assert units[names.index("swing:right orientation")] == "rad"
    assert list(data["joint_names"]) == robot.joint_names
    assert str(data["robot"]) == "humanoid15" and str(data["behaviour"]) == "one-leg"


@pytest.mark.parametrize("behaviour,name", CASES)
def test_executed_zmp_stays_in_support(runs, behaviour, name):
    robot, run, s = runs(behaviour, name)
    assert s["min_zmp_margin_m"] >= 0.0
    assert s["passed"], (s["failed_criteria"], s)


def test_executed_zmp_independent_oracle(runs):
    """The summary's ZMP margin against a computation from the logged q, v (Pinocchio centerOfMass and
    computeCentroidalMomentum, np.diff), single-support ticks only so the oracle is a plain rectangle distance in
    the sole frame. Multi-body ZMP: p_x = c_x − (m h c̈_x + L̇_y)/(m(g + c̈_z)), p_y = c_y − (m h c̈_y − L̇_x)/(m(g + c̈_z))."""

    robot, run, s = runs("one-leg", "talos")
    mass, com, acc, ldot = centroidal_oracle(robot.model, run.q, run.v, run.dt)
    single = np.flatnonzero(run.support == LEFT_STANCE)
    worst = np.inf
    for k in single:
        pose = run.left_sole[k]
        h = com[k, 2] - pose[2, 3]
        fz = mass * (acc[k, 2] + 9.81)
        zmp = np.array([com[k, 0] - (mass * h * acc[k, 0] + ldot[k, 1]) / fz,
                        com[k, 1] - (mass * h * acc[k, 1] - ldot[k, 0]) / fz])
        local = pose[:2, :2].T @ (zmp - pose[:2, 3])  # in the sole frame (yaw only)
        worst = min(worst, min(robot.sole_length / 2 - abs(local[0]), robot.sole_width / 2 - abs(local[1])))
    assert 0.0 < worst < 0.2
    # the summary's min covers double support too, so it cannot exceed the single-support minimum
    assert s["min_zmp_margin_m"] <= worst + 1e-9
    assert s["min_zmp_margin_m"] >= 0.0


def test_reach_without_polygon_constraint_leaves_the_polygon(robots):
    """The constraint is what keeps the reach balanced: with it disabled the same reach tips the CoM out."""
    robot = robots("talos")
    config = Configuration(robot)
    from wbc.scenarios.balance_reach import ReachBehaviour

    class Unconstrained(ReachBehaviour):
        def setup(self, ctrl):
            super().setup(ctrl)
            ctrl.controller.remove_constraint(ctrl.com_polygon)

    run = run_balance(robot, Unconstrained(robot, config), config=config)
    assert run.com_margin.min() < 0.0


def test_squat_without_zmp_constraint_leaves_the_support(robots):
    """The dynamic-balance constraints are what keep G1's squat balanced: without the executed-ZMP constraint and
    the acceleration/braking limits the ankles stop at their limit within one tick and the executed ZMP leaves the
    feet (measured −33 mm before these constraints existed)."""
    robot = robots("g1")
    config = Configuration(robot)
    from wbc.scenarios.balance_squat import SquatBehaviour

    class Unconstrained(SquatBehaviour):
        def setup(self, ctrl):
            super().setup(ctrl)
            for c in (ctrl.zmp, *ctrl.smoothness):
                ctrl.controller.remove_constraint(c)
            ctrl.zmp, ctrl.smoothness = None, ()

    run = run_balance(robot, Unconstrained(robot, config), config=config)
    s = balance_summary(robot, run)
    assert s["min_zmp_margin_m"] < 0.0 and not s["passed"]


def test_min_jerk_profile():
    assert min_jerk(-1.0, 0.0, 2.0) == (0.0, 0.0) and min_jerk(3.0, 0.0, 2.0) == (1.0, 0.0)
    s, ds = min_jerk(1.0, 0.0, 2.0)
    assert s == pytest.approx(0.5) and ds == pytest.approx(30 / 16 / 2.0)
    eps = 1e-6
    for t in (0.3, 1.1, 1.7):
        num = (min_jerk(t + eps, 0.0, 2.0)[0] - min_jerk(t - eps, 0.0, 2.0)[0]) / (2 * eps)
        assert min_jerk(t, 0.0, 2.0)[1] == pytest.approx(num, rel=1e-6)
    path = MinJerkPath([0.0, 0.0], [(1.0, 0.5, [1.0, 2.0]), (2.0, 0.0, [0.0, 0.0])])
    assert path.end_time == 3.5
    np.testing.assert_allclose(path(1.2)[0], [1.0, 2.0])
    np.testing.assert_allclose(path(1.2)[1], 0.0)
    np.testing.assert_allclose(path(2.5)[0], [0.5, 1.0])
    np.testing.assert_allclose(path(10.0)[0], 0.0)
    with pytest.raises(InvalidInputError):
        MinJerkPath([0.0], [(-1.0, 0.0, [1.0])])


def test_polygon_constraint_follows_the_support(robots):
    """The CoM polygon constraint is re-targeted at every support change: both soles, then the stance sole."""
    robot = robots("g1")
    config = Configuration(robot)
    ctrl = BalanceController(robot, config, polygon_margin=0.0125)
    assert isinstance(ctrl.com_polygon, wbc.constraints.ComPolygonConstraint)
    assert any(c is ctrl.com_polygon for c in ctrl.controller.constraints)
    size = robot.sole_length, robot.sole_width
    np.testing.assert_allclose(ctrl.com_polygon.polygon, support_polygon([ctrl.contact[s].placement
                                                                          for s in ("left", "right")], *size))
    ctrl.set_support(LEFT_STANCE, config)
    np.testing.assert_allclose(ctrl.com_polygon.polygon, support_polygon([ctrl.contact["left"].placement], *size))
    assert not any(c is ctrl.contact["right"] for c in ctrl.controller.constraints)
    assert ctrl.has_task(ctrl.swing["right"])
    ctrl.set_support(DOUBLE, config)
    assert len(ctrl.com_polygon.polygon) == 4 and not ctrl.has_task(ctrl.swing["right"])


def test_bad_behaviour_inputs_raise_typed_errors(robots):
    robot = robots("humanoid15")
    with pytest.raises(InvalidInputError, match="valid"):
        run_balance(robot, "cartwheel")
    with pytest.raises(InvalidInputError, match="stance"):
        run_balance(robot, "one-leg", stance="middle")
    with pytest.raises(InvalidInputError, match="dt"):
        run_balance(robot, "shift", dt=0.0)


def test_cli_balance_writes_summary_and_log(tmp_path, capsys):
    js, log = tmp_path / "s.json", tmp_path / "b.npz"
    code = main(["balance", "squat", "--robot", "humanoid15", "--json", str(js), "--log", str(log)])
    out = capsys.readouterr().out
    assert code == 0, out
    assert "squat_depth_m" in out
    summary = json.loads(js.read_text())
    assert summary["passed"] and summary["behaviour"] == "squat" and summary["robot"] == "humanoid15"
    assert summary["squat_depth_m"] == pytest.approx(0.15, abs=0.005)
    data = np.load(log)
    assert data["q"].shape[0] == summary["ticks"]
    assert main(["balance", "squat", "--robot", "atlas"]) == 2
    with pytest.raises(SystemExit):
        main(["balance", "cartwheel"])


def test_common_criteria_fail_on_bad_summaries():
    from wbc.scenarios.balance import balance_passes

    good = {"min_com_margin_m": 0.02, "min_zmp_margin_m": 0.01, "max_stance_slip_m": 0.0, "joint_position_violations": 0,
            "joint_velocity_violations": 0, "solver_failures": 0, "nan": False}
    assert balance_passes(good, COMMON_CRITERIA) == (True, [])
    for key, bad in (("min_com_margin_m", -1e-4), ("min_zmp_margin_m", -1e-4), ("joint_position_violations", 1), ("solver_failures", 2),
                     ("nan", True)):
        ok, failed = balance_passes({**good, key: bad}, COMMON_CRITERIA)
        assert not ok and len(failed) == 1
    ok, failed = balance_passes({}, COMMON_CRITERIA)
    assert not ok and len(failed) == len(COMMON_CRITERIA)
