"""Per-tick latency of the main job: Talos walks 8 × 0.15 m under the 500 Hz kinematic QP.

Runs the whole walk ``--repeats`` times in this process and reports, per repeat and as the median over repeats,
the median / p99 / max wall time of one control tick (targets + QP + integration), with the 2 ms budget of a
500 Hz controller as reference. Machines are shared and noisy: compare medians over repeats.

Usage: python benchmarks/walk_latency.py [--robot talos] [--repeats 5] [--solver daqp] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time

import numpy as np

import wbc
from wbc.solvers import DEFAULT_SOLVER
from wbc.scenarios.walk import plan_default_walk, run_walk, walk_summary

BUDGET_US = 2000.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", default="talos")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--solver", default=DEFAULT_SOLVER)
    parser.add_argument("--json", default=None)
    args = parser.parse_args()

    robot = wbc.load_robot(args.robot)
    plan = plan_default_walk(robot)
    rows = []
    for i in range(args.repeats):
        run = run_walk(robot, plan, solver=args.solver)
        s = walk_summary(robot, plan, run)
        tt = s["tick_time_us"]
        rows.append(tt)
        print(f"repeat {i + 1}: {s['ticks']} ticks  median {tt['median']:7.1f} µs  p99 {tt['p99']:7.1f} µs  "
              f"max {tt['max']:7.1f} µs  (failures {s['solver_failures']}, CoM error {s['max_com_error_m']:.2e} m)")
    med = {k: float(np.median([r[k] for r in rows])) for k in ("median", "p99", "max")}
    print(f"median over {args.repeats} repeats: tick median {med['median']:.1f} µs, p99 {med['p99']:.1f} µs, "
          f"max {med['max']:.1f} µs; p99 is {med['p99'] / BUDGET_US:.1%} of the 2 ms budget "
          f"({'within' if med['p99'] < BUDGET_US else 'OVER'} budget)")
    if args.json:
        info = {"date": time.strftime("%Y-%m-%d"), "machine": platform.processor() or platform.machine(),
                "cpus": os.cpu_count(), "load_avg": os.getloadavg(), "robot": args.robot, "solver": args.solver}
        with open(args.json, "w") as f:
            json.dump({"info": info, "repeats": rows, "median_over_repeats": med}, f, indent=2)


if __name__ == "__main__":
    main()
