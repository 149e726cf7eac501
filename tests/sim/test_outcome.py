"""The operator's outcome of a closed-loop run (wbc.sim.outcome): tilt and non-foot contact falls, joint speed
exceedances, landing slide — each checked against an independent reference (Pinocchio kinematics, MuJoCo's
contact list, numbers set by hand)."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pinocchio as pin
import pytest

import wbc
from wbc.sim.baseline import JointPDController
from wbc.sim.closed_loop import run_closed_loop
from wbc.sim.mujoco_model import build_mujoco_model
from wbc.sim.outcome import OutcomeMonitor
from wbc.sim.scenarios import StandScenario, acceptance, summarize


@pytest.fixture(scope="module")
def talos_sim():
    return build_mujoco_model(wbc.load_robot("talos"))


def _joint_q(robot, name):
    return robot.model.joints[robot.model.getJointId(name)].idx_q


def _tilt_deg(robot, q0, q, frame):
    """Angle (deg) between the frame's initially-up axis and world z (Pinocchio, independent of MuJoCo)."""
    m, d = robot.model, robot.model.createData()
    pin.framesForwardKinematics(m, d, q0)
    up = d.oMf[robot.frame_id(frame)].rotation.T @ [0, 0, 1]
    pin.framesForwardKinematics(m, d, q)
    return math.degrees(math.acos(np.clip((d.oMf[robot.frame_id(frame)].rotation @ up)[2], -1, 1)))


class _LeanTorso(JointPDController):
    """Joint PD that drives the torso pitch joint to 0.75 rad (43°) while the legs hold the stance."""

    def __init__(self, robot, dt):
        super().__init__(robot, dt)
        self.q_ref = self.q_ref.copy()
        self.q_ref[_joint_q(robot, "torso_2_joint")] = 0.75


def test_torso_tilt_past_30deg_with_base_up_is_a_fall(talos_sim):
    sim, robot = talos_sim, talos_sim.robot
    scenario = StandScenario(2.0)
    run = run_closed_loop(sim, _LeanTorso(robot, sim.timestep), scenario)
    s = summarize(run, scenario)
    passed, failed = acceptance(s, scenario)
    assert run.fell and not passed and any("no fall" in f for f in failed)
    assert "tilt" in run.fall_reason and "torso" in run.fall_reason, run.fall_reason
    k = int(round(run.fall_time / run.dt))  # the fall is seen on the state after tick k - 1
    # independent reference: Pinocchio on the logged MuJoCo state, around the fall
    tilt = [_tilt_deg(robot, run.q[0], run.q[i], robot.torso) for i in (k - 3, min(k + 1, len(run.t) - 1))]
    assert tilt[0] < 30.5 and tilt[1] > 29.5, tilt
    assert run.q[0, 2] - run.q[: k + 1, 2].min() < 0.2  # the base stayed up
    pelvis = _tilt_deg(robot, run.q[0], run.q[k - 1], "base_link")
    assert pelvis < 30.0


def test_knee_on_the_ground_is_a_fall(talos_sim):
    sim, robot = talos_sim, talos_sim.robot
    mujoco.mj_resetData(sim.model, sim.data)
    sim.set_state(robot.q_ref)
    monitor = OutcomeMonitor(sim)
    q = robot.q_ref.copy()
    q[_joint_q(robot, "leg_left_3_joint")] = -1.6  # hip flexed, knee bent: the knee is the leg's lowest point
    q[_joint_q(robot, "leg_left_4_joint")] = 2.2
    knee_body = sim.model.body("leg_left_4_link").id
    thigh_body = sim.model.body("leg_left_3_link").id
    touching = set()
    while not touching & {knee_body, thigh_body}:
        q[2] -= 0.005
        sim.set_state(q)
        touching = set()
        for i in range(sim.data.ncon):  # MuJoCo's contact list: the reference
            g1, g2 = sim.data.contact.geom1[i], sim.data.contact.geom2[i]
            if sim.floor_geom in (g1, g2):
                touching.add(int(sim.model.geom_bodyid[g2 if g1 == sim.floor_geom else g1]))
        assert q[2] > 0
    assert monitor.update(0.0)
    assert "non-foot contact" in monitor.fall_reason
    assert any(sim.body_name(b) in monitor.fall_reason for b in touching & {knee_body, thigh_body})


