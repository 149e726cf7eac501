"""QP backends by name (:func:`make_backend`, :func:`available_solvers`, the default ``fast``) and the backends
besides DAQP's: :class:`ProxQPBackend` (proxsuite) and :class:`QpsolversBackend` (``qpsolvers.solve_qp``).

qpsolvers is imported here, with :mod:`wbc.solvers`: its import (tens of milliseconds) would otherwise land inside
the first tick whose failed solve :meth:`~wbc.solvers.base.QPBackend.confirm` re-solves.
"""

from __future__ import annotations

import numpy as np
import qpsolvers

from wbc.exceptions import InvalidInputError, UnknownSolverError
from wbc.solvers.base import INFINITE_BOUND, QPBackend
from wbc.solvers.daqp import DaqpBackend
from wbc.solvers.fast import FastBackend

__all__ = ["DEFAULT_SOLVER", "PROXQP_MAX_ITER", "ProxQPBackend", "QpsolversBackend", "available_solvers",
           "make_backend"]

#: Backend used when none is named (:mod:`wbc.solvers.fast`): the trajectories of "daqp" to < 1e-11, faster
#: (benchmarks/fast_path.py).
DEFAULT_SOLVER = "fast"
#: Tight settings per qpsolvers backend so that joint limits hold to solver precision.
_SETTINGS = {"osqp": {"eps_abs": 1e-9, "eps_rel": 0.0, "polishing": True, "max_iter": 20000}}
#: Default iteration cap of :class:`ProxQPBackend` (proxsuite ``max_iter``; ``max_iter_in`` min(cap, 100)).
PROXQP_MAX_ITER = 1000


class QpsolversBackend(QPBackend, role="qpsolvers"):
    """Any backend of ``qpsolvers.solve_qp`` (daqp, osqp, quadprog, ...), cold-started each call; the bounds and
    two-sided rows converted to qpsolvers' one-sided form.

    Args:
        solver: qpsolvers backend name.
        **settings: passed to the backend, over wbc's tight defaults for that backend (osqp: ``eps_abs=1e-9``,
            ``eps_rel=0``, polishing, 20000 iterations) so that joint limits hold to solver precision.
    """

    def __init__(self, solver: str, tolerance: float = 1e-6, **settings):
        self.name = solver
        self.tolerance = tolerance
        self.settings = {**_SETTINGS.get(solver, {}), **settings}

    def _solve(self, H, g, A, b, C, l, u, lb, ub):
        G = h = None
        if C.shape[0]:
            lo, hi = np.isfinite(l), np.isfinite(u)
            G = np.vstack([C[hi], -C[lo]])
            h = np.concatenate([u[hi], -l[lo]])
        return qpsolvers.solve_qp(
            H, g, G, h, A if A.shape[0] else None, b if A.shape[0] else None,
            np.maximum(lb, -INFINITE_BOUND), np.minimum(ub, INFINITE_BOUND), solver=self.name, **self.settings,
        )


class ProxQPBackend(QPBackend, role="proxqp"):
    """proxsuite's dense ProxQP, warm-started from the previous tick's solution and dual variables.

    Args:
        eps_abs: absolute stopping tolerance of ProxQP (primal and dual residuals).
        tolerance: largest scaled row violation of an accepted answer (:meth:`QPBackend.solve`).
        max_iter: iteration cap (proxsuite ``max_iter``; ``max_iter_in`` min(max_iter, 100)), an integer ≥ 1. A call
            that reaches it is a failed solve, never the unconverged iterate (proxsuite's own caps let one walking QP
            run for minutes).

    Raises:
        InvalidInputError: a ``max_iter`` that is not an integer ≥ 1.
    """

    name = "proxqp"

    def __init__(self, eps_abs: float = 1e-9, tolerance: float = 1e-6, max_iter: int = PROXQP_MAX_ITER):
        import proxsuite

        if isinstance(max_iter, bool) or not isinstance(max_iter, (int, np.integer)) or max_iter < 1:
            raise InvalidInputError(f"ProxQP max_iter must be an integer ≥ 1 (iterations), got {max_iter!r}")
        self.max_iter = int(max_iter)
        self._proxsuite = proxsuite
        self.eps_abs = eps_abs
        self.tolerance = tolerance
        self._qp = None
        self._dims: tuple[int, int, int] | None = None

    def _solve(self, H, g, A, b, C, l, u, lb, ub):
        n, n_eq, n_in = H.shape[0], A.shape[0], C.shape[0]
        lbf, ubf = np.maximum(lb, -INFINITE_BOUND), np.minimum(ub, INFINITE_BOUND)
        lf, uf = (np.maximum(l, -INFINITE_BOUND), np.minimum(u, INFINITE_BOUND)) if n_in else (None, None)
        Cn = C if n_in else None
        if self._dims != (n, n_eq, n_in):
            qp = self._proxsuite.proxqp.dense.QP(n, n_eq, n_in, True)
            qp.settings.eps_abs = self.eps_abs
            qp.settings.eps_rel = 0.0
            qp.settings.verbose = False
            qp.settings.max_iter = self.max_iter  # bounded work (class docstring)
            qp.settings.max_iter_in = min(self.max_iter, 100)
            qp.init(H, g, A, b, Cn, lf, uf, lbf, ubf)
            qp.solve()
            # Warm start only once a previous result exists: proxsuite 0.8 segfaults otherwise.
            qp.settings.initial_guess = self._proxsuite.proxqp.InitialGuess.WARM_START_WITH_PREVIOUS_RESULT
            self._qp, self._dims = qp, (n, n_eq, n_in)
        else:
            self._qp.update(H, g, A, b, Cn, lf, uf, lbf, ubf)
            self._qp.solve()
        if self._qp.results.info.status != self._proxsuite.proxqp.QPSolverOutput.PROXQP_SOLVED:
            self._dims = None  # restart cold next time
            return None
        return self._qp.results.x.copy()


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
