"""Instructions per kinematic tick, counted by valgrind's callgrind: a measure that does not move with machine load.

Each library runs the ``wbc bench`` kinematic scenario (:mod:`wbc.bench.kinematic`) in a child process under
``valgrind --tool=callgrind --instr-atstart=no`` (imports, model loading, JIT loading and 20 warm-up ticks run
uninstrumented, which is several times faster); then instrumentation is switched on and the counters zeroed
(``callgrind_control``), the child runs N ticks, the parent reads the instruction count Ir(N), the child runs N
more, the parent reads Ir(2N): (Ir(2N) − Ir(N)) / N is the instructions per tick, free of start-up effects.

Child entry point: ``python -m wbc.bench.instructions <library> <N> [robot]`` (library: ``wbc`` or ``placo``);
it prints READY / HALF / DONE and waits for a line on stdin after each.

Compiled kernels: numba's on-disk cache is indexed by the CPU name and features LLVM detects, and valgrind's
emulated CPU reports other features than the host, so a child under valgrind would find no cached kernel and
compile every one under emulation (tens of minutes). Every callgrind child therefore runs with
:func:`callgrind_env` (numba targets the generic x86-64 CPU, the baseline that placo's manylinux wheel is built
for, and caches in a folder of its own), and the same child is first run once natively with that environment
(:func:`prime_child`), which compiles the kernels or finds them cached; under valgrind they are then loaded. The
counts are thus the instructions of generic x86-64 code, for wbc's kernels as for placo (or, with
``WBC_CALLGRIND_CPU``, of wbc's kernels compiled for that CPU).
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

__all__ = ["callgrind_available", "callgrind_env", "callgrind_half_and_done", "instructions_per_tick", "prime_child",
           "walk_instructions_per_tick"]

LIBRARIES = ("wbc", "placo")


def callgrind_available() -> bool:
    """Whether ``valgrind`` and ``callgrind_control`` are on the PATH."""
    return shutil.which("valgrind") is not None and shutil.which("callgrind_control") is not None


def callgrind_env(cpu: str | None = None) -> dict[str, str]:
    """The environment of a callgrind child: this process's, with numba compiling for the generic x86-64 CPU
    (``NUMBA_CPU_NAME=generic``, no extra CPU features) into its own on-disk cache
    (``NUMBA_CACHE_DIR`` = ``$XDG_CACHE_HOME/wbc/numba-generic``, default ``~/.cache/wbc/numba-generic``), so that
    the cache a native run wrote is the one a run under valgrind finds. ``WBC_CALLGRIND_CPU`` names another LLVM
    CPU (e.g. ``haswell``: x86-64 with AVX2, which valgrind emulates) for a count of code tuned beyond the baseline;
    its cache is ``numba-<cpu>``; ``cpu`` (an LLVM CPU name) overrides both.

    Returns:
        A copy of ``os.environ`` with those variables set (``NUMBA_CPU_FEATURES`` empty: the named CPU's features,
        none detected).
    """
    env = dict(os.environ)
    cpu = cpu or env.get("WBC_CALLGRIND_CPU") or "generic"
    cache = Path(env.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "wbc" / f"numba-{cpu}"
    env["NUMBA_CPU_NAME"] = cpu
    env["NUMBA_CPU_FEATURES"] = ""  # the CPU's own features; unset, numba adds the ones it detects (all but generic)
    env["NUMBA_CACHE_DIR"] = str(cache)
    return env


def prime_child(module: str, args: list[str], label: str, log=print, cpu: str | None = None) -> float:
    """Run the callgrind child ``python -m module *args`` once natively with :func:`callgrind_env`, answering each
    of its markers, so that every kernel it calls is compiled into (or already found in) that environment's
    numba cache before the run under valgrind (``cpu``: as :func:`callgrind_env`).

    Returns:
        The wall time of the run (s).

    Raises:
        RuntimeError: the child failed.
    """
    t0 = time.perf_counter()
    r = subprocess.run([sys.executable, "-m", module, *args], env=callgrind_env(cpu), input="go\n" * 4,
                       capture_output=True, text=True, timeout=3600)
    if r.returncode:
        raise RuntimeError(f"callgrind child {label} failed natively: {r.stderr[-2000:]}")
    seconds = time.perf_counter() - t0
    log(f"callgrind {label}: kernels compiled or loaded for CPU {callgrind_env(cpu)['NUMBA_CPU_NAME']} natively "
        f"({seconds:.0f} s)")
    return seconds


def _start_under_callgrind(module: str, args: list[str], out_dir: str, cpu: str | None) -> subprocess.Popen:
    return subprocess.Popen(["valgrind", "--tool=callgrind", "--instr-atstart=no",
                             f"--callgrind-out-file={out_dir}/cg.out", sys.executable, "-m", module, *args],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=callgrind_env(cpu))


def _child(library: str, n: int, robot_name: str = "talos") -> None:
    from wbc.bench.kinematic import KinematicSpec, PlacoRunner, WbcRunner
    from wbc.bench.stats import limit_blas_threads
    from wbc.robot import load_robot

    limit_blas_threads(1)
    robot = load_robot(robot_name)
    spec = KinematicSpec(robot=robot_name, ticks=2 * n, warmup=20)
    runner = {"wbc": WbcRunner, "placo": PlacoRunner}[library](spec, robot)
    run_marked(runner, library, spec.warmup, n)


def run_marked(runner, library: str, warmup: int, n: int) -> None:
    """A callgrind child's tick loop: ``warmup`` ticks then READY, ``n`` ticks then HALF, ``n`` more then DONE —
    each marker printed on stdout, then a line awaited on stdin (the parent toggles instrumentation meanwhile).

    Raises:
        SystemExit: the runner reported failed ticks.
    """
    runner.reset()
    k = 0
    for marker, ticks in (("READY", warmup), ("HALF", n), ("DONE", n)):
        for _ in range(ticks):
            runner.tick(k)
            k += 1
        print(marker, flush=True)
        sys.stdin.readline()
    if runner.failures:
        raise SystemExit(f"{library}: {runner.failures} failed ticks ({runner.first_error})")


def _walk_child(library: str, n_steps: int, robot_name: str = "talos") -> None:
    """The walk tick (:mod:`wbc.bench.walk`: ``wbc`` = set_references + solve + step, ``placo`` = placo with both
    soles hard on the same plan): 20 ticks uninstrumented, then every remaining tick of the plan (printed)."""
    from wbc.bench.stats import limit_blas_threads
    from wbc.bench.walk import walk_ticks
    from wbc.robot import load_robot
    from wbc.scenarios.walk import plan_default_walk

    limit_blas_threads(1)
    robot = load_robot(robot_name)
    plan = plan_default_walk(robot, n_steps=n_steps)
    ticks = walk_ticks("wbc" if library == "wbc" else "placo-hard", robot, plan)
    warm = 20
    for _ in range(warm):
        next(ticks)
    print("READY", flush=True)
    sys.stdin.readline()
    n = 0
    for _ in ticks:
        n += 1
    print(f"DONE {n}", flush=True)
    sys.stdin.readline()


def walk_instructions_per_tick(n_steps: int = 2, robot_name: str = "talos", log=print,
                               libraries: tuple[str, ...] = LIBRARIES) -> dict[str, object]:
    """Instructions per walk tick of wbc and placo (hard feet) on the same plan (``plan_default_walk`` with
    ``n_steps``): each library's ticks after the first 20 counted under callgrind and averaged (support switches
    included, the same ticks for both).

    Returns:
        {"n_steps", "ticks", "instructions": {lib: per tick}, "ratio_wbc_placo" (when both ran)}.

    Raises:
        RuntimeError: valgrind missing or a child run failed.
    """
    if not callgrind_available():
        raise RuntimeError("valgrind is not installed (apt-get install valgrind)")
    per, ticks = {}, 0
    for lib in libraries:
        args = ["walk-" + lib, str(n_steps), robot_name]
        prime_child("wbc.bench.instructions", args, f"walk {lib}", log)
        with tempfile.TemporaryDirectory() as d:
            p = _start_under_callgrind("wbc.bench.instructions", args, d, None)
            try:
                line = p.stdout.readline().strip()
                if line != "READY":
                    raise RuntimeError(f"callgrind walk child {lib}: {line!r}: {p.stderr.read()[-2000:]}")
                _control(p.pid, "-i", "on")
                _control(p.pid, "-z")
                p.stdin.write("go\n")
                p.stdin.flush()
                line = p.stdout.readline().strip()
                if not line.startswith("DONE"):
                    raise RuntimeError(f"callgrind walk child {lib}: {line!r}: {p.stderr.read()[-2000:]}")
                ticks = int(line.split()[1])
                m = re.search(r"Th 1\s+([\d,]+)", _control(p.pid, "-e", "Ir"))
                if not m:
                    raise RuntimeError("callgrind_control printed no Ir total")
                per[lib] = int(m.group(1).replace(",", "")) / ticks
                p.stdin.write("go\n")
                p.stdin.flush()
                p.wait(timeout=600)
            finally:
                if p.poll() is None:
                    p.kill()
        log(f"callgrind walk {lib}: {per[lib]:,.0f} instructions per tick over {ticks} ticks")
    out = {"n_steps": n_steps, "ticks": ticks, "instructions": per}
    if "wbc" in per and "placo" in per:
        out["ratio_wbc_placo"] = per["wbc"] / per["placo"]
    return out


def _control(pid: int, *args: str) -> str:
    r = subprocess.run(["callgrind_control", *args, str(pid)], capture_output=True, text=True, timeout=600)
    if r.returncode:
        raise RuntimeError(f"callgrind_control {' '.join(args)} failed: {r.stderr[-500:]}")
    return r.stdout


def callgrind_half_and_done(module: str, args: list[str], label: str, log=print,
                            cpu: str | None = None) -> tuple[int, int]:
    """Run ``python -m module *args`` under valgrind callgrind with instrumentation off, and read its instruction
    totals at two points of a line protocol: the child prints READY (instrumentation is switched on and zeroed),
    HALF (after N ticks) and DONE (after 2N ticks), each time waiting for a "go" line on stdin. The child is first
    run natively (:func:`prime_child`) so that under valgrind it loads its kernels from the cache (``cpu``: the
    LLVM CPU they are compiled for, :func:`callgrind_env`).

    Returns:
        (Ir at HALF, Ir at DONE), counted from READY (instructions of thread 1).

    Raises:
        RuntimeError: the child printed something else, failed, or callgrind_control gave no Ir total.
    """
    prime_child(module, args, label, log, cpu)
    with tempfile.TemporaryDirectory() as d:
        p = _start_under_callgrind(module, args, d, cpu)
        try:
            irs = []
            for marker in ("READY", "HALF", "DONE"):
                line = p.stdout.readline().strip()
                if line != marker:
                    raise RuntimeError(f"callgrind child {label}: expected {marker}, got {line!r}: "
                                       f"{p.stderr.read()[-2000:]}")
                if marker == "READY":
                    _control(p.pid, "-i", "on")
                    _control(p.pid, "-z")
                else:
                    m = re.search(r"Th 1\s+([\d,]+)", _control(p.pid, "-e", "Ir"))
                    if not m:
                        raise RuntimeError("callgrind_control printed no Ir total")
                    irs.append(int(m.group(1).replace(",", "")))
                p.stdin.write("go\n")
                p.stdin.flush()
            p.wait(timeout=600)
            if p.returncode:
                raise RuntimeError(f"callgrind child {label} failed: {p.stderr.read()[-2000:]}")
        finally:
            if p.poll() is None:
                p.kill()
        return irs[0], irs[1]


def instructions_per_tick(n: int = 200, robot_name: str = "talos", log=print,
                          cpu: str | None = None) -> dict[str, object]:
    """Instructions per kinematic tick of wbc and placo (module docstring); ``cpu``: the LLVM CPU wbc's kernels are
    compiled for (:func:`callgrind_env`; placo's wheel is the same code whatever it is).

    Returns:
        {"n": n, "robot", "instructions": {lib: per tick}, "raw": {lib: [Ir(N), Ir(2N)]}, "cpu" (the LLVM CPU
        numba compiled for), "ratio_wbc_placo", "seconds"}.

    Raises:
        RuntimeError: valgrind missing or a child run failed.
    """
    if not callgrind_available():
        raise RuntimeError("valgrind is not installed (apt-get install valgrind)")
    t0 = time.perf_counter()
    raw: dict[str, list[int]] = {}
    for lib in LIBRARIES:
        t1 = time.perf_counter()
        raw[lib] = list(callgrind_half_and_done("wbc.bench.instructions", [lib, str(n), robot_name], lib, log, cpu))
        log(f"callgrind {lib}: {raw[lib][0]:,} instructions after {n} ticks, {raw[lib][1]:,} after {2 * n} "
            f"({time.perf_counter() - t1:.0f} s)")
    per = {lib: (r[1] - r[0]) / n for lib, r in raw.items()}
    return {"n": n, "robot": robot_name, "instructions": per, "raw": raw, "cpu": callgrind_env(cpu)["NUMBA_CPU_NAME"],
            "ratio_wbc_placo": per["wbc"] / per["placo"], "seconds": time.perf_counter() - t0}


if __name__ == "__main__":
    if sys.argv[1].startswith("walk-"):
        _walk_child(sys.argv[1][5:], int(sys.argv[2]), sys.argv[3] if len(sys.argv) > 3 else "talos")
    else:
        _child(sys.argv[1], int(sys.argv[2]), sys.argv[3] if len(sys.argv) > 3 else "talos")
