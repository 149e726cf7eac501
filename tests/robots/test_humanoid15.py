"""The humanoid15 teaching robot: structure, inertias, limits, standing reference, self-collisions, MuJoCo,
and reachability of the footholds of a walk."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import coal
import numpy as np
import pinocchio as pin
import pytest
from scipy.spatial import ConvexHull

import wbc

SIDES = ("left", "right")
JOINTS = {
    "torso_yaw",
    "neck",
    *(f"{s}_{j}" for s in SIDES for j in ("hip_pitch", "hip_roll", "knee", "ankle_pitch", "ankle_roll")),
    *(f"{s}_{j}" for s in SIDES for j in ("shoulder_pitch", "elbow")),
}
SOLES = {"left_sole", "right_sole"}  # massless frame links, without geometry


@pytest.fixture(scope="module")
def robot():
    return wbc.load_robot("humanoid15")


@pytest.fixture(scope="module")
def urdf(robot):
    return ET.parse(robot.urdf_path).getroot()


def _adjacent_links(urdf) -> set[frozenset[str]]:
    return {frozenset((j.find("parent").get("link"), j.find("child").get("link"))) for j in urdf.findall("joint")}


def _link_of(robot, geom) -> str:
    return robot.model.frames[geom.parentFrame].name


def _placement_in_link(robot, geom) -> pin.SE3:
    """Geometry placement in its link frame (Pinocchio stores it in the parent joint frame)."""
    return robot.model.frames[geom.parentFrame].placement.actInv(geom.placement)


def _closed_form_inertia(shape, mass: float) -> np.ndarray:
    if isinstance(shape, coal.Box):
        a, b, c = 2.0 * np.asarray(shape.halfSide)
        return mass / 12.0 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])
    if isinstance(shape, coal.Cylinder):
        r, length = shape.radius, 2.0 * shape.halfLength
        i = mass * (3.0 * r * r + length * length) / 12.0
        return np.diag([i, i, mass * r * r / 2.0])
    if isinstance(shape, coal.Sphere):
        return 2.0 / 5.0 * mass * shape.radius**2 * np.eye(3)
    raise AssertionError(f"unexpected shape {type(shape).__name__}")


def _floats(text: str) -> np.ndarray:
    return np.array([float(x) for x in text.split()])


def _configuration(robot, base_xyz, joints: dict[str, float]) -> np.ndarray:
    q = pin.neutral(robot.model)
    q[:3] = base_xyz
    for name, angle in joints.items():
        q[robot.model.joints[robot.joint_id(name)].idx_q] = angle
    return q


def test_model_structure(robot, urdf):
    assert (robot.nq, robot.nv) == (23, 22)
    assert len(robot.joint_names) == 16
    assert set(robot.joint_names) == JOINTS
    assert {j.get("name") for j in urdf.findall("joint") if j.get("type") == "revolute"} == JOINTS
    urdf_mass = sum(float(m.get("value")) for m in urdf.iter("mass"))
    assert robot.mass == pytest.approx(urdf_mass, abs=1e-12)
    assert 30.0 <= robot.mass <= 35.0
    for frame in ("left_sole", "right_sole", "torso", "left_hand", "right_hand", "pelvis", "head"):
        robot.frame_id(frame)


def test_every_link_has_visual_and_collision_geometry(robot, urdf):
    links = {link.get("name") for link in urdf.findall("link")}
    for gmodel in (robot.collision_model, robot.visual_model):
        per_link = {}
        for geom in gmodel.geometryObjects:
            per_link[_link_of(robot, geom)] = per_link.get(_link_of(robot, geom), 0) + 1
        assert set(per_link) == links - SOLES
        assert all(n == 1 for n in per_link.values())
    for link in urdf.findall("link"):
        if link.get("name") in SOLES:
            assert link.find("inertial") is None and link.find("visual") is None
        else:
            assert link.find("inertial") is not None


def test_inertias_are_closed_form_of_the_shapes(robot, urdf):
    masses = {}
    for link in urdf.findall("link"):
        inertial = link.find("inertial")
        if inertial is None:
            continue
        name = link.get("name")
        geom = robot.collision_model.geometryObjects[robot.collision_model.getGeometryId(f"{name}_0")]
        assert _link_of(robot, geom) == name
        placement = _placement_in_link(robot, geom)
        origin = inertial.find("origin")
        # inertial origin == geometry origin (no rotation)
        np.testing.assert_allclose(_floats(origin.get("xyz")), placement.translation, atol=1e-12)
        np.testing.assert_allclose(_floats(origin.get("rpy")), 0.0, atol=0.0)
        np.testing.assert_allclose(placement.rotation, np.eye(3), atol=1e-12)
        mass = float(inertial.find("mass").get("value"))
        i = inertial.find("inertia").attrib
        tensor = np.array(
            [
                [i["ixx"], i["ixy"], i["ixz"]],
                [i["ixy"], i["iyy"], i["iyz"]],
                [i["ixz"], i["iyz"], i["izz"]],
            ],
            dtype=float,
        )
        np.testing.assert_allclose(tensor, _closed_form_inertia(geom.geometry, mass), rtol=0, atol=1e-9)
        masses[name] = mass
    # What Pinocchio built (links rigidly attached to a joint summed up, expressed in the joint frame) is the
    # sum of the shapes' inertias.
    expected = [pin.Inertia.Zero() for _ in range(robot.model.njoints)]
    for geom in robot.collision_model.geometryObjects:
        name = _link_of(robot, geom)
        inertia = pin.Inertia(masses[name], np.zeros(3), _closed_form_inertia(geom.geometry, masses[name]))
        expected[geom.parentJoint] += geom.placement.act(inertia)
    for j in range(1, robot.model.njoints):
        np.testing.assert_allclose(robot.model.inertias[j].matrix(), expected[j].matrix(), rtol=0, atol=1e-9)


def test_joint_limits(robot):
    m = robot.model
    assert np.all(np.isfinite(m.lowerPositionLimit[7:])) and np.all(np.isfinite(m.upperPositionLimit[7:]))
    assert np.all(m.lowerPositionLimit[7:] < m.upperPositionLimit[7:])
    assert np.all(m.velocityLimit[6:] > 0) and np.all(m.effortLimit[6:] > 0)
    for side in SIDES:
        knee = robot.model.joints[robot.joint_id(f"{side}_knee")].idx_q
        assert m.lowerPositionLimit[knee] <= 0.0 and m.upperPositionLimit[knee] >= 2.2


def test_srdf_reference_and_collision_pairs(robot, urdf):
    model = robot.model.copy()
    pin.loadReferenceConfigurations(model, str(robot.srdf_path), False)
    assert "standing" in [entry.key() for entry in model.referenceConfigurations]
    np.testing.assert_allclose(model.referenceConfigurations["standing"], robot.q_ref, atol=1e-9)
    adjacent = _adjacent_links(urdf)
    srdf = ET.parse(robot.srdf_path).getroot()
    disabled = [frozenset((d.get("link1"), d.get("link2"))) for d in srdf.iter("disable_collisions")]
    assert set(disabled) <= adjacent
    gmodel = robot.collision_model.copy()
    gmodel.addAllCollisionPairs()
    pin.removeCollisionPairs(robot.model, gmodel, str(robot.srdf_path))
    for pair in gmodel.collisionPairs:
        a = _link_of(robot, gmodel.geometryObjects[pair.first])
        b = _link_of(robot, gmodel.geometryObjects[pair.second])
        assert frozenset((a, b)) not in set(disabled)


def test_reference_stance(robot):
    m, d, q = robot.model, robot.model.createData(), robot.q_ref
    pin.framesForwardKinematics(m, d, q)
    corners = []
    for sole in (robot.left_sole, robot.right_sole):
        placement = d.oMf[robot.frame_id(sole)]
        np.testing.assert_allclose(placement.rotation, np.eye(3), atol=1e-9)
        assert abs(placement.translation[2]) < 1e-9
        corners += [placement.act(c)[:2] for c in robot.sole_corners_local()]
    soles = [d.oMf[robot.frame_id(sole)].translation for sole in (robot.left_sole, robot.right_sole)]
    feet_mid = 0.5 * (soles[0] + soles[1])
    com = pin.centerOfMass(m, d, q)
    hull = ConvexHull(np.array(corners))
    # hull.equations: n . x + b <= 0 inside; require 2 cm of margin
    assert np.all(hull.equations[:, :2] @ com[:2] + hull.equations[:, 2] <= -0.02)
    assert abs(com[0] - feet_mid[0]) < 0.01 and abs(com[1] - feet_mid[1]) < 1e-9
    margin = np.minimum(q[7:] - m.lowerPositionLimit[7:], m.upperPositionLimit[7:] - q[7:])
    assert margin.min() >= 0.1
    # hip_pitch -0.4, knee 0.8, ankle_pitch -0.4
    for side in SIDES:
        angles = [q[m.joints[robot.joint_id(f"{side}_{j}")].idx_q] for j in ("hip_pitch", "knee", "ankle_pitch")]
        np.testing.assert_allclose(angles, [-0.4, 0.8, -0.4])


def test_no_self_collision_in_reference_stance(robot, urdf):
    gmodel = robot.collision_model.copy()
    gmodel.addAllCollisionPairs()
    gdata = pin.GeometryData(gmodel)
    data = robot.model.createData()
    pin.updateGeometryPlacements(robot.model, data, gmodel, gdata, robot.q_ref)
    pin.computeCollisions(gmodel, gdata, False)
    pin.computeDistances(gmodel, gdata)
    adjacent = _adjacent_links(urdf)
    checked = 0
    for k, pair in enumerate(gmodel.collisionPairs):
        a = _link_of(robot, gmodel.geometryObjects[pair.first])
        b = _link_of(robot, gmodel.geometryObjects[pair.second])
        if frozenset((a, b)) in adjacent:
            continue
        checked += 1
        assert not gdata.collisionResults[k].isCollision(), (a, b)
        assert gdata.distanceResults[k].min_distance > 0.01, (a, b)
        if {a, b} == {"left_foot", "right_foot"}:
            assert gdata.distanceResults[k].min_distance > 0.05
    assert checked > 100


def test_mujoco_compiles_with_the_same_mass(robot):
    mujoco = pytest.importorskip("mujoco")
    text = robot.urdf_path.read_text()
    text = text.replace(
        '<robot name="humanoid15">',
        '<robot name="humanoid15">\n  <mujoco><compiler discardvisual="false" fusestatic="false"/></mujoco>',
        1,
    )
    m = mujoco.MjModel.from_xml_string(text)
    assert m.body_mass.sum() == pytest.approx(robot.mass, abs=1e-9)
    assert m.njnt == 16
    for j in range(m.njnt):
        idx = robot.model.joints[robot.joint_id(m.joint(j).name)].idx_q
        np.testing.assert_allclose(
            m.jnt_range[j], [robot.model.lowerPositionLimit[idx], robot.model.upperPositionLimit[idx]], atol=1e-12
        )


def _leg_ik(robot, q, side, target: pin.SE3, iters=50):
    """Damped Gauss-Newton on one leg's 5 joints, base fixed; returns q and the final 6D error."""
    m, d = robot.model, robot.model.createData()
    fid = robot.frame_id(f"{side}_sole")
    names = [f"{side}_{j}" for j in ("hip_roll", "hip_pitch", "knee", "ankle_pitch", "ankle_roll")]
    iq = [m.joints[robot.joint_id(n)].idx_q for n in names]
    iv = [m.joints[robot.joint_id(n)].idx_v for n in names]
    q = q.copy()
    for _ in range(iters):
        pin.framesForwardKinematics(m, d, q)
        err = pin.log6(d.oMf[fid].actInv(target)).vector
        if np.linalg.norm(err) < 1e-12:
            break
        jac = pin.computeFrameJacobian(m, d, q, fid, pin.LOCAL)[:, iv]
        q[iq] += np.linalg.solve(jac.T @ jac + 1e-12 * np.eye(5), jac.T @ err)
    pin.framesForwardKinematics(m, d, q)
    return q, np.linalg.norm(pin.log6(d.oMf[fid].actInv(target)).vector)


