"""The MuJoCo plant's terrain (wbc.sim.mujoco_model.add_terrain) against wbc.terrain: MuJoCo's own ray casting
sees the heights the planner uses; a robot body on a step is a non-foot ground contact."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from wbc.robot import load_robot
from wbc.sim.mujoco_model import build_mujoco_model
from wbc.terrain import parse_terrain


@pytest.fixture(scope="module")
def talos():
    return load_robot("talos")


@pytest.mark.parametrize("spec,tol", [("stairs:0.15:0.3:3:updown", 1e-9), ("slope:10", 1e-9),
                                      ("rough:0.02:1", 1e-6), ("stairs:0.1:0.3:3:down", 1e-9)])
def test_plant_ground_height_is_the_terrain_height(talos, spec, tol):
    terrain = parse_terrain(spec)
    sim = build_mujoco_model(talos, terrain=terrain, sensors=False)
    m, d = sim.model, sim.data
    mujoco.mj_forward(m, d)
    rng = np.random.default_rng(0)
    xs, ys = rng.uniform(0.4, 5.0, 200), rng.uniform(0.45, 0.95, 200)  # beside the robot (it stands at y = 0)
    gid = np.zeros(1, dtype=np.int32)
    top = 2.0
    ray = np.array([top - mujoco.mj_ray(m, d, np.array([x, y, top]), np.array([0.0, 0.0, -1.0]), None, 1, -1, gid)
                    for x, y in zip(xs, ys)])
    assert np.abs(ray - terrain.height(xs, ys)).max() <= tol  # float32 hfield data: 1e-6
    assert len(sim.ground_geoms) == 1 + len(terrain.boxes) + (terrain.heightfield is not None)


def test_a_body_on_a_step_is_a_non_foot_ground_contact(talos):
    """The robot lowered onto the first step: its feet hang over the riser, its legs hit the step box."""
    terrain = parse_terrain("stairs:0.4:0.5:1")  # one 40 cm block from x = 0.25
    sim = build_mujoco_model(talos, terrain=terrain, sensors=False)
    q = talos.q_ref.copy()
    q[0] += 0.2  # the shins reach over the block's front edge at x = 0.25
    sim.set_state(q, np.zeros(talos.model.nv))
    mujoco.mj_forward(sim.model, sim.data)
    assert sim.non_foot_ground_contacts(), "a leg inside the step box must count as a ground contact"
    flat = build_mujoco_model(talos, sensors=False)
    flat.set_state(q, np.zeros(talos.model.nv))
    mujoco.mj_forward(flat.model, flat.data)
    assert flat.non_foot_ground_contacts() == []


def test_recording_draws_the_terrain():
    """meshcat scene commands for a terrain: one box object per terrain box (its size and pose) and one triangle
    mesh for a heightfield, under /meshcat/terrain."""
    import meshcat

    from wbc.viz import _scene

    for spec, n_boxes, hf in (("stairs:0.1:0.3:3:updown", 5, False), ("rough:0.02:1", 0, True)):
        terrain = parse_terrain(spec)
        rec = _scene.CommandRecorder()
        _scene.draw_terrain(meshcat.Visualizer(window=rec), terrain)
        objs = [c for c in rec.commands if c["type"] == "set_object" and c["path"].startswith(_scene.TERRAIN_ROOT)]
        boxes = [c for c in objs if "/box_" in c["path"]]
        assert len(boxes) == n_boxes == len(terrain.boxes)
        assert len(objs) - len(boxes) == int(hf)
        poses = [c for c in rec.commands if c["type"] == "set_transform" and "/box_" in c["path"]]
        for c, box in zip(poses, terrain.boxes):
            T = np.array(c["matrix"], dtype=float).reshape(4, 4).T  # column-major
            assert np.allclose(T[:3, 3], box.center)
