"""MuJoCo model built from the robot's URDF agrees with the Pinocchio model (wbc.sim.mujoco_model)."""

from __future__ import annotations


import mujoco
import numpy as np
import pinocchio as pin
import pytest

import wbc
from wbc.exceptions import ConfigurationError, InvalidInputError, UnknownFrameError
from wbc.sim.mujoco_model import ENV_BIT, ROBOT_BIT, build_mujoco_model, stiff_foot_friction

ROBOTS = ["talos", "g1"] + (["humanoid15"] if "humanoid15" in wbc.catalog() else [])
TOL = 1e-9


@pytest.fixture(scope="module", params=ROBOTS)
def sim(request):
    return build_mujoco_model(wbc.load_robot(request.param))


def _random_states(robot, n=4, seed=0):
    """(q, v) with joints uniform within their limits, a random base pose 5 m above the floor."""
    rng = np.random.default_rng(seed)
    pm = robot.model
    for _ in range(n):
        q = pin.neutral(pm)
        q[7:] = rng.uniform(pm.lowerPositionLimit[7:], pm.upperPositionLimit[7:])
        q[0:3] = rng.uniform(-1.0, 1.0, 3) + [0.0, 0.0, 5.0]
        q[3:7] = pin.Quaternion(pin.exp3(rng.normal(size=3))).coeffs()
        yield q, rng.normal(size=pm.nv)


def _body_frame(pm, name):
    return pm.getFrameId(name, pin.FrameType.BODY)


def _full_mass_matrix(m, d):
    M = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, M)
    return M


def test_structure_actuators_and_mass(sim):
    robot, m = sim.robot, sim.model
    pm = robot.model
    assert m.opt.timestep <= 0.002
    assert m.nu == robot.nv - 6 and m.nv == robot.nv
    assert [m.actuator(i).name for i in sim.actuator_ids] == robot.joint_names
    effort = np.array([pm.effortLimit[pm.joints[pm.getJointId(n)].idx_v] for n in robot.joint_names])
    np.testing.assert_array_equal(m.actuator_ctrlrange[sim.actuator_ids], np.c_[-effort, effort])
    np.testing.assert_array_equal(m.actuator_forcerange[sim.actuator_ids], np.c_[-effort, effort])
    assert np.all(m.actuator_gear[:, 0] == 1.0)
    # The free joint is on the URDF root link, the body that carries Pinocchio's free flyer.
    assert m.jnt_type[0] == mujoco.mjtJoint.mjJNT_FREE and m.jnt_bodyid[0] == 1
    root_frame = pm.frames[_body_frame(pm, m.body(1).name)]
    assert root_frame.parentJoint == 1 and root_frame.placement.isIdentity()
    assert abs(sim.total_mass - robot.mass) <= TOL
    assert np.all(m.dof_damping == 0.0) and np.all(m.dof_frictionloss == 0.0)
    # Collision bits: robot geoms touch only the environment, the floor touches the robot.
    robot_geoms = np.flatnonzero(m.geom_contype != 0)
    robot_geoms = robot_geoms[robot_geoms != sim.floor_geom]
    assert np.all(m.geom_contype[robot_geoms] == ROBOT_BIT) and np.all(m.geom_conaffinity[robot_geoms] == ENV_BIT)
    assert m.geom_conaffinity[sim.floor_geom] & ROBOT_BIT
    # Visual meshes are kept.
    assert np.sum((m.geom_contype == 0) & (m.geom_conaffinity == 0)) > 0


