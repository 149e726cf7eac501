"""ProxQP backend: :class:`ProxQPBackend`, proxsuite's dense ProxQP with one warm-started problem per size (rebuilt
only when the number of rows changes), its iterations capped (:data:`PROXQP_MAX_ITER`).
"""

from __future__ import annotations

import numpy as np

from wbc.exceptions import InvalidInputError
from wbc.solvers.base import INFINITE_BOUND, QPBackend

__all__ = ["PROXQP_MAX_ITER", "ProxQPBackend"]

#: Default iteration cap of :class:`ProxQPBackend` (proxsuite ``max_iter``; ``max_iter_in`` min(cap, 100)).
PROXQP_MAX_ITER = 1000


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
        lbf = np.maximum(lb, -INFINITE_BOUND)
        ubf = np.minimum(ub, INFINITE_BOUND)
        lf = np.maximum(l, -INFINITE_BOUND) if n_in else None
        uf = np.minimum(u, INFINITE_BOUND) if n_in else None
        Cn = C if n_in else None
        if self._dims != (n, n_eq, n_in):
            dense = self._proxsuite.proxqp.dense
            qp = dense.QP(n, n_eq, n_in, True)
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
        status = self._qp.results.info.status
        if status != self._proxsuite.proxqp.QPSolverOutput.PROXQP_SOLVED:
            self._dims = None  # restart cold next time
            return None
        return self._qp.results.x.copy()
