"""QP solvers: the backends that solve each formulation's QP (:mod:`~wbc.solvers.qp_data`), chosen by name
(:func:`make_backend`, :func:`available_solvers`, default :data:`DEFAULT_SOLVER`: ``fast``, the in-house compiled
kernels with DAQP as fallback), and what runs around them: the interface and a tick's counted work
(:mod:`~wbc.solvers.base`), the compiled inverse-dynamics solver and the ladder after it
(:mod:`~wbc.solvers.compiled_id`, :mod:`~wbc.solvers.fallback`, :mod:`~wbc.solvers.independent`), the cascade of
strict levels (:mod:`~wbc.solvers.hierarchy`), which hard constraints conflict (:mod:`~wbc.solvers.diagnosis`), the
kernels' exit codes and shared linear algebra (:mod:`~wbc.solvers.status`, :mod:`~wbc.solvers.linalg`).
"""

from __future__ import annotations

from wbc.solvers.base import QPBackend, TickWork
from wbc.solvers.daqp import DaqpBackend
from wbc.solvers.fast import FastBackend
from wbc.solvers.registry import DEFAULT_SOLVER, ProxQPBackend, QpsolversBackend, available_solvers, make_backend
from wbc.solvers.status import SolverStatus

__all__ = ["DEFAULT_SOLVER", "DaqpBackend", "FastBackend", "ProxQPBackend", "QPBackend", "QpsolversBackend",
           "SolverStatus", "TickWork", "available_solvers", "make_backend"]
