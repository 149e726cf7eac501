"""Loading compiled (numba, ``cache=True``) kernels once per process.

numba compiles a kernel, or loads it from its on-disk cache, on its first call with a given set of argument types.
That first call takes from milliseconds (cache) to seconds (compilation); paid inside a controller's first tick it
would break the tick budget. Each module with kernels therefore has one loader, a function without arguments that
calls its kernels on small example arrays of the types a real call uses, decorated with :func:`once_per_process` and
called when a task, constraint or backend is constructed.

:func:`compile_all` runs every loader of :data:`LOADER_MODULES` ahead of time (``wbc compile``, after an install),
so that the first run finds every kernel in the on-disk cache.
"""

from __future__ import annotations

import functools
import importlib
from time import perf_counter
from typing import Callable, Iterable, TypeVar

from wbc.exceptions import InvalidInputError

__all__ = ["FASTMATH", "LOADER_MODULES", "compile_all", "loader_modules", "once_per_process", "set_load_listener"]

#: LLVM fast-math flags of the compiled kernels: reassociation (vectorised dot products) and fused multiply-add only;
#: ±inf bounds stay legitimate input (no "no-inf/no-nan" assumption).
FASTMATH = {"reassoc", "contract"}  # a set: numba takes a bool, dict or set

R = TypeVar("R")

_listener: Callable[[str, float], None] | None = None
_loaders: dict[str, list[Callable[[], object]]] = {}  # module name -> its once_per_process loaders (once imported)

#: Every module with a :func:`once_per_process` loader, the kinematic controller's first (what ``wbc walk`` loads),
#: then the inverse-dynamics controller's and the simulation's (``wbc sim``).
LOADER_MODULES = (
    "wbc.formulations.velocity_kernel", "wbc.solvers.fast", "wbc.tasks.frame", "wbc.configuration", "wbc.tasks.com",
    "wbc.tasks.posture", "wbc.constraints.contact", "wbc.constraints.zmp", "wbc.constraints.acceleration",
    "wbc.constraints.braking", "wbc.constraints.limits", "wbc.formulations.reference",
    "wbc.formulations.idkernel", "wbc.dynamics.controller", "wbc.constraints.joint_acceleration_bounds",
    "wbc.sim.actuators", "wbc.sim.closed_loop", "wbc.sim.conventions", "wbc.sim.estimated_state",
    "wbc.sim.outcome", "wbc.sim.sensors", "wbc.sim.walk",
)


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
    """Import each module and run its loaders: every kernel they call is compiled and written to numba's on-disk
    cache (``__pycache__`` next to the source, or under ``NUMBA_CACHE_DIR``), or loaded from it when already there.
    Loaders that already ran in this process are not run again.

    Args:
        modules: names among :data:`LOADER_MODULES` (default, or empty: all of them), loaded in this order.

    Returns:
        The wall time in seconds each module took (import and loaders), by name.

    Raises:
        InvalidInputError: a name is not in :data:`LOADER_MODULES` (before any module is imported).
    """
    seconds = {}
    for name in loader_modules(modules):
        t0 = perf_counter()
        importlib.import_module(name)
        for load in _loaders.get(name, ()):
            load()
        seconds[name] = perf_counter() - t0
    return seconds
