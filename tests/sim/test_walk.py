"""``wbc sim walk``: 4-step physics walks in MuJoCo (talos, g1, humanoid15) with the acceptance criteria written
here; a lateral push in single support recovered by step adjustment; a standing push recovered by a capture step.

Independent references: the walked distance and the stance slip are measured on MuJoCo's ground-truth sole
positions; the CoP is computed from MuJoCo's contact forces; the commanded distance is the footstep geometry
(3 walking steps of ``step_length``; the 4th closes alongside). No wall-clock assertion.
"""

import numpy as np
import pytest

from wbc.robot import load_robot
from wbc.sim.mujoco_model import build_mujoco_model
from wbc.sim.physics_scenarios import id_options_for, walk_options_for
from wbc.sim.scenarios import make_controller, run_scenario
from wbc.geometry import polygon_margin
from wbc.sim.walk import WalkScenario
from wbc.sim.walk_steps import WalkSteps
from wbc.sim.walk_summary import measured_cop


@pytest.mark.parametrize("name, step_length, step_duration",
                         [("talos", 0.24, 0.6), ("g1", 0.24, 0.8), ("humanoid15", 0.15, 0.8)])  # 0.4, 0.3, 0.19 m/s
def test_four_step_walk(name, step_length, step_duration):
    robot = load_robot(name)
    sim = build_mujoco_model(robot)
    # the controller options `wbc sim walk` uses: the soles shrunk while walking (humanoid15 also: near
    # rank-deficient two-sole rows, DAQP primal_tol 1e-6)
    controller = make_controller(robot, "id", dt=sim.timestep, **walk_options_for(robot))
    scenario = WalkScenario(4, step_length, step_duration)
    run, s = run_scenario(sim, controller, scenario)
    commanded = 3 * step_length
    assert s["commanded_distance_m"] == pytest.approx(commanded)
    # Walked distance from MuJoCo's sole positions (feet mid-point), within 5 % of commanded.
    mid = run.sole_pos[:, :, :2].mean(axis=1)
    walked = float(np.linalg.norm(mid[-1] - mid[0]))
    assert abs(walked - commanded) <= 0.05 * commanded
    assert not s["fell"] and s["completed"]
    # humanoid15 (near rank-deficient two-sole rows, ProxQP): 1–3 of its 3000 ticks (measured) find no solution
    # since the independent re-solve of a failed QP left the control path (0 with it); they take the held
    # command, then the safe command, and the walk is on target. An open item, not a tolerance to keep.
    assert s["solver_failures"] <= (5 if name == "humanoid15" else 0)
    assert s["touchdowns"] == 4
    # Stance slip ≤ 5 mm for every stance interval; landing within 2 cm of the planned footstep.
    assert len(s["stance_slip_m"]) >= 5 and max(s["stance_slip_m"]) <= 0.005
    assert max(s["landing_error_m"]) <= 0.02
    # Measured CoP (plant contact forces) stays at least 2 mm inside the loaded soles' hull (the foot is not about
    # to tip; G1 at 0.3 m/s with the whole sole as the QP's contact rectangle: 0.08 mm, on the outer edge).
    assert s["min_measured_cop_margin_m"] >= 0.002
    # Straight walk: final heading within 5 deg of commanded (0).
    assert abs(s["walked_heading_rad"]) <= np.radians(5.0)
    # Released feet carry no QP force, and the plant's force on a released foot is small (ramp-out worked).
    phase = run.extra["support_phase"]
    for j in range(2):
        swing = phase[:, j] == 2
        assert swing.any()
        assert np.abs(run.qp_forces[swing, 12 * j + 2:12 * j + 12:3]).max() <= 1e-6
        start = np.flatnonzero(np.diff(swing.astype(int)) == 1) + 1  # first swing tick of each release
        assert run.sim_wrench[start, j, 2].max() <= 0.1 * robot.mass * 9.81
    # No force jump: the QP's total normal force on a foot changes by < 10 % of the weight per tick.
    fz = run.qp_forces.reshape(len(run.t), 2, 4, 3)[:, :, :, 2].sum(axis=2)
    assert np.abs(np.diff(fz, axis=0)).max() < 0.1 * robot.mass * 9.81


