"""Loading compiled (numba, ``cache=True``) kernels once per process.

numba compiles a kernel, or loads it from its on-disk cache, on its first call with a given set of argument types.
That first call takes from milliseconds (cache) to seconds (compilation); paid inside a controller's first tick it
would break the tick budget. Each module with kernels therefore has one loader, a function without arguments that
calls its kernels on small example arrays of the types a real call uses, decorated with :func:`once_per_process` and
called when a task, constraint or backend is constructed.

A process's first construction of such an object therefore compiles, or loads, the kernels of that object's module,
and only those: a command compiles what it needs when it first needs it (:func:`set_load_listener` reports each
module as it becomes ready). ``wbc compile`` (:mod:`wbc.cli.kernels`) runs every loader (:func:`run_loaders`) ahead
of time, in parallel worker processes that share numba's on-disk cache, so that no later run compiles any.

A call through a numba dispatcher first finds the compiled version for its arguments' types (their numba types,
then a lookup); a control tick's hot calls, whose arguments are their caller's own buffers of fixed types, call that
version directly (:func:`specialise`), once the caller has it.
"""

from __future__ import annotations

import functools
import os
from time import perf_counter
from typing import Callable, TypeVar

import numba as nb
import numpy as np

__all__ = ["FASTMATH", "NO_NRT", "CHECK_TYPES", "once_per_process", "run_loaders", "set_load_listener", "specialise"]

#: LLVM fast-math flags of the compiled kernels: reassociation (vectorised dot products) and fused multiply-add only;
#: ±inf bounds stay legitimate input (no "no-inf/no-nan" assumption).
FASTMATH = {"reassoc", "contract"}  # a set: numba takes a bool, dict or set

#: jit options of the per-tick kernels that allocate no array: numba's reference-counting runtime (NRT) off, so that
#: an array argument is unboxed without the MemInfo that NRT creates and frees around every call (an allocation in
#: such a kernel is a compile-time error)
NO_NRT = {"_nrt": False}

R = TypeVar("R")

#: When true (environment variable ``WBC_CHECK_KERNEL_TYPES=1`` at import; the test suite sets it), every call of a
#: :func:`specialise` function first checks that its arguments have the numba types it was specialised for.
CHECK_TYPES: bool = os.environ.get("WBC_CHECK_KERNEL_TYPES", "") == "1"

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


def specialise(kernel, *args) -> Callable:
    """The compiled version of the numba dispatcher ``kernel`` for the numba types of ``args`` (loaded from the
    on-disk cache, or compiled, now; the same version a call ``kernel(*args)`` would run), callable without the
    dispatcher's per-call type resolution.

    The returned function does not check its arguments: a number is converted to the specialised type (as
    ``float(x)`` / ``int(x)``) and an array of another dtype raises TypeError, but an array of another layout
    (strided instead of contiguous) or number of dimensions is read as if it had the specialised one. Use it only where every argument is of a fixed type by construction: the caller's own preallocated buffers,
    Pinocchio's views of its Data, or inputs checked for dtype, shape and contiguity just before the call. With
    :data:`CHECK_TYPES` each call checks its array arguments' numba types and raises TypeError on a difference.

    Args:
        kernel: a numba dispatcher (``numba.njit`` function).
        *args: arguments of a real call (their numba types select the version).

    Returns:
        The compiled function, called with arguments of the same types as ``args``.

    Raises:
        AttributeError: ``kernel`` is not a numba dispatcher (it has no ``compile``).
        numba.core.errors.TypingError: the kernel does not compile for these argument types (as a call would).
        TypeError: (from the returned function) an array argument of another dtype; with :data:`CHECK_TYPES`, any
            array argument of another numba type, or another number of arguments.
    """
    types = tuple(nb.typeof(a) for a in args)
    entry = kernel.compile(types)
    if not CHECK_TYPES:
        return entry

    arrays = [i for i, a in enumerate(args) if isinstance(a, np.ndarray)]

    def checked(*call_args):
        got = tuple(nb.typeof(a) for a in call_args)
        if len(got) != len(types) or any(got[i] != types[i] for i in arrays):
            raise TypeError(f"{kernel.__name__} specialised for {types}, called with {got}")
        return entry(*call_args)

    return checked