@pytest.mark.parametrize("raised, fell", [(0.21, True), (0.19, False)])
def test_an_upright_base_lower_than_its_start_by_more_than_0_2_m_is_a_fall(talos_sim, raised, fell):
    """The base-drop criterion alone: the run starts with the robot held ``raised`` m above the floor (no contact,
    pelvis and torso level), then stands on its soles upright — a base 0.21 m lower than at the start is a fall,
    0.19 m lower is not (the 0.2 m of the issue, set by hand; the height read from MuJoCo's qpos, no tilt and no
    non-foot contact involved)."""
    sim, robot = talos_sim, talos_sim.robot
    mujoco.mj_resetData(sim.model, sim.data)
    q = robot.q_ref.copy()
    q[2] += raised
    sim.set_state(q)
    assert sim.data.ncon == 0  # in the air at the start
    monitor = OutcomeMonitor(sim)
    assert not monitor.update(0.0)
    sim.set_state(robot.q_ref)  # on its soles, upright
    feet = {int(g) for s in ("left", "right") for g in np.atleast_1d(sim.foot_geoms[s])}
    touching = {int(sim.data.contact.geom1[i]) for i in range(sim.data.ncon)} | {
        int(sim.data.contact.geom2[i]) for i in range(sim.data.ncon)}
    assert touching - {int(sim.floor_geom)} <= feet  # only the soles touch the floor
    assert monitor.update(0.002) is fell
    assert monitor.max_tilt_deg["pelvis"] < 1e-3 and monitor.max_tilt_deg["torso"] < 1e-3  # deg
    if fell:
        assert monitor.fall_reason == "base height dropped by more than 0.2 m", monitor.fall_reason
        assert monitor.fall_time == 0.002
    else:
        assert monitor.fall_reason == ""


def test_upright_stand_is_not_a_fall_and_speeds_are_counted(talos_sim):
    sim, robot = talos_sim, talos_sim.robot
    mujoco.mj_resetData(sim.model, sim.data)
    sim.set_state(robot.q_ref)
    monitor = OutcomeMonitor(sim)
    assert not monitor.update(0.0)
    assert monitor.speed_exceedances == 0 and monitor.max_tilt_deg["pelvis"] < 1e-9
    m = robot.model
    v = np.zeros(m.nv)
    j = m.getJointId("arm_left_5_joint")
    vmax = m.velocityLimit[m.joints[j].idx_v]
    v[m.joints[j].idx_v] = -1.5 * vmax
    sim.set_state(robot.q_ref, v)
    monitor.update(0.002)
    monitor.update(0.004)
    assert monitor.speed_exceedances == 2
    assert monitor.max_speed_joint == "arm_left_5_joint"
    assert monitor.max_speed_ratio == pytest.approx(1.5, rel=1e-12)


def test_landing_slide_is_the_travel_of_the_contact_corners(talos_sim):
    """Both feet on the floor at t = 0; the whole robot is then translated by 7 mm in x and 4 mm in y while the
    feet keep touching: every contact corner travelled hypot(7, 4) mm."""
    sim, robot = talos_sim, talos_sim.robot
    mujoco.mj_resetData(sim.model, sim.data)
    q = robot.q_ref.copy()
    q[2] -= 0.0005  # press the soles 0.5 mm into the floor: all 8 corners in contact
    sim.set_state(q)
    monitor = OutcomeMonitor(sim)
    monitor.update(0.0)
    for i in range(1, 11):
        q[0] += 0.0007
        q[1] += 0.0004
        sim.set_state(q)
        monitor.update(0.002 * i)
    expected = math.hypot(0.007, 0.004)
    assert monitor.max_landing_slide_m["left"] == pytest.approx(expected, abs=1e-9)
    assert monitor.max_landing_slide_m["right"] == pytest.approx(expected, abs=1e-9)
    assert not monitor.fell


