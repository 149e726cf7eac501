"""Cost of the self-collision constraint per tick, with and without temporal pruning, and the distances held.

Scenario (as ``tests/test_self_collision.py``): Talos stands (soles hard), a right-hand position target is driven
through the torso over 1.2 s at 500 Hz, the default :class:`~wbc.constraints.SelfCollisionConstraint`
(883 default pairs, min_distance 20 mm) keeps the arm away. Both variants run interleaved ``--repeats`` times in
this process; per variant: median / p99 of ``SelfCollisionConstraint.compute`` per tick (µs; wall and thread CPU), coal distance calls
per tick, the smallest watched distance reached (coal on the original meshes), and the largest difference of the
joint trajectory between the two variants (0 when pruning drops only pairs that could not have produced a row).

Usage: python benchmarks/self_collision.py [--robot talos] [--repeats 3]
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path
from time import perf_counter_ns, thread_time_ns

import numpy as np
import pinocchio as pin

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))


def run(robot, pruning: bool):
    from conftest import standing_controller
    from test_self_collision import DT, THROUGH, watched_model

    from wbc.configuration import Configuration
    from wbc.constraints import SelfCollisionConstraint
    from wbc.tasks import PositionTask

    config = Configuration(robot)
    hand = PositionTask(robot, robot.right_hand, gain=10.0, name="hand")
    sc = SelfCollisionConstraint(robot, min_distance=0.02, temporal_pruning=pruning)
    ctrl, _ = standing_controller(robot, config, sc, tasks=(hand,), posture_weight=1e-3)
    gm, gd = watched_model(robot)
    data = robot.model.createData()
    times, cpu, calls = [], [], [0]
    compute = sc.compute
    distance = pin.computeDistance

    def timed(config, dt):
        c0 = thread_time_ns()
        t0 = perf_counter_ns()
        out = compute(config, dt)
        times.append(perf_counter_ns() - t0)
        cpu.append(thread_time_ns() - c0)
        return out

    def counted(*a):
        calls[0] += 1
        return distance(*a)

    sc.compute = timed
    pin.computeDistance = counted
    try:
        p0 = config.frame_placement(hand.frame_id).translation.copy()
        frame, end = THROUGH[robot.name]
        T = config.frame_placement(robot.frame_id(frame))
        p_mid, p_end = T.act(np.zeros(3)), T.act(np.array(end))
        qs, d_min = [], np.inf
        n = int(1.2 / DT)
        for k in range(n):
            s = min(1.0, k * DT / 1.0)
            hand.set_target(p0 + (p_mid - p0) * min(1.0, 2 * s) + (p_end - p_mid) * max(0.0, 2 * s - 1))
            res = ctrl.solve(config, DT)
            assert res.ok, res.message
            config.update(config.integrate(res.v, DT))
            qs.append(config.q.copy())
            pin.computeDistances(robot.model, data, gm, gd, config.q)
            d_min = min(d_min, min(r.min_distance for r in gd.distanceResults))
    finally:
        pin.computeDistance = distance
    t = np.array(times) / 1e3
    return {"median_us": float(np.median(t)), "p99_us": float(np.percentile(t, 99)),
            "cpu_median_us": float(np.median(cpu)) / 1e3,
            "coal_calls_per_tick": calls[0] / n, "min_distance_mm": 1e3 * d_min, "q": np.array(qs)}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--robot", default="talos")
    p.add_argument("--repeats", type=int, default=3)
    a = p.parse_args()
    import wbc
    from wbc.bench.stats import limit_blas_threads

    limit_blas_threads(1)
    robot = wbc.load_robot(a.robot)
    print(f"self-collision, {a.robot}, hand through the torso, {a.repeats} interleaved repeats; "
          f"load {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    out: dict[bool, list[dict]] = {True: [], False: []}
    for _ in range(a.repeats):
        for pruning in (False, True):
            out[pruning].append(run(robot, pruning))
    for pruning, rs in out.items():
        print(f"  temporal_pruning={pruning!s:5s}: compute median {np.median([r['median_us'] for r in rs]):7.1f} µs, "
              f"p99 {np.median([r['p99_us'] for r in rs]):7.1f} µs, CPU median "
              f"{np.median([r['cpu_median_us'] for r in rs]):7.1f} µs, coal calls/tick {rs[0]['coal_calls_per_tick']:.1f}, "
              f"min watched distance {rs[0]['min_distance_mm']:.2f} mm")
    gap = max(float(np.abs(x["q"] - y["q"]).max()) for x in out[True] for y in out[False])
    print(f"  largest joint-trajectory difference pruned vs unpruned: {gap:.1e}; "
          f"load {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
