"""Dense QP backends.

Every backend solves

    min_x ½ xᵀ H x + gᵀ x   s.t.   A x = b,   l ≤ C x ≤ u,   lb ≤ x ≤ ub

and returns x, or raises :class:`~wbc.exceptions.SolverError`. ``daqp`` calls DAQP's dual active-set solver
directly (no conversion layer; equalities as sense-5 rows, bounds as DAQP's simple bounds, the previous tick's
active bounds as warm start); ``proxqp`` keeps one warm-started ``proxsuite.proxqp.dense.QP`` per problem size
(rebuilt only when the number of rows changes); every other name goes through ``qpsolvers.solve_qp``. After a solve, the solution is checked against every constraint: a
violation above the backend's tolerance is a failure; one below it is projected onto the bounds so that
integrating x never crosses a joint limit.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod

import numpy as np
import qpsolvers

from wbc.exceptions import SolverError, UnknownSolverError

__all__ = ["QPBackend", "DaqpBackend", "ProxQPBackend", "QpsolversBackend", "make_backend", "available_solvers"]

#: Backend used when none is named: measured fastest on the Talos tick while holding bounds exactly
#: (benchmarks/: ``wbc bench`` solver table).
DEFAULT_SOLVER = "daqp"

_BIG = 1e10  # stands for an infinite bound where a backend needs a finite number


def available_solvers() -> list[str]:
    """Names accepted by :func:`make_backend` (installed qpsolvers backends)."""
    return sorted(qpsolvers.available_solvers)


class QPBackend(ABC):
    """Common interface. ``tolerance`` is the largest constraint violation accepted (in constraint units)."""

    name: str = ""
    tolerance: float = 1e-6

    @abstractmethod
    def _solve(self, H, g, A, b, C, l, u, lb, ub) -> np.ndarray | None:
        """Raw solution, or None on failure."""

    def solve(self, H, g, A, b, C, l, u, lb, ub) -> np.ndarray:
        """Solve the QP (module docstring). A/C may have 0 rows; lb/ub are (n,) with ±inf for free entries.

        Returns:
            x (n,).

        Raises:
            SolverError: the backend failed, returned a non-finite x, or violates a constraint by more than
                ``tolerance``.
        """
        x = self._solve(H, g, A, b, C, l, u, lb, ub)
        if x is None or not math.isfinite(x @ x):
            raise SolverError(f"QP backend {self.name!r} found no solution")
        viol = self.violation(x, A, b, C, l, u, lb, ub)
        if viol > self.tolerance:
            raise SolverError(f"QP backend {self.name!r} returned a solution violating constraints by {viol:.3g}")
        return np.clip(x, lb, ub, out=x)

    @staticmethod
    def violation(x, A, b, C, l, u, lb, ub) -> float:
        """Largest violation of any constraint by x (0 when feasible)."""
        worst = max(0.0, (lb - x).max(), (x - ub).max())
        if A.shape[0]:
            worst = max(worst, np.abs(A @ x - b).max())
        if C.shape[0]:
            cx = C @ x
            worst = max(worst, (l - cx).max(), (cx - u).max())
        return float(worst)


class DaqpBackend(QPBackend):
    """DAQP (Arnström, Bemporad, Axehill, "A dual active-set solver for embedded quadratic programming using
    recursive LDLᵀ updates", IEEE TAC 2022) called directly: bounds as simple bounds, equalities as sense-5 rows,
    the previous tick's active bounds as warm start (sense 1)."""

    name = "daqp"

    def __init__(self, tolerance: float = 1e-6):
        import daqp

        self._daqp = daqp
        self.tolerance = tolerance
        self._sense: np.ndarray | None = None
        self._layout: tuple[int, int, int] | None = None

    def _solve(self, H, g, A, b, C, l, u, lb, ub):
        n, n_eq, n_in = H.shape[0], A.shape[0], C.shape[0]
        if self._layout != (n, n_eq, n_in):
            self._sense = np.zeros(n + n_eq + n_in, dtype=np.int32)
            self._layout = (n, n_eq, n_in)
        sense = self._sense
        sense[n:n + n_eq] = 5
        if n_in:
            G = np.vstack([A, C]) if n_eq else C
            upper = np.concatenate([ub, b, u])
            lower = np.concatenate([lb, b, l])
        else:
            G = A
            upper = np.concatenate([ub, b])
            lower = np.concatenate([lb, b])
        x, _, exitflag, info = self._daqp.solve(H, g, G, upper, lower, sense)
        if exitflag < 1:
            sense[:] = 0
            return None
        active = np.abs(info["lam"]) > 0
        sense[:n] = active[:n]
        if n_in:
            sense[n + n_eq:] = active[n + n_eq:]
        return x


class ProxQPBackend(QPBackend):
    """proxsuite's dense ProxQP, warm-started from the previous tick's solution and dual variables.

    Args:
        eps_abs: absolute stopping tolerance of ProxQP (primal and dual residuals).
    """

    name = "proxqp"

    def __init__(self, eps_abs: float = 1e-9, tolerance: float = 1e-6):
        import proxsuite

        self._proxsuite = proxsuite
        self.eps_abs = eps_abs
        self.tolerance = tolerance
        self._qp = None
        self._dims: tuple[int, int, int] | None = None

    def _solve(self, H, g, A, b, C, l, u, lb, ub):
        n, n_eq, n_in = H.shape[0], A.shape[0], C.shape[0]
        lbf = np.maximum(lb, -_BIG)
        ubf = np.minimum(ub, _BIG)
        lf = np.maximum(l, -_BIG) if n_in else None
        uf = np.minimum(u, _BIG) if n_in else None
        Cn = C if n_in else None
        if self._dims != (n, n_eq, n_in):
            dense = self._proxsuite.proxqp.dense
            qp = dense.QP(n, n_eq, n_in, True)
            qp.settings.eps_abs = self.eps_abs
            qp.settings.eps_rel = 0.0
            qp.settings.verbose = False
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


class QpsolversBackend(QPBackend):
    """Any backend of ``qpsolvers.solve_qp`` (daqp, osqp, quadprog, ...), cold-started each call.

    Args:
        solver: qpsolvers backend name.
        **settings: passed to the backend (e.g. ``eps_abs=1e-9`` for osqp).
    """

    def __init__(self, solver: str, tolerance: float = 1e-6, **settings):
        self.name = solver
        self.tolerance = tolerance
        self.settings = settings

    def _solve(self, H, g, A, b, C, l, u, lb, ub):
        G = h = None
        if C.shape[0]:
            lo, hi = np.isfinite(l), np.isfinite(u)
            G = np.vstack([C[hi], -C[lo]])
            h = np.concatenate([u[hi], -l[lo]])
        return qpsolvers.solve_qp(
            H, g, G, h, A if A.shape[0] else None, b if A.shape[0] else None,
            np.maximum(lb, -_BIG), np.minimum(ub, _BIG), solver=self.name, **self.settings,
        )


#: Tight settings per qpsolvers backend so that joint limits hold to solver precision.
_SETTINGS = {
    "osqp": {"eps_abs": 1e-9, "eps_rel": 0.0, "polishing": True, "max_iter": 20000},
}


def make_backend(name: str) -> QPBackend:
    """Create a backend by name: ``proxqp`` (warm-started proxsuite) or any installed qpsolvers backend.

    Raises:
        UnknownSolverError: the name is not installed; the message lists the available ones.
    """
    if name not in available_solvers():
        raise UnknownSolverError(f"unknown or uninstalled QP solver {name!r}; available: {available_solvers()}")
    if name == "proxqp":
        return ProxQPBackend()
    if name == "daqp":
        return DaqpBackend()
    return QpsolversBackend(name, **_SETTINGS.get(name, {}))
