"""Physics wave (``wbc sim wave``) and the equality-reducing QP backend used for humanoid15's contacts."""

import numpy as np
import pytest

pytest.importorskip("mujoco", reason="the mujoco extra is not installed")

from wbc.robot import load_robot  # noqa: E402
from wbc.sim.mujoco_model import build_mujoco_model  # noqa: E402
from wbc.sim.physics_scenarios import (  # noqa: E402
    WaveScenario,
    contacts_rank_deficient,
    id_options_for,
    wave_acceptance,
)
from wbc.sim.scenarios import OneLegScenario, make_controller, run_scenario  # noqa: E402


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


@pytest.mark.parametrize("name", ["g1", "humanoid15"])
def test_one_leg_in_mujoco(name):
    robot = load_robot(name)
    sim = build_mujoco_model(robot)
    sc = OneLegScenario(hold=1.0)
    run, s = run_scenario(sim, make_controller(robot, "id", dt=sim.timestep, **id_options_for(robot)), sc)
    assert not run.fell
    hold = (run.t >= sc.t_hold) & (run.t < sc.t_hold + sc.hold)
    assert run.sole_pos[hold, 1, 2].min() > 0.04  # right (swing) sole, MuJoCo ground truth
    assert run.ok.all()  # every tick solved the QP (humanoid15 needs id_options_for: see its docstring)


def test_cli_wave_needs_the_id_controller():
    from wbc.cli import main

    assert main(["sim", "wave", "--robot", "g1", "--controller", "pd"]) == 2
