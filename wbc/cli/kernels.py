"""``wbc compile``: compile every numba kernel ahead of the first run (the step after ``pip install``).

wbc's kernels are compiled on first use and cached on disk (``__pycache__`` next to each source file, or under
``NUMBA_CACHE_DIR``); the first run after an install would otherwise spend a minute or more compiling them before
its first tick. ``wbc compile`` runs every kernel loader (:func:`compile_all`) with a progress bar on a
terminal (one line per module otherwise), then runs each command of :data:`WARM_UP_RUNS` for two steps in a
child process (:func:`run_warm_up`): a kernel a command calls with array types or layouts no loader used (a MuJoCo
contact slice, a column-major mass matrix, the inverse-dynamics tick) is compiled and cached there, not inside the
user's first run. Run again, it loads the cached kernels and takes seconds.
"""

from __future__ import annotations

import sys
import time
from typing import Iterable

from wbc.exceptions import InvalidInputError

__all__ = ["LOADER_MODULES", "WARM_UP_RUNS", "register", "check_compile_args", "cmd_compile", "compile_all",
           "loader_modules", "run_warm_up"]

#: Every module with a :func:`wbc.compiled.once_per_process` loader, the kinematic controller's first (what
#: ``wbc walk`` loads), then the inverse-dynamics controller's and the simulation's (``wbc sim``).
LOADER_MODULES = (
    "wbc.formulations.velocity_kernel", "wbc.solvers.fast", "wbc.tasks.frame", "wbc.configuration", "wbc.tasks.com",
    "wbc.tasks.posture", "wbc.constraints.contact", "wbc.constraints.zmp", "wbc.constraints.acceleration",
    "wbc.constraints.braking", "wbc.constraints.limits", "wbc.formulations.reference",
    "wbc.formulations.idkernel", "wbc.controllers.inverse_dynamics", "wbc.dynamics.actuator_compensation",
    "wbc.constraints.joint_acceleration_bounds",
    "wbc.sim.actuators", "wbc.sim.closed_loop", "wbc.sim.conventions", "wbc.sim.estimated_state",
    "wbc.sim.outcome", "wbc.sim.sensors", "wbc.sim.walk",
)

#: ``wbc`` commands ``wbc compile`` runs (two steps each, ``--quiet``) after the loaders: they call kernels no loader
#: reaches with their real argument types (the closed loop on MuJoCo: inverse-dynamics tick, state estimator,
#: outcome checks on MuJoCo's contact arrays).
WARM_UP_RUNS = (("sim", "walk", "--steps", "2"),)


def run_warm_up(argv: tuple[str, ...]) -> float:
    """Run ``python -m wbc *argv --quiet`` in a child process (same interpreter, same environment, so the same numba
    cache), its output discarded: every kernel it calls is loaded from numba's on-disk cache, or compiled and
    written there.

    Args:
        argv: a ``wbc`` command line without the program name, e.g. ``("sim", "walk", "--steps", "2")``.

    Returns:
        The wall time in seconds the run took.

    Raises:
        SimulationError: the run exited with a code other than 0 or 1 (1: its acceptance failed, which a warm-up
            does not judge; the last lines of its standard error in the message).
    """
    import subprocess

    from wbc.exceptions import SimulationError

    t0 = time.perf_counter()
    out = subprocess.run([sys.executable, "-m", "wbc", *argv, "--quiet"], stdout=subprocess.DEVNULL,
                         stderr=subprocess.PIPE, text=True)
    if out.returncode not in (0, 1):  # 1: the run's acceptance failed, its kernels ran all the same
        raise SimulationError(f"`wbc {' '.join(argv)}` (run by wbc compile to compile its kernels) exited with "
                              f"{out.returncode}: {out.stderr.strip()[-500:]}")
    return time.perf_counter() - t0


def loader_modules(names: Iterable[str] = ()) -> list[str]:
    """The kernel modules ``names`` checked against :data:`LOADER_MODULES` (all of them when ``names`` is empty).

    Raises:
        InvalidInputError: a name is not in :data:`LOADER_MODULES`.
    """
    names = list(names)
    unknown = [m for m in names if m not in LOADER_MODULES]
    if unknown:
        raise InvalidInputError(f"no numba kernel loader in {', '.join(unknown)}; the modules with one: "
                                f"{', '.join(LOADER_MODULES)}")
    return names or list(LOADER_MODULES)


