"""Kinematics through Configuration against finite differences of Pinocchio's own forward kinematics."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from conftest import CATALOG, random_configuration
from wbc.configuration import LOCAL, LOCAL_WORLD_ALIGNED, Configuration, frame_jacobian_columns, local_jacobian_into
from wbc.exceptions import ConfigurationError

EPS = 1e-6


def _fd_frame(model, q, fid, dq):
    """World-frame linear and angular velocity of frame fid for the tangent direction dq, by central differences."""
    data = model.createData()
    plus, minus = pin.integrate(model, q, EPS * dq), pin.integrate(model, q, -EPS * dq)
    pin.framesForwardKinematics(model, data, plus)
    Mp = data.oMf[fid].copy()
    pin.framesForwardKinematics(model, data, minus)
    Mm = data.oMf[fid].copy()
    lin = (Mp.translation - Mm.translation) / (2 * EPS)
    ang = pin.log3(Mp.rotation @ Mm.rotation.T) / (2 * EPS)
    return lin, ang


@pytest.mark.parametrize("name", CATALOG)
def test_frame_jacobians_match_finite_differences(robots, name):
    robot = robots(name)
    rng = np.random.default_rng(0)
    for _ in range(3):
        config = Configuration(robot, random_configuration(robot, rng))
        for frame in (robot.left_sole, robot.right_sole, robot.torso):
            fid = robot.frame_id(frame)
            dq = rng.standard_normal(robot.nv)
            lin, ang = _fd_frame(robot.model, config.q, fid, dq)
            J = config.frame_jacobian(fid, LOCAL_WORLD_ALIGNED)
            np.testing.assert_allclose(J[:3] @ dq, lin, atol=1e-6)
            np.testing.assert_allclose(J[3:] @ dq, ang, atol=1e-6)
            # LOCAL = the same twist expressed in the frame's axes
            R = config.frame_placement(fid).rotation
            JL = config.frame_jacobian(fid, LOCAL)
            np.testing.assert_allclose(R @ (JL[:3] @ dq), lin, atol=1e-6)
            np.testing.assert_allclose(R @ (JL[3:] @ dq), ang, atol=1e-6)


@pytest.mark.parametrize("name", CATALOG)
def test_local_jacobian_from_the_joint_jacobians_is_pinocchios(robots, name):
    """local_jacobian_into (data.J turned into each frame's axes, on its support columns) gives bit for bit
    ``pin.getFrameJacobian(..., LOCAL)`` for every frame of the model (zeros, of either sign, included), and those
    columns are the ones where Pinocchio's Jacobian can be nonzero."""
    robot = robots(name)
    model = robot.model
    rng = np.random.default_rng(3)
    config = Configuration(robot)
    for _ in range(3):
        config.update(random_configuration(robot, rng))
        data = config.data
        for fid in range(1, model.nframes):
            ref = pin.getFrameJacobian(model, data, fid, LOCAL)
            columns = frame_jacobian_columns(model, fid)
            out = np.zeros((6, model.nv))
            local_jacobian_into(data.J, data.oMf[fid].rotation, data.oMf[fid].translation, columns, out)
            assert np.array_equal(out, ref) and np.array_equal(np.signbit(out), np.signbit(ref)), model.frames[fid].name
            assert not np.delete(ref, columns, axis=1).any()


@pytest.mark.parametrize("name", CATALOG)
def test_com_and_com_jacobian_match_finite_differences(robots, name):
    robot = robots(name)
    rng = np.random.default_rng(1)
    q = random_configuration(robot, rng)
    config = Configuration(robot, q)
    data = robot.model.createData()
    np.testing.assert_allclose(config.com, pin.centerOfMass(robot.model, data, q), atol=1e-12)
    dq = rng.standard_normal(robot.nv)
    cp = pin.centerOfMass(robot.model, data, pin.integrate(robot.model, q, EPS * dq)).copy()
    cm = pin.centerOfMass(robot.model, data, pin.integrate(robot.model, q, -EPS * dq)).copy()
    np.testing.assert_allclose(config.com_jacobian @ dq, (cp - cm) / (2 * EPS), atol=1e-6)


@pytest.mark.parametrize("name", CATALOG)
def test_reference_configuration_stands_on_the_ground(robots, name):
    robot = robots(name)
    config = Configuration(robot)
    for frame in (robot.left_sole, robot.right_sole):
        M = config.frame_placement(robot.frame_id(frame))
        assert abs(M.translation[2]) < 1e-9
        # Talos's SRDF half_sitting rolls each sole by 1.7 mrad; level within 5 mrad
        np.testing.assert_allclose(M.rotation[:, 2], [0, 0, 1], atol=5e-3)


def test_configuration_rejects_bad_vectors(robots):
    robot = robots("talos")
    config = Configuration(robot)
    with pytest.raises(ConfigurationError, match=r"shape \(39,\)"):
        config.update(np.zeros(12))
    q = robot.q_ref.copy()
    q[10] = np.nan
    with pytest.raises(ConfigurationError, match="finite"):
        config.update(q)
    q = robot.q_ref.copy()
    q[3:7] = [0, 0, 0, 2.0]
    with pytest.raises(ConfigurationError, match="unit norm"):
        config.update(q)


@pytest.mark.parametrize("name", CATALOG)
def test_kept_centroidal_map_leaves_the_kinematics_unchanged(robots, name):
    """keep_centroidal_map swaps the forward kinematics of the update for computeCentroidalMap: the joint placements,
    Jacobians, frame placements, CoM and CoM Jacobian must stay the same numbers (bit for bit), and the kept Ag must
    be Pinocchio's computeCentroidalMap at q on a fresh Data."""
    robot = robots(name)
    rng = np.random.default_rng(3)
    plain, kept = Configuration(robot), Configuration(robot)
    kept.keep_centroidal_map()
    assert kept.keeps_centroidal_map and not plain.keeps_centroidal_map
    for _ in range(4):
        q = random_configuration(robot, rng)
        plain.update(q.copy())
        kept.update(q.copy())
        v = rng.standard_normal(robot.nv)
        for config in (plain, kept):
            config.step(v, 0.002)
        assert np.array_equal(plain.q, kept.q)
        assert np.array_equal(plain.data.J, kept.data.J)
        assert np.array_equal(plain.com, kept.com) and np.array_equal(plain.com_jacobian, kept.com_jacobian)
        for a, b in zip(plain.data.oMf, kept.data.oMf):
            assert np.array_equal(a.homogeneous, b.homogeneous)
        reference = pin.computeCentroidalMap(robot.model, robot.model.createData(), kept.q)
        assert np.array_equal(kept.centroidal_momentum_matrix, reference)
        np.testing.assert_allclose(plain.centroidal_momentum_matrix, reference, rtol=0, atol=1e-12)


@pytest.mark.parametrize("name", CATALOG)
def test_update_gives_the_numbers_of_pinocchios_separate_passes(robots, name):
    """The update's single pass (jacobianCenterOfMass at q, then the frame placements) gives bit for bit what
    Pinocchio's separate passes give on a fresh Data: computeJointJacobians, updateFramePlacements,
    jacobianCenterOfMass."""
    robot = robots(name)
    model = robot.model
    rng = np.random.default_rng(11)
    config = Configuration(robot)
    for _ in range(4):
        q = random_configuration(robot, rng)
        config.update(q.copy())
        ref = model.createData()
        pin.computeJointJacobians(model, ref, q)
        pin.updateFramePlacements(model, ref)
        jcom = pin.jacobianCenterOfMass(model, ref, False)
        assert np.array_equal(config.data.J, ref.J)
        assert np.array_equal(config.com, ref.com[0]) and np.array_equal(config.com_jacobian, jcom)
        for a, b in zip(config.data.oMi, ref.oMi):
            assert np.array_equal(a.homogeneous, b.homogeneous)
        for a, b in zip(config.data.oMf, ref.oMf):
            assert np.array_equal(a.homogeneous, b.homogeneous)
        for fid in (robot.frame_id(robot.left_sole), robot.frame_id(robot.torso)):
            assert np.array_equal(config.frame_jacobian(fid, LOCAL), pin.getFrameJacobian(model, ref, fid, LOCAL))


@pytest.mark.parametrize("name", CATALOG)
def test_every_frame_is_current_when_data_is_read_after_a_step(robots, name):
    """Frames are placed on the first read of ``data`` after an update: after steps in which only the rows' own frames
    were placed (frame_jacobian on kinematics_data), every frame of ``data.oMf`` equals Pinocchio's
    framesForwardKinematics at the new q on a fresh Data, bit for bit."""
    robot = robots(name)
    model = robot.model
    rng = np.random.default_rng(12)
    config = Configuration(robot, random_configuration(robot, rng))
    torso = robot.frame_id(robot.torso)
    for _ in range(3):
        config.step(0.5 * rng.standard_normal(robot.nv), 0.01)
        config.frame_jacobian(torso, LOCAL)  # places the torso frame only
        assert config.kinematics_data is config.data
        ref = model.createData()
        pin.framesForwardKinematics(model, ref, config.q)
        for a, b in zip(config.data.oMf, ref.oMf):
            assert np.array_equal(a.homogeneous, b.homogeneous)
        assert np.array_equal(config.frame_placement(robot.frame_id(robot.left_sole)).homogeneous,
                              ref.oMf[robot.frame_id(robot.left_sole)].homogeneous)


def test_step_rejects_non_finite_velocity_and_keeps_q(robots):
    robot = robots("talos")
    config = Configuration(robot)
    q0 = config.q.copy()
    v = np.zeros(robot.nv)
    v[7] = np.nan
    with pytest.raises(ConfigurationError):
        config.step(v, 0.002)
    assert np.array_equal(config.q, q0)
    v[7] = 0.3
    config.step(v, 0.002)
    np.testing.assert_array_equal(config.q, pin.integrate(robot.model, q0, v * 0.002))
    config.step(list(v), 0.002)  # a list is converted (check_vector), the same step
    np.testing.assert_array_equal(config.q, pin.integrate(robot.model, pin.integrate(robot.model, q0, v * 0.002),
                                                          v * 0.002))


@pytest.mark.parametrize("keep_ag", [False, True])
def test_step_adopts_a_matching_lookahead_with_pinocchios_numbers(robots, keep_ag):
    """lookahead(v·dt) leaves the configuration at q and gives Pinocchio's kinematics at q ⊕ v·dt; a step with that
    v·dt adopts it: q, joint placements and Jacobians, every frame, CoM and its Jacobian (and Ag) equal, bit for bit,
    Pinocchio's passes at pin.integrate(q, v·dt) on a fresh Data. A step with another v, or after q was updated,
    computes its own kinematics (the same comparison)."""
    robot = robots("talos")
    model = robot.model
    rng = np.random.default_rng(21)
    config = Configuration(robot, random_configuration(robot, rng))
    if keep_ag:
        config.keep_centroidal_map()
    sole = robot.frame_id(robot.left_sole)

    def check(q):
        ref = model.createData()
        pin.computeJointJacobians(model, ref, q)
        pin.updateFramePlacements(model, ref)
        jcom = pin.jacobianCenterOfMass(model, ref, False)
        assert np.array_equal(config.q, q)
        assert np.array_equal(config.data.J, ref.J)
        assert np.array_equal(config.com, ref.com[0]) and np.array_equal(config.com_jacobian, jcom)
        for a, b in zip(config.data.oMf, ref.oMf):
            assert np.array_equal(a.homogeneous, b.homogeneous)
        if keep_ag:
            assert np.array_equal(config.centroidal_momentum_matrix,
                                  pin.computeCentroidalMap(model, model.createData(), q))

    for case in ("adopt", "other v", "updated", "adopt"):
        q0 = config.q.copy()
        v = 0.5 * rng.standard_normal(robot.nv)
        dt = 0.01
        ahead = config.lookahead(v * dt)
        assert np.array_equal(config.q, q0) and ahead is not config.kinematics_data
        pin.updateFramePlacement(model, ahead, sole)
        q1 = pin.integrate(model, q0, v * dt)
        ref = model.createData()
        pin.framesForwardKinematics(model, ref, q1)
        assert np.array_equal(ahead.oMf[sole].homogeneous, ref.oMf[sole].homogeneous)
        if case == "other v":
            v = v.copy()
            v[10] += 1e-3
            q1 = pin.integrate(model, q0, v * dt)
        elif case == "updated":
            q0 = random_configuration(robot, rng)
            config.update(q0.copy())
            q1 = pin.integrate(model, q0, v * dt)
        config.step(v, dt)
        check(q1)


@pytest.mark.parametrize("vdt", [np.zeros(5), np.full(38, np.nan), [0.0] * 37 + [np.inf], "x"])
def test_lookahead_rejects_bad_displacement(robots, vdt):
    """lookahead raises ConfigurationError (not a Pinocchio error, not a NaN Data) on a displacement of the wrong size
    or not finite, leaves q as it was, and a later step computes its own kinematics (Pinocchio's at q ⊕ v·dt)."""
    robot = robots("talos")
    config = Configuration(robot, random_configuration(robot, np.random.default_rng(5)))
    q0 = config.q.copy()
    with pytest.raises(ConfigurationError, match="displacement vdt"):
        config.lookahead(vdt)
    assert np.array_equal(config.q, q0)
    v = np.full(robot.nv, 0.1)
    config.step(v, 0.01)
    assert np.array_equal(config.q, pin.integrate(robot.model, q0, v * 0.01))


def test_lookahead_accepts_a_list_as_the_same_displacement(robots):
    """A finite list of nv floats is converted (check_vector): the Data equals the array's lookahead bit for bit."""
    robot = robots("talos")
    config = Configuration(robot, random_configuration(robot, np.random.default_rng(6)))
    vdt = 0.01 * np.random.default_rng(7).standard_normal(robot.nv)
    ref = config.lookahead(vdt).J.copy()
    assert np.array_equal(config.lookahead(list(vdt)).J, ref)
