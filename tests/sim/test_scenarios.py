"""Closed-loop MuJoCo scenarios under the inverse-dynamics controller (acceptance criteria of ``wbc sim``).

Durations are short but honest: the stand runs 2 s, the pushes run 0.5 s + the push + 2.5 s of recovery.
"""

from __future__ import annotations

import json
import os

import numpy as np
import pytest

import wbc
from wbc.cli import main
from wbc.sim.actuators import actuator_model, compensation_options
from wbc.sim.mujoco_model import build_mujoco_model
from wbc.sim.scenarios import (
    DEFAULT_PUSH_FORCE,
    OneLegScenario,
    PushScenario,
    StandScenario,
    capture_point_bound,
    make_controller,
    run_scenario,
)

_SIMS: dict[str, object] = {}


def _sim(name):
    if name not in _SIMS:
        _SIMS[name] = build_mujoco_model(wbc.load_robot(name))
    return _SIMS[name]


def _check_id_summary(s):
    assert s["max_dynamics_residual"] < 1e-6
    assert s["solver_failures"] == 0 and s["relaxed_qp_ticks"] == 0
    assert s["min_friction_margin_n"] > -1e-6 and s["min_normal_force_margin_n"] > -1e-6
    assert s["min_cop_margin_m"] > -1e-9 and s["min_torque_margin_nm"] > -1e-6


@pytest.mark.parametrize("robot_name", ["talos", "g1"])
def test_stand(robot_name):
    sim = _sim(robot_name)
    run, s = run_scenario(sim, make_controller(sim.robot, "id"), StandScenario(2.0))
    assert s["passed"], s["failed_criteria"]
    assert not s["fell"] and s["com_drift_m"] < 0.005
    _check_id_summary(s)


@pytest.mark.parametrize("robot_name", ["talos", "g1"])
def test_push(robot_name):
    """Talos 450 N, G1 120 N, 0.1 s, lateral, at the torso link origin: no fall, feet stay (no stepping), no joint
    above its URDF speed limit — on the plant ``wbc sim push`` uses by default (realistic drives, the controller's
    compensation). On the ideal plant (no rotor armature) the same Talos push drives arm_left_5 to 1.31 × its
    URDF speed limit (65 exceedances), which the outcome criteria report as a failure."""
    robot = wbc.load_robot(robot_name)
    sim = build_mujoco_model(robot, plant="realistic")
    options = compensation_options(robot, actuator_model(robot))
    force = DEFAULT_PUSH_FORCE[robot_name]
    run, s = run_scenario(sim, make_controller(robot, "id", **options), PushScenario(force, 0.1))
    assert s["passed"], s["failed_criteria"]
    assert not s["fell"] and s["feet_moved_m"] < 0.02
    assert abs(s["push_impulse_ns"] - 0.1 * force) < 1e-6 * force
    assert np.abs(run.ext_force[:, 1]).max() == force
    _check_id_summary(s)


def test_pd_baseline_falls_where_id_survives():
    sim = _sim("talos")
    _, s = run_scenario(sim, make_controller(sim.robot, "pd"), PushScenario(DEFAULT_PUSH_FORCE["talos"], 0.1))
    assert s["fell"] or s["feet_moved_m"] > 0.02
    assert not s["passed"]


def test_one_leg_talos():
    sim = _sim("talos")
    run, s = run_scenario(sim, make_controller(sim.robot, "id"), OneLegScenario())
    assert s["passed"], s["failed_criteria"]
    assert s["hold_completed"] and s["lifted_foot_min_height_m"] >= 0.04
    _check_id_summary(s)


def test_capture_point_bound_talos():
    cp = capture_point_bound(wbc.load_robot("talos"), 0.1)
    # d = sole half-width + half feet distance (0.065 + 0.085) minus the CoM's lateral offset.
    assert 0.14 < cp["edge_distance_m"] < 0.155
    assert cp["f_max_finite_n"] > cp["f_max_impulse_n"] > 400.0


