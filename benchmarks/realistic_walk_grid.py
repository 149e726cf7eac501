"""Walks on the defaults of ``wbc sim`` (estimated state, realistic plant) plus a 2-tick control delay and ±10 %
link masses, one seeded run after another (one process at a time): Talos 20 × 0.24 m at 0.6 s/step, G1 20 steps at
0.3 m/s, humanoid15 10 steps. Prints one row per run — completed, fall (reason, time), the largest pelvis/torso tilt
from the start orientation, joint-speed exceedances and the worst ratio, landing slide, stance slip — and the
estimator's errors (base drift % of the distance walked, orientation error, base velocity RMS), all read from the
run's JSON summary.

Usage: python benchmarks/realistic_walk_grid.py [--robots talos g1 humanoid15] [--seeds 0 1 ...] [--extra ARGS]
       [--keep DIR]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile

WALKS = {
    "talos": ["--steps", "20", "--step-length", "0.24", "--step-duration", "0.6"],
    "g1": ["--steps", "20", "--vx", "0.3"],
    "humanoid15": ["--steps", "10"],
}
PERTURBATION = ["--delay", "2", "--mass-error", "10"]


def run(robot: str, seed: int, extra: list[str], keep: str | None = None) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(keep or tmp, f"{robot}_seed{seed}.json")
        cmd = [sys.executable, "-m", "wbc", "sim", "walk", "--robot", robot, *WALKS[robot], *PERTURBATION,
               "--seed", str(seed), *extra, "--json", out, "--quiet"]
        subprocess.run(cmd, check=False, stdout=subprocess.DEVNULL)  # exit 1: the run did not pass (still summarised)
        with open(out) as f:
            return json.load(f)


def row(robot: str, seed: int, s: dict) -> str:
    e = s.get("estimation_error", {})
    fall = f"{s.get('fall_reason')} at {s.get('fall_time_s')} s" if s.get("fell") else "no"
    tilt = max((s.get("max_tilt_deg") or {}).values(), default=float("nan"))
    return (f"| {robot} | {seed} | {s.get('completed')} | {fall} | {tilt:.1f} | {s.get('joint_speed_exceedances')} | "
            f"{s.get('max_joint_speed_ratio', 0):.3f} {s.get('max_joint_speed_joint')} | "
            f"{1e3 * s.get('max_landing_slide_m', float('nan')):.1f} | {1e3 * s.get('max_stance_slip_m', float('nan')):.1f} | "
            f"{s.get('solver_failures')} | {e.get('base_position_drift_percent', float('nan')):.2f} | "
            f"{e.get('max_orientation_error_deg', float('nan')):.2f} | {e.get('base_velocity_rms_error_mps', float('nan')):.4f} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robots", nargs="+", default=list(WALKS), choices=list(WALKS))
    ap.add_argument("--seeds", type=int, nargs="+", default=list(range(10)))
    ap.add_argument("--extra", default="", help="more `wbc sim walk` options, one string")
    ap.add_argument("--keep", default=None, metavar="DIR",
                    help="keep each run's JSON summary as DIR/<robot>_seed<S>.json (default: discarded)")
    args = ap.parse_args()
    if args.keep:
        os.makedirs(args.keep, exist_ok=True)
    print("| robot | seed | completed | fell | max tilt ° | speed exceedances | worst ratio | landing slide mm | "
          "stance slip mm | solver failures | drift % | orientation ° | base v RMS m/s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for robot in args.robots:
        for seed in args.seeds:
            print(row(robot, seed, run(robot, seed, args.extra.split(), args.keep)), flush=True)


if __name__ == "__main__":
    main()
