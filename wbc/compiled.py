"""Loading compiled (numba, ``cache=True``) kernels once per process.

numba compiles a kernel, or loads it from its on-disk cache, on its first call with a given set of argument types.
That first call takes from milliseconds (cache) to seconds (compilation); paid inside a controller's first tick it
would break the tick budget. Each module with kernels therefore has one loader, a function without arguments that
calls its kernels on small example arrays of the types a real call uses, decorated with :func:`once_per_process` and
called when a task, constraint or backend is constructed.

``wbc compile`` (:mod:`wbc.cli.kernels`) imports every module with a loader and runs it (:func:`run_loaders`) ahead
of the first run, after an install, so that the first run finds every kernel in the on-disk cache.
"""

from __future__ import annotations

import functools
from time import perf_counter
from typing import Callable, TypeVar

__all__ = ["FASTMATH", "NO_NRT", "once_per_process", "run_loaders", "set_load_listener"]

#: LLVM fast-math flags of the compiled kernels: reassociation (vectorised dot products) and fused multiply-add only;
#: ±inf bounds stay legitimate input (no "no-inf/no-nan" assumption).
FASTMATH = {"reassoc", "contract"}  # a set: numba takes a bool, dict or set

#: jit options of the per-tick kernels that allocate no array: numba's reference-counting runtime (NRT) off, so that
#: an array argument is unboxed without the MemInfo that NRT creates and frees around every call (an allocation in
#: such a kernel is a compile-time error)
NO_NRT = {"_nrt": False}

R = TypeVar("R")

_listener: Callable[[str, float], None] | None = None
_loaders: dict[str, list[Callable[[], object]]] = {}  # module name -> its once_per_process loaders (once imported)

def set_load_listener(listener: Callable[[str, float], None] | None) -> Callable[[str, float], None] | None:
    """Install ``listener(module, seconds)``, called after each loader of :func:`once_per_process` has run (the
    module that defines the loader and the wall time the load — or the compilation — took), e.g. to show progress
    while the kernels compile on a first run. None removes it.

    Returns:
        The listener installed before (None if none).
    """
    global _listener
    previous, _listener = _listener, listener
    return previous


def once_per_process(load: Callable[[], R]) -> Callable[[], R | None]:
    """Decorator: the decorated loader runs the first time it is called in this process and returns its value;
    later calls return None at once.

    Args:
        load: a function without arguments (e.g. one that calls compiled kernels on example arrays).

    Returns:
        The wrapped function (same name and docstring).
    """
    done = False

    @functools.wraps(load)
    def wrapper() -> R | None:
        nonlocal done
        if done:
            return None
        done = True
        if _listener is None:
            return load()
        t0 = perf_counter()
        value = load()
        _listener(load.__module__, perf_counter() - t0)
        return value

    _loaders.setdefault(load.__module__, []).append(wrapper)
    return wrapper


def run_loaders(module: str) -> int:
    """Run the :func:`once_per_process` loaders defined in the module named ``module`` (imported beforehand; none
    if it defines none): their kernels are compiled and written to numba's on-disk cache (``__pycache__`` next to
    the source, or under ``NUMBA_CACHE_DIR``), or loaded from it. Loaders that already ran in this process do not
    run again.

    Args:
        module: a dotted module name (e.g. ``"wbc.tasks.frame"``); one not imported yet has no loaders registered.

    Returns:
        The number of loaders the module defines (0 for a module without loaders or not imported).
    """
    loaders = _loaders.get(module, ())
    for load in loaders:
        load()
    return len(loaders)
