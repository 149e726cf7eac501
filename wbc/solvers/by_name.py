"""Any backend of ``qpsolvers.solve_qp`` by name: :class:`QpsolversBackend` (osqp, quadprog, daqp one-shot, ...),
cold-started each call; the bounds and two-sided rows converted to qpsolvers' form.
"""

from __future__ import annotations

import numpy as np
import qpsolvers

from wbc.solvers.base import INFINITE_BOUND, QPBackend

__all__ = ["QpsolversBackend"]

#: Tight settings per qpsolvers backend so that joint limits hold to solver precision.
_SETTINGS = {
    "osqp": {"eps_abs": 1e-9, "eps_rel": 0.0, "polishing": True, "max_iter": 20000},
}


class QpsolversBackend(QPBackend, role="qpsolvers"):
    """Any backend of ``qpsolvers.solve_qp`` (daqp, osqp, quadprog, ...), cold-started each call.

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
