"""Time of one ``mujoco.mj_step`` for a catalog robot standing on its foot contacts under a joint PD at q_ref
(moved here from the test suite: timing is measured, never asserted in tests).

Usage: python benchmarks/mj_step_time.py [--robot talos] [--steps 500]
"""

from __future__ import annotations

import argparse
import time

import mujoco
import numpy as np

import wbc
from wbc.sim.mujoco_model import build_mujoco_model


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robot", default="talos")
    ap.add_argument("--steps", type=int, default=500)
    args = ap.parse_args()
    robot = wbc.load_robot(args.robot)
    sim = build_mujoco_model(robot)
    sim.set_state(robot.q_ref)
    q0 = robot.q_ref
    kp, kd = 200.0, 5.0
    times = []
    for k in range(50 + args.steps):
        q, v = sim.get_state()
        sim.set_torques(kp * (q0[7:] - q[7:]) - kd * v[6:])
        t0 = time.perf_counter()
        mujoco.mj_step(sim.model, sim.data)
        if k >= 50:
            times.append(time.perf_counter() - t0)
    us = 1e6 * np.asarray(times)
    print(f"{args.robot} mj_step: median {np.median(us):.1f} us, p99 {np.percentile(us, 99):.1f} us "
          f"({sim.data.ncon} contacts, {args.steps} steps)")


if __name__ == "__main__":
    main()
