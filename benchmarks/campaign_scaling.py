"""Campaign throughput: trials per minute serially and on a local Ray with 1 and 2 workers, and Ray's per-trial
overhead against the same trials run serially.

Each configuration runs the same ``--trials`` trials of one campaign (a push campaign of short physics walks by
default; ``--toy`` for a 1 ms trial that measures the executor's overhead alone) into a fresh results folder. The
overhead per trial is (Ray wall time × workers − Σ trial run time) / trials, i.e. what Ray adds to each trial's own
``wall_s`` (scheduling, serialisation, result transfer, and Ray's start-up and each worker's first import and
numba load, which a longer campaign spreads over more trials). Prints the load before and after.

Usage: python benchmarks/campaign_scaling.py [--trials 40] [--steps 2] [--toy] [--workers 1 2]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

CODE = r"""
import json, sys, time
from wbc.campaign import RayExecutor, SerialExecutor, default_spec, run, read_results
cfg = json.loads(sys.argv[1])
spec = default_spec("push", trials=cfg["trials"], seed=5,
                    scenario={"robot": "talos", "steps": cfg["steps"], "step_length": 0.1})
fn = None
if cfg["toy"]:
    def fn(spec, params):
        t = time.perf_counter()
        while time.perf_counter() - t < 0.001:
            pass
        return {"survived": True, "outcome": "survived", "fall_reason": ""}
ex = SerialExecutor() if cfg["workers"] == 0 else RayExecutor(workers=cfg["workers"])
t0 = time.perf_counter()
table = run(spec, cfg["out"], executor=ex, trial_fn=fn, progress=False)
wall = time.perf_counter() - t0
rows = table.to_pylist()
print(json.dumps({"wall": wall, "sum_trial": sum(r["wall_s"] for r in rows), "n": len(rows),
                  "survived": sum(bool(r["survived"]) for r in rows)}))
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=40)
    ap.add_argument("--steps", type=int, default=2, help="walk steps per trial (default 2)")
    ap.add_argument("--toy", action="store_true", help="a 1 ms busy-wait trial instead of a physics walk")
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2], help="Ray worker counts (default 1 2)")
    args = ap.parse_args()
    print(f"load before: {os.getloadavg()}")
    tmp = Path(tempfile.mkdtemp(prefix="wbc-campaign-scaling-"))
    results = {}
    try:
        for w in [0, *args.workers]:
            out = tmp / f"w{w}"
            cfg = {"trials": args.trials, "steps": args.steps, "toy": args.toy, "workers": w, "out": str(out)}
            p = subprocess.run([sys.executable, "-c", CODE, json.dumps(cfg)], capture_output=True, text=True)
            if p.returncode != 0:
                sys.exit(f"workers {w}: failed\n{p.stderr[-3000:]}")
            r = json.loads(p.stdout.strip().splitlines()[-1])
            results[w] = r
            name = "serial" if w == 0 else f"ray, {w} worker(s)"
            per_min = 60.0 * r["n"] / r["wall"]
            line = (f"{name:>18}: {r['n']} trials in {r['wall']:.1f} s = {per_min:.1f} trials/min, "
                    f"mean trial run time {r['sum_trial'] / r['n']:.3f} s, survived {r['survived']}")
            if w:
                overhead = (r["wall"] * w - r["sum_trial"]) / r["n"]
                line += f", wall × workers − Σ trial time = {overhead:.3f} s per trial"
            print(line, flush=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    print(f"load after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
