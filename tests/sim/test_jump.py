"""A G1 vertical jump in MuJoCo (``wbc sim jump``): criteria of issue 14 measured on MuJoCo's state."""

import numpy as np
import pytest

pytest.importorskip("mujoco", reason="the mujoco extra is not installed")

from wbc.robot import load_robot  # noqa: E402
from wbc.sim.jump import JUMP_OPTIONS, JumpScenario  # noqa: E402
from wbc.sim.mujoco_model import build_mujoco_model  # noqa: E402
from wbc.sim.scenarios import make_controller, run_scenario  # noqa: E402


def _longest(mask) -> int:
    best = cur = 0
    for m in mask:
        cur = cur + 1 if m else 0
        best = max(best, cur)
    return best


def test_g1_vertical_jump():
    robot = load_robot("g1")
    sim = build_mujoco_model(robot)
    sc = JumpScenario()
    run, s = run_scenario(sim, make_controller(robot, "id", dt=sim.timestep, **JUMP_OPTIONS), sc)
    assert not run.fell
    assert run.t[-1] >= sc.duration - 2 * run.dt
    # MuJoCo ground truth: sole positions and plant ground reaction forces, not the plan
    rise = run.sole_pos[:, :, 2] - run.sole_pos[0, :, 2]
    both_up = rise.min(axis=1) >= 0.05
    assert _longest(both_up) * run.dt >= 0.1, _longest(both_up) * run.dt
    fz = run.sim_wrench[:, :, 2].sum(axis=1)
    assert (fz[both_up] < 1e-6).all()  # no ground force while both feet are up
    # landed and stands: the last 0.5 s on both feet with the robot's weight on them, feet not slid
    last = run.t > run.t[-1] - 0.5
    weight = robot.mass * 9.81
    assert np.abs(fz[last].mean() - weight) < 0.1 * weight
    assert (np.abs(rise[last]) < 0.005).all()
    air = np.flatnonzero(both_up)
    after = run.t > run.t[air[-1]] + 0.05  # from 50 ms after the last airborne tick: feet down, no sliding
    pos = run.sole_pos[after, :, :2]
    assert np.linalg.norm(pos - pos[0], axis=2).max() <= 0.02
    slide = np.linalg.norm(run.sole_pos[-1, :, :2] - run.sole_pos[0, :, :2], axis=1).max()
    assert slide <= 0.02, slide
    # applied torques within the URDF effort limits, and every one of them from a QP solved with those limits
    # (no tick fell back to clipping the torques of the relaxed QP)
    lim = robot.model.effortLimit[6:]
    assert (np.abs(run.tau) <= lim * (1 + 1e-9)).all()
    assert s["torque_clipped_ticks"] == 0, s["torque_limited_ticks"]
    # the recording overlays of `wbc sim jump --out` accept the jump run (the CLI passes scenario.plan or None)
    from wbc.viz.overlays import sim_overlays

    scene = sim_overlays(run, robot, getattr(sc, "plan", None))
    assert len(scene["points"]["com"]) == len(run.t)