def test_kinematics_com_and_mass_matrix_agree(sim):
    robot, m, d = sim.robot, sim.model, sim.data
    pm = robot.model
    pd = pm.createData()
    for q, v in _random_states(robot):
        sim.set_state(q, v)
        pin.framesForwardKinematics(pm, pd, q)
        for b in range(1, m.nbody):
            oMf = pd.oMf[_body_frame(pm, m.body(b).name)]
            assert np.abs(d.xpos[b] - oMf.translation).max() < TOL
            assert np.abs(d.xmat[b].reshape(3, 3) - oMf.rotation).max() < TOL
        assert np.abs(d.subtree_com[1] - pin.centerOfMass(pm, pd, q)).max() < TOL
        M_pin = pin.crba(pm, pd, q)
        M_pin = np.triu(M_pin) + np.triu(M_pin, 1).T
        T = sim.state_map.velocity_transform(q)
        M_mj = _full_mass_matrix(m, d)
        assert np.abs(M_pin - T.T @ M_mj @ T).max() < TOL * np.abs(M_pin).max()


def test_velocity_round_trip_and_body_velocities(sim):
    robot, m, d = sim.robot, sim.model, sim.data
    pm = robot.model
    pd = pm.createData()
    for q, v in _random_states(robot, seed=1):
        sim.set_state(q, v)
        q2, v2 = sim.get_state()
        np.testing.assert_array_equal(q2[7:], q[7:])
        assert np.abs(q2 - q).max() < 1e-15 and np.abs(v2 - v).max() < 1e-13
        assert np.abs(sim.state_map.velocity_transform(q) @ v - d.qvel).max() < 1e-13
        pin.forwardKinematics(pm, pd, q, v)
        pin.updateFramePlacements(pm, pd)
        res = np.zeros(6)
        for b in range(1, m.nbody):
            mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_XBODY, b, res, 0)  # (ang, lin) at xpos, world
            vp = pin.getFrameVelocity(pm, pd, _body_frame(pm, m.body(b).name), pin.LOCAL_WORLD_ALIGNED)
            assert np.abs(res[3:6] - vp.linear).max() < TOL and np.abs(res[0:3] - vp.angular).max() < TOL


def test_state_from_mj_is_q_from_mj_then_v_from_mj(sim):
    """One-pass conversion of a MuJoCo state: the arrays of the two conversions, the state it came from. q is
    gathered (bit for bit); v's base rows are R_baseᵀ qvel, a 3 × 3 product whose sum order differs between the
    compiled pass and numpy's matmul (whose kernel depends on the CPU: 1-ulp differences on an AVX-512 host), so they
    agree to 4 ulp of |qvel|."""
    sm = sim.state_map
    for q, v in _random_states(sim.robot, seed=2):
        qpos, qvel = sm.q_to_mj(q), sm.v_to_mj(q, v)
        q1, v1 = sm.state_from_mj(qpos, qvel)
        np.testing.assert_array_equal(q1, sm.q_from_mj(qpos))
        v_ref = sm.v_from_mj(q1, qvel)
        np.testing.assert_array_equal(v1[3:], v_ref[3:])
        assert np.abs(v1[:3] - v_ref[:3]).max() <= 4 * np.finfo(float).eps * np.abs(qvel[:3]).max()
        assert np.abs(q1 - q).max() < 1e-15 and np.abs(v1 - v).max() < 1e-13
    with pytest.raises(ConfigurationError):
        sm.state_from_mj(qpos, np.full(sm.nv, np.nan))
    with pytest.raises(ConfigurationError):
        sm.state_from_mj(qpos[:-1], qvel)
    bad = qpos.copy()
    bad[3] *= 1.01  # base quaternion 1 % off unit norm
    with pytest.raises(InvalidInputError):
        sm.state_from_mj(bad, qvel)


