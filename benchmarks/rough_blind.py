"""Blind walks over random rough terrain in MuJoCo (issue 24, "blind robustness"): the plant gets
``rough:AMPLITUDE:SEED`` (a heightfield, :func:`wbc.terrain.rough`), the planner plans flat (``--blind``), the
controller runs on the estimated state and the realistic drives (the ``wbc sim walk`` defaults). One
``wbc sim walk`` process per seed, one after the other; one row per seed from its JSON summary.

    nice -n 10 python benchmarks/rough_blind.py [--robot talos] [--amplitude 0.02] [--seeds 1-10]
        [--steps 41] [--step-length 0.25] [--step-duration D] [--keep DIR] [--log] [--sim-args "..."]

The defaults walk 41 steps of 0.25 m at the robot's step duration (Talos 0.8 s): 10.0 m commanded, the
heightfield spans x ∈ [−1, 12] m with a flat start for x ≤ 0.4 m (the gait chosen for blind rough ground in
benchmarks/README.md, "Walking on terrain": 0.35 m steps at 0.8 s exceed Talos's joint speed limits). Columns:
fell (and when, why), touch-downs, walked distance (m), solver failures, joint speed exceedances and the largest
speed ratio to the URDF limit, largest landing slide and stance slip (mm), pelvis tilt, and the walk criteria that
failed ("-" when all pass).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def _seeds(text: str) -> list[int]:
    out = []
    for part in text.split(","):
        if "-" in part:
            a, b = part.split("-")
            out.extend(range(int(a), int(b) + 1))
        else:
            out.append(int(part))
    return out


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--robot", default="talos")
    p.add_argument("--amplitude", type=float, default=0.02, help="height amplitude (m) of the rough terrain")
    p.add_argument("--seeds", default="1-10", help="seeds, e.g. 1-10 or 1,3,5")
    p.add_argument("--steps", type=int, default=41)
    p.add_argument("--step-length", type=float, default=0.25)
    p.add_argument("--step-duration", type=float, default=None)
    p.add_argument("--keep", default=None, help="directory for the per-seed JSON summaries (default: a temp dir)")
    p.add_argument("--log", action="store_true", help="also write each seed's time series (wbc sim walk --log) "
                   "next to its summary, for benchmarks/contact_replay.py")
    p.add_argument("--sim-args", default="", help="further wbc sim walk options, one string (e.g. "
                   "\"--sole-margin 0.02\")")
    args = p.parse_args()
    out_dir = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="rough_blind_"))
    out_dir.mkdir(parents=True, exist_ok=True)
    env = dict(os.environ)
    env["PYTHONPATH"] = str(Path(__file__).resolve().parents[1]) + os.pathsep + env.get("PYTHONPATH", "")
    print(f"{args.robot}, rough:{args.amplitude:g}:SEED --blind, {args.steps} steps of {args.step_length} m; "
          f"summaries in {out_dir}")
    print(f"{'seed':>4} {'fell':>18} {'td':>3} {'walked':>7} {'fail':>4} {'exc':>3} {'speed':>5} {'slide':>6} "
          f"{'slip':>5} {'pelvis':>6} {'wall':>5}  failed criteria")
    n_ok = 0
    for seed in _seeds(args.seeds):
        js = out_dir / f"{args.robot}_rough{args.amplitude:g}_{seed}.json"
        cmd = [sys.executable, "-m", "wbc", "sim", "walk", "--robot", args.robot, "--terrain",
               f"rough:{args.amplitude:g}:{seed}", "--blind", "--steps", str(args.steps), "--step-length",
               str(args.step_length), "--quiet", "--json", str(js)]
        if args.step_duration is not None:
            cmd += ["--step-duration", str(args.step_duration)]
        if args.log:
            cmd += ["--log", str(js.with_suffix(".npz"))]
        cmd += args.sim_args.split()
        t0 = time.perf_counter()
        r = subprocess.run(cmd, env=env, capture_output=True, text=True)
        wall = time.perf_counter() - t0
        if r.returncode not in (0, 1) or not js.exists():
            print(f"{seed:>4} error (exit {r.returncode}): {r.stderr.strip().splitlines()[-1:]}")
            continue
        s = json.loads(js.read_text())
        fell = f"{s['fall_time_s']:.2f} s" if s.get("fell") else "no"
        tilt = s.get("max_tilt_deg", {})
        pelvis = tilt.get("pelvis", float("nan")) if isinstance(tilt, dict) else float("nan")
        failed = s.get("failed_criteria") or []
        n_ok += not s.get("fell")
        print(f"{seed:>4} {fell:>18} {s.get('touchdowns', 0):>3} {s.get('walked_distance_m', 0):>7.3f} "
              f"{s.get('solver_failures', 0):>4} {s.get('joint_speed_exceedances', 0):>3} "
              f"{s.get('max_joint_speed_ratio', 0):>5.3f} {1e3 * s.get('max_landing_slide_m', 0):>6.1f} "
              f"{1e3 * s.get('max_stance_slip_m', 0):>5.1f} {pelvis:>6.2f} {wall:>5.0f}  "
              f"{'; '.join(failed) if failed else '-'}")
        if s.get("fell"):
            print(f"{'':>4} fall: {s.get('fall_reason')}")
    print(f"no fall in {n_ok} of {len(_seeds(args.seeds))} seeds")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
