"""Share of the kinematic walk tick spent setting the references (``WalkController.set_references``) vs the whole
tick (references + QP + integration), median over a 4-step walk.

    python benchmarks/walk_references.py [ROBOT]
"""

import time, numpy as np, sys
from wbc.robot import load_robot
from wbc.configuration import Configuration
from wbc.scenarios.walk import plan_default_walk, WalkController
robot = load_robot(sys.argv[1] if len(sys.argv) > 1 else "talos")
config = Configuration(robot)
plan = plan_default_walk(robot, n_steps=4)
w = WalkController(robot, config)
n = len(plan.t)
tset = np.empty(n); ttick = np.empty(n)
for k in range(n):
    t0 = time.perf_counter()
    w.set_references(plan, k, config)
    t1 = time.perf_counter()
    r = w.controller.solve(config, plan.dt)
    config.step(r.v, plan.dt)
    t2 = time.perf_counter()
    tset[k] = t1 - t0; ttick[k] = t2 - t0
print(f"set_references median {np.median(tset)*1e6:.1f} us, tick median {np.median(ttick)*1e6:.1f} us, share {np.median(tset)/np.median(ttick):.0%}")