def test_states_from_mj_is_state_from_mj_row_by_row(sim):
    """The batch conversion writes, row by row, the arrays of the one-state conversion bit for bit (the same
    arithmetic), and the states they came from; a bad row raises the one-state conversion's error; wrong output
    arrays raise InvalidInputError."""
    sm = sim.state_map
    states = list(_random_states(sim.robot, n=6, seed=3))
    qpos = np.array([sm.q_to_mj(q) for q, _ in states])
    qvel = np.array([sm.v_to_mj(q, v) for q, v in states])
    q_out, v_out = np.empty((len(states), sm.nq)), np.empty((len(states), sm.nv))
    sm.states_from_mj(qpos, qvel, q_out, v_out)
    for k, (q, v) in enumerate(states):
        q1, v1 = sm.state_from_mj(qpos[k], qvel[k])
        np.testing.assert_array_equal(q_out[k], q1)
        np.testing.assert_array_equal(v_out[k], v1)
        assert np.abs(q_out[k] - q).max() < 1e-15 and np.abs(v_out[k] - v).max() < 1e-13
    bad = qvel.copy()
    bad[4, 7] = np.nan
    with pytest.raises(ConfigurationError):
        sm.states_from_mj(qpos, bad, q_out, v_out)
    off = qpos.copy()
    off[2, 3:7] *= 1.01  # base quaternion 1 % off unit norm
    with pytest.raises(InvalidInputError):
        sm.states_from_mj(off, qvel, q_out, v_out)
    with pytest.raises(InvalidInputError):
        sm.states_from_mj(qpos, qvel, q_out[:-1], v_out)


def test_bias_forces_and_forward_dynamics(sim):
    robot, m, d = sim.robot, sim.model, sim.data
    pm = robot.model
    pd = pm.createData()
    rng = np.random.default_rng(2)
    for q, v in _random_states(robot, seed=2):
        tau = rng.uniform(-1.0, 1.0, robot.nv - 6) * np.minimum(sim.effort_limit, 50.0)
        sim.set_state(q, v, forward=False)
        sim.set_torques(tau)
        mujoco.mj_forward(m, d)
        assert d.ncon == 0 and d.nefc == 0  # in the air, joints strictly inside their limits
        T = sim.state_map.velocity_transform(q)
        nle_mj = T.T @ (d.qfrc_bias + _full_mass_matrix(m, d) @ sim.state_map.acceleration_offset(q, v))
        nle = pin.nonLinearEffects(pm, pd, q, v)
        assert np.abs(nle - nle_mj).max() < TOL * np.abs(nle).max()
        a = pin.aba(pm, pd, q, v, np.r_[np.zeros(6), tau])
        assert np.abs(sim.get_acceleration() - a).max() < TOL * np.abs(a).max()
    sim.set_torques(np.zeros(robot.nv - 6))


def test_external_force_at_point(sim):
    robot, m, d = sim.robot, sim.model, sim.data
    pm = robot.model
    pd = pm.createData()
    q, v = next(_random_states(robot, n=1, seed=3))
    body = robot.torso
    force = np.array([30.0, -20.0, 10.0])
    for point in (None, np.array([0.1, 0.2, 5.3])):
        sim.set_state(q, v)
        qacc0 = d.qacc.copy()
        sim.apply_external_force(body, force, point)
        mujoco.mj_forward(m, d)
        gen_mj = _full_mass_matrix(m, d) @ (d.qacc - qacc0)
        sim.clear_external_forces()
        gen_pin = sim.state_map.force_to_pin(q, gen_mj)
        fid = _body_frame(pm, body)
        J = pin.computeFrameJacobian(pm, pd, q, fid, pin.LOCAL_WORLD_ALIGNED)
        r = np.zeros(3) if point is None else point - pd.oMf[fid].translation
        J_point = J[0:3] - pin.skew(r) @ J[3:6]
        expected = J_point.T @ force
        assert np.abs(gen_pin - expected).max() < TOL * np.abs(expected).max()
    with pytest.raises(UnknownFrameError):
        sim.apply_external_force("no_such_body", force)


