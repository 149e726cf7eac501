"""The compiled hot path (``solver="fast"``, :mod:`wbc.fastqp`) against wbc's general DAQP path and placo.

Timing: the ``wbc bench`` kinematic scenario (Talos, feet hard, CoM sway, torso, posture, position + velocity
limits; :mod:`wbc.bench.kinematic`) run interleaved A B C A B C ... in this one process, ``--repeats`` times;
medians over the repeats of each run's median CPU tick, ratios against placo, machine load (``os.getloadavg``)
printed before and after. Then the walk tick (targets + QP + integration) of the default Talos walk with
``--walk-steps`` steps, fast vs daqp interleaved, median and p99.

Instructions (``--callgrind``): every library runs the scenario under ``valgrind --tool=callgrind`` once with N and
once with 2N timed ticks; (Ir(2N) − Ir(N)) / N is its instructions per tick, free of start-up and independent of
machine load. Slow (≈ 50× under valgrind): keep N small.

Usage: python benchmarks/fast_path.py [--repeats 5] [--ticks 2000] [--walk-steps 4] [--callgrind 200]
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time

import numpy as np

LIBS = ("wbc-fast", "wbc-daqp", "placo")


def _runner(lib: str, ticks: int, robot):
    from wbc.bench.kinematic import KinematicSpec, PlacoRunner, WbcRunner

    if lib == "placo":
        return PlacoRunner(KinematicSpec(ticks=ticks), robot)
    return WbcRunner(KinematicSpec(ticks=ticks, solver=lib.split("-")[1]), robot)


def _load() -> str:
    return "load " + " ".join(f"{x:.2f}" for x in os.getloadavg())


def timing(repeats: int, ticks: int) -> dict[str, float]:
    import wbc
    from wbc.bench.stats import limit_blas_threads
    from wbc.fastqp import warm_up

    limit_blas_threads(1)
    print(f"numba kernel first call (compile or on-disk cache load): {warm_up() * 1e3:.0f} ms")
    robot = wbc.load_robot("talos")
    runners = {lib: _runner(lib, ticks, robot) for lib in LIBS}
    med: dict[str, list[float]] = {lib: [] for lib in LIBS}
    finals = {}
    print(f"kinematic tick, Talos, {ticks} ticks x {repeats} repeats, interleaved; {_load()}")
    for _ in range(repeats):
        for lib, r in runners.items():
            run = r.run()
            assert r.failures == 0, (lib, r.first_error)
            med[lib].append(float(np.median(run.cpu_ns)) / 1e3)
            finals[lib] = np.asarray(run.metrics["final_com"])
    out = {lib: float(np.median(v)) for lib, v in med.items()}
    for lib in LIBS:
        print(f"  {lib:9s} median CPU tick {out[lib]:7.1f} us  (per repeat: "
              f"{', '.join(f'{v:.1f}' for v in med[lib])})  / placo {out[lib] / out['placo']:.2f}")
    fast = runners["wbc-fast"].controller.backend
    print(f"  fast backend: {fast.kernel_solves} kernel solves, {fast.fallbacks} DAQP fallbacks; "
          f"final CoM fast vs daqp {np.abs(finals['wbc-fast'] - finals['wbc-daqp']).max():.1e} m; {_load()}")
    return out


def walk(repeats: int, steps: int) -> None:
    import wbc
    from wbc.scenarios.walk import plan_default_walk, run_walk

    robot = wbc.load_robot("talos")
    plan = plan_default_walk(robot, n_steps=steps)
    stats: dict[str, list[tuple[float, float]]] = {"fast": [], "daqp": []}
    for _ in range(repeats):
        for s in stats:
            t = run_walk(robot, plan, solver=s).tick_time * 1e6
            stats[s].append((float(np.median(t)), float(np.percentile(t, 99))))
    print(f"walk tick, Talos, {steps} steps ({len(plan.t)} ticks) x {repeats} repeats, interleaved; {_load()}")
    for s, v in stats.items():
        a = np.array(v)
        print(f"  wbc-{s:5s} median {np.median(a[:, 0]):7.1f} us  p99 {np.median(a[:, 1]):7.1f} us (medians over repeats)")


def _one(lib: str, ticks: int) -> None:
    """Child process under valgrind: build and run one library's scenario."""
    import wbc
    from wbc.fastqp import warm_up

    warm_up()
    robot = wbc.load_robot("talos")
    r = _runner(lib, ticks, robot)
    r.run()


def callgrind(n: int, libs: tuple[str, ...] = LIBS) -> None:
    irs: dict[str, float] = {}
    for lib in libs:
        ir = []
        for ticks in (n, 2 * n):
            with tempfile.TemporaryDirectory() as d:
                t0 = time.time()
                p = subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={d}/cg.out",
                                    sys.executable, __file__, "--child", lib, "--ticks", str(ticks)],
                                   capture_output=True, text=True)
                m = re.search(r"Collected : (\d+)", p.stderr)
                if p.returncode or not m:
                    raise RuntimeError(f"callgrind run of {lib} failed: {p.stderr[-2000:]}")
                ir.append(int(m.group(1)))
                print(f"  callgrind {lib} {ticks} ticks: {ir[-1]:,} Ir ({time.time() - t0:.0f} s)", flush=True)
        irs[lib] = (ir[1] - ir[0]) / n
    print(f"instructions per kinematic tick (callgrind, {n} vs {2 * n} ticks differenced):")
    for lib in libs:
        print(f"  {lib:9s} {irs[lib] / 1e3:8.0f} k   / placo {irs[lib] / irs['placo']:.2f}")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeats", type=int, default=5)
    p.add_argument("--ticks", type=int, default=2000)
    p.add_argument("--walk-steps", type=int, default=4)
    p.add_argument("--callgrind", type=int, default=0, help="N ticks for the instruction count (0: skip)")
    p.add_argument("--callgrind-libs", default=",".join(LIBS), help="comma-separated subset of " + ",".join(LIBS))
    p.add_argument("--only-callgrind", action="store_true", help="skip the timing sections")
    p.add_argument("--child", default=None, help=argparse.SUPPRESS)
    a = p.parse_args()
    if a.child:
        _one(a.child, a.ticks)
        return
    if not a.only_callgrind:
        timing(a.repeats, a.ticks)
        if a.walk_steps:
            walk(a.repeats, a.walk_steps)
    if a.callgrind:
        libs = tuple(a.callgrind_libs.split(","))
        if "placo" not in libs or not set(libs) <= set(LIBS):
            p.error(f"--callgrind-libs must be a subset of {LIBS} that includes placo")
        callgrind(a.callgrind, libs)


if __name__ == "__main__":
    main()
