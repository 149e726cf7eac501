"""QP solvers: the backends that solve the QP of each formulation (:mod:`~wbc.solvers.qp_data` states it), chosen by
name (:func:`make_backend`, :func:`available_solvers`, default :data:`DEFAULT_SOLVER`), and what runs around them.

* :mod:`~wbc.solvers.base` — :class:`QPBackend` (the interface, the solution check, polish, independent re-solve)
  and :class:`TickWork` (a tick's counted work).
* :mod:`~wbc.solvers.fast` — ``fast``, the default: the in-house compiled active-set kernels
  (:mod:`~wbc.solvers.box_eq`, :mod:`~wbc.solvers.active_set`), DAQP as fallback; :mod:`~wbc.solvers.daqp` —
  ``daqp``; :mod:`~wbc.solvers.proxqp` — ``proxqp``; :mod:`~wbc.solvers.by_name` — any other qpsolvers backend.
* :mod:`~wbc.solvers.compiled_id` — the compiled inverse-dynamics solver; :mod:`~wbc.solvers.fallback` — the ladder
  of solvers asked after it; :mod:`~wbc.solvers.independent` — re-solves of a QP reported infeasible.
* :mod:`~wbc.solvers.hierarchy` — the cascade of strict levels; :mod:`~wbc.solvers.diagnosis` — which hard
  constraints conflict; :mod:`~wbc.solvers.status` and :mod:`~wbc.solvers.linalg` — the kernels' exit codes and
  shared linear algebra.
"""

from __future__ import annotations

from wbc.solvers.base import QPBackend, TickWork
from wbc.solvers.by_name import QpsolversBackend
from wbc.solvers.daqp import DaqpBackend
from wbc.solvers.fast import FastBackend
from wbc.solvers.proxqp import ProxQPBackend
from wbc.solvers.registry import DEFAULT_SOLVER, available_solvers, make_backend
from wbc.solvers.status import SolverStatus

__all__ = ["DEFAULT_SOLVER", "DaqpBackend", "FastBackend", "ProxQPBackend", "QPBackend", "QpsolversBackend",
           "SolverStatus", "TickWork", "available_solvers", "make_backend"]