def test_walk_options_shrink_the_soles():
    from wbc.exceptions import InvalidInputError

    g1, h15 = load_robot("g1"), load_robot("humanoid15")
    assert walk_options_for(g1)["sole_margin"] == pytest.approx(0.1 * 0.05)  # G1 sole 0.17 x 0.05 m
    assert walk_options_for(g1, sole_margin=0.0)["sole_margin"] == 0.0
    assert walk_options_for(h15)["sole_margin"] >= 0.02  # the rank-deficient robot keeps its 2 cm
    for bad in (-0.01, float("nan")):
        with pytest.raises(InvalidInputError, match="sole_margin"):
            walk_options_for(g1, sole_margin=bad)


def test_measured_cop_and_margin():
    # Two vertical forces: 300 N at (0, 0.1), 100 N at (0.2, −0.1) → CoP (0.05, 0.05) (lever rule).
    w = np.zeros((2, 6))
    w[0, 2], w[1, 2] = 300.0, 100.0
    pos = np.array([[0.0, 0.1, 0.0], [0.2, -0.1, 0.0]])
    assert measured_cop(w, pos) == pytest.approx([0.05, 0.05])
    # A pure moment about the sole origin shifts the CoP: τ_y = −F_z Δx.
    w2 = np.zeros((2, 6))
    w2[0, 2], w2[0, 4] = 400.0, -400.0 * 0.03
    assert measured_cop(w2, np.zeros((2, 3))) == pytest.approx([0.03, 0.0])
    # On a tread at h = 0.15 m a force (60, 0, 400) N acting at the sole origin (0.3, 0, 0.15): its CoP on the tread
    # is the origin's xy; on the floor plane z = 0 its line of action lands h F_x / F_z = 22.5 mm behind.
    w3 = np.zeros((2, 6))
    w3[0, :3] = [60.0, 0.0, 400.0]
    pos3 = np.array([[0.3, 0.0, 0.15], [0.3, -0.2, 0.15]])
    assert measured_cop(w3, pos3, height=0.15) == pytest.approx([0.3, 0.0], abs=1e-12)
    assert measured_cop(w3, pos3) == pytest.approx([0.3 - 0.15 * 60.0 / 400.0, 0.0], abs=1e-12)
    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    assert polygon_margin(np.array([0.5, 0.2]), square) == pytest.approx(0.2)
    assert polygon_margin(np.array([1.3, 0.5]), square) == pytest.approx(-0.3)


def test_perturb_plant_and_controller():
    from wbc.exceptions import InvalidInputError
    from wbc.sim.perturb import PerturbedController, perturb_plant

    robot = load_robot("talos")
    sim = build_mujoco_model(robot)
    m0 = float(sim.model.body_mass.sum())
    base = sim.model.body_mass.copy()
    info = perturb_plant(sim, mass_error=0.05, payload=5.0, friction=0.5, armature=0.1, seed=3)
    ratio = sim.model.body_mass[1:] / np.where(base[1:] > 0, base[1:], 1.0)
    torso = sim.body_id(robot.torso)
    others = np.delete(np.arange(1, sim.model.nbody), torso - 1)
    assert np.all(np.abs(ratio[others - 1][base[others] > 0] - 1.0) <= 0.05 + 1e-12)
    assert info["model_mass_kg"] == pytest.approx(m0)
    assert abs(float(sim.model.body_mass.sum()) - (m0 + 5.0)) <= 0.05 * m0
    assert np.all(sim.model.dof_frictionloss[6:] == 0.5)
    with pytest.raises(InvalidInputError, match="mass_error"):
        perturb_plant(sim, mass_error=1.5)
    # Delay: with 2 ticks, the torque applied at tick k is the one computed (undelayed) at tick k − 2.
    q, v = robot.q_ref.copy(), np.zeros(robot.nv)
    ref = PerturbedController(robot, dt=0.002)
    late = PerturbedController(robot, dt=0.002, delay=2)
    ref.reset(q, v)
    late.reset(q, v)
    taus, outs = [], []
    for k in range(5):
        vk = v.copy()
        vk[6:] = 0.01 * k  # a different state every tick
        taus.append(ref.solve(q, vk).tau.copy())
        outs.append(late.solve(q, vk).tau.copy())
    np.testing.assert_allclose(outs[4], taus[2], atol=1e-9)
    np.testing.assert_allclose(outs[3], taus[1], atol=1e-9)
    with pytest.raises(InvalidInputError, match="delay"):
        PerturbedController(robot, delay=-1)


