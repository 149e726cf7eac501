"""Cost of the self-collision constraint per tick (issue 10 target: ≤ 200 µs on Talos), broad phase vs exhaustive.

Scenario (as ``tests/constraints/test_self_collision.py``): Talos stands (soles hard), a right-hand position target is driven
through the torso over 1.2 s at 500 Hz, the default :class:`~wbc.constraints.SelfCollisionConstraint`
(883 default pairs, min_distance 20 mm) keeps the arm away. Variants, run interleaved ``--repeats`` times in this
process:

* ``broad``: the default constraint (broad phase: coal only on the pairs whose distance bounds may give them a row;
  the compiled narrow phase ``wbc.constraints.narrow_phase`` when it is built — printed);
* ``broad-pinocchio``: the same with ``compiled=False`` (coal through Pinocchio's ``computeDistances`` and bindings);
* ``exhaustive``: ``broad_phase=False`` (coal on all 883 pairs at every tick: the reference);
* ``none``: the same controller without the constraint (the arm then runs into the torso).

Printed per variant: ``SelfCollisionConstraint.compute`` per tick (median / p99 µs, wall and thread CPU), coal
distances per tick (``SelfCollisionConstraint.coal_calls``; the test counts them independently), the smallest
distance held (coal on the original meshes of the arm–torso pairs, and the smallest active distance of the
constraint's hulls), the whole controller tick (median thread CPU µs: wall time on a loaded machine includes
waiting) and its excess over ``none``, and how the tick's QPs were answered (compiled kernel / DAQP fallback,
:class:`wbc.solvers.fast.FastBackend`); then whether the broad phase gave the same active pairs at every tick and the
same joint trajectory as the exhaustive variant.

Verdict of the issue-10 target (≤ 200 µs per tick), read as what a user pays for turning self-collision avoidance
on: PASS only when BOTH the median ``compute`` (wall) AND the median tick's increase over ``none`` (thread CPU)
are ≤ 200 µs, the active pairs are the exhaustive variant's at every tick and the arm stays ≥ min_distance
(20 mm) from the torso on the original meshes; exit status 1 otherwise. The machine load (``os.getloadavg``) is
printed before and after: wall-clock numbers on a loaded machine are inflated; the instruction counts
(``--callgrind``, valgrind) are not.

Usage: python benchmarks/self_collision.py [--robot talos] [--repeats 3] [--callgrind N]
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path
from time import perf_counter_ns, thread_time_ns

import numpy as np
import pinocchio as pin

for _sub in ("tests", "tests/constraints"):  # conftest, and the scenario of tests/constraints/test_self_collision.py
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / _sub))

TARGET_US = 200.0  # issue 10: self-collision on Talos ≤ 200 µs per tick
MIN_DISTANCE = 0.02  # m, the constraint's min_distance in this scenario


def load() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def run(robot, variant: str) -> dict:
    from conftest import standing_controller
    from test_self_collision import DT, THROUGH, watched_model

    from wbc.configuration import Configuration
    from wbc.constraints import SelfCollisionConstraint
    from wbc.tasks import PositionTask

    config = Configuration(robot)
    hand = PositionTask(robot, robot.right_hand, gain=10.0, name="hand")
    sc = None if variant == "none" else SelfCollisionConstraint(
        robot, min_distance=MIN_DISTANCE, broad_phase=variant.startswith("broad"),
        compiled=False if variant == "broad-pinocchio" else None)
    ctrl, _ = standing_controller(robot, config, *([sc] if sc else []), tasks=(hand,), posture_weight=1e-3)
    gm, gd = watched_model(robot)
    data = robot.model.createData()
    times, cpu, tick, active, calls = [], [], [], [], 0
    distances = pin.computeDistances

    if sc is not None:
        compute = sc.compute

        def timed(config, dt):  # summed over the tick's calls (the general path may call it again: cached)
            c0 = thread_time_ns()
            t0 = perf_counter_ns()
            out = compute(config, dt)
            times[-1] += perf_counter_ns() - t0
            cpu[-1] += thread_time_ns() - c0
            return out

        sc.compute = timed
    p0 = config.frame_placement(hand.frame_id).translation.copy()
    frame, end = THROUGH[robot.name]
    T = config.frame_placement(robot.frame_id(frame))
    p_mid, p_end = T.act(np.zeros(3)), T.act(np.array(end))
    qs, d_min, d_hull = [], np.inf, np.inf
    n = int(1.2 / DT)
    for k in range(n):
        s = min(1.0, k * DT / 1.0)
        hand.set_target(p0 + (p_mid - p0) * min(1.0, 2 * s) + (p_end - p_mid) * max(0.0, 2 * s - 1))
        times.append(0)
        cpu.append(0)
        c0 = thread_time_ns()
        res = ctrl.solve(config, DT)
        tick.append(thread_time_ns() - c0)
        assert res.ok, res.message
        if sc is not None:
            active.append([a[:2] for a in sc.active])
            calls += sc.coal_calls
            d_hull = min(d_hull, min((a[2] for a in sc.active), default=np.inf))
        config.update(config.integrate(res.v, DT))
        qs.append(config.q.copy())
    for q in qs:  # after the run: the mesh distances would evict the constraint's data from the caches
        distances(robot.model, data, gm, gd, q)
        d_min = min(d_min, min(r.min_distance for r in gd.distanceResults))
    t = np.array(times) / 1e3
    return {"median_us": float(np.median(t)), "p99_us": float(np.percentile(t, 99)),
            "cpu_median_us": float(np.median(cpu)) / 1e3, "tick_median_us": float(np.median(tick)) / 1e3,
            "coal_per_tick": calls / n, "min_mesh_mm": 1e3 * d_min, "min_hull_mm": 1e3 * d_hull,
            "kernel_solves": getattr(ctrl.backend, "kernel_solves", 0), "fallbacks": getattr(ctrl.backend, "fallbacks", 0),
            "q": np.array(qs), "active": active, "narrow_phase": sc.narrow_phase if sc else None}


# -- instruction counts (callgrind): compute() over 2N ticks of the recorded trajectory (after 5 uninstrumented),
#    minus the same ticks without compute (Configuration.update only) ------------------------------------------------------------
def _callgrind_child(variant: str, n: int, traj: str) -> None:
    import wbc
    from wbc.configuration import Configuration
    from wbc.constraints import SelfCollisionConstraint

    robot = wbc.load_robot("talos")
    qs = np.load(traj)
    config = Configuration(robot)
    sc = SelfCollisionConstraint(robot, min_distance=0.02, broad_phase=variant == "broad")
    k = 0
    for marker, ticks in (("READY", 5), ("HALF", n), ("DONE", n)):
        for _ in range(ticks):
            config.update(qs[k % len(qs)])
            if variant != "update":
                sc.compute(config, 0.002)
            k += 1
        print(marker, flush=True)
        sys.stdin.readline()


def _callgrind(variant: str, n: int, traj: str) -> list[int]:
    with tempfile.TemporaryDirectory() as d:
        p = subprocess.Popen(["valgrind", "--tool=callgrind", "--instr-atstart=no", f"--callgrind-out-file={d}/cg.out",
                              sys.executable, __file__, "--child", variant, str(n), traj],
                             stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        irs = []
        try:
            for marker in ("READY", "HALF", "DONE"):
                line = p.stdout.readline().strip()
                if line != marker:
                    raise RuntimeError(f"callgrind child: expected {marker}, got {line!r}: {p.stderr.read()[-2000:]}")
                ctl = ["callgrind_control"]
                if marker == "READY":
                    subprocess.run([*ctl, "-i", "on", str(p.pid)], capture_output=True, check=True)
                    subprocess.run([*ctl, "-z", str(p.pid)], capture_output=True, check=True)
                else:
                    out = subprocess.run([*ctl, "-e", "Ir", str(p.pid)], capture_output=True, text=True).stdout
                    irs.append(int(re.search(r"Th 1\s+([\d,]+)", out).group(1).replace(",", "")))
                p.stdin.write("go\n")
                p.stdin.flush()
            p.wait(timeout=600)
        finally:
            if p.poll() is None:
                p.kill()
        return irs


def instructions(robot, n: int) -> dict[str, float]:
    """Instructions per compute() (broad, exhaustive) over ticks 5..5 + 2n of the recorded broad-phase trajectory
    (n = 297: all of it), minus the same ticks without compute()."""
    q = run(robot, "broad")["q"]
    with tempfile.TemporaryDirectory() as d:
        traj = f"{d}/traj.npy"
        np.save(traj, q)
        irs = {v: _callgrind(v, n, traj) for v in ("update", "broad", "exhaustive")}
    return {v: (irs[v][1] - irs["update"][1]) / (2 * n) for v in ("broad", "exhaustive")}


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        _callgrind_child(sys.argv[2], int(sys.argv[3]), sys.argv[4])
        return
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--robot", default="talos")
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--callgrind", type=int, default=0, metavar="N",
                   help="also count instructions per compute() with valgrind over N ticks (0: no)")
    p.add_argument("--json", default=None, help="write the numbers to this file")
    a = p.parse_args()
    import wbc
    from wbc.bench.stats import limit_blas_threads

    limit_blas_threads(1)
    robot = wbc.load_robot(a.robot)
    print(f"self-collision, {a.robot}, hand through the torso, {a.repeats} interleaved repeats; load {load()}")
    # broad: the default constraint (broad phase, compiled narrow phase when built); broad-pinocchio: the same with
    # Pinocchio's narrow phase (bindings); exhaustive: coal on every pair (the reference)
    variants = ("broad", "broad-pinocchio", "exhaustive", "none")
    out: dict[str, list[dict]] = {v: [] for v in variants}
    for _ in range(a.repeats):
        for v in variants:
            out[v].append(run(robot, v))
    med = {v: {key: float(np.median([r[key] for r in rs])) for key in rs[0] if key not in ("q", "active", "narrow_phase")}
           for v, rs in out.items()}
    for v in variants:
        m = med[v]
        sc = "" if v == "none" else (
            f"compute median {m['median_us']:7.1f} µs (CPU {m['cpu_median_us']:7.1f}), p99 {m['p99_us']:7.1f} µs, "
            f"coal {m['coal_per_tick']:6.1f}/tick, min hull distance {m['min_hull_mm']:.2f} mm, ")
        narrow = "" if v == "none" else f" [{out[v][0]['narrow_phase']} narrow phase]"
        print(f"  {v + narrow:46s}: {sc}tick CPU {m['tick_median_us']:7.1f} µs (+{m['tick_median_us'] - med['none']['tick_median_us']:6.1f} "
              f"over none), QPs kernel/DAQP {m['kernel_solves']:.0f}/{m['fallbacks']:.0f}, "
              f"min arm–torso mesh distance {m['min_mesh_mm']:.2f} mm")
    same_active = all(x["active"] == y["active"] for x in out["broad"] for y in out["exhaustive"])
    gap = max(float(np.abs(x["q"] - y["q"]).max()) for x in out["broad"] for y in out["exhaustive"])
    print(f"  broad vs exhaustive: same active pairs at every tick: {same_active}; largest joint-trajectory "
          f"difference {gap:.1e}; load {load()}")
    gap_narrow = max(float(np.abs(x["q"] - y["q"]).max()) for x in out["broad"] for y in out["broad-pinocchio"])
    print(f"  {out['broad'][0]['narrow_phase']} vs pinocchio narrow phase: largest joint-trajectory difference "
          f"{gap_narrow:.1e}; tick increment {med['broad']['tick_median_us'] - med['none']['tick_median_us']:.1f} vs "
          f"{med['broad-pinocchio']['tick_median_us'] - med['none']['tick_median_us']:.1f} µs")
    compute_us = med["broad"]["median_us"]
    increment_us = med["broad"]["tick_median_us"] - med["none"]["tick_median_us"]
    held = med["broad"]["min_mesh_mm"] >= 1e3 * MIN_DISTANCE
    verdict = {"compute()": compute_us <= TARGET_US, "tick increment": increment_us <= TARGET_US,
               "same active pairs": same_active, "min distance held": held}
    ok = all(verdict.values())
    print(f"  target (issue 10): self-collision ≤ {TARGET_US:.0f} µs per tick (load {load()}):\n"
          f"    compute() median {compute_us:.1f} µs (wall) -> {'PASS' if verdict['compute()'] else 'FAIL'}\n"
          f"    tick increment over none {increment_us:.1f} µs (thread CPU medians) -> "
          f"{'PASS' if verdict['tick increment'] else 'FAIL'}\n"
          f"    same active pairs as exhaustive: {same_active}; min arm–torso mesh distance "
          f"{med['broad']['min_mesh_mm']:.2f} mm ≥ {1e3 * MIN_DISTANCE:.0f} mm: {held}\n"
          f"  -> {'PASS' if ok else 'FAIL: ' + ', '.join(k for k, v in verdict.items() if not v)}")
    result = {"load": os.getloadavg(), "median": med, "same_active": same_active, "trajectory_gap": gap,
              "narrow_phase": out["broad"][0]["narrow_phase"], "trajectory_gap_narrow_phases": gap_narrow,
              "compute_us": compute_us, "increment_us": increment_us, "verdict": verdict, "pass": ok}
    if a.callgrind:
        ir = instructions(robot, a.callgrind)
        print(f"  instructions per compute() (callgrind, {2 * a.callgrind} ticks): broad {ir['broad']:,.0f}, "
              f"exhaustive {ir['exhaustive']:,.0f}")
        result["instructions"] = ir
    if a.json:
        Path(a.json).write_text(json.dumps(result, indent=1))
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
