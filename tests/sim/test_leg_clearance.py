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
from wbc.terrain import parse_terrain

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


def test_talos_on_022_stairs_keeps_its_shins_15mm_from_the_step_edges(talos, tmp_path, capsys):
    """``wbc sim walk --terrain stairs:0.22:0.3:6:updown`` (the defaults: realistic plant, estimated state, the
    steps that cross it) passes, and over its logged plant configurations (every 4th tick and the summary's worst
    one) no shin, knee, thigh or ankle of either leg comes within 15 mm of a step box — coal's distance between the
    links' collision-mesh hulls placed by Pinocchio and the terrain's boxes, not MuJoCo's. The summary's MuJoCo
    minimum agrees with coal at its tick within 0.1 mm. (Planned footholds near the middle of the treads going up
    left the stance shin 0.5 mm from the next nosing, record 46; the back of the tread, record 49.)"""
    import json

    from wbc.cli import main

    spec, log, summary = "stairs:0.22:0.3:6:updown", tmp_path / "walk.npz", tmp_path / "walk.json"
    assert main(["sim", "walk", "--terrain", spec, "--quiet", "--log", str(log), "--json", str(summary)]) == 0
    capsys.readouterr()
    s, q = json.loads(summary.read_text()), np.load(log)["q"]
    assert s["passed"] and not s["fell"]
    worst = s["min_leg_terrain_clearance_t_index"]
    terrain = parse_terrain(spec)
    cm = talos.collision_model
    links = {f"leg_{side}_{i}_link" for side in ("left", "right") for i in (3, 4, 5)}  # thigh, shin (knee), ankle
    geoms = [(i, go) for i, go in enumerate(cm.geometryObjects) if talos.model.frames[go.parentFrame].name in links]
    assert len(geoms) >= 6
    for _, go in geoms:
        go.geometry.buildConvexRepresentation(False)
    boxes = [(coal.Box(*b.size), coal.Transform3s(np.array(b.rotation), np.array(b.center))) for b in terrain.boxes]
    data, gdata = talos.model.createData(), pin.GeometryData(cm)

    def coal_min(qk):
        pin.updateGeometryPlacements(talos.model, data, cm, gdata, qk)
        best = np.inf
        for i, go in geoms:
            T = coal.Transform3s(gdata.oMg[i].rotation, gdata.oMg[i].translation)
            for box, B in boxes:
                best = min(best, coal.distance(go.geometry.convex, T, box, B, coal.DistanceRequest(),
                                               coal.DistanceResult()))
        return best

    at_worst = coal_min(q[worst])
    assert s["min_leg_terrain_clearance_m"] == pytest.approx(at_worst, abs=1e-4)
    assert min(at_worst, min(coal_min(qk) for qk in q[::4])) >= 0.015