def test_lateral_push_in_single_support_is_recovered_by_a_step():
    # Talos, 400 N x 0.1 s to the right at mid single support of the 4th swing (right foot swinging, 0.6 s steps:
    # single support 0.48 s from 0.8 + 3 x 0.6 s). The right foot must land further right than planned.
    robot = load_robot("talos")
    sim = build_mujoco_model(robot)
    controller = make_controller(robot, "id", dt=sim.timestep)
    t_mid = 0.8 + 3 * 0.6 + 0.24
    scenario = WalkScenario(6, 0.2, 0.6, push=400.0, push_time=t_mid - 0.05, push_duration=0.1, push_dir=-90.0)
    run, s = run_scenario(sim, controller, scenario)
    assert not s["fell"] and s["completed"]
    assert s["solver_failures"] == 0
    assert s["step_adjustments"] >= 1
    # The pushed step, from MuJoCo's sole position at its touch-down, lies > 10 cm right of the nominal footstep.
    nominal = scenario.plan.footsteps[3]
    assert nominal.side == "right"
    k_td = next(ph.end for ph in scenario.plan.phases if ph.step == 3)
    td = [t for t, side, e in scenario.switcher.events if side == "right" and e == "touchdown" and t > 2.6]
    i = int(round(td[0] / sim.timestep))
    assert abs(i - k_td) <= 25
    assert run.sole_pos[i, 1, 1] < nominal.y - 0.10
    # The push was applied as commanded (MuJoCo external force log).
    assert np.abs(run.ext_force[:, 1]).max() == pytest.approx(400.0)


def test_push_towards_the_stance_leg_is_recovered_by_cutting_the_step_short():
    # Talos 8 x 0.25 m at 0.6 s/step; 300 N x 0.1 s at t = 2.816 s towards +y (84.4 deg; seed 26 of
    # benchmarks/walk_push_trials.py) while the right foot swings (4th swing, single support 2.6-3.08 s, left
    # stance): the right foot cannot land left of the stance leg, so the reach clips it and the swing is cut short
    # (step timing adjustment); the left step then goes out. With the timing fixed this push fell (measured). The
    # cut alone: the double support after the cut swing keeps its planned length (the default ends it at the
    # touch-down, tests/sim/test_walk_hurry.py, which runs this push with the defaults).
    robot = load_robot("talos")
    sim = build_mujoco_model(robot)
    controller = make_controller(robot, "id", dt=sim.timestep)
    scenario = WalkScenario(8, 0.25, 0.6, push=300.0, push_time=2.816, push_duration=0.1, push_dir=84.4,
                            hurry_double_support=False)
    run, s = run_scenario(sim, controller, scenario)
    assert not s["fell"] and s["completed"]
    assert s["solver_failures"] == 0
    assert max(s["step_timing_changes_s"]) >= 0.05
    # The pushed right foot touched down (MuJoCo state) before its planned landing at 3.08 s (step timing QP: at
    # 3.046 s, measured; the fixed cut heuristic before it: before 3.04 s).
    td = [t for t, side, e in scenario.switcher.events if side == "right" and e == "touchdown" and 2.6 < t < 3.2]
    assert td and td[0] < 3.08 - 0.02
    # Every shortened swing still reached its (adjusted) footstep: MuJoCo's sole at touch-down within 2 cm.
    assert max(s["landing_error_m"]) <= 0.02
    # The left step after it went out to the left by more than 30 cm (MuJoCo's sole position, at the end).
    assert run.sole_pos[-1, 0, 1] > 0.085 + 0.30


