"""QP solvers: the backends that solve the QP of each formulation, chosen by name, and what runs around them.

Every backend solves

    min_x ½ xᵀ H x + gᵀ x   s.t.   A x = b,   l ≤ C x ≤ u,   lb ≤ x ≤ ub

and returns x, or raises :class:`~wbc.exceptions.SolverError` (:meth:`QPBackend.solve`: one tolerance policy, an
independent re-solve before a failure stands). :func:`make_backend` builds one by name (:func:`available_solvers`;
default :data:`DEFAULT_SOLVER`, ``fast``). The modules:

* :mod:`~wbc.solvers.base` — :class:`QPBackend` (the interface, the solution check, polish and independent re-solve)
  and :class:`TickWork` (a tick's counted work); :mod:`~wbc.solvers.qp_data` — the QP handed over and the answer.
* :mod:`~wbc.solvers.fast` — ``fast``, :class:`FastBackend`: the in-house compiled exact active-set kernels (bounds
  and equalities :mod:`~wbc.solvers.box_eq`, inequality rows too :mod:`~wbc.solvers.active_set`), warm-started,
  DAQP as fallback; the default and the compiled kinematic tick's solver (:mod:`wbc.formulations.velocity_kernel`).
* :mod:`~wbc.solvers.daqp` — ``daqp``, :class:`DaqpBackend`: DAQP's dual active set called directly, warm-started;
  :mod:`~wbc.solvers.proxqp` — ``proxqp``, :class:`ProxQPBackend`; :mod:`~wbc.solvers.by_name` — any other
  qpsolvers backend (:class:`QpsolversBackend`, cold-started); :mod:`~wbc.solvers.registry` — the names.
* :mod:`~wbc.solvers.compiled_id` — the compiled solver of the inverse-dynamics QP (its block strategy
  :mod:`~wbc.solvers.active_set_block`); :mod:`~wbc.solvers.fallback` — the ladder of solvers asked after it.
* :mod:`~wbc.solvers.independent` — re-solves of a QP a backend reported infeasible; :mod:`~wbc.solvers.hierarchy`
  — the lexicographic cascade of strict levels; :mod:`~wbc.solvers.diagnosis` — which hard constraints conflict.
* :mod:`~wbc.solvers.status` — the kernels' exit codes; :mod:`~wbc.solvers.linalg` — their shared linear algebra.
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
