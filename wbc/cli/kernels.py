"""``wbc compile``: compile every numba kernel ahead of the first run (the step after ``pip install``).

wbc's kernels are compiled on first use and cached on disk (``__pycache__`` next to each source file, or under
``NUMBA_CACHE_DIR``); the first run after an install would otherwise spend a minute or more compiling them before
its first tick. ``wbc compile`` runs every kernel loader (:func:`compile_all`) with a progress bar on a
terminal (one line per module otherwise); run again, it loads the cached kernels and takes seconds.
"""

from __future__ import annotations

import sys
import time
from typing import Iterable

from wbc.exceptions import InvalidInputError

__all__ = ["LOADER_MODULES", "register", "check_compile_args", "cmd_compile", "compile_all", "loader_modules"]

#: Every module with a :func:`wbc.compiled.once_per_process` loader, the kinematic controller's first (what
#: ``wbc walk`` loads), then the inverse-dynamics controller's and the simulation's (``wbc sim``).
LOADER_MODULES = (
    "wbc.formulations.velocity_kernel", "wbc.solvers.fast", "wbc.tasks.frame", "wbc.configuration", "wbc.tasks.com",
    "wbc.tasks.posture", "wbc.constraints.contact", "wbc.constraints.zmp", "wbc.constraints.acceleration",
    "wbc.constraints.braking", "wbc.constraints.limits", "wbc.formulations.reference",
    "wbc.formulations.idkernel", "wbc.dynamics.controller", "wbc.constraints.joint_acceleration_bounds",
    "wbc.sim.actuators", "wbc.sim.closed_loop", "wbc.sim.conventions", "wbc.sim.estimated_state",
    "wbc.sim.outcome", "wbc.sim.sensors", "wbc.sim.walk",
)


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
    """`wbc compile`: run the loaders of every (or each given) kernel module, one module at a time, with a progress
    bar on a terminal naming the module being compiled (redrawn every second), one line per module otherwise; prints
    the total time. Exit code 0."""
    import threading

    from wbc.cli.output import sigint_received, uncompiled_kernels

    modules = loader_modules(args.modules)
    t0 = time.perf_counter()
    bar = beat = None
    if not args.quiet:
        missing = len(uncompiled_kernels(modules))
        print(f"wbc compile: compiling the numba kernels of {len(modules)} modules ({missing} without on-disk cache; "
              "a minute or two once) ..." if missing else
              f"wbc compile: loading the cached numba kernels of {len(modules)} modules ...", file=sys.stderr, flush=True)
        if getattr(sys.stderr, "isatty", lambda: False)():
            from tqdm import tqdm

            bar = tqdm(total=len(modules), desc="wbc compile", unit="module", file=sys.stderr,
                       bar_format="{desc}: {n_fmt}/{total_fmt} modules |{bar}| {elapsed}{postfix}")  # postfix: ", module"
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
    finally:
        if bar is not None:
            beat.set()
            bar.set_postfix_str("")
            bar.close()
    print(f"wbc compile: the numba kernels of {len(modules)} modules compiled and cached in "
          f"{time.perf_counter() - t0:.1f} s")
    return 0