def test_push_late_in_a_swing_is_recovered_by_lengthening_the_swing(monkeypatch):
    # Talos 8 x 0.25 m at 0.6 s/step; 300 N x 0.1 s at t = 2.999 s towards -y and slightly forward (292.3 deg;
    # seed 204 of benchmarks/walk_push_trials.py), 0.08 s before the right foot's planned landing at 3.08 s (4th
    # swing, left stance). Landing at its nominal place, the DCM ends beyond the right sole's outer edge and the
    # left foot cannot cross to catch it: with the swing length fixed (max_stretch=0) this push fell (measured).
    # The swing is lengthened instead and the right foot lands later and further right.
    robot = load_robot("talos")
    sim = build_mujoco_model(robot)
    controller = make_controller(robot, "id", dt=sim.timestep)
    # Every swing-foot position row weighted alike (swing_height_weight=1): with the default clearance-first
    # weighting the same push is recovered by cutting the swing instead (timing changes [0.17, 0.098] s, measured).
    # The post-impact excess cost is off here (WalkSteps.impact_excess_weight 0; default 10): with it this lengthened
    # swing's landing is predicted past the joint speed limits (2.5x), the cost lifts the descending sole from 28 to
    # 37 mm, it lands 0.10 s later and the pelvis passes 30 deg at 3.48 s (measured, benchmarks/records/71). At the
    # default swing_height_weight the push is cut, not lengthened, and survives at either weight (measured).
    monkeypatch.setattr(WalkSteps, "impact_excess_weight", 0.0)
    scenario = WalkScenario(8, 0.25, 0.6, push=300.0, push_time=2.99938388023065, push_duration=0.1,
                            push_dir=292.3110388691157, swing_height_weight=1.0)
    run, s = run_scenario(sim, controller, scenario)
    assert not s["fell"] and s["completed"]
    assert s["solver_failures"] == 0
    assert min(s["step_timing_changes_s"]) <= -0.05  # a lengthened swing (negative: later)
    # The right foot touched down (MuJoCo state, the switcher's state-based detection) after its planned 3.08 s …
    td = [t for t, side, e in scenario.switcher.events if side == "right" and e == "touchdown" and 2.6 < t < 3.5]
    assert td and td[0] > 3.08 + 0.05
    # … and MuJoCo's sole there lies > 8 cm right of the nominal footstep (y = -0.085 m).
    i = int(round(td[0] / sim.timestep))
    nominal = scenario.plan.footsteps[3]
    assert nominal.side == "right"
    assert run.sole_pos[i, 1, 1] < nominal.y - 0.08
    # The feet stayed apart by ≥ a sole width laterally at the end (no crossing).
    assert run.sole_pos[-1, 0, 1] - run.sole_pos[-1, 1, 1] > robot.sole_width


@pytest.mark.parametrize("push_dir, sign", [(180.0, -1.0), (0.0, 1.0)])  # from the front (towards -x), from behind
def test_standing_push_from_the_front_and_behind_is_recovered_by_a_capture_step(push_dir, sign):
    from wbc.sim.capture_step import CaptureStepScenario

    robot = load_robot("talos")
    sim = build_mujoco_model(robot)
    controller = make_controller(robot, "id", dt=sim.timestep)
    scenario = CaptureStepScenario(450.0, 0.1, t_push=0.5, push_dir=push_dir)
    run, s = run_scenario(sim, controller, scenario)
    assert not s["fell"] and s["completed"] and s["solver_failures"] == 0
    assert s["stepped"] and 0.5 <= s["trigger_time_s"] <= 0.6
    # Both feet ended > 10 cm from where they started along the push (MuJoCo sole positions): the robot stepped.
    assert np.all(sign * (run.sole_pos[-1, :, 0] - run.sole_pos[0, :, 0]) > 0.1)
    assert np.abs(run.ext_force[:, 0]).max() == pytest.approx(450.0)


