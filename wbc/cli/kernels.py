"""``wbc compile``: compile every numba kernel ahead of the first run (the step after ``pip install``).

wbc's kernels are compiled on first use and cached on disk (``__pycache__`` next to each source file, or under
``NUMBA_CACHE_DIR``); the first run after an install would otherwise spend a minute or more compiling them before
its first tick. ``wbc compile`` runs every kernel loader (:func:`wbc.compiled.compile_all`) with a progress bar on a
terminal (one line per module otherwise); run again, it loads the cached kernels and takes seconds.
"""

from __future__ import annotations

import sys
import time

__all__ = ["register", "check_compile_args", "cmd_compile"]


def register(sub, add_outputs=None) -> None:
    """Add the ``compile`` sub-command to ``wbc``'s sub-parsers (``add_outputs`` is not used)."""
    from wbc.compiled import LOADER_MODULES

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
    """Raises InvalidInputError: a module without kernel loader (see :data:`wbc.compiled.LOADER_MODULES`)."""
    from wbc.compiled import loader_modules

    loader_modules(args.modules)


def cmd_compile(args) -> int:
    """`wbc compile`: run the loaders of every (or each given) kernel module, one module at a time, with a progress
    bar on a terminal naming the module being compiled (redrawn every second), one line per module otherwise; prints
    the total time. Exit code 0."""
    import threading

    from wbc.cli.output import sigint_received, uncompiled_kernels
    from wbc.compiled import compile_all, loader_modules

    modules = loader_modules(args.modules)
    t0 = time.perf_counter()
    bar = beat = None
    if not args.quiet:
        print(f"wbc compile: compiling the numba kernels of {len(modules)} modules "
              f"({len(uncompiled_kernels())} without on-disk cache; a minute or two once) ...", file=sys.stderr,
              flush=True)
        if getattr(sys.stderr, "isatty", lambda: False)():
            from tqdm import tqdm

            bar = tqdm(total=len(modules), desc="wbc compile", unit="module", file=sys.stderr,
                       bar_format="{desc}: {n_fmt}/{total_fmt} modules |{bar}| {elapsed} {postfix}")
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
