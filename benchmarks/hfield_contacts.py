"""How far MuJoCo's heightfield contact normals are from the terrain's facet normals (issue 24, blind rough terrain).

A 50 kg box of Talos's sole size (0.21 × 0.11 × 0.005 m, as ``foot_contact="box"``) is dropped at 0.3 m/s (and
slid at ``--vx``) onto ``rough:0.02:SEED`` at ``--drops`` random places in x ∈ [1, 10], |y| ≤ 0.5, 0.3 s each at a
2 ms step (elliptic cones, impratio 10: the plant's settings). Every contact carrying more than 20 N is compared
with :meth:`wbc.terrain.Terrain.normal` at its point (the facet under it). Variants: the model as built by
:func:`wbc.sim.mujoco_model.add_terrain`; a stiffer terrain contact (``solref`` 0.004 s); MuJoCo's native CCD or
its multi-contact CCD disabled; a grid of 5 × 3 spheres of 1 cm radius instead of the box; the heightfield replaced
by one convex mesh per facet, grown 5 mm past its edges into its neighbours (``add_slabs``).

    nice -n 10 python benchmarks/hfield_contacts.py [--seed 9] [--drops 60] [--vx 0.3]
"""

from __future__ import annotations

import argparse
import math

import mujoco
import numpy as np

from wbc.sim.mujoco_model import ENV_BIT, ROBOT_BIT, add_terrain
from wbc.terrain import parse_terrain

L, W = 0.21, 0.11  # m, Talos's sole


def add_slabs(spec, terr, region, grow=0.005, depth=0.03):
    """Each heightfield triangle in ``region`` (x0, x1, y0, y1) as a convex mesh: the triangle grown in its plane
    (scaled about its centroid so that its inradius grows by ``grow``), extruded ``depth`` down. Neighbouring slabs
    overlap by ``grow`` past their shared edge, so a sole crossing an edge is deep inside the slab it leaves
    horizontally, not a sliver from its side wall; the price is a lip of at most ``grow · tan(Δ slope)`` where a
    grown slab overhangs a lower neighbour (a ridge)."""
    hf = terr.heightfield
    h, d, (ox, oy) = hf.heights, hf.spacing, hf.origin
    x0, x1, y0, y1 = region
    j0, j1 = max(int((x0 - ox) / d), 0), min(int((x1 - ox) / d) + 1, h.shape[1] - 1)
    i0, i1 = max(int((y0 - oy) / d), 0), min(int((y1 - oy) / d) + 1, h.shape[0] - 1)
    k = 0
    for i in range(i0, i1):
        for j in range(j0, j1):
            P = lambda a, b: np.array([ox + (j + b) * d, oy + (i + a) * d, h[i + a, j + b]])  # noqa: E731
            for tri in ((P(0, 0), P(0, 1), P(1, 1)), (P(0, 0), P(1, 1), P(1, 0))):
                t = np.array(tri)
                c = t.mean(axis=0)
                e = [np.linalg.norm(t[(q + 1) % 3] - t[(q + 2) % 3]) for q in range(3)]
                area = 0.5 * np.linalg.norm(np.cross(t[1] - t[0], t[2] - t[0]))
                r = 2 * area / sum(e)
                top = c + (t - c) * (r + grow) / r
                verts = np.vstack([top, top - [0, 0, depth]])
                name = f"slab_{k}"
                spec.add_mesh(name=name, uservert=verts.ravel().tolist())
                spec.worldbody.add_geom(name=name + "_g", type=mujoco.mjtGeom.mjGEOM_MESH, meshname=name,
                                        contype=ENV_BIT, conaffinity=ENV_BIT | ROBOT_BIT, priority=1,
                                        friction=[1.0, 0.005, 0.0001])
                k += 1
    return k


def run(terr, label, drops, vx, solref=None, flags=0, spheres=False, slabs=False):
    spec = mujoco.MjSpec()
    spec.option.timestep = 0.002
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    spec.option.impratio = 10
    spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.05], contype=ENV_BIT,
                            conaffinity=ENV_BIT | ROBOT_BIT)
    if slabs:
        spec.geom("floor").pos = [0, 0, -0.2]
        add_slabs(spec, terr, (0.7, 10.3, -0.8, 0.8))
    else:
        add_terrain(spec, terr)
    if solref:
        spec.geom("terrain_hfield").solref = solref
    b = spec.worldbody.add_body(name="foot")
    b.add_freejoint()
    if spheres:
        r = 0.01
        for x in np.linspace(-L / 2 + r, L / 2 - r, 5):
            for y in np.linspace(-W / 2 + r, W / 2 - r, 3):
                b.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[r, 0, 0], pos=[x, y, r], contype=ROBOT_BIT,
                           conaffinity=ENV_BIT, mass=50 / 15)
    else:
        b.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[L / 2, W / 2, 0.0025], pos=[0, 0, 0.0025],
                   contype=ROBOT_BIT, conaffinity=ENV_BIT, mass=50)
    m = spec.compile()
    m.opt.disableflags |= flags
    d = mujoco.MjData(m)
    rng = np.random.default_rng(0)
    f6 = np.zeros(6)
    angles, tang = [], []
    u, w = np.meshgrid(np.linspace(-L / 2, L / 2, 21), np.linspace(-W / 2, W / 2, 11))
    for _ in range(drops):
        mujoco.mj_resetData(m, d)
        x, y = rng.uniform(1, 10), rng.uniform(-0.5, 0.5)
        d.qpos[:3] = [x, y, terr.height(x + u, y + w).max() + 0.005]
        d.qpos[3:7] = [1, 0, 0, 0]
        d.qvel[0], d.qvel[2] = vx, -0.3
        for _ in range(150):
            mujoco.mj_step(m, d)
            for i in range(d.ncon):
                c = d.contact[i]
                mujoco.mj_contactForce(m, d, i, f6)
                if f6[0] < 20:
                    continue
                n = terr.normal(float(c.pos[0]), float(c.pos[1]))
                angles.append(math.degrees(math.acos(min(1.0, abs(float(c.frame[:3] @ n))))))
                tang.append(f6[0] * math.sqrt(max(0.0, 1 - float(c.frame[:3] @ n) ** 2)))
    a = np.array(angles)
    big = a > 30
    print(f"{label:34s} {len(a):>6} {100 * big.mean():>6.1f} {a.max():>6.0f} "
          f"{(np.array(tang)[big].max() if big.any() else 0):>8.0f}")


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seed", type=int, default=9)
    p.add_argument("--drops", type=int, default=60)
    p.add_argument("--vx", type=float, default=0.3)
    a = p.parse_args()
    terr = parse_terrain(f"rough:0.02:{a.seed}")
    print(f"rough:0.02:{a.seed}, {a.drops} drops, vx {a.vx} m/s; contacts > 20 N")
    print(f"{'variant':34s} {'n':>6} {'%>30°':>6} {'worst°':>6} {'max N off':>8}")
    run(terr, "add_terrain (as built)", a.drops, a.vx)
    run(terr, "terrain solref 0.004 s", a.drops, a.vx, solref=[0.004, 1.0])
    run(terr, "native CCD off", a.drops, a.vx, flags=int(mujoco.mjtDisableBit.mjDSBL_NATIVECCD))
    run(terr, "multi-CCD off", a.drops, a.vx, flags=int(mujoco.mjtDisableBit.mjDSBL_MULTICCD))
    run(terr, "5 x 3 spheres r 1 cm", a.drops, a.vx, spheres=True)
    run(terr, "facet slabs (grown 5 mm), no hfield", a.drops, a.vx, slabs=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