def compile_all(modules: Iterable[str] = ()) -> dict[str, float]:
    """Import each module and run its loaders (:func:`wbc.compiled.run_loaders`): every kernel they call is compiled
    and written to numba's on-disk cache, or loaded from it when already there.

    Args:
        modules: names among :data:`LOADER_MODULES` (default, or empty: all of them), loaded in this order.

    Returns:
        The wall time in seconds each module took (import and loaders), by name.

    Raises:
        InvalidInputError: a name is not in :data:`LOADER_MODULES` (before any module is imported).
    """
    import importlib

    from wbc.compiled import run_loaders

    seconds = {}
    for name in loader_modules(modules):
        t0 = time.perf_counter()
        importlib.import_module(name)
        run_loaders(name)
        seconds[name] = time.perf_counter() - t0
    return seconds


def register(sub, add_outputs=None) -> None:
    """Add the ``compile`` sub-command to ``wbc``'s sub-parsers (``add_outputs`` is not used)."""
    p = sub.add_parser("compile", help="compile every numba kernel now and cache it on disk (run once after install)",
                       description="Compile wbc's numba kernels ahead of the first run and cache them on disk, so "
                                   "that the first `wbc walk` (or sim, balance...) starts at once; a second "
                                   "`wbc compile` only loads the cached kernels.")
    p.add_argument("modules", nargs="*", metavar="MODULE",
                   help=f"only these modules' kernels (default: all {len(LOADER_MODULES)}: "
                        f"{', '.join(LOADER_MODULES)})")
    p.add_argument("--quiet", action="store_true", help="no progress bar or per-module lines, only the final line")
    p.set_defaults(func=cmd_compile, check=check_compile_args)


def check_compile_args(args) -> None:
    """Raises InvalidInputError: a module without kernel loader (see :data:`LOADER_MODULES`)."""
    loader_modules(args.modules)


def cmd_compile(args) -> int:
    """`wbc compile`: run the loaders of every (or each given) kernel module, one module at a time, then (all modules
    only) the commands of :data:`WARM_UP_RUNS`, with a progress bar on a terminal naming the module or command being
    compiled (redrawn every second), one line per item otherwise; prints the total time. Exit code 0.

    Raises:
        SimulationError: a command of :data:`WARM_UP_RUNS` failed.
    """
    import threading

    from wbc.cli.output import sigint_received, uncompiled_kernels

    modules = loader_modules(args.modules)
    runs = () if args.modules else WARM_UP_RUNS
    t0 = time.perf_counter()
    bar = beat = None
    if not args.quiet:
        missing = len(uncompiled_kernels(modules))
        print(f"wbc compile: compiling the numba kernels of {len(modules)} modules ({missing} without on-disk cache; "
              "a minute or two once) ..." if missing else
              f"wbc compile: loading the cached numba kernels of {len(modules)} modules ...", file=sys.stderr, flush=True)
        if getattr(sys.stderr, "isatty", lambda: False)():
            from tqdm import tqdm

            bar = tqdm(total=len(modules) + len(runs), desc="wbc compile", unit="item", file=sys.stderr,
                       bar_format="{desc}: {n_fmt}/{total_fmt} |{bar}| {elapsed}{postfix}")  # postfix: ", module"
            beat = threading.Event()

            def redraw() -> None:  # the elapsed time moves while a module compiles
                while not beat.wait(1.0):
                    bar.refresh()

            threading.Thread(target=redraw, daemon=True, name="wbc-compile-heartbeat").start()
    try:
        for name in modules:
            if bar is not None:
                bar.set_postfix_str(name)
            seconds = compile_all([name])[name]
            if sigint_received():  # a Ctrl-C swallowed inside numba's compiler (a C callback): stop here
                raise KeyboardInterrupt
            if bar is not None:
                bar.update()
            elif not args.quiet:
                print(f"wbc compile: {name} ({seconds:.1f} s)", file=sys.stderr, flush=True)
        for argv in runs:
            command = "wbc " + " ".join(argv)
            if bar is not None:
                bar.set_postfix_str(command)
            seconds = run_warm_up(argv)
            if bar is not None:
                bar.update()
            elif not args.quiet:
                print(f"wbc compile: {command} ({seconds:.1f} s)", file=sys.stderr, flush=True)
    finally:
        if bar is not None:
            beat.set()
            bar.set_postfix_str("")
            bar.close()
    ran = f" and {len(runs)} warm-up run{'s' if len(runs) > 1 else ''} ({', '.join(' '.join(r) for r in runs)})" \
        if runs else ""
    print(f"wbc compile: the numba kernels of {len(modules)} modules{ran} compiled and cached in "
          f"{time.perf_counter() - t0:.1f} s")
    return 0
