#!/usr/bin/env python
"""Run every example of ``examples/`` on its defaults (no ``--quick``), one at a time, and print what each one
measured and its exit code: ``python benchmarks/examples_defaults.py [--only NAME ...] [--json FILE]``.

CI runs the examples with ``--quick``; this job checks the forms a user runs first. Each example runs in a fresh
temporary working folder (so that a file it leaves behind, e.g. MuJoCo's ``MUJOCO_LOG.TXT``, is seen and reported),
under ``nice -n 5``, with the current interpreter and ``PYTHONPATH``. For each: the exit code, the child's CPU time
(user + system, s; wall time beside it with the load average, which drifts with the machine's load), the lines it
printed (its measured criteria and verdict), the last line of stderr when it failed, and any file left in the
working folder. Exit code: 0 when every example exited 0, 1 otherwise.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


def run_example(path: Path, timeout: float) -> dict:
    """Run ``path`` on its defaults in a new temporary folder; returns its exit code, CPU and wall time (s), load
    average before the run, stdout lines, last stderr line and the files left in the folder."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    load = Path("/proc/loadavg").read_text().split()[:3] if Path("/proc/loadavg").exists() else []
    with tempfile.TemporaryDirectory(prefix=f"wbc-example-{path.stem}-") as cwd:
        start = time.monotonic()
        try:
            proc = subprocess.run(["nice", "-n", "5", sys.executable, str(path)], cwd=cwd, capture_output=True,
                                  text=True, timeout=timeout, env=dict(os.environ))
            code, out, err = proc.returncode, proc.stdout, proc.stderr
        except subprocess.TimeoutExpired as exc:
            code, out, err = None, exc.stdout or "", f"timed out after {timeout:g} s"
            out = out.decode() if isinstance(out, bytes) else out
            err = err if isinstance(err, str) else ""
        wall = time.monotonic() - start
        left = sorted(p.name for p in Path(cwd).iterdir())
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    err_lines = [line for line in err.splitlines() if line.strip()]
    return {"example": path.name, "exit_code": code, "cpu_s": round(cpu, 1), "wall_s": round(wall, 1),
            "loadavg_before": " ".join(load), "stdout": out.splitlines(),
            "stderr_last": err_lines[-1] if err_lines and code != 0 else "", "files_left": left}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", nargs="*", default=None, help="example file stems to run (default: all)")
    parser.add_argument("--timeout", type=float, default=3600.0, help="per example, s (default 3600)")
    parser.add_argument("--json", type=Path, default=None, help="also write the results as JSON")
    args = parser.parse_args()
    paths = sorted(EXAMPLES.glob("*.py"))
    if args.only:
        paths = [p for p in paths if p.stem in args.only]
    results = []
    for path in paths:
        result = run_example(path, args.timeout)
        results.append(result)
        print(f"== {result['example']}: exit {result['exit_code']}, CPU {result['cpu_s']} s, wall {result['wall_s']} s "
              f"(load {result['loadavg_before']})", flush=True)
        for line in result["stdout"][-25:]:
            print(f"   | {line}")
        if result["stderr_last"]:
            print(f"   stderr: {result['stderr_last']}")
        if result["files_left"]:
            print(f"   left in the working folder: {', '.join(result['files_left'])}")
    failed = [r["example"] for r in results if r["exit_code"] != 0]
    print(f"{len(results) - len(failed)} of {len(results)} examples exit 0 on their defaults"
          + (f"; not: {', '.join(failed)}" if failed else ""))
    if args.json is not None:
        args.json.write_text(json.dumps(results, indent=1))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