def test_a_corner_lifted_by_the_sole_turning_about_its_toe_is_not_sliding(talos_sim):
    """Both feet flat on the floor, then the whole robot turned by 20° about the line through its toe corners: the
    heels rise and their corners move L (1 − cos 20°) ≈ 1.2 cm horizontally over the turn, but the toes, the only
    corners still touching, stay put: no slide (blind rough seed 10 counted 11.8 mm for a heel 45 mm in the air).
    Sliding on the toes then counts, and a heel set down again elsewhere counts from where it first touched."""
    sim, robot = talos_sim, talos_sim.robot
    mujoco.mj_resetData(sim.model, sim.data)
    q = robot.q_ref.copy()
    q[2] -= 0.0005  # all 8 corners in contact
    sim.set_state(q)
    monitor = OutcomeMonitor(sim)
    monitor.update(0.0)
    toe = monitor.corners_world(0)[[0, 3]].mean(axis=0)  # corners 0 and 3: the front (+x) ones
    base = pin.XYZQUATToSE3(q[:7])

    def turned(deg: float, shift=(0.0, 0.0)) -> np.ndarray:
        pivot = pin.SE3(np.eye(3), toe + np.array([shift[0], shift[1], 0.0]))
        turn = pin.SE3(pin.rpy.rpyToMatrix(0.0, math.radians(deg), 0.0), np.zeros(3))
        qk = q.copy()
        qk[:7] = pin.SE3ToXYZQUAT(pivot * turn * pin.SE3(np.eye(3), -toe) * base)
        return qk

    for i in range(1, 11):
        sim.set_state(turned(2.0 * i))
        monitor.update(0.002 * i)
    heels = monitor.corners_world(0)[[1, 2]]
    assert heels[:, 2].min() > toe[2] + 0.05  # the heels are up (sole length ≥ 0.15 m)
    # the toes stay within 0.1 mm (the soles of q_ref are not exactly level); the heels moved about 12 mm
    assert monitor.max_landing_slide_m["left"] < 1e-4 and monitor.max_landing_slide_m["right"] < 1e-4
    for i in range(1, 6):  # slide 3 mm forward on the toes
        sim.set_state(turned(20.0, (0.0006 * i, 0.0)))
        monitor.update(0.02 + 0.002 * i)
    assert monitor.max_landing_slide_m["left"] == pytest.approx(0.003, abs=1e-4)
    sim.set_state(turned(0.0, (0.003, 0.0)))  # flat again, 3 mm ahead: the heels touch 3 mm from where they did
    monitor.update(0.04)
    assert monitor.max_landing_slide_m["left"] == pytest.approx(0.003, abs=1e-4)
    assert monitor.max_landing_slide_m["right"] == pytest.approx(0.003, abs=1e-4)
    assert not monitor.fell


