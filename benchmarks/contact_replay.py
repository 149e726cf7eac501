"""Replay a logged MuJoCo walk at given times and list its ground contacts against the terrain's true surface.

A fall by "foot strike" on a heightfield is either a real sole edge pressing on the ground (the sole tilted against
the terrain under it) or a MuJoCo artefact (a heightfield is collided as triangular prisms, whose side walls give
contacts a horizontal normal; ``benchmarks/hfield_contacts.py``). This script tells them apart from a run's log
(``wbc sim walk ... --log FILE``): at each time it sets the plant to the logged ground-truth ``q, v``
(``mj_forward``) and prints, for each robot-ground contact, the body, the contact point, the gap between its height
and the terrain's (:meth:`wbc.terrain.Terrain.height`), MuJoCo's contact normal, its angle to the terrain facet's
normal under the point (:meth:`wbc.terrain.Terrain.normal`), the normal force (``mj_contactForce``), and the tilt of
both soles from the world vertical (Pinocchio, the logged ``q``).

    python benchmarks/contact_replay.py LOG.npz --terrain rough:0.02:10 --times 6.972,7.504 [--robot talos]
    python benchmarks/contact_replay.py LOG.npz --terrain rough:0.02:10 --summary [--until T]

``--summary`` replays every logged tick (up to ``--until`` s, e.g. the fall time) and counts the foot-ground contacts
over 20 N whose MuJoCo normal is more than 30° from the facet normal (the artefact of
``benchmarks/hfield_contacts.py``), with their share of the summed normal force.
"""

from __future__ import annotations

import argparse
import math

import mujoco
import numpy as np
import pinocchio as pin

from wbc.robot import load_robot
from wbc.sim.mujoco_model import build_mujoco_model
from wbc.terrain import parse_terrain


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("log", help="npz written by wbc sim walk --log")
    p.add_argument("--terrain", required=True, help="the run's --terrain")
    p.add_argument("--times", default="", help="comma-separated times (s)")
    p.add_argument("--summary", action="store_true", help="count off-facet contacts over the whole log")
    p.add_argument("--until", type=float, default=None, help="--summary: last time (s)")
    p.add_argument("--robot", default="talos")
    args = p.parse_args()
    log = np.load(args.log, allow_pickle=True)
    terrain = parse_terrain(args.terrain)
    robot = load_robot(args.robot)
    sim = build_mujoco_model(robot, terrain=terrain)
    model, data = sim.model, sim.data
    pdata = robot.model.createData()
    soles = {s: robot.frame_id(getattr(robot, f"{s}_sole")) for s in ("left", "right")}
    dt = float(log["dt"])
    f6 = np.zeros(6)
    if args.summary:
        n_end = len(log["t"]) if args.until is None else min(len(log["t"]), int(round(args.until / dt)) + 1)
        count = off = 0
        force = force_off = 0.0
        worst = 0.0
        for k in range(n_end):
            sim.set_state(log["q"][k], log["v"][k])
            mujoco.mj_forward(model, data)
            for i in range(data.ncon):
                c = data.contact[i]
                names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, int(model.geom_bodyid[g]))
                         for g in (c.geom1, c.geom2)]
                if "world" not in names:
                    continue
                mujoco.mj_contactForce(model, data, i, f6)
                if f6[0] <= 20.0:
                    continue
                n = np.array(c.frame[:3])
                angle = math.degrees(math.acos(min(1.0, abs(float(n @ terrain.normal(float(c.pos[0]),
                                                                                      float(c.pos[1])))))))
                count += 1
                force += f6[0]
                if angle > 30.0:
                    off += 1
                    force_off += f6[0]
                    worst = max(worst, angle)
        print(f"{n_end} ticks: {count} ground contacts > 20 N, {off} ({100.0 * off / max(count, 1):.2f} %) more than "
              f"30 deg from the facet normal (worst {worst:.0f} deg), {100.0 * force_off / max(force, 1e-9):.2f} % of "
              "the summed normal force")
    for t in (float(x) for x in args.times.split(",") if x):
        k = min(int(round(t / dt)), len(log["t"]) - 1)
        q, v = log["q"][k], log["v"][k]
        sim.set_state(q, v)
        mujoco.mj_forward(model, data)
        pin.framesForwardKinematics(robot.model, pdata, q)
        tilt = {s: math.degrees(math.acos(min(1.0, float(pdata.oMf[f].rotation[2, 2])))) for s, f in soles.items()}
        print(f"t = {log['t'][k]:.3f} s: sole tilt left {tilt['left']:.1f} deg, right {tilt['right']:.1f} deg")
        for i in range(data.ncon):
            c = data.contact[i]
            bodies = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, int(model.geom_bodyid[g]))
                      for g in (c.geom1, c.geom2)]
            mujoco.mj_contactForce(model, data, i, f6)
            n = np.array(c.frame[:3])
            x, y, z = (float(a) for a in c.pos)
            facet = terrain.normal(x, y)
            angle = math.degrees(math.acos(min(1.0, abs(float(n @ facet)))))
            gap = z - terrain.height(x, y)
            print(f"  {bodies[0]}-{bodies[1]} at ({x:.3f}, {y:.3f}, {z:.4f}) m, {1e3 * gap:+.2f} mm from the surface, "
                  f"normal ({n[0]:.2f}, {n[1]:.2f}, {n[2]:.2f}), {angle:.1f} deg from the facet's, {f6[0]:.1f} N")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
