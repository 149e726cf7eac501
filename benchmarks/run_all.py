#!/usr/bin/env python
"""Regenerate every benchmark table and plot in one run: ``python benchmarks/run_all.py``.

1. ``wbc bench`` (all sections: kinematic tick vs placo and Pink, breakdown, QP backends, scaling, inverse
   dynamics, gait planning, the walk tick, the cost of an extra frame task, instruction counts; 2000 ticks × 5
   interleaved repeats), in this process;
2. then ``benchmarks/self_collision.py`` (self-collision cost per tick, broad phase vs exhaustive), in a child
   process (its scenario helpers live in ``tests/``);
3. then ``benchmarks/sim_rtf.py`` (real-time factor of the Talos 20-step physics walk, ``wbc sim walk``: ID tick +
   MuJoCo step + sensors, estimator and outcome checks; CPU and wall time of the closed loop, start-up excluded,
   load average printed; target CPU real-time factor ≥ 6, issue 59), in a child process (skipped with ``--quick``).

Outputs in ``benchmarks/results/`` next to this file (not committed): results.json, results.md (the self-collision
report appended), latency.png, latencies.npz, self_collision.json. Extra arguments are passed to ``wbc bench``
(e.g. ``--repeats 7``, ``--quick``; with ``--quick`` the self-collision part runs 1 repeat). Exit code: 0 when
every acceptance criterion of every part is met, 1 otherwise (each part says which it missed).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

# BLAS threads are also limited at run time by `wbc bench --blas-threads 1`; the environment variables cover
# libraries that read them only when loaded (and the child process).
for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(var, "1")

from wbc.cli import main  # noqa: E402

if __name__ == "__main__":
    here = Path(__file__).resolve().parent
    # the folder of every part's results: --out-dir when given (wbc bench reads the same option), else results/
    out_parser = argparse.ArgumentParser(add_help=False)
    out_parser.add_argument("--out-dir", type=Path, default=here / "results")
    out_dir = out_parser.parse_known_args(sys.argv[1:])[0].out_dir.resolve()
    argv = ["bench", "--out-dir", str(out_dir), *sys.argv[1:]]
    code = main(argv)
    repeats = "1" if "--quick" in sys.argv[1:] else "3"
    t0 = time.strftime("%Y-%m-%dT%H:%M:%S%z")
    sc = subprocess.run([sys.executable, str(here / "self_collision.py"), "--repeats", repeats, "--json",
                         str(out_dir / "self_collision.json")], capture_output=True, text=True)
    sys.stdout.write(sc.stdout)
    sys.stderr.write(sc.stderr)
    with open(out_dir / "results.md", "a") as md:
        md.write(f"\n## 10. Self-collision (`benchmarks/self_collision.py --repeats {repeats}`, started {t0}, "
                 f"exit {sc.returncode})\n\n```\n{sc.stdout.strip()}\n```\n")
    if sc.returncode != 0:
        print("run_all: self-collision target missed (see above)", file=sys.stderr)
    rtf_code = 0
    if "--quick" not in sys.argv[1:]:
        t0 = time.strftime("%Y-%m-%dT%H:%M:%S%z")
        rt = subprocess.run([sys.executable, str(here / "sim_rtf.py"), "--json", str(out_dir / "sim_rtf.json")],
                            capture_output=True, text=True)
        sys.stdout.write(rt.stdout)
        sys.stderr.write(rt.stderr)
        rtf_code = rt.returncode
        with open(out_dir / "results.md", "a") as md:
            md.write(f"\n## 11. Physics walk real-time factor (`benchmarks/sim_rtf.py`, started {t0}, exit {rtf_code})"
                     f"\n\n```\n{rt.stdout.strip()}\n```\n")
        if rtf_code != 0:
            print("run_all: physics walk real-time factor target missed (see above)", file=sys.stderr)
    sys.exit(1 if code or sc.returncode or rtf_code else 0)