def _standing_torques(robot, sim):
    """Contact-consistent gravity compensation at q_ref (weight shared by the feet) plus stable joint PD gains."""
    pm, q0 = robot.model, robot.q_ref
    pd = pm.createData()
    g = pin.rnea(pm, pd, q0, np.zeros(pm.nv), np.zeros(pm.nv))
    J = np.vstack([
        pin.computeFrameJacobian(pm, pd, q0, robot.frame_id(f), pin.LOCAL_WORLD_ALIGNED)
        for f in (robot.left_sole, robot.right_sole)
    ])
    wrenches = np.linalg.lstsq(J[:, :6].T, g[:6], rcond=None)[0]
    M = pin.crba(pm, pd, q0)
    M = np.triu(M) + np.triu(M, 1).T
    i_eff = 1.0 / np.diag(np.linalg.inv(M))[6:]  # joint inertia seen with the base free
    dt = sim.timestep
    kp = np.minimum(10.0 * sim.effort_limit, 0.1 * i_eff / dt**2)
    kd = 0.5 * i_eff / dt
    return (g - J.T @ wrenches)[6:], kp, kd


def test_standing_contacts_and_ground_reaction(sim):
    robot, d = sim.robot, sim.data
    q0 = robot.q_ref
    mujoco.mj_resetData(sim.model, d)
    sim.set_state(q0)
    # Initial contact set: only foot boxes touch the floor, no self-contact.
    assert sim.non_foot_ground_contacts() == [] and sim.self_contacts() == []
    foot_geoms = np.concatenate(list(sim.foot_geoms.values()))
    for i in range(d.ncon):
        assert {d.contact.geom1[i], d.contact.geom2[i]} - {sim.floor_geom} <= set(foot_geoms)
    tau_ff, kp, kd = _standing_torques(robot, sim)
    mg = 9.81 * robot.mass
    fz = []
    for _ in range(250):
        q, v = sim.get_state()
        sim.set_torques(tau_ff + kp * (q0[7:] - q[7:]) - kd * v[6:])
        sim.step()
        assert sim.non_foot_ground_contacts() == [] and sim.self_contacts() == []
        f = sim.foot_contact_forces()
        fz.append(f["left"][2] + f["right"][2])
    points = sim.foot_contact_points()
    assert {s: len(p) for s, p in points.items()} == {"left": 4, "right": 4}
    # The 4 contacts are the sole rectangle's corners.
    for side, pts in points.items():
        pose = sim.sole_pose(side)
        corners = robot.sole_corners_local() @ pose.rotation.T + pose.translation
        dist = np.min(np.linalg.norm(pts[:, None, :2] - corners[None, :, :2], axis=2), axis=1)
        assert dist.max() < 2e-3 and np.abs(pts[:, 2]).max() < 2e-3
    assert abs(np.mean(fz[-50:]) / mg - 1.0) < 0.01
    q, _ = sim.get_state()
    assert abs(q[2] - q0[2]) < 5e-3 and np.abs(q[7:] - q0[7:]).max() < 0.05
    wrench = sim.foot_contact_wrenches()
    np.testing.assert_allclose(wrench["left"][:3], sim.foot_contact_forces()["left"])
    sim.set_torques(np.zeros(robot.nv - 6))


def test_invalid_inputs(sim):
    robot = sim.robot
    with pytest.raises(InvalidInputError):
        sim.set_torques(np.zeros(robot.nv - 5))
    with pytest.raises(InvalidInputError):
        sim.set_torques(np.full(robot.nv - 6, np.nan))
    with pytest.raises(InvalidInputError):
        sim.set_state(robot.q_ref[:-1])
    bad = robot.q_ref.copy()
    bad[3:7] = [0.0, 0.0, 0.0, 2.0]
    with pytest.raises(InvalidInputError):
        sim.set_state(bad)
    with pytest.raises(InvalidInputError):
        build_mujoco_model(robot, timestep=0.004)
    with pytest.raises(InvalidInputError):
        build_mujoco_model(robot, foot_contact="spheres")