def test_a_toe_pressed_into_a_riser_is_a_foot_strike_fall():
    """Talos standing 3 mm into the riser of a 10 cm stair (its sole fronts 3 mm past x = 0.2): MuJoCo's contact list
    has foot contacts with a horizontal normal and a normal force > 20 N — a foot strike, reported as a fall. 15 mm
    before the riser (soles on the floor only) it is not."""
    from wbc.sim.outcome import OutcomeMonitor
    from wbc.terrain import parse_terrain

    robot = wbc.load_robot("talos")
    sim = build_mujoco_model(robot, terrain=parse_terrain("stairs:0.1:0.3:3"))
    riser_x = 0.2
    for gap, strike in ((-0.003, True), (0.015, False)):
        mujoco.mj_resetData(sim.model, sim.data)
        q = robot.q_ref.copy()
        q[2] -= 0.0005  # soles 0.5 mm into the floor
        q[0] += riser_x - gap - 0.5 * robot.sole_length  # sole front edges (x = q[0] + length / 2) at riser - gap
        sim.set_state(q)
        monitor = OutcomeMonitor(sim)
        assert monitor.update(0.0) == strike, monitor.fall_reason
        # the reference: MuJoCo's contacts of the foot geoms, their normals and normal forces
        side_hits = len(_pressing_foot_contacts(sim, 0.1))
        assert (side_hits > 0) == strike, side_hits
        if strike:
            assert monitor.fall_reason.startswith("foot strike"), monitor.fall_reason
            assert "90°" in monitor.fall_reason, monitor.fall_reason


def test_a_heightfield_prism_side_normal_is_not_a_foot_strike():
    """Talos standing 5 mm into the rough heightfield ``rough:0.02:1`` at x + 1.6 m: MuJoCo (which collides a
    heightfield as a union of triangular prisms) reports a foot contact pressing > 20 N along a normal more than 45°
    from the sole's, at a point whose facet (the terrain's own triangle, wbc.terrain) is tilted by less than 30° — a
    prism side wall, not a riser. The monitor judges the strike by the facet's normal: no fall."""
    from wbc.terrain import parse_terrain

    robot = wbc.load_robot("talos")
    terrain = parse_terrain("rough:0.02:1")
    sim = build_mujoco_model(robot, terrain=terrain)
    q = robot.q_ref.copy()
    q[0] += 1.6
    xs, ys = np.meshgrid(np.linspace(1.45, 1.75, 31), np.linspace(-0.2, 0.2, 41))
    q[2] += float(terrain.height(xs, ys).max()) - 0.005  # the highest ground under the feet 5 mm into the soles
    mujoco.mj_resetData(sim.model, sim.data)
    sim.set_state(q)
    hits = _pressing_foot_contacts(sim, math.cos(math.radians(45.0)))  # soles level: sole normal = +z
    for c in hits:
        n = terrain.normal(float(c.pos[0]), float(c.pos[1]))
        assert math.degrees(math.acos(n[2])) < 30.0
    side_hits = len(hits)
    assert side_hits > 0  # the situation under test exists in MuJoCo's contact list
    monitor = OutcomeMonitor(sim)
    assert not monitor.update(0.0), monitor.fall_reason


def _pressing_foot_contacts(sim, max_normal_z):
    """MuJoCo's contacts of the foot geoms pressing > 20 N (mj_contactForce) along a normal whose world z component
    is below ``max_normal_z`` in magnitude (the independent reference of the strike tests)."""
    feet = {int(g) for s in ("left", "right") for g in np.atleast_1d(sim.foot_geoms[s])}
    f6, hits = np.zeros(6), []
    for i in range(sim.data.ncon):
        c = sim.data.contact[i]
        if {int(c.geom1), int(c.geom2)} & feet:
            mujoco.mj_contactForce(sim.model, sim.data, i, f6)
            if abs(c.frame[2]) < max_normal_z and f6[0] > 20.0:
                hits.append(c)
    return hits


