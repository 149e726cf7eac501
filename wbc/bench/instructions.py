"""Instructions per kinematic tick, counted by valgrind's callgrind: a measure that does not move with machine load.

Each library runs the ``wbc bench`` kinematic scenario (:mod:`wbc.bench.kinematic`) in a child process under
``valgrind --tool=callgrind``, once with N and once with 2N timed ticks (same warm-up); (Ir(2N) − Ir(N)) / N is
its instructions per tick, with interpreter start-up, imports, model loading and JIT loading cancelled out.
Slow (≈ 50× under valgrind): N of a few hundred ticks.

Child entry point: ``python -m wbc.bench.instructions <library> <ticks>`` (library: ``wbc`` or ``placo``).
"""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
import tempfile
import time

__all__ = ["callgrind_available", "instructions_per_tick"]

LIBRARIES = ("wbc", "placo")


def callgrind_available() -> bool:
    """Whether ``valgrind`` is on the PATH."""
    return shutil.which("valgrind") is not None


def _child(library: str, ticks: int, robot_name: str = "talos") -> None:
    from wbc.bench.kinematic import KinematicSpec, PlacoRunner, WbcRunner
    from wbc.bench.stats import limit_blas_threads
    from wbc.robot import load_robot

    limit_blas_threads(1)
    robot = load_robot(robot_name)
    spec = KinematicSpec(robot=robot_name, ticks=ticks, warmup=20)
    runner = {"wbc": WbcRunner, "placo": PlacoRunner}[library](spec, robot)
    runner.run()
    if runner.failures:
        raise SystemExit(f"{library}: {runner.failures} failed ticks ({runner.first_error})")


def _count(library: str, ticks: int, robot_name: str) -> int:
    with tempfile.TemporaryDirectory() as d:
        p = subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={d}/cg.out",
                            sys.executable, "-m", "wbc.bench.instructions", library, str(ticks), robot_name],
                           capture_output=True, text=True)
        m = re.search(r"Collected : (\d+)", p.stderr)
        if p.returncode or not m:
            raise RuntimeError(f"callgrind run of {library} ({ticks} ticks) failed: {p.stderr[-2000:]}")
        return int(m.group(1))


def instructions_per_tick(n: int = 200, robot_name: str = "talos", log=print) -> dict[str, object]:
    """Instructions per kinematic tick of wbc and placo (module docstring).

    Returns:
        {"n": n, "robot", "instructions": {lib: per tick}, "raw": {lib: [Ir(N), Ir(2N)]}, "ratio_wbc_placo",
        "seconds"}.

    Raises:
        RuntimeError: valgrind missing or a child run failed.
    """
    if not callgrind_available():
        raise RuntimeError("valgrind is not installed (apt-get install valgrind)")
    from wbc.fastqp import ensure_compiled

    ensure_compiled()  # the JIT cache is written here, so that both child runs only load it
    t0 = time.perf_counter()
    raw: dict[str, list[int]] = {}
    for lib in LIBRARIES:
        raw[lib] = []
        for ticks in (n, 2 * n):
            t1 = time.perf_counter()
            raw[lib].append(_count(lib, ticks, robot_name))
            log(f"callgrind {lib} {ticks} ticks: {raw[lib][-1]:,} instructions ({time.perf_counter() - t1:.0f} s)")
    per = {lib: (r[1] - r[0]) / n for lib, r in raw.items()}
    return {"n": n, "robot": robot_name, "instructions": per, "raw": raw,
            "ratio_wbc_placo": per["wbc"] / per["placo"], "seconds": time.perf_counter() - t0}


if __name__ == "__main__":
    _child(sys.argv[1], int(sys.argv[2]), sys.argv[3] if len(sys.argv) > 3 else "talos")