def test_damping_friction_kept_and_srdf_self_collision():
    robot = wbc.load_robot("talos")
    sim = build_mujoco_model(robot, zero_joint_damping_friction=False, self_collision="srdf")
    dofs = sim.state_map.mj_qvel
    np.testing.assert_array_equal(sim.model.dof_damping[dofs], robot.model.damping[6:])
    np.testing.assert_array_equal(sim.model.dof_frictionloss[dofs], robot.model.friction[6:])
    np.testing.assert_array_equal(sim.joint_damping, robot.model.damping[6:])
    assert sim.damping_friction_in_sim and sim.joint_friction.max() == 1.0
    # half_sitting: the SRDF's disabled pairs remove every overlap of Talos's collision meshes.
    assert sim.self_contacts() == []
    assert len(build_mujoco_model(robot, self_collision="all").self_contacts()) > 0


def _add_crate(spec):
    """A 10 kg box (0.2 × 0.1 × 0.05 m) on the floor at x = 3 m, colliding with the ground as a robot geom."""
    b = spec.worldbody.add_body(name="crate", pos=[3.0, 0.0, 0.0249], mass=10.0,
                                inertia=[0.0104, 0.0354, 0.0417], ipos=[0.0, 0.0, 0.0])
    b.add_freejoint(name="crate_joint")
    b.add_geom(name="crate_geom", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.1, 0.05, 0.025],
               contype=ROBOT_BIT, conaffinity=ENV_BIT)


def _crate_displacement(cone, impratio, force_ratio, robot, friction_timeconst=0.0):
    """x displacement (m) in 1 s of the box of :func:`_add_crate` resting on the floor of the robot's plant, pushed
    horizontally at its centre by ``force_ratio`` × its weight; ``friction_timeconst`` > 0: its floor contact made a
    foot contact by :func:`stiff_foot_friction`."""

    def add_crate(spec):
        _add_crate(spec)
        if friction_timeconst > 0.0:
            root = spec.worldbody.first_body().name  # the robot's root link, built before the crate
            assert stiff_foot_friction(spec, root, {"crate": {"crate"}}, friction_timeconst) == 1

    kw = {} if cone is None else {"cone": cone, "impratio": impratio}
    sim = build_mujoco_model(robot, customize=add_crate, **kw)
    m, d = sim.model, sim.data
    body, adr = m.body("crate").id, m.jnt_qposadr[m.joint("crate_joint").id]
    for _ in range(100):  # settle
        mujoco.mj_step(m, d)
    x0 = float(d.qpos[adr])
    d.xfrc_applied[body, 0] = force_ratio * 10.0 * 9.81
    for _ in range(int(round(1.0 / m.opt.timestep))):
        mujoco.mj_step(m, d)
    return float(d.qpos[adr]) - x0


def test_plant_friction_holds_below_the_friction_limit():
    # Coulomb: a box pushed at 0.3 of its weight on a floor of μ = 1 does not move. MuJoCo's soft friction creeps;
    # the builder's default (elliptic cones, impratio 10) creeps < 0.2 mm in 1 s, MuJoCo's own defaults (pyramidal,
    # impratio 1) more than 5 times as much (measured 0.08 vs 1.5 mm). Above the limit (1.2 × weight) the box
    # slides in both (the friction coefficient is unchanged): ½ (0.2 g) t² = 0.98 m.
    robot = wbc.load_robot("g1")
    sim = build_mujoco_model(robot)
    assert sim.model.opt.cone == mujoco.mjtCone.mjCONE_ELLIPTIC and sim.model.opt.impratio == 10.0
    held = _crate_displacement(None, None, 0.3, robot)
    soft = _crate_displacement("pyramidal", 1.0, 0.3, robot)
    assert 0.0 <= held < 2e-4 and soft > 5 * held
    for cone, imp in ((None, None), ("pyramidal", 1.0)):
        assert _crate_displacement(cone, imp, 1.2, robot) == pytest.approx(0.5 * 0.2 * 9.81, rel=0.1)
    with pytest.raises(InvalidInputError, match="cone"):
        build_mujoco_model(robot, cone="conic")
    with pytest.raises(InvalidInputError, match="impratio"):
        build_mujoco_model(robot, impratio=0.5)


