"""The feet `wbc robot init` gives a humanoid: the controller's sole rectangle lies where the foot's own geometry
touches a flat floor (checked against MuJoCo's contact points and against the URDF's geometry read directly), and
the plant touches the ground through that geometry (``[mujoco] foot = "urdf"``), the visual meshes when the URDF
has no collision geometry."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import mujoco
import numpy as np
import pinocchio as pin
import pytest
import trimesh

from wbc.geometry import convex_hull, rectangle_in_polygon, signed_distance
from wbc.robot import build_robot, example_robot_data_dir
from wbc.robot_inspect import infer_robot_spec
from wbc.sim.mujoco_model import build_mujoco_model

ERD = example_robot_data_dir() / "example-robot-data" / "robots"
G1 = ERD / "g1_description" / "urdf" / "g1_29dof_rev_1_0.urdf"
ALEXANDER = ERD / "alexander_description" / "urdf" / "alexander_v1.lowerBodyOnly.urdf"


def test_rectangle_in_polygon_closed_form():
    # diamond |x|/a + |y|/b <= 1: the corner (s L/2, s W/2) is on its edge when s (L/(2a) + W/(2b)) = 1
    a, b, length, width = 0.3, 0.1, 0.2, 0.05
    diamond = np.array([[a, 0.0], [0.0, b], [-a, 0.0], [0.0, -b]])
    s = 1.0 / (length / (2 * a) + width / (2 * b))
    assert np.allclose(rectangle_in_polygon(diamond, length, width), (s * length, s * width), atol=1e-12)
    # a rectangle in itself (clockwise order too)
    box = np.array([[0.1, 0.04], [0.1, -0.04], [-0.1, -0.04], [-0.1, 0.04]])
    assert np.allclose(rectangle_in_polygon(box, 1.0, 0.4), (0.2, 0.08), atol=1e-12)
    # the origin outside: nothing fits
    assert rectangle_in_polygon(box + [0.2, 0.0], 1.0, 0.4) == (0.0, 0.0)


def _corners(length: float, width: float) -> np.ndarray:
    return np.array([[sx * length / 2, sy * width / 2] for sx in (-1, 1) for sy in (-1, 1)])


def _sole_contacts(sim, robot, side: str, sink: float = 0.001) -> np.ndarray:
    """(k, 2) MuJoCo foot–floor contact points in the sole frame, the robot at q_ref lowered by ``sink`` m."""
    q = robot.q_ref.copy()
    q[2] -= sink
    sim.set_state(q, np.zeros(robot.nv))
    mujoco.mj_forward(sim.model, sim.data)
    pts = sim.foot_contact_points()[side]
    sole = sim.sole_pose(side)
    return ((pts - sole.translation) @ sole.rotation)[:, :2]


@pytest.fixture(scope="module")
def g1():
    spec, notes = infer_robot_spec(G1)
    return spec, build_robot(spec)


def test_g1_sole_rectangle_inside_its_sphere_feet(g1):
    """G1's URDF feet are four 5 mm spheres each; a flat floor touches their lowest points only. The rectangle
    must lie inside the polygon of those points — read from the URDF's XML (sphere origins, radius), not from the
    code under test — and inside MuJoCo's contact points. (Measured on the spheres' bounding boxes it was 6 mm
    wider than the heel's two contacts.)"""
    spec, robot = g1
    assert spec.mujoco.foot == "urdf"
    root = ET.parse(G1).getroot()
    link = next(lk for lk in root.iter("link") if lk.get("name") == "left_ankle_roll_link")
    bottoms = []
    for col in link.iter("collision"):
        r = float(col.find("geometry/sphere").get("radius"))
        xyz = np.array([float(x) for x in col.find("origin").get("xyz").split()])
        bottoms.append(xyz - [0.0, 0.0, r])
    model = robot.model
    frame = model.frames[model.getFrameId(robot.left_sole)]
    body = model.frames[model.getFrameId("left_ankle_roll_link")]
    assert frame.parentJoint == body.parentJoint
    sole_m_body = frame.placement.inverse() * body.placement
    in_sole = np.array([sole_m_body.act(p) for p in bottoms])
    assert np.allclose(in_sole[:, 2], 0.0, atol=1e-4)  # the sole plane is at the spheres' bottoms
    hull = convex_hull(in_sole[:, :2])
    corners = _corners(robot.sole_length, robot.sole_width)
    assert signed_distance(corners, hull).min() >= 0.0
    # and it is not needlessly small: at least 80 % of the hull's length and width
    assert robot.sole_length >= 0.8 * np.ptp(in_sole[:, 0]) and robot.sole_width >= 0.8 * 0.05
    sim = build_mujoco_model(robot, foot_contact=spec.mujoco.foot)
    contacts = _sole_contacts(sim, robot, "left")
    assert len(contacts) == 4
    assert signed_distance(corners, convex_hull(contacts)).min() >= -1e-6


