"""Closed loop on estimated state: the controller reads ``wbc.estimation.FloatingBaseEstimator``'s estimate from the
plant's noisy sensors (``wbc.sim.sensors``), a 4-step Talos walk at 0.4 m/s. The criteria are measured on MuJoCo's
ground truth (logged q, v, sole positions); the estimate is compared with it here, independently of
``wbc.sim.estimated_state.estimation_errors``. No wall-clock assertion."""

import numpy as np
import pytest
import pinocchio as pin

from wbc.robot import load_robot
from wbc.sim.estimated_state import EstimatedState, estimation_errors
from wbc.sim.mujoco_model import build_mujoco_model
from wbc.sim.physics_scenarios import walk_options_for
from wbc.sim.scenarios import make_controller, run_scenario
from wbc.sim.walk import WalkScenario


def test_talos_walks_on_estimated_state():
    robot = load_robot("talos")
    sim = build_mujoco_model(robot)
    controller = make_controller(robot, "id", dt=sim.timestep, **walk_options_for(robot))
    state = EstimatedState(sim, seed=3)
    run, s = run_scenario(sim, controller, WalkScenario(4, 0.24, 0.6), state=state)
    assert not run.fell and s["completed"] and s["solver_failures"] == 0
    mid = run.sole_pos[:, :, :2].mean(axis=1)  # MuJoCo's sole positions
    walked = float(np.linalg.norm(mid[-1] - mid[0]))
    assert abs(walked - 3 * 0.24) <= 0.05 * 3 * 0.24
    assert s["max_stance_slip_m"] <= 0.005
    qe, ve = run.extra["q_est"], run.extra["v_est"]
    assert qe.shape == run.q.shape and not np.array_equal(qe, run.q)  # the log keeps the ground truth
    # Estimate vs MuJoCo: base position drift ≤ 2 % of the distance walked, orientation error ≤ 1 deg,
    # world-frame base velocity RMS error ≤ 0.05 m/s.
    n = len(run.t)
    ang, dv = np.empty(n), np.empty(n)
    for k in range(n):
        R = pin.Quaternion(run.q[k, 3:7]).toRotationMatrix()  # (x, y, z, w) coefficients
        Re = pin.Quaternion(qe[k, 3:7]).normalized().toRotationMatrix()
        ang[k] = np.linalg.norm(pin.log3(Re.T @ R))
        dv[k] = np.linalg.norm(R @ run.v[k, :3] - Re @ ve[k, :3])
    drift = np.linalg.norm(qe[-1, :3] - run.q[-1, :3])
    assert drift <= 0.02 * walked
    assert np.degrees(ang.max()) <= 1.0
    assert np.sqrt(np.mean(dv**2)) <= 0.05
    e = estimation_errors(run.q, run.v, qe, ve, walked)
    # (the same norm summed along another axis: equal to rounding)
    assert e["base_position_drift_m"] == pytest.approx(drift, rel=1e-12, abs=1e-15)
    assert abs(e["max_orientation_error_deg"] - np.degrees(ang.max())) < 1e-9


def test_cli_state_options_are_checked():
    from wbc.cli import main

    assert main(["sim", "walk", "--state", "ground-truth", "--zmp-feedback", "0.5"]) == 2
    with pytest.raises(SystemExit) as exc:  # refused while parsing
        main(["sim", "walk", "--zmp-feedback", "-1"])
    assert exc.value.code == 2


def test_compiled_measured_zmp_matches_a_numpy_reference():
    """The compiled ZMP of EstimatedState.measured_zmp equals the plane-of-zero-horizontal-moment point written here
    with numpy (sum of R f, R m + t × R f over the two soles, moved to the plane z = h) to 1e-12 m, on random
    wrenches and sole placements, on flat ground (h = 0) and at a tread height; below min_fz of total normal force
    there is none."""
    from wbc.sim.estimated_state import _zmp_kernel

    rng = np.random.default_rng(5)
    n_none = 0
    for it in range(500):
        X = [pin.SE3(pin.rpy.rpyToMatrix(*rng.normal(scale=0.2, size=3)), rng.normal(scale=0.3, size=3))
             for _ in range(2)]
        w = rng.normal(scale=[30, 30, 200, 10, 10, 5], size=(2, 6))
        h = (0.0, 0.12)[it % 2]
        F = sum(Xi.rotation @ wi[:3] for Xi, wi in zip(X, w))
        M = sum(Xi.rotation @ wi[3:] + np.cross(Xi.translation, Xi.rotation @ wi[:3]) for Xi, wi in zip(X, w))
        M = M - np.cross([0.0, 0.0, h], F)
        found, x, y = _zmp_kernel(w, X[0].rotation, X[0].translation, X[1].rotation, X[1].translation, 10.0, h)
        assert found == (F[2] >= 10.0)
        if found:
            np.testing.assert_allclose([x, y], [-M[1] / F[2], M[0] / F[2]], rtol=1e-12, atol=1e-12)
        n_none += not found
    assert 10 < n_none < 490


class _RecordingViewer:
    """A viewer that reads the configuration: keeps every q it is given, with MuJoCo's state at that call."""

    def __init__(self, sim):
        self.sim, self.q, self.qpos = sim, [], []

    def update(self, q, t):
        self.q.append(np.array(q))
        self.qpos.append(self.sim.data.qpos.copy())


def test_ground_truth_log_is_the_same_whether_or_not_a_viewer_reads_it():
    """With an estimated state the loop reads MuJoCo's ground truth only for the log (converted after the loop)
    unless the viewer reads the configuration: both runs log the same q, v and CoM, bit for bit, and the CoM is
    Pinocchio's ``centerOfMass`` of the logged q."""
    from wbc.sim.scenarios import StandScenario
    from wbc.viz.progress import ProgressViewer

    robot = load_robot("talos")
    runs = []
    viewer = None
    for reads in (False, True):
        sim = build_mujoco_model(robot)
        controller = make_controller(robot, "id", dt=sim.timestep)
        viewer = _RecordingViewer(sim) if reads else ProgressViewer(0.1, None, enabled=False)
        assert getattr(viewer, "reads_configuration", True) is reads
        run, _ = run_scenario(sim, controller, StandScenario(duration=0.1), state=EstimatedState(sim, seed=1),
                              viewer=viewer)
        runs.append(run)
    a, b = runs
    for key in ("q", "v", "com", "tau", "sim_wrench"):
        assert np.array_equal(getattr(a, key), getattr(b, key)), key
    assert np.array_equal(np.array(viewer.q), b.q)
    # the viewer is called after the step: MuJoCo then holds the state of log row k + 1 (base position)
    assert np.array_equal(np.array(viewer.qpos)[:-1, :3], b.q[1:, :3])
    model = robot.model
    data = model.createData()
    for k in (0, len(b.t) // 2, len(b.t) - 1):
        assert np.array_equal(pin.centerOfMass(model, data, b.q[k], False), b.com[k])