def _squat_sole_drift(robot, **build):
    """Largest horizontal displacement (m) of a sole over 4 s of G1 squatting in double support under a joint PD
    (hip, knee and ankle pitch at -0.5, 1.5, -1 times 0.3 (1 - cos 2π 1.5 t) / 2 rad about q_ref), and the largest
    tangential-to-normal force ratio of a foot over the run (realistic plant)."""
    sim = build_mujoco_model(robot, plant="realistic", **build)  # rotor armature: the PD below is stable
    m, d = sim.model, sim.data
    dofs = np.array([m.jnt_dofadr[m.actuator_trnid[i, 0]] for i in range(m.nu)])
    adr = np.array([m.jnt_qposadr[m.actuator_trnid[i, 0]] for i in range(m.nu)])
    names = [m.joint(m.actuator_trnid[i, 0]).name for i in range(m.nu)]
    shape = np.zeros(m.nu)
    for side in ("left", "right"):
        for joint, k in (("hip_pitch", -0.5), ("knee", 1.5), ("ankle_pitch", -1.0)):
            shape[names.index(f"{side}_{joint}_joint")] = k
    q0, dt, w = d.qpos[adr].copy(), m.opt.timestep, 2.0 * np.pi * 1.5
    ratio = 0.0

    def pd(q_ref, v_ref):
        d.ctrl[:] = d.qfrc_bias[dofs] + 300.0 * (q_ref - d.qpos[adr]) + 6.0 * (v_ref - d.qvel[dofs])

    for _ in range(250):  # settle on the floor
        pd(q0, 0.0)
        mujoco.mj_step(m, d)
    start = {s: sim.sole_pose(s).translation.copy() for s in ("left", "right")}
    for k in range(int(round(4.0 / dt))):
        t = k * dt
        ramp = min(1.0, t / 0.5)
        pd(q0 + ramp * 0.15 * (1.0 - np.cos(w * t)) * shape, ramp * 0.15 * w * np.sin(w * t) * shape)
        mujoco.mj_step(m, d)
        for f in sim.foot_contact_forces().values():
            ratio = max(ratio, np.hypot(f[0], f[1]) / max(f[2], 1e-9))
    drift = max(np.linalg.norm((sim.sole_pose(s).translation - start[s])[:2]) for s in start)
    return drift, ratio


def test_stance_soles_do_not_creep_while_the_legs_move():
    # Coulomb: a flat sole loaded at < 0.1 of its normal force stays put. MuJoCo's friction rows have no position
    # term: the contact solver drives J·qacc to -b·v (b = 2 / (dmax · timeconst)) while the contact point's
    # acceleration is J·qacc + J̇·q̇, so a leg moving over a stance foot (J̇·q̇ from the joint rates) makes the sole
    # slide at J̇·q̇ / b. With the contact's own timeconst (0.02 s, b = 105 /s) G1's soles slide 2.2 mm in 4 s of
    # squats; the friction rows at 2 timesteps (b = 526 /s) keep them within 0.5 mm (0.23 mm).
    robot = wbc.load_robot("g1")
    held, ratio = _squat_sole_drift(robot)
    assert ratio < 0.1 and held < 5e-4
    soft, _ = _squat_sole_drift(robot, friction_timeconst=0.0)
    assert soft > 1.5e-3


def test_foot_contact_pairs_are_the_dynamic_contacts_but_for_the_friction_time_constant():
    # friction_timeconst equal to the contact's own timeconst (0.02 s): the explicit pairs reproduce MuJoCo's
    # dynamic foot contacts (same condim, friction, solref, solimp), so the plant moves the same.
    robot = wbc.load_robot("g1")
    a, b = (build_mujoco_model(robot, friction_timeconst=tc) for tc in (0.0, 0.02))
    assert a.model.npair == 0 and b.model.npair == 2 and b.model.nexclude == 2
    for sim in (a, b):
        for _ in range(200):
            mujoco.mj_step(sim.model, sim.data)
    np.testing.assert_allclose(a.data.qpos, b.data.qpos, atol=1e-9)
    default = build_mujoco_model(robot)
    np.testing.assert_array_equal(default.model.pair_solreffriction, [[0.004, 1.0]] * 2)
    for _ in range(200):
        mujoco.mj_step(default.model, default.data)
    feet = set(np.concatenate(list(default.foot_geoms.values())))
    con = default.data.contact
    assert all(con.solreffriction[i][0] == 0.004 for i in range(default.data.ncon)
               if con.geom1[i] in feet or con.geom2[i] in feet) and default.data.ncon == 8
    with pytest.raises(InvalidInputError, match="friction_timeconst"):
        build_mujoco_model(robot, friction_timeconst=0.003)


