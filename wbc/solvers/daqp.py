"""DAQP backend: :class:`DaqpBackend`, DAQP's dual active-set solver called directly (no conversion layer)."""

from __future__ import annotations

import math
from time import thread_time

import numpy as np

from wbc.exceptions import InvalidInputError
from wbc.solvers.base import PROX_ITERATIONS_PER_SOLVE, QPBackend

__all__ = ["DAQP_ITERATION_COST", "DAQP_PRIMAL_TOL", "DUAL_RETRY_PRIMAL_FACTOR", "DaqpBackend", "ITERATION_LIMIT",
           "MEASURED_CALL_ITERATIONS", "MEASURED_COST_DECAY", "MIN_CALL_ITERATIONS", "WORK_LIMIT_FACTOR"]

#: DAQP's iteration cap in :class:`DaqpBackend` (unless its settings give ``iter_limit``)
ITERATION_LIMIT = 1000

#: factor of the work cap where a DAQP call stops, and its least iterations (:meth:`DaqpBackend.call_limit`)
WORK_LIMIT_FACTOR = 1.9
MIN_CALL_ITERATIONS = 10

#: CPU time (s) of one DAQP iteration assumed by :attr:`DaqpBackend.deadline` (a humanoid's inverse-dynamics QP,
#: 46–62 variables, ~190 constraints; benchmarks/README.md, "The ID failure path ordered by cost")
DAQP_ITERATION_COST = 3.5e-6
#: a call under a deadline measures its CPU time per iteration when it ran at least this many (:meth:`_timed`);
#: the measured cost falls by MEASURED_COST_DECAY per call that measured less, and rises at once
MEASURED_CALL_ITERATIONS = 50
MEASURED_COST_DECAY = 0.97
#: DAQP's exit flag of a call stopped by its iteration limit
_DAQP_ITERATION_LIMIT = -4
#: DAQP's default ``primal_tol``
DAQP_PRIMAL_TOL = 1e-6
#: ``warm_start="dual"``: a failed cold solve is asked once more with DAQP's primal tolerance at this multiple of
#: the backend's ``tolerance``
DUAL_RETRY_PRIMAL_FACTOR = 10.0