def test_a_capture_step_the_planner_refuses_leaves_the_robot_standing_with_the_reason(monkeypatch):
    # When the recovery walk cannot be planned at the trigger (GaitError, e.g. a sole already rolled onto its edge:
    # Alexander pushed at its CoM height), the scenario keeps balancing on both soles, does not try again every
    # tick, and the summary says why no step was taken (it used to test the DCM against an empty hull next tick:
    # IndexError).
    import wbc.sim.capture_step as cs
    from wbc.exceptions import GaitError

    calls = []

    def refuse(self, *args, **kwargs):
        calls.append(1)
        raise GaitError("left_sole must lie flat on the ground (test)")

    monkeypatch.setattr(cs.WalkScenario, "setup", refuse)
    robot = load_robot("talos")
    sim = build_mujoco_model(robot)
    controller = make_controller(robot, "id", dt=sim.timestep)
    scenario = cs.CaptureStepScenario(450.0, 0.1, t_push=0.1, push_dir=0.0, settle=0.3)
    run, s = run_scenario(sim, controller, scenario)
    assert len(calls) == 1
    assert s["stepped"] is False and s["trigger_time_s"] is None
    assert "lie flat" in s["step_refused"]
    # it ran on after the refusal (here until the fall: 450 N from behind needs a step on Talos), no exception
    assert s["fell"] or s["completed"]
    assert run.t[-1] > 0.3


def test_touchdown_before_the_planned_landing_waits_for_the_floor(tmp_path, capsys):
    # `wbc sim walk` (estimated state: encoders, IMU, ankle F/T). Reference: MuJoCo's contact force on the sole.
    # The height test alone (sole within 3 mm, not rising) fired 30-40 ms before the planned landing on this walk,
    # at 0 N in the plant. Now a switch before the planned landing time needs the plant's floor already pushing on
    # the sole; from the planned time on, a sole still within 3 mm is set down (it would otherwise hover).
    import json

    from wbc.cli import main

    log, summary = tmp_path / "walk.npz", tmp_path / "walk.json"
    assert main(["sim", "walk", "--robot", "g1", "--steps", "2", "--quiet", "--log", str(log),
                 "--json", str(summary)]) == 0
    capsys.readouterr()
    d = np.load(log)
    delays = json.loads(summary.read_text())["touchdown_delay_s"]
    ca, fz, t, dt = d["contact_active"], d["sim_wrench"][:, :, 2], d["t"], float(d["dt"])
    weight = fz[5].sum()
    switches = sorted((k, j) for j in range(2) for k in np.flatnonzero(ca[1:, j] & ~ca[:-1, j]) + 1 if t[k] > 0.3)
    assert len(switches) == 2 == len(delays)
    for (k, j), delay in zip(switches, delays):
        if delay < -1.5 * dt:  # before the planned landing: the plant must already load the sole
            assert fz[k, j] > 0.01 * weight, (t[k], j, delay, fz[k - 5:k + 5, j])

def test_dependent_contact_rows_are_made_consistent():
    from wbc.constraints.contact_acceleration import consistent_contact_rhs

    rng = np.random.default_rng(4)
    # Rank 11 of 12 (a dependent row, as two flat soles of 5-DoF legs): the projected b is the least-squares
    # consistent right-hand side J J⁺ b (numpy pinv as the reference) and J x = b is then solvable exactly.
    J = rng.standard_normal((12, 20))
    J[11] = J[:11].T @ rng.standard_normal(11)
    b = rng.standard_normal(12)
    ref = J @ np.linalg.pinv(J, rcond=1e-10) @ b
    out = b.copy()
    assert consistent_contact_rhs(J, out) == 1
    np.testing.assert_allclose(out, ref, atol=1e-10)
    x = np.linalg.lstsq(J, out, rcond=None)[0]
    np.testing.assert_allclose(J @ x, out, atol=1e-10)
    # Nearly dependent (σ_min/σ_max = 1e-3 < 1e-2): projected like the exact case, onto the other 11 directions.
    U, _, Vt = np.linalg.svd(rng.standard_normal((12, 20)), full_matrices=False)
    s = np.linspace(1.0, 0.5, 12)
    s[-1] = 1e-3
    Jn = U @ np.diag(s) @ Vt
    out = b.copy()
    assert consistent_contact_rhs(Jn, out) == 1
    np.testing.assert_allclose(out, b - U[:, -1] * (U[:, -1] @ b), atol=1e-10)
    # Well conditioned (the 12 rows of two 6-DoF legs): b untouched.
    out = b.copy()
    assert consistent_contact_rhs(rng.standard_normal((12, 20)), out) == 0
    assert np.array_equal(out, b)