def test_stiff_foot_friction_keeps_the_friction_coefficient():
    # The friction rows' time constant changes the soft regime only: the crate as a foot (solreffriction 0.004 s)
    # holds at 0.3 of its weight (< 0.05 mm in 1 s) and slides at 1.2 of it as ½ (0.2 g) t² = 0.98 m (μ = 1).
    robot = wbc.load_robot("g1")
    assert 0.0 <= _crate_displacement(None, None, 0.3, robot, 0.004) < 5e-5
    assert _crate_displacement(None, None, 1.2, robot, 0.004) == pytest.approx(0.5 * 0.2 * 9.81, rel=0.03)


def _resting_depth(robot, ground_timeconst):
    """Mean depth (m) of the 4 floor contacts of the box of :func:`_add_crate` after 1 s at rest."""
    sim = build_mujoco_model(robot, customize=_add_crate, ground_timeconst=ground_timeconst)
    m, d = sim.model, sim.data
    for _ in range(500):
        mujoco.mj_step(m, d)
    crate = m.geom("crate_geom").id
    depth = [-d.contact.dist[i] for i in range(d.ncon) if crate in (d.contact.geom1[i], d.contact.geom2[i])]
    assert len(depth) == 4
    return float(np.mean(depth))


def test_ground_time_constant_is_the_stiffness_of_every_ground_contact():
    # MuJoCo's soft contact (documentation, Modeling, "Solver parameters"): a row of depth r is pulled back at
    # a_ref = −k r with k = 1 / (d_max² τ² ζ²) (solref (τ, ζ = 1), d_max = solimp[1] = 0.95) and the impedance
    # d(r) of solimp (0.9, 0.95, 0.001, 0.5, 2: d = 0.9 + 0.05 · 2 (r / 1 mm)² below 0.5 mm); at rest the row's
    # force f meets R f = −a_ref with R = (1 − d) / d · A (A the row's inverse inertia), so for one body resting on
    # the same contacts r k d / (1 − d) = A f is the same whatever τ: a stiffer ground sinks by k's ratio, ~(τ ratio)².
    robot = wbc.load_robot("g1")

    def invariant(tau, r):
        d = 0.9 + 0.05 * 2.0 * (r / 1e-3) ** 2
        return r * d / (1.0 - d) / (0.95 * tau) ** 2

    soft, stiff = _resting_depth(robot, None), _resting_depth(robot, 0.004)
    assert stiff < soft / 20.0
    assert invariant(0.004, stiff) == pytest.approx(invariant(0.02, soft), rel=0.01)
    # every ground geom (floor, terrain boxes, heightfield) and so the foot pairs that copy them
    sim = build_mujoco_model(robot, ground_timeconst=0.01, terrain="rough:0.02:3")
    m = sim.model
    assert len(sim.ground_geoms) == 2
    np.testing.assert_array_equal(m.geom_solref[sim.ground_geoms], [[0.01, 1.0]] * 2)
    np.testing.assert_array_equal(m.pair_solref, [[0.01, 1.0]] * m.npair)
    assert m.npair == 4
    for bad in (0.003, float("nan"), -1.0, "0.01", True, [0.01]):
        with pytest.raises(InvalidInputError, match="ground_timeconst"):
            build_mujoco_model(robot, ground_timeconst=bad)
