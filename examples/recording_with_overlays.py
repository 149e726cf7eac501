"""A meshcat recording with overlays: a short walk written as one self-contained HTML page (plays offline),
with the CoM, the planned ZMP and DCM as points, the support polygon of each phase, the footsteps and the
swing-sole paths.

Run: python examples/recording_with_overlays.py [--out walk.html] [--quick]
"""

import argparse
import tempfile
from pathlib import Path

import numpy as np

import wbc
from wbc.gait import convex_hull, pose_to_xy_yaw, sole_polygon
from wbc.scenarios.walk import plan_default_walk, run_walk
from wbc.viz import record_html

parser = argparse.ArgumentParser(description=" ".join(__doc__.split("\n\n")[0].split()))  # the first paragraph
parser.add_argument("--robot", default="talos", help="catalog robot (default talos)")
parser.add_argument("--out", type=Path, default=Path(tempfile.gettempdir()) / "wbc_walk_overlays.html")
parser.add_argument("--quick", action="store_true", help="humanoid15, 2 steps (CI)")
args = parser.parse_args()

robot = wbc.load_robot("humanoid15" if args.quick else args.robot)
plan = plan_default_walk(robot, n_steps=2 if args.quick else 6)
run = run_walk(robot, plan)

ground = np.zeros((len(run.t), 1))                       # ZMP and DCM drawn on the ground
overlays = {"com": run.com, "zmp": np.hstack([plan.zmp, ground]), "dcm": np.hstack([plan.dcm, ground])}
L, W = robot.sole_length, robot.sole_width


def sole(pose):                                          # (4, 2) corners of a sole at a (4, 4) world pose
    return sole_polygon(*pose_to_xy_yaw(pose), L, W)


polygons = []                                            # (t_start, t_end, (K, 3) outline) per support phase
for ph in plan.phases:
    k = ph.first
    feet = {0: [run.left_sole[k], run.right_sole[k]], 1: [run.left_sole[k]], 2: [run.right_sole[k]]}[ph.support]
    hull = convex_hull(np.vstack([sole(f) for f in feet]))
    polygons.append((plan.t[k], plan.t[k] + ph.count * plan.dt, np.c_[hull, np.zeros(len(hull))]))
footsteps = [np.c_[sole_polygon(f.x, f.y, f.yaw, L, W), np.zeros(4)] for f in plan.footsteps]
paths = {"left sole": [run.left_sole[:, :3, 3]], "right sole": [run.right_sole[:, :3, 3]]}

path = record_html(robot, run.t, run.q, args.out, overlays=overlays, polygons=polygons,
                   outlines={"footsteps": footsteps}, paths=paths)
size = path.stat().st_size
print(f"{robot.name}: {len(run.t)} ticks recorded to {path} ({size / 1e6:.2f} MB); open it in a browser")
raise SystemExit(0 if size > 10_000 else 1)