def test_push_moment_of_the_bound_is_the_angular_momentum_mujoco_gives():
    """The push-step bound counts the angular momentum h J a push at the torso gives about the CoM. Reference:
    MuJoCo — the robot floating (gravity off, 1 m up), pushed at its torso origin for 10 ms, joints passive; the
    centroidal angular momentum of the resulting state (Pinocchio) about e_z × push direction is h J within 3 %."""
    import pinocchio as pin

    robot = wbc.load_robot("talos")
    sim = build_mujoco_model(robot)
    sim.model.opt.gravity[:] = 0.0
    q = robot.q_ref.copy()
    q[2] += 1.0
    sim.set_state(q, np.zeros(robot.model.nv))
    force, t_push = 400.0, 0.01
    for deg in (90.0, 0.0):
        u = np.array([np.cos(np.radians(deg)), np.sin(np.radians(deg)), 0.0])
        cp = capture_point_bound(robot, 0.1, u)
        sim.set_state(q, np.zeros(robot.model.nv))
        n = int(round(t_push / sim.timestep))
        for _ in range(n):
            sim.apply_external_force(robot.torso, force * u)
            sim.step()
        sim.clear_external_forces()
        qm, vm = sim.get_state()
        h = pin.computeCentroidalMomentum(robot.model, robot.model.createData(), qm, vm)
        L = float(np.asarray(h.angular) @ np.cross([0.0, 0.0, 1.0], u))
        J = force * n * sim.timestep
        assert np.asarray(h.linear) @ u == pytest.approx(J, rel=1e-3)
        assert L == pytest.approx(cp["push_height_above_com_m"] * J, rel=0.03)
    # the bound shrinks by z_c / (z_c + h)
    assert cp["f_max_impulse_moment_n"] == pytest.approx(
        cp["f_max_impulse_n"] * cp["com_height_m"] / (cp["com_height_m"] + cp["push_height_above_com_m"]))


def test_unloaded_contacts_counts_active_soles_the_plant_does_not_load():
    from wbc.sim.scenarios import unloaded_contacts

    n, dt, weight = 100, 0.002, 400.0
    ca = np.ones((n, 2), dtype=bool)
    fz = np.full((n, 2), 200.0)
    fz[10:40, 1] = 0.0  # right sole unloaded 30 ticks while a contact
    fz[50:55, 1] = 3.9  # 5 ticks below 1 % of the weight (4 N)
    fz[60:80, 0] = 0.0
    ca[60:80, 0] = False  # left sole released (a swing): not counted
    fz[90:95, 0] = 4.0  # at the threshold: loaded
    assert unloaded_contacts(ca, fz, dt, weight) == {"left": 0.0, "right": pytest.approx(30 * dt)}
    assert unloaded_contacts(ca, fz, dt, weight, until=20 * dt)["right"] == pytest.approx(11 * dt)  # ticks 10..20


def test_default_push_is_the_bound_along_the_push():
    """The default push of `sim push` / `sim push-step` is the capture-point impulse bound m ω d / T along the push
    direction (it was always the lateral bound: a push from behind on a robot with long feet and a narrow stance
    got a sideways-sized force). Reference: d from Pinocchio's sole placements and the sole rectangle corners."""
    import math

    import pinocchio as pin

    from wbc.sim.scenarios import default_push_force

    robot = wbc.load_robot("humanoid15")
    model, data = robot.model, robot.model.createData()
    com = pin.centerOfMass(model, data, robot.q_ref)
    pin.framesForwardKinematics(model, data, robot.q_ref)
    corners = [data.oMf[model.getFrameId(f)].act(np.array([sx * robot.sole_length / 2, sy * robot.sole_width / 2, 0]))
               for f in (robot.left_sole, robot.right_sole) for sx in (-1, 1) for sy in (-1, 1)]
    omega = math.sqrt(9.81 / com[2])
    # push-step: the pushed torso origin is h above the CoM, its angular impulse h J costs ω h J/(m g) of DCM travel
    h = data.oMf[model.getFrameId(robot.torso)].translation[2] - com[2]
    assert h > 0.05
    for deg, axis in ((0.0, 0), (90.0, 1)):
        d = max(c[axis] - com[axis] for c in corners)
        ref = robot.mass * omega * d / 0.1
        assert default_push_force(robot, "push-step", 0.1, deg) == pytest.approx(ref * com[2] / (com[2] + h), abs=0.06)
        assert default_push_force(robot, "push", 0.1, deg) == pytest.approx(0.5 * ref, rel=1e-9)
    # the sagittal and lateral bounds differ (so the direction matters)
    assert abs(default_push_force(robot, "push-step", 0.1, 0.0) - default_push_force(robot, "push-step", 0.1, 90.0)) > 5
    assert default_push_force(wbc.load_robot("talos"), "push-step", 0.1, 0.0) == 450.0


def test_cli_stand_json(tmp_path):
    out = tmp_path / "s.json"
    log = tmp_path / "s.npz"
    code = main(["sim", "stand", "--robot", "g1", "--duration", "0.5", "--json", str(out), "--log", str(log)])
    assert code == 0
    s = json.loads(out.read_text())
    for key in ("fell", "fall_reason", "com_drift_m", "max_com_error_m", "min_friction_margin_n",
                "min_torque_margin_nm", "max_dynamics_residual", "real_time_factor", "tick_time_us"):
        assert key in s
    assert set(s["tick_time_us"]) == {"median", "p99", "max"}
    data = np.load(log)
    assert data["q"].shape == (250, wbc.load_robot("g1").nq)
    assert main(["sim", "sway", "--robot", "g1", "--controller", "pd", "--duration", "0.2"]) == 2


