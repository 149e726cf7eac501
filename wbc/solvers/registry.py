"""QP backends by name: :func:`make_backend`, :func:`available_solvers` and the default, ``fast``.

qpsolvers is imported here, with :mod:`wbc.solvers`: its import (tens of milliseconds) would otherwise land inside
the first tick whose failed solve :meth:`~wbc.solvers.base.QPBackend.confirm` re-solves.
"""

from __future__ import annotations

import qpsolvers

from wbc.exceptions import UnknownSolverError
from wbc.solvers.base import QPBackend
from wbc.solvers.by_name import QpsolversBackend
from wbc.solvers.daqp import DaqpBackend
from wbc.solvers.fast import FastBackend
from wbc.solvers.proxqp import ProxQPBackend

__all__ = ["DEFAULT_SOLVER", "available_solvers", "make_backend"]

#: Backend used when none is named (:mod:`wbc.solvers.fast`): the trajectories of "daqp" to < 1e-11, faster
#: (benchmarks/fast_path.py).
DEFAULT_SOLVER = "fast"


def available_solvers() -> list[str]:
    """Names accepted by :func:`make_backend` (installed qpsolvers backends, and ``fast``: :mod:`wbc.solvers.fast`)."""
    return sorted([*qpsolvers.available_solvers, "fast"])


def make_backend(name: str, **settings) -> QPBackend:
    """Create a backend by name: ``fast``, ``daqp``, ``proxqp`` or any other installed qpsolvers backend.

    Args:
        name: backend name (:func:`available_solvers`).
        **settings: solver settings passed to the backend (e.g. ``primal_tol=1e-9`` for daqp).

    Raises:
        UnknownSolverError: the name is not installed; the message lists the available ones.
    """
    if name not in available_solvers():
        raise UnknownSolverError(f"unknown or uninstalled QP solver {name!r}; available: {available_solvers()}")
    own = {"fast": FastBackend, "proxqp": ProxQPBackend, "daqp": DaqpBackend}.get(name)
    return QpsolversBackend(name, **settings) if own is None else own(**settings)
