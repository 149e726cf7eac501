"""How close the legs came to the terrain: the smallest distance between the leg links' collision geoms (shins,
knees, thighs, ankles: every body of a leg above its foot) and the terrain's box geoms over a run.

A shin or knee touching a step edge is already a fall (:mod:`wbc.sim.outcome`: any non-foot geom on the ground);
this is the margin a run kept. :func:`leg_terrain_clearance` replays the plant's logged configurations in a
MuJoCo data of its own (``mj_kinematics``, the run's data untouched) and asks ``mj_geomDistance`` (MuJoCo's
collision geometry: a mesh by its convex hull) for the signed distance of each (leg geom, terrain box) pair within
``distmax``; pairs whose bounding sphere (leg geom) and box (terrain) are farther apart than ``distmax`` are
skipped. Units: metres; negative: penetration.
"""

from __future__ import annotations

import mujoco
import numpy as np

__all__ = ["leg_geoms", "leg_terrain_clearance", "CLEARANCE_DISTMAX"]

CLEARANCE_DISTMAX = 0.2  #: m: distances beyond this are not resolved (reported as this bound)


def leg_geoms(sim) -> dict[str, np.ndarray]:
    """Collision geoms of each leg's links above its foot, by link (MuJoCo body) name: from the foot body of
    :attr:`MujocoModel.foot_bodies` up through its parents to the body under the floating base (excluded), the
    foot bodies excluded.

    Args:
        sim: a :class:`wbc.sim.mujoco_runtime.MujocoModel`.

    Returns:
        ``{link name: (k,) geom ids}`` for the links with at least one colliding geom.
    """
    m = sim.model
    colliding = (m.geom_contype != 0) | (m.geom_conaffinity != 0)
    out = {}
    for side, feet in sim.foot_bodies.items():
        b = int(m.body_parentid[int(min(feet))])
        while b > 0 and m.body_jntnum[b] and m.jnt_type[m.body_jntadr[b]] != mujoco.mjtJoint.mjJNT_FREE:
            if b not in feet:
                ids = np.flatnonzero(colliding & (m.geom_bodyid == b))
                if ids.size:
                    out[m.body(b).name] = ids
            b = int(m.body_parentid[b])
    return out


def _box_geoms(sim) -> np.ndarray:
    m = sim.model
    ground = np.asarray(sim.ground_geoms if sim.ground_geoms is not None else [], dtype=int)
    return ground[m.geom_type[ground] == mujoco.mjtGeom.mjGEOM_BOX]


def leg_terrain_clearance(sim, q: np.ndarray, stride: int = 1, distmax: float = CLEARANCE_DISTMAX) -> dict:
    """Smallest signed distance (m) between the leg links' collision geoms (:func:`leg_geoms`) and the terrain's
    box geoms over the configurations ``q`` (module docstring).

    Args:
        sim: the :class:`wbc.sim.mujoco_runtime.MujocoModel` the run used (its terrain boxes).
        q: (N, nq) Pinocchio configurations of the plant (``SimRun.q``). stride: every ``stride``-th row is
            measured (and the last). distmax: m, the bound of the search.

    Returns:
        ``{}`` without a terrain box; else ``min_leg_terrain_clearance_m`` (m, at most ``distmax``),
        ``min_leg_terrain_clearance_link`` (the link), ``min_leg_terrain_clearance_box`` (the terrain geom),
        ``min_leg_terrain_clearance_t_index`` (the row of ``q``) and ``leg_terrain_clearance_m`` (the minimum per
        link).
    """
    boxes = _box_geoms(sim)
    if boxes.size == 0 or len(q) == 0:
        return {}
    m = sim.model
    d = mujoco.MjData(m)
    links = leg_geoms(sim)
    per_link = {name: float(distmax) for name in links}
    best = (float(distmax), None, None, None)
    half = m.geom_size[boxes]
    rows = list(range(0, len(q), max(1, int(stride))))
    if rows[-1] != len(q) - 1:
        rows.append(len(q) - 1)
    for k in rows:
        sim.set_state(q[k], data=d, forward=False)
        mujoco.mj_kinematics(m, d)
        # terrain boxes' world AABBs (a rotated box: |R| @ half sizes)
        R = np.abs(d.geom_xmat[boxes].reshape(-1, 3, 3))
        ext = np.einsum("bij,bj->bi", R, half)
        lo, hi = d.geom_xpos[boxes] - ext, d.geom_xpos[boxes] + ext
        for name, ids in links.items():
            for g in ids:
                c, r = d.geom_xpos[g], m.geom_rbound[g]
                gap = np.linalg.norm(np.maximum(np.maximum(lo - c, c - hi), 0.0), axis=1) - r
                for j in np.flatnonzero(gap < per_link[name]):
                    dist = mujoco.mj_geomDistance(m, d, int(g), int(boxes[j]), float(distmax), None)
                    if dist < per_link[name]:
                        per_link[name] = float(dist)
                        if dist < best[0]:
                            best = (float(dist), name, m.geom(int(boxes[j])).name, k)
    return {"min_leg_terrain_clearance_m": best[0], "min_leg_terrain_clearance_link": best[1],
            "min_leg_terrain_clearance_box": best[2], "min_leg_terrain_clearance_t_index": best[3],
            "leg_terrain_clearance_m": per_link}