@pytest.mark.parametrize(
    "offset",
    [
        # double support, step length 0.10 m: each foot 0.05 m ahead of / behind the pelvis
        (0.05, 0.0, 0.0),
        (-0.05, 0.0, 0.0),
        # single support with the pelvis shifted 0.08 m over the stance foot: stance foot 0.08 m inwards,
        # swing foot 0.08 m outwards, from 0.10 m behind to 0.10 m ahead, lifted 5 cm half-way
        (0.0, -0.08, 0.0),
        (-0.10, 0.08, 0.0),
        (0.0, 0.08, 0.05),
        (0.10, 0.08, 0.0),
        (0.05, 0.08, 0.05),
    ],
)
def test_walking_footholds_reachable_with_flat_sole_and_bent_knee(robot, offset):
    """Sole poses relative to the pelvis kept at its reference height and orientation (left leg; y outwards)."""
    m, d = robot.model, robot.model.createData()
    pin.framesForwardKinematics(m, d, robot.q_ref)
    for side, sign in (("left", 1.0), ("right", -1.0)):
        ref = d.oMf[robot.frame_id(f"{side}_sole")]
        dx, dy, dz = offset
        target = pin.SE3(np.eye(3), ref.translation + np.array([dx, sign * dy, dz]))
        q, err = _leg_ik(robot, robot.q_ref, side, target)
        assert err < 1e-9
        assert np.all(q[7:] >= m.lowerPositionLimit[7:] + 0.05) and np.all(q[7:] <= m.upperPositionLimit[7:] - 0.05)
        assert q[m.joints[robot.joint_id(f"{side}_knee")].idx_q] > 0.3
