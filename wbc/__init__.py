"""wbc: whole-body kinematics and control for humanoid robots, built on Pinocchio.

Data flows one way: robot model (:func:`load_robot`) → kinematics (:class:`Configuration`) → tasks and
constraints (:mod:`wbc.tasks`, :mod:`wbc.constraints`) → one QP per tick (:class:`KinematicController`) →
command v, integrated on the manifold.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # the names below are imported on first use (PEP 562): `import wbc` itself stays instant
    from wbc.configuration import Configuration
    from wbc.controllers.kinematic import KinematicController
    from wbc.robot import Robot, catalog, load_robot
    from wbc.solve import solve_ik

__all__ = ["Configuration", "KinematicController", "Robot", "catalog", "load_robot", "solve_ik"]
__version__ = "0.1.0"

# numba does not see a change in a file that a cached kernel calls into: drop wbc's kernel caches when any kernel
# source changed (wbc.kernel_cache; about 1 ms when none did).
from wbc.kernel_cache import drop_stale_caches  # noqa: E402

drop_stale_caches()

# Loading these modules loads (or, on the first run after an install, compiles) wbc's numba kernels: seconds to a
# minute. Deferring them lets `wbc ...` say so and handle Ctrl-C before that work starts.
_LAZY = {"Configuration": "wbc.configuration", "KinematicController": "wbc.controllers.kinematic",
         "Robot": "wbc.robot", "catalog": "wbc.robot", "load_robot": "wbc.robot", "solve_ik": "wbc.solve"}


def __getattr__(name: str):
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'wbc' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