def test_compiled_tick_matches_a_numpy_reference_on_random_states(talos_sim):
    """Every tick's numbers of OutcomeMonitor.update (worst joint speed ratio and its joint, exceedances, tilts,
    landing slide of the corners) equal a plain numpy reference written here, on random states with both feet
    pressed into the floor and random joint speeds (some above the limits): exactly for the speeds and the counts,
    to 1e-12 m for the slide (the corner placement's products may be summed in another order), 1e-6° for the tilts."""
    sim, robot = talos_sim, talos_sim.robot
    m = robot.model
    rng = np.random.default_rng(7)
    mujoco.mj_resetData(sim.model, sim.data)
    q = robot.q_ref.copy()
    q[2] -= 0.0005  # all 8 sole corners in contact
    sim.set_state(q)
    monitor = OutcomeMonitor(sim)
    d = sim.data
    idx = [m.joints[j].idx_v for j in range(2, m.njoints)]
    vlim = np.array([m.velocityLimit[i] for i in idx])
    ups = [np.array(d.xmat[b]).reshape(3, 3)[2] for b in monitor.tilt_body_ids]
    start = [None, None]  # the reference's corner positions at the start of the support phase (xy)
    exceed, worst_seen, slide = 0, 0.0, [0.0, 0.0]
    tilt_max = {"pelvis": 0.0, "torso": 0.0}
    for k in range(40):
        qk = q.copy()
        qk[0:2] += 1e-4 * k * np.array([1.0, -0.5])  # the robot slides: the corners travel
        v = np.zeros(m.nv)
        v[6:] = rng.uniform(-1.3, 1.3, m.nv - 6) * vlim
        sim.set_state(qk, v)
        monitor.update(0.002 * k)
        # -- reference
        ratio = np.abs(v[6:]) / vlim
        exceed += int(np.sum(ratio > 1.0))
        if ratio.max() > worst_seen:
            worst_seen = ratio.max()
            assert monitor.max_speed_joint == m.names[2 + int(np.argmax(ratio))]
        assert monitor.speed_exceedances == exceed and monitor.max_speed_ratio == worst_seen
        for key, b, up in zip(("pelvis", "torso"), monitor.tilt_body_ids, ups):
            tilt = math.degrees(math.acos(np.clip(np.array(d.xmat[b]).reshape(3, 3)[2] @ up, -1, 1)))
            tilt_max[key] = max(tilt_max[key], tilt)
            # (acos near 1 turns a last-bit difference of the cosine into 1e-8 rad)
            assert monitor.max_tilt_deg[key] == pytest.approx(tilt_max[key], abs=1e-6)
        for s, side in enumerate(("left", "right")):
            bid, off = sim.sole_placements[side]
            X = pin.SE3(np.array(d.xmat[bid]).reshape(3, 3), np.array(d.xpos[bid])) * off
            corners = np.array([X.act(c) for c in robot.sole_corners_local()])
            if start[s] is None:
                start[s] = corners[:, :2].copy()
            slide[s] = max(slide[s], float(np.max(np.linalg.norm(corners[:, :2] - start[s], axis=1))))
            assert monitor.max_landing_slide_m[side] == pytest.approx(slide[s], rel=1e-12, abs=1e-12)
    assert exceed > 0 and slide[0] > 1e-3


def test_mujoco_warnings_reach_python_not_a_log_file_in_the_cwd(tmp_path, monkeypatch):
    """An unstable simulation (a body thrown by 1e30 N): MuJoCo's warning is routed to Python, and no
    MUJOCO_LOG.TXT appears in the current folder (MuJoCo's default handler appends to it)."""
    from wbc.sim.outcome import MUJOCO_WARNINGS, route_mujoco_warnings

    monkeypatch.chdir(tmp_path)
    route_mujoco_warnings()
    model = mujoco.MjModel.from_xml_string(
        "<mujoco><worldbody><body><freejoint/><geom size='0.1'/></body></worldbody></mujoco>")
    data = mujoco.MjData(model)
    data.xfrc_applied[1, 0] = 1e30
    before = len(MUJOCO_WARNINGS)
    with pytest.warns(RuntimeWarning, match="MuJoCo: Nan, Inf or huge value in QACC"):
        mujoco.mj_step(model, data)
    assert len(MUJOCO_WARNINGS) == before + 1
    assert list(tmp_path.iterdir()) == []