def test_turning_is_refused_for_legs_without_hip_yaw():
    # humanoid15 (5-DoF legs, no hip yaw): the soles' relative yaw rate has a zero Jacobian (Pinocchio), so a
    # turning plan is refused with a typed error at setup; straight walking is planned.
    import pinocchio as pin

    from wbc.exceptions import GaitError

    robot = load_robot("humanoid15")
    model, data = robot.model, robot.model.createData()
    pin.computeJointJacobians(model, data, robot.q_ref)
    pin.framesForwardKinematics(model, data, robot.q_ref)
    Jl, Jr = (pin.getFrameJacobian(model, data, robot.frame_id(f), pin.LOCAL_WORLD_ALIGNED)
              for f in (robot.left_sole, robot.right_sole))
    assert np.abs(Jl[5] - Jr[5]).max() < 1e-12
    sim = build_mujoco_model(robot)
    controller = make_controller(robot, "id", dt=sim.timestep, **id_options_for(robot))
    q, v = robot.q_ref.copy(), np.zeros(robot.nv)
    controller.reset(q, v)
    with pytest.raises(GaitError, match="cannot yaw"):
        WalkScenario(4, 0.0, 0.8, turn=np.radians(8.0)).setup(controller, sim, q, v)
    WalkScenario(4, 0.1, 0.8).setup(controller, sim, q, v)  # straight: planned
    # Talos (hip yaw joints) is planned with the same turn.
    talos = load_robot("talos")
    tsim = build_mujoco_model(talos)
    tc = make_controller(talos, "id", dt=tsim.timestep)
    tc.reset(talos.q_ref.copy(), np.zeros(talos.nv))
    WalkScenario(4, 0.0, 0.8, turn=np.radians(8.0)).setup(tc, tsim, talos.q_ref.copy(), np.zeros(talos.nv))


def test_from_motion_plans_the_dcm_from_the_measured_com_state():
    # WalkScenario(from_motion=True) — the re-plan of `wbc ros2 node --sim` in a double support: the footsteps
    # from the current soles, the plan's DCM starting at the measured one, c + ċ/ω (Englsberger 2015, eq. 3),
    # computed here with Pinocchio from the same state; and the planned footsteps are those of a plan at rest.
    import pinocchio as pin

    from wbc.exceptions import InvalidInputError

    with pytest.raises(InvalidInputError, match="exclusive"):
        WalkScenario(2, 0.1, 0.8, from_state=True, from_motion=True)
    robot = load_robot("g1")
    sim = build_mujoco_model(robot)
    controller = make_controller(robot, "id", dt=sim.timestep, **walk_options_for(robot, "fast"))
    q, v = robot.q_ref.copy(), np.zeros(robot.nv)
    v[0] = 0.25  # the base (and the whole robot) moving forward at 0.25 m/s
    controller.reset(q, v)
    moving = WalkScenario(1, 0.0, 0.8, t_init=0.16, from_motion=True, first_side="right")
    moving.setup(controller, sim, q, v)
    rest = WalkScenario(1, 0.0, 0.8, first_side="right")  # (from rest, the CoM shift needs the default t_init)
    rest.setup(controller, sim, q, np.zeros(robot.nv))
    data = robot.model.createData()
    pin.centerOfMass(robot.model, data, q, v)
    xi = data.com[0][:2] + data.vcom[0][:2] / moving.plan.omega
    assert data.vcom[0][0] > 0.2
    np.testing.assert_allclose(moving.plan.dcm[0], xi, atol=1e-9)
    assert moving.plan.footsteps == rest.plan.footsteps
    assert moving.steps_left == 1 and moving.steps_done == 0 and moving.next_side == "right"
    assert moving.between_steps()
