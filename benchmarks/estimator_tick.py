"""Cost of one estimated-state tick: ``PlantSensors.read`` (noise, bias, quantisation) and
``FloatingBaseEstimator.update`` (attitude filter, Pinocchio kinematics with velocities, F/T compensation, contact
detection, Kalman filter), on a robot standing at its reference configuration in MuJoCo, settled 0.3 s under the joint-PD
baseline (both feet in contact: the full update). Prints median and p99 in µs; not part of ``run_all.py``.

    python benchmarks/estimator_tick.py [--robot talos] [--ticks 5000]
"""

from __future__ import annotations

import argparse
from time import perf_counter_ns

import mujoco
import numpy as np

from wbc.robot import load_robot
from wbc.sim.estimated_state import EstimatedState
from wbc.sim.mujoco_model import build_mujoco_model


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robot", default="talos")
    ap.add_argument("--ticks", type=int, default=5000)
    args = ap.parse_args()
    robot = load_robot(args.robot)
    sim = build_mujoco_model(robot)
    from wbc.sim.scenarios import make_controller

    pd = make_controller(robot, "pd", dt=sim.timestep)  # settle 0.3 s on both feet (loaded contacts)
    q, v = sim.get_state()
    pd.reset(q, v)
    for _ in range(150):
        sim.set_torques(pd.solve(*sim.get_state()))
        mujoco.mj_step(sim.model, sim.data)
    mujoco.mj_forward(sim.model, sim.data)
    state = EstimatedState(sim, seed=0)
    q, v = sim.get_state()
    state.reset(q, v)
    sens, est = np.empty(args.ticks), np.empty(args.ticks)
    for k in range(args.ticks):
        t0 = perf_counter_ns()
        r = state.sensors.read(k * sim.timestep)
        t1 = perf_counter_ns()
        state.estimator.update(r.joint_q, r.gyro, r.accel, r.ft)
        t2 = perf_counter_ns()
        sens[k], est[k] = (t1 - t0) / 1e3, (t2 - t1) / 1e3
    contacts = state.estimator.contact
    print(f"{args.robot}: {args.ticks} ticks, contacts {contacts}")
    for name, x in (("sensors.read", sens), ("estimator.update", est), ("total", sens + est)):
        print(f"  {name:18s} median {np.median(x):7.1f} µs   p99 {np.percentile(x, 99):7.1f} µs")


if __name__ == "__main__":
    main()