def test_upper_body_tilt_is_a_fall_when_the_robot_file_names_the_pelvis_as_torso():
    """A robot file whose torso is the pelvis (as `robot init` once chose for JVRC-1): the upper body (the link above
    the waist, torso_2_link) is still the tilt body. Talos standing on its soles with its torso pitched 0.75 rad
    (43°, Pinocchio the reference) and its pelvis level is a fall; at 0.45 rad (26°) it is not."""
    robot = wbc.load_robot("talos", torso="base_link")
    sim = build_mujoco_model(robot)
    for pitch, fell in ((0.75, True), (0.45, False)):
        mujoco.mj_resetData(sim.model, sim.data)
        sim.set_state(robot.q_ref)
        monitor = OutcomeMonitor(sim)
        assert monitor.tilt_bodies["torso"] == "torso_2_link"
        q = robot.q_ref.copy()
        q[_joint_q(robot, "torso_2_joint")] = pitch
        sim.set_state(q)
        assert monitor.update(0.002) is fell, monitor.fall_reason
        expected = _tilt_deg(robot, robot.q_ref, q, "torso_2_link")
        assert monitor.max_tilt_deg["torso"] == pytest.approx(expected, abs=1e-6)
        assert monitor.max_tilt_deg["pelvis"] < 1e-6
        if fell:
            assert "torso (torso_2_link)" in monitor.fall_reason, monitor.fall_reason


def _crouched_on(robot, q, bend: float, ground: float) -> tuple[np.ndarray, float]:
    """``q`` with both legs bent by ``bend`` rad (hip pitch −bend, knee +2 bend, ankle pitch −bend: soles and pelvis
    level) and the base height set so the soles stand on ``ground`` (m; Pinocchio's sole frames); and the base's
    height above the soles (m)."""
    q = q.copy()
    for side in ("left", "right"):
        q[_joint_q(robot, f"leg_{side}_3_joint")] -= bend
        q[_joint_q(robot, f"leg_{side}_4_joint")] += 2 * bend
        q[_joint_q(robot, f"leg_{side}_5_joint")] -= bend
    d = robot.model.createData()
    pin.framesForwardKinematics(robot.model, d, q)
    sole = min(d.oMf[robot.frame_id(f)].translation[2] for f in (robot.left_sole, robot.right_sole))
    q[2] += ground - sole
    return q, float(q[2] - ground)


@pytest.mark.parametrize("bend, fell", [(0.0, False), (0.75, True)])
def test_the_base_drop_is_measured_over_the_ground_under_the_feet(bend, fell):
    """Stairs down (0.25 m rises): Talos standing on the top landing at the start, then standing on the first tread
    down — its base 0.25 m lower than at the start, over ground 0.25 m lower: not a fall. On the same tread crouched
    (legs bent 0.75 rad, pelvis level, soles flat on the tread: the base more than 0.2 m lower over the ground under
    its feet, from Pinocchio) it is a fall by the base drop alone."""
    from wbc.terrain import parse_terrain

    robot = wbc.load_robot("talos")
    sim = build_mujoco_model(robot, terrain=parse_terrain("stairs:0.25:0.5:2:down"))
    mujoco.mj_resetData(sim.model, sim.data)
    sim.set_state(robot.q_ref)
    monitor = OutcomeMonitor(sim)
    assert not monitor.update(0.0)
    _, standing = _crouched_on(robot, robot.q_ref, 0.0, 0.0)
    q = robot.q_ref.copy()
    q[0] += 0.45  # the soles (x ≈ ±0.105 about q[0]) on the first tread, x in [0.25, 0.75)
    q, height = _crouched_on(robot, q, bend, -0.25)
    assert (standing - height > 0.2) is fell  # the reference: the base's drop over the soles, Pinocchio
    sim.set_state(q)
    assert monitor.update(0.002) is fell, monitor.fall_reason
    assert monitor.max_tilt_deg["pelvis"] < 1e-3 and monitor.max_tilt_deg["torso"] < 1e-3
    assert monitor.fall_reason == ("base height dropped by more than 0.2 m" if fell else "")
