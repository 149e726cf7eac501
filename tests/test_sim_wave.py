"""Physics wave (``wbc sim wave``) and the equality-reducing QP backend used for humanoid15's contacts."""

import numpy as np
import pytest

pytest.importorskip("mujoco", reason="the mujoco extra is not installed")

from wbc.qp import make_backend  # noqa: E402
from wbc.robot import load_robot  # noqa: E402
from wbc.sim.mujoco_model import build_mujoco_model  # noqa: E402
from wbc.sim.physics_scenarios import (  # noqa: E402
    ReducedEqualityBackend,
    WaveScenario,
    contacts_rank_deficient,
    wave_acceptance,
)
from wbc.sim.scenarios import OneLegScenario, make_controller, run_scenario  # noqa: E402


def test_reduced_backend_matches_kkt_of_independent_rows():
    rng = np.random.default_rng(3)
    n = 6
    M = rng.standard_normal((n, n))
    H = M @ M.T + np.eye(n)
    g = rng.standard_normal(n)
    A0 = rng.standard_normal((2, n))
    b0 = rng.standard_normal(2)
    # third row = first + second (dependent, consistent); an exact duplicate of the first row
    A = np.vstack([A0, A0[0] + A0[1], A0[0]])
    b = np.concatenate([b0, [b0[0] + b0[1], b0[0]]])
    K = np.block([[H, A0.T], [A0, np.zeros((2, 2))]])
    x_ref = np.linalg.solve(K, np.concatenate([-g, b0]))[:n]
    be = ReducedEqualityBackend(make_backend("daqp"))
    inf = np.full(n, np.inf)
    x = be.solve(H, g, A, b, np.zeros((0, n)), np.zeros(0), np.zeros(0), -inf, inf)
    assert be.dropped_rows == 2
    np.testing.assert_allclose(x, x_ref, atol=1e-8)
    assert np.abs(A @ x - b).max() < 1e-8


def test_humanoid15_contacts_are_rank_deficient_and_g1_not():
    # humanoid15 has no hip yaw: the relative yaw of two flat feet is singular at q_ref
    assert contacts_rank_deficient(load_robot("humanoid15"))
    assert not contacts_rank_deficient(load_robot("g1"))


@pytest.mark.parametrize("name", ["g1"])
def test_wave_in_mujoco(name):
    robot = load_robot(name)
    sim = build_mujoco_model(robot)
    sc = WaveScenario(wave_time=2.0, raise_time=0.6, settle=0.4)
    run, s = run_scenario(sim, make_controller(robot, "id", dt=sim.timestep), sc)
    assert not run.fell
    assert wave_acceptance(s) == []
    # independent of the summary: MuJoCo's sole positions and the measured joint angles of the run
    moved = np.linalg.norm(run.sole_pos[:, :, :2] - run.sole_pos[0, :, :2], axis=2).max()
    assert moved < 0.02
    waving = (run.t > sc.t_wave + 0.5) & (run.t < sc.t_lower - 0.5)
    swept = np.ptp(run.q[waving][:, sc.iq], axis=0)
    assert (swept > 0.5).all(), swept  # commanded ±0.5 rad on the G1 shoulder yaw
    assert run.t[-1] >= sc.duration - 2 * run.dt


def test_one_leg_g1_in_mujoco():
    robot = load_robot("g1")
    sim = build_mujoco_model(robot)
    sc = OneLegScenario(hold=1.0)
    run, s = run_scenario(sim, make_controller(robot, "id", dt=sim.timestep), sc)
    assert not run.fell
    hold = (run.t >= sc.t_hold) & (run.t < sc.t_hold + sc.hold)
    assert run.sole_pos[hold, 1, 2].min() > 0.04  # right (swing) sole, MuJoCo ground truth