def test_feet_without_collision_geometry_touch_through_their_visual_meshes():
    """Alexander's URDF has no <collision> at all: with ``foot = "urdf"`` the plant's feet are its visual foot
    meshes (before, the feet had no contact geometry and the robot sank through the floor), and the sole rectangle
    lies inside the footprint of those meshes, read with trimesh: their vertices within 2 mm of the lowest."""
    spec, _ = infer_robot_spec(ALEXANDER)
    assert spec.mujoco.foot == "urdf"
    robot = build_robot(spec)
    with pytest.warns(UserWarning, match="no collision geometry"):
        sim = build_mujoco_model(robot, foot_contact="urdf")
    corners = _corners(robot.sole_length, robot.sole_width)
    for side in ("left", "right"):
        assert len(sim.foot_geoms[side]) > 0
        assert len(_sole_contacts(sim, robot, side)) >= 3
        assert sim.non_foot_ground_contacts() == []
        p = _foot_mesh_points(robot, robot.visual_model, side)
        touch = p[p[:, 2] <= p[:, 2].min() + 0.002]
        assert abs(p[:, 2].min()) < 1e-3  # the sole plane at the foot's bottom
        assert signed_distance(corners, convex_hull(touch[:, :2])).min() >= 0.0


def _foot_mesh_points(robot, geometry_model, side: str) -> np.ndarray:
    """(n, 3) vertices of the meshes of ``geometry_model`` on the joint of ``side``'s sole frame, in the sole frame
    (m), read with trimesh from the mesh files (scaled as the URDF says)."""
    model = robot.model
    frame = model.frames[model.getFrameId(getattr(robot, f"{side}_sole"))]
    pts = []
    for g in geometry_model.geometryObjects:
        if g.parentJoint != frame.parentJoint:
            continue
        mesh = trimesh.load(g.meshPath, force="mesh")
        v = np.asarray(mesh.vertices) * np.asarray(g.meshScale)
        m = frame.placement.inverse() * g.placement
        pts.append(v @ m.rotation.T + m.translation)
    return np.vstack(pts)


ROMEO = ERD / "romeo_description" / "urdf" / "romeo.urdf"


def test_flat_mesh_foot_stands_on_its_whole_patch():
    """Romeo's foot is a collision mesh with a flat bottom. MuJoCo's plane–mesh collider alone gives it the deepest
    vertex and at most three of its neighbours, a triangle or quad that does not hold the controller's sole
    rectangle (the foot rocked between such vertex sets while standing). With the pads on its patch corners, the
    plant's contact points span the foot's flat bottom — read with trimesh from the collision mesh: its vertices
    within 2 mm of the lowest — and hold the sole rectangle, the foot sunk 3 mm (as under a walk's load)."""
    spec, _ = infer_robot_spec(ROMEO)
    assert spec.mujoco.foot == "urdf"
    robot = build_robot(spec)
    sim = build_mujoco_model(robot, foot_contact="urdf")
    corners = _corners(robot.sole_length, robot.sole_width)
    for side in ("left", "right"):
        contacts = _sole_contacts(sim, robot, side, sink=0.003)
        p = _foot_mesh_points(robot, robot.collision_model, side)
        patch = convex_hull(p[p[:, 2] <= p[:, 2].min() + 0.002][:, :2])
        hull = convex_hull(contacts)
        # every corner of the mesh's flat patch is a contact point (within 1 mm), and the rectangle is inside
        assert signed_distance(patch, hull).min() >= -1e-3
        assert signed_distance(corners, hull).min() >= 0.0
