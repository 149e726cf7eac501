"""wbc.sim.leg_clearance: the legs' distance to the terrain boxes, against coal (hpp-fcl) on the same poses.

Hand-placed poses of Talos at its reference posture slid along x in front of the first riser of
``stairs:0.22:0.3:6:updown`` (riser at x = 0.2 m): shins clear of it, then into it. The reference distance is coal's
GJK between the convex hull of each leg link's URDF collision mesh (Pinocchio's collision model, placed by
Pinocchio's forward kinematics, not MuJoCo's) and a coal box at each terrain box's pose and size
(:class:`wbc.terrain.Box`, not the MuJoCo geom).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from wbc.sim.leg_clearance import CLEARANCE_DISTMAX, leg_geoms, leg_terrain_clearance
from wbc.sim.mujoco_model import build_mujoco_model

coal = pytest.importorskip("coal")

TERRAIN = "stairs:0.22:0.3:6:updown"


@pytest.fixture(scope="module")
def talos(robots):
    return robots("talos")


@pytest.fixture(scope="module")
def stairs_sim(talos):
    return build_mujoco_model(talos, terrain=TERRAIN)


def _coal_min(robot, terrain, q, link: str) -> float:
    """Smallest coal distance (m) between ``link``'s collision mesh hull and the terrain boxes at ``q``."""
    cm = robot.collision_model
    data, gdata = robot.model.createData(), pin.GeometryData(cm)
    pin.updateGeometryPlacements(robot.model, data, cm, gdata, q)
    best = np.inf
    for i, go in enumerate(cm.geometryObjects):
        if robot.model.frames[go.parentFrame].name != link and not go.name.startswith(link + "_"):
            continue
        go.geometry.buildConvexRepresentation(False)
        hull = go.geometry.convex
        T = coal.Transform3s(gdata.oMg[i].rotation, gdata.oMg[i].translation)
        for box in terrain.boxes:
            res = coal.DistanceResult()
            d = coal.distance(hull, T, coal.Box(*box.size), coal.Transform3s(np.array(box.rotation),
                                                                            np.array(box.center)),
                              coal.DistanceRequest(), res)
            best = min(best, d)
    return float(best)


def test_leg_links_are_the_legs_above_the_feet(stairs_sim):
    """Talos: leg_{left,right}_1..5_link (hip to ankle), not the feet (leg_*_6_link) nor the base."""
    assert sorted(leg_geoms(stairs_sim)) == sorted(f"leg_{s}_{i}_link" for s in ("left", "right") for i in range(1, 6))


def test_clearance_matches_coal_on_hand_placed_poses(talos, stairs_sim):
    """Per link, the minimum over the poses equals coal's within 0.1 mm, in clearance (> 0) and in penetration
    (< 0); the overall minimum names its link and pose."""
    q = np.tile(talos.q_ref, (4, 1))
    q[:, 0] = (-0.3, -0.05, 0.02, 0.1)  # the shins' front ~8 cm behind the riser, then into it
    got = leg_terrain_clearance(stairs_sim, q)
    terrain = stairs_sim.terrain
    checked = 0
    for link, dist in got["leg_terrain_clearance_m"].items():
        want = min(_coal_min(talos, terrain, qk, link) for qk in q)
        if want >= CLEARANCE_DISTMAX:
            assert dist == CLEARANCE_DISTMAX, link
            continue
        assert dist == pytest.approx(want, abs=1e-4), link
        checked += 1
    assert checked >= 6  # shins, thighs and ankles of both legs within the bound
    assert got["min_leg_terrain_clearance_m"] < 0 and got["min_leg_terrain_clearance_t_index"] == 3
    assert got["min_leg_terrain_clearance_link"] in ("leg_left_4_link", "leg_right_4_link")  # the shins


def test_each_pose_alone_matches_coal(talos, stairs_sim):
    """Pose by pose (one row each): the shins' distance to the riser as coal gives it, positive then negative."""
    signs = []
    for x in (-0.05, 0.02, 0.1):
        q = talos.q_ref.copy()
        q[0] = x
        got = leg_terrain_clearance(stairs_sim, q[None])
        want = _coal_min(talos, stairs_sim.terrain, q, "leg_left_4_link")
        assert got["leg_terrain_clearance_m"]["leg_left_4_link"] == pytest.approx(want, abs=1e-4), x
        signs.append(np.sign(want))
    assert signs[0] > 0 and signs[-1] < 0


def test_no_terrain_box_no_entry(talos):
    sim = build_mujoco_model(talos)
    assert leg_terrain_clearance(sim, talos.q_ref[None]) == {}