@pytest.mark.skipif(os.environ.get("MUJOCO_GL", "egl") != "egl" and not os.environ.get("DISPLAY"),
                    reason="offscreen rendering needs MUJOCO_GL=egl")
def test_video(tmp_path):
    pytest.importorskip("imageio_ffmpeg")
    from wbc.sim.video import render_video

    sim = _sim("g1")
    t = np.arange(0.0, 0.4, 0.002)
    q = np.tile(sim.robot.q_ref, (t.size, 1))
    path = render_video(sim, t, q, tmp_path / "v.mp4", fps=10, width=160, height=120)
    assert path.stat().st_size > 1000


def test_logged_foot_wrenches_match_contact_forces():
    """The closed loop's cfrc_ext-based foot wrenches equal MujocoModel.foot_contact_wrenches (contact by contact)."""
    import mujoco

    from wbc.sim.closed_loop import _FootWrenches

    sim = _sim("talos")
    mujoco.mj_resetData(sim.model, sim.data)
    sim.set_state(sim.robot.q_ref)
    sim.apply_external_force(sim.robot.torso, [20.0, 40.0, 0.0])
    for _ in range(5):
        mujoco.mj_step(sim.model, sim.data)
    sim.clear_external_forces()
    sides = ("left", "right")
    out_w, out_p = np.zeros((2, 6)), np.zeros((2, 3))
    _FootWrenches(sim)(out_w, out_p)
    ref = sim.foot_contact_wrenches()
    for i, s in enumerate(sides):
        assert np.abs(out_w[i] - ref[s]).max() < 1e-9 * max(1.0, np.abs(ref[s]).max())
        assert np.abs(out_p[i] - sim.sole_pose(s).translation).max() < 1e-12


def test_foot_wrenches_reuse_the_steps_cfrc_ext_only_when_it_is_mj_rnePostConstraints():
    """On the plant with F/T sensors (implicitfast: MuJoCo's step already ran ``mj_rnePostConstraint`` for its
    sensors), the logged foot wrenches equal, bit for bit, those after a fresh ``mj_rnePostConstraint`` call; with
    RK4 (several dynamics stages per step) the call is made."""
    import mujoco

    from wbc.sim.closed_loop import _FootWrenches

    sim = build_mujoco_model(wbc.load_robot("talos"), sensors=True)
    assert int(sim.model.opt.integrator) == int(mujoco.mjtIntegrator.mjINT_IMPLICITFAST)
    mujoco.mj_resetData(sim.model, sim.data)
    sim.set_state(sim.robot.q_ref)
    fw = _FootWrenches(sim)
    calls = []
    for k in range(30):
        mujoco.mj_step(sim.model, sim.data)
        assert sim.data.flg_rnepost
        out_w, out_p = np.zeros((2, 6)), np.zeros((2, 3))
        fw(out_w, out_p)
        mujoco.mj_rnePostConstraint(sim.model, sim.data)
        ref_w, ref_p = np.zeros((2, 6)), np.zeros((2, 3))
        fw(ref_w, ref_p)
        assert np.array_equal(out_w, ref_w) and np.array_equal(out_p, ref_p)
        calls.append(out_w[:, 2].sum())
    assert calls[-1] > 0.0  # the feet are loaded: the compared wrenches are not zeros
    sim.model.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
    assert not _FootWrenches(sim).single_stage


def test_effort_saturation_counts_ticks_at_the_limit_before_the_fall():
    """Seconds at ≥ 99 % of the effort limit per joint, up to the fall time, longest first (hand-built torques)."""
    from wbc.sim.scenarios import effort_saturation

    robot = wbc.load_robot("humanoid15")
    model = robot.model
    effort = np.asarray(model.effortLimit[6:])
    names = [model.names[j] for j in range(2, model.njoints)]
    tau = np.zeros((100, len(effort)))
    tau[:30, 0] = effort[0]           # 30 ticks at the limit
    tau[10:20, 3] = -0.995 * effort[3]  # 10 ticks at 99.5 % (negative)
    tau[:, 5] = 0.98 * effort[5]      # below 99 %: not counted
    tau[60:, 7] = effort[7]           # only after the fall
    dt = 0.002
    assert effort_saturation(model, tau, dt, until=0.1) == {names[0]: 0.06, names[3]: 0.02}
    assert effort_saturation(model, tau, dt) == {names[7]: 0.08, names[0]: 0.06, names[3]: 0.02}
    assert effort_saturation(model, np.zeros_like(tau), dt) == {}
