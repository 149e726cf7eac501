"""QP solvers: the backends that solve the QP of each formulation, chosen by name, and what runs around them.

Every backend solves

    min_x ½ xᵀ H x + gᵀ x   s.t.   A x = b,   l ≤ C x ≤ u,   lb ≤ x ≤ ub

and returns x, or raises :class:`~wbc.exceptions.SolverError` (:meth:`QPBackend.solve`: one tolerance policy, an
independent re-solve before a failure stands). :func:`make_backend` builds one by name (:func:`available_solvers`;
default :data:`DEFAULT_SOLVER`, ``fast``).

Which solver does what:

* ``fast`` (:class:`FastBackend`, :mod:`wbc.solvers.fast`): the in-house compiled exact active-set kernels — bounds and
  equalities (:mod:`wbc.solvers.box_eq`), inequality rows too (:mod:`wbc.solvers.active_set`) — warm-started, with
  DAQP as fallback; the default, and the solver of the compiled kinematic tick
  (:mod:`wbc.formulations.velocity_kernel`).
* ``daqp`` (:class:`DaqpBackend`, :mod:`wbc.solvers.daqp`): DAQP's dual active-set method called directly, warm-started
  from the previous working set or dual variables, its iterations bounded by the tick's counted work.
* ``proxqp`` (:class:`ProxQPBackend`, :mod:`wbc.solvers.proxqp`): proxsuite's dense ProxQP, warm-started.
* any other installed qpsolvers backend (:class:`QpsolversBackend`, :mod:`wbc.solvers.by_name`): osqp, quadprog, ...,
  cold-started each call.

The files:

* :mod:`wbc.solvers.base` — :class:`QPBackend` (the interface, the solution check, polish and independent re-solve)
  and :class:`TickWork` (a tick's counted work).
* :mod:`wbc.solvers.daqp`, :mod:`wbc.solvers.proxqp`, :mod:`wbc.solvers.by_name`, :mod:`wbc.solvers.fast` — the
  backends above; :mod:`wbc.solvers.registry` — :func:`make_backend`, :func:`available_solvers`,
  :data:`DEFAULT_SOLVER`.
* :mod:`wbc.solvers.independent` — re-solves of a QP a backend reported infeasible: quadprog with the pinned
  variables eliminated, the second opinion of two active-set solvers, the feasibility of the constraints alone.
* :mod:`wbc.solvers.hierarchy` — strict task priorities: the lexicographic cascade of QPs.
* :mod:`wbc.solvers.diagnosis` — which hard constraints conflict after a failed solve (slack-relaxed solve).
* :mod:`wbc.solvers.status` — :class:`SolverStatus`, the exit codes of the in-house kernels, and their plain-int
  constants.
* :mod:`wbc.solvers.linalg` — the compiled dense linear algebra the kernels share (Cholesky, substitutions).
* :mod:`wbc.solvers.box_eq`, :mod:`wbc.solvers.active_set` — the compiled exact QP kernels.
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