class DaqpBackend(QPBackend, role="daqp"):
    """DAQP (Arnström, Bemporad, Axehill, "A dual active-set solver for embedded quadratic programming using
    recursive LDLᵀ updates", IEEE TAC 67(8), 2022): bounds are its simple bounds, equalities sense-5 rows. A failed
    warm-started solve is repeated cold (a fresh workspace, then the one-shot ``daqp.solve``); a workspace call that
    ran its whole ``iter_limit`` (cycling) is repeated with the one-shot call first.

    Args:
        tolerance: largest constraint violation accepted (constraint units).
        warm_start: ``"workspace"`` (persistent ``daqp.Model``, the previous working set; fastest on the kinematic
            tick) or ``"dual"`` (one-shot ``daqp.solve`` from the previous dual variables; fastest on the
            inverse-dynamics QP, many inequalities).
        **settings: DAQP settings (e.g. ``eps_prox``, ``primal_tol``), ``iter_limit`` default :data:`ITERATION_LIMIT`.
            A call stopped by its limit (:meth:`call_limit`) is a failed attempt, never an unconverged answer.

    Raises:
        InvalidInputError: unknown ``warm_start``.
    """

    name = "daqp"

    def __init__(self, tolerance: float = 1e-6, warm_start: str = "workspace", **settings):
        import daqp

        if warm_start not in ("workspace", "dual"):
            raise InvalidInputError(f"warm_start must be 'workspace' or 'dual', got {warm_start!r}")
        self._daqp = daqp
        self.tolerance = tolerance
        self.warm_start = warm_start
        self.settings = {"iter_limit": ITERATION_LIMIT, **settings}
        if self.settings.get("eps_prox", 0.0) > 0.0:
            self.iterations_per_solve = PROX_ITERATIONS_PER_SOLVE  # a proximal iteration's work (TickWork)
        self._model = None
        self._cold_ran = False
        self._dual: np.ndarray | None = None
        self._layout: tuple[int, int, int] | None = None
        #: DAQP's multipliers of the last solve that returned a solution ((n + n_eq + n_in,): bounds, equality rows,
        #: inequality rows; > 0 at an upper side, < 0 at a lower one), else None.
        self.last_multipliers: np.ndarray | None = None
        #: a call of the current solve stopped at the tick work's or the deadline's limit: no further call
        self.budget_capped = False
        self._model_limit = None  # the iteration limit set on the persistent workspace
        self._oneshot_first = False  # the last solve's workspace calls failed and its one-shot call succeeded
        #: CPU time (``time.thread_time``) by which every call must end (``math.inf``: none; the inverse-dynamics
        #: clock guard sets it), at max(``iteration_cost``, ``measured_iteration_cost``) s per iteration
        self.deadline = math.inf
        self.measured_iteration_cost = 0.0  # :meth:`_timed`
        self.iteration_cost = DAQP_ITERATION_COST
        #: a caller's cap on each call's iterations (int ≥ 1) or None; a call stopped there sets ``iterations_capped``
        self.call_iterations: int | None = None
        #: DAQP's proximal outer iterations beyond each call's first (``nodes`` − 1), summed since construction
        self.proximal_iterations = 0
        #: DAQP settings of :meth:`solve_scaled`'s calls over the backend's own (e.g. ``{"eps_prox": -1e-8}``)
        self.scaled_settings: dict = {}
        self.iterations_capped = False

    def solve(self, H, g, A, b, C, l, u, lb, ub, *, confirm: bool = True) -> np.ndarray:
        """:meth:`QPBackend.solve` (``budget_capped`` and ``iterations_capped`` reset first)."""
        self.budget_capped = False
        self.iterations_capped = False
        return super().solve(H, g, A, b, C, l, u, lb, ub, confirm=confirm)

    def call_limit(self) -> int:
        """Iteration limit of the next DAQP call: the settings' ``iter_limit``, at most ``call_iterations``, and under
        a counted tick work (``work`` with a finite cap) at most the iterations left before ``solves`` reaches
        :data:`WORK_LIMIT_FACTOR` × ``cap`` (``reserve`` and one solve for the call held back); with a finite
        ``deadline`` also at most the iterations that fit before it. At least :data:`MIN_CALL_ITERATIONS` under
        either."""
        limit = int(self.settings["iter_limit"])
        if self.call_iterations is not None:
            limit = min(limit, int(self.call_iterations))
        work = self.work
        if work is not None and math.isfinite(work.cap):
            left = ((WORK_LIMIT_FACTOR * work.cap - work.reserve - work.solves - 1.0) * self.iterations_per_solve
                    - self.last_iterations)
            limit = min(limit, max(MIN_CALL_ITERATIONS, int(left)))
        if self.deadline < math.inf:
            left = (self.deadline - thread_time()) / max(self.iteration_cost, self.measured_iteration_cost)
            limit = min(limit, int(max(MIN_CALL_ITERATIONS, left)))
        return limit

    def _oneshot(self, H, g, note: bool = True, **extra) -> tuple:
        """One ``daqp.solve`` on the formed constraints (settings, ``extra`` over them, :meth:`call_limit`),
        :meth:`_timed`: (x, or None when DAQP found none; DAQP's info dict)."""
        limit = self.call_limit()
        x, _, info = self._timed(lambda: self._daqp.solve(
            H, g, self._G, self._upper, self._lower, self._sense, **{**self.settings, "iter_limit": limit, **extra}),
            limit, note)
        return x, info

    def _timed(self, call, limit: int, note: bool = True) -> tuple:
        """``call()`` (a DAQP solve of iteration limit ``limit``), its iterations (``last_iterations``) and proximal
        iterations counted, its stop by a lowered limit noted unless ``note`` is False; under a deadline its CPU time
        per iteration updates ``measured_iteration_cost`` (it varies several-fold on one QP: later calls are sized at
        it). (x, or None when DAQP found none; DAQP's exit flag; its info dict)."""
        timed = self.deadline != math.inf
        t0 = thread_time() if timed else 0.0
        x, _, exitflag, info = call()
        self.proximal_iterations += max(0, int(info.get("nodes", 1)) - 1)
        iterations = int(info["iterations"])
        if timed and iterations >= MEASURED_CALL_ITERATIONS:
            cost = (thread_time() - t0) / iterations
            self.measured_iteration_cost = (cost if cost > self.measured_iteration_cost
                                            else MEASURED_COST_DECAY * self.measured_iteration_cost)
        self.last_iterations += iterations
        if note and exitflag == _DAQP_ITERATION_LIMIT and limit < int(self.settings["iter_limit"]):
            # stopped by a lowered limit: call_iterations' (iterations_capped), else the tick work's or deadline's
            if self.call_iterations is not None and limit == int(self.call_iterations):
                self.iterations_capped = True
            else:
                self.budget_capped = True
        return (x if exitflag >= 1 else None), exitflag, info

    def _daqp_form(self, A, b, C, l, u, lb, ub) -> tuple:
        """(G, upper, lower) of DAQP's form of the QP's constraints, in the buffers of this size."""
        n, n_eq, n_in = lb.shape[0], A.shape[0], C.shape[0]
        if self._layout != (n, n_eq, n_in):  # buffers of this size; no warm start of another size
            self._layout, self._dual, self._model = (n, n_eq, n_in), None, None
            self._G = np.empty((n_eq + n_in, n))
            self._upper, self._lower = np.empty(n + n_eq + n_in), np.empty(n + n_eq + n_in)
            self._sense = np.zeros(n + n_eq + n_in, dtype=np.int32)
            self._sense[n:n + n_eq] = 5
        G, upper, lower = self._G, self._upper, self._lower
        e = n + n_eq
        upper[:n], lower[:n] = ub, lb  # DAQP reads ±inf (and |bound| ≥ 1e30) as "no bound"
        upper[n:e], lower[n:e] = b, b
        G[:n_eq] = A
        if n_in:
            G[n_eq:] = C
            upper[e:], lower[e:] = u, l
        return G, upper, lower

    def _solve(self, H, g, A, b, C, l, u, lb, ub):
        G, upper, lower = self._daqp_form(A, b, C, l, u, lb, ub)
        self._cold_ran = False  # this call ran the cold path (_solve_cold does not repeat it)
        if self.budget_capped:
            return None  # the tick's work limit stopped a call of this solve: no further call
        if self.warm_start == "dual":
            return self._solve_dual(H, g)
        tried_oneshot = self._oneshot_first and self.cold_retry
        if tried_oneshot:  # the last solve's workspace failed where the one-shot call succeeded: that first
            x = self._solve_oneshot(H, g)
            if x is not None or self.budget_capped:
                return x
        if self._model is not None:  # warm-started
            self._model.update(H=H, f=g, A=G, bupper=upper, blower=lower)
            limit = self.call_limit()
            if limit != self._model_limit:
                self._model.settings = {"iter_limit": limit}
                self._model_limit = limit
            x, exitflag, info = self._timed(self._model.solve, limit)
            if x is not None:
                self.last_multipliers = info["lam"]
                return x
            self._model = None  # failed: the cold paths below, or the next solve's
            if not self.cold_retry or self.budget_capped:  # one call (a trial, or the work limit)
                return None
            if exitflag == _DAQP_ITERATION_LIMIT and not (tried_oneshot or self.iterations_capped):
                # the workspace cycled to its iteration limit: the one-shot call, the cold workspace only after it
                x = self._solve_oneshot(H, g)
                self._cold_ran = x is not None
                if x is not None or self.budget_capped:
                    return x
                tried_oneshot = True
        # first solve of this size, or the warm-started one failed: fresh workspace (cold start)
        model = self._daqp.Model()
        limit = self.call_limit()
        model.settings = {**self.settings, "iter_limit": limit}
        if model.setup(H, g, G, upper, lower, self._sense)[0] >= 0:
            x, _, info = self._timed(model.solve, limit)
            if x is not None:
                self._model = model
                self._model_limit = limit
                self.last_multipliers = info["lam"]
                self._cold_ran = True
                return x
        if not self.cold_retry or self.budget_capped:
            return None
        self._cold_ran = True
        if tried_oneshot:  # both cold calls ran and failed
            return None
        # DAQP's one-shot interface: measured to solve degenerate problems (e.g. the ±1e-9 bands of a priority
        # cascade) that a Model workspace reports infeasible; when it does, the next solve starts with it
        return self._solve_oneshot(H, g)

    def _solve_oneshot(self, H, g):
        """:meth:`_oneshot`, counted, its multipliers kept; the next solve starts with it when it succeeded (else
        not): x or None."""
        x, info = self._oneshot(H, g)
        self.last_multipliers = None if x is None else info["lam"]
        self._oneshot_first = x is not None
        return x

    def _solve_cold(self, H, g, A, b, C, l, u, lb, ub):
        self._dual = None
        x = None
        if not self._cold_ran:  # (else this problem's attempt ran the cold path already: not computed twice)
            self._model = None
            self._oneshot_first = False  # the workspace path first, then the one-shot
            x = self._solve(H, g, A, b, C, l, u, lb, ub)
            if x is not None and self.accepted(x, A, b, C, l, u, lb, ub, self.tolerance) is not None:
                return x
        if self.budget_capped:
            return None  # the tick's work limit stopped this problem's cold solve: no retry
        # the retries below within the tick's counted work left (call_limit)
        low = self.settings.get("primal_tol", DAQP_PRIMAL_TOL) < self.tolerance
        if low or self.warm_start == "dual":
            # DAQP's infeasibility verdict was measured wrong on feasible QPs with a primal tolerance far below the
            # accepted violation (1e-9 on the ID QP), and at it on ill-conditioned ones (dual warm start): once more
            # at the tolerance, resp. DUAL_RETRY_PRIMAL_FACTOR × it (the answer is held to ``tolerance`` all the same)
            primal = self.tolerance if low else DUAL_RETRY_PRIMAL_FACTOR * self.tolerance
            x2, info = self._oneshot(H, g, primal_tol=primal)
            if x2 is not None:
                if not low:
                    self.last_multipliers = None
                return x2
            if self.budget_capped:
                return None
        scale = _cost_scale(H, g)
        if scale < 1.0:
            # the same minimiser with the cost divided by max(1, |g|∞, |H|max): DAQP's absolute dual tolerances
            # reported feasible inverse-dynamics QPs with a large |g| and an ill-conditioned Hessian infeasible
            x3, info = self._oneshot(H * scale, g * scale, note=False, **self.scaled_settings)
            if x3 is not None:
                self.last_multipliers = None
                return x3
        return x

    def solve_scaled(self, H, g, A, b, C, l, u, lb, ub) -> np.ndarray | None:
        """One cold DAQP call on the QP with its cost divided by max(1, |g|∞, |H|max) (the same minimiser),
        ``scaled_settings`` over the backend's; a solution's (unscaled) multipliers become ``last_multipliers`` and,
        with ``warm_start="dual"``, the next solve's dual start.

        Returns:
            x (n,) within [lb, ub] meeting every row to ``tolerance`` (the check of :meth:`QPBackend.solve`), or None.
        """
        self._daqp_form(A, b, C, l, u, lb, ub)
        scale = _cost_scale(H, g)
        x, info = self._oneshot(H * scale, g * scale, **self.scaled_settings)
        self.last_iterations = int(info["iterations"])  # (this call's alone)
        xc = None if x is None else self.accepted(x, A, b, C, l, u, lb, ub, self.tolerance)
        if xc is None:
            return None
        # the multipliers of the unscaled QP (the scaled cost scales them): the next solve's dual warm start
        self.last_multipliers = np.asarray(info["lam"]) / scale
        if self.warm_start == "dual":
            self._dual = self.last_multipliers.copy()
        return xc

    def _solve_dual(self, H, g):
        x, info = self._oneshot(H, g, **({} if self._dual is None else {"dual_start": self._dual}))
        if x is None:
            self._cold_ran = self._dual is None  # a cold call failed (_solve_cold does not repeat it)
            self._dual = None
            return None
        self._dual = np.array(info["lam"])
        self.last_multipliers = self._dual
        return x


def _cost_scale(H: np.ndarray, g: np.ndarray) -> float:
    """1 / max(1, |g|∞, |H|max): the factor of the cost-scaled QP (the same minimiser)."""
    return 1.0 / max(1.0, float(np.abs(g).max(initial=0.0)), float(np.abs(H).max(initial=0.0)))
