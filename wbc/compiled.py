"""Loading compiled (numba, ``cache=True``) kernels once per process.

numba compiles a kernel, or loads it from its on-disk cache, on its first call with a given set of argument types.
That first call takes from milliseconds (cache) to seconds (compilation); paid inside a controller's first tick it
would break the tick budget. Each module with kernels therefore has one loader, a function without arguments that
calls its kernels on small example arrays of the types a real call uses, decorated with :func:`once_per_process` and
called when a task, constraint or backend is constructed.
"""

from __future__ import annotations

import functools
from typing import Callable, TypeVar

__all__ = ["once_per_process"]

R = TypeVar("R")


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
        return load()

    return wrapper
