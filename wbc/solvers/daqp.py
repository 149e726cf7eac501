"""DAQP backend: :class:`DaqpBackend`, DAQP's dual active-set solver called directly (no conversion layer).

Equalities are DAQP's sense-5 rows, bounds its simple bounds, and the previous tick's working set (persistent
``daqp.Model`` workspace) or dual variables (one-shot ``daqp.solve``) the warm start; each call's iterations are
bounded (:data:`ITERATION_LIMIT`, and the tick's counted work: :meth:`DaqpBackend.call_limit`). Under a CPU-time
stop (:attr:`DaqpBackend.stop_at`) a call that could reach it runs in slices, the clock read between them
(:meth:`DaqpBackend.call`).
"""

from __future__ import annotations

import math
from time import thread_time

import numpy as np

from wbc.exceptions import InvalidInputError
from wbc.solvers.base import ITERATIONS_PER_SOLVE, QPBackend, register_backend_class

__all__ = ["DAQP_ITERATION_COST", "DAQP_PRIMAL_TOL", "DUAL_RETRY_PRIMAL_FACTOR", "DaqpBackend", "ITERATION_LIMIT",
           "MIN_CALL_ITERATIONS", "SLICE_COST_FACTOR", "SLICE_ITERATIONS", "WORK_LIMIT_FACTOR"]

#: DAQP's iteration cap in :class:`DaqpBackend` (unless its settings give ``iter_limit``)
ITERATION_LIMIT = 1000

#: a DAQP call of :class:`DaqpBackend` under a controller's counted tick work (``QPBackend.work`` with a finite cap)
#: may take at most the iterations that keep the tick's count below WORK_LIMIT_FACTOR × its cap
#: (:data:`ITERATIONS_PER_SOLVE` iterations per solve, one solve kept for what follows the call), at least
#: :data:`MIN_CALL_ITERATIONS`: a stage already started cannot run past the budget by a full iteration cap
WORK_LIMIT_FACTOR = 1.9
MIN_CALL_ITERATIONS = 10

#: CPU time (s) of one DAQP iteration assumed by :attr:`DaqpBackend.deadline` (an inverse-dynamics QP of a humanoid,
#: 46–62 variables and ~190 constraints; benchmarks/README.md, "The ID failure path ordered by cost")
DAQP_ITERATION_COST = 3.5e-6

#: DAQP's exit flag of a call stopped by its iteration limit
_DAQP_ITERATION_LIMIT = -4
#: DAQP's sense bits: a row or bound in the (starting) working set, at its lower side, never removed (equalities)
_DAQP_ACTIVE, _DAQP_LOWER, _DAQP_IMMUTABLE = 1, 2, 4

#: under a stop (:attr:`DaqpBackend.stop_at` finite) a DAQP call that could reach it runs in slices, after its first
#: of at most this many iterations on a ``daqp.Model`` workspace, each resuming from the working set where the one
#: before stopped, and the CPU time read between slices: a call ends at most one slice past the stop, whatever one
#: iteration costs (an iteration's cost varies fivefold on one inverse-dynamics QP: with DAQP's proximal
#: regularisation of a Hessian conditioned ~1e10 it is several times the nominal :data:`DAQP_ITERATION_COST`)
SLICE_ITERATIONS = 25
#: the first slice of a call under a stop takes the iterations that fit before it at this multiple of the nominal
#: cost (at least :data:`SLICE_ITERATIONS`): the most one iteration was seen to cost is ~5.7 × the nominal (DAQP's
#: proximal iterations), so the first slice ends by the stop and most calls need no second
SLICE_COST_FACTOR = 6.0
#: DAQP's default primal tolerance (its settings' ``primal_tol``)
DAQP_PRIMAL_TOL = 1e-6

#: ``DaqpBackend(warm_start="dual")``: after a failed cold solve, DAQP is asked once more with its primal tolerance
#: (the feasibility threshold of its infeasibility verdict) at this multiple of the backend's ``tolerance``.
DUAL_RETRY_PRIMAL_FACTOR = 10.0


@register_backend_class("daqp")
class DaqpBackend(QPBackend):
    """DAQP (Arnström, Bemporad, Axehill, "A dual active-set solver for embedded quadratic programming using
    recursive LDLᵀ updates", IEEE TAC 67(8), 2022) through a persistent ``daqp.Model`` workspace: set up once
    per problem size, then ``update`` + ``solve`` every tick, warm-started from the previous tick's working set;
    a warm-started solve that fails, or whose solution fails the independent constraint check, is repeated from a
    cold start (then with DAQP's one-shot ``daqp.solve``) before the tick is declared failed.
    Bounds are DAQP's simple bounds, equalities sense-5 rows, inequalities two-sided rows.

    Args:
        tolerance: largest constraint violation accepted (constraint units).
        warm_start: ``"workspace"`` (persistent ``daqp.Model``: the factorisations and working set are reused;
            fastest on the kinematic tick, few inequalities) or ``"dual"`` (one-shot ``daqp.solve`` started from
            the previous tick's dual variables; fastest on the inverse-dynamics QP, many inequalities).
        **settings: DAQP settings (e.g. ``eps_prox`` for the semidefinite levels of a hierarchy,
            ``primal_tol``); DAQP's defaults otherwise, except ``iter_limit`` (default :data:`ITERATION_LIMIT`: one
            call's work is bounded; a solve that reaches it is a failed attempt). Under a controller's counted tick
            work (``work`` with a finite cap) each call's limit is also at most what keeps the count below
            :data:`WORK_LIMIT_FACTOR` × the cap (:meth:`call_limit`); a call stopped there is a failed attempt
            (``budget_capped`` True until the next solve), never an unconverged answer.

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
        # an iteration cap, so that one call's work is bounded (DAQP's default, 10 000, was measured to take 24 ms
        # on a kinematic level that cycled; the largest count of a solved kinematic QP seen was 233)
        self.settings = {"iter_limit": ITERATION_LIMIT, **settings}
        self._model = None
        self._cold_outcome = None
        self._dual: np.ndarray | None = None
        self._layout: tuple[int, int, int] | None = None
        #: DAQP iterations of the last solve attempt (every DAQP call it made; QPBackend.solve resets it).
        self.last_iterations = 0
        #: warm-started solves that failed and were solved again from a cold start.
        self.warm_failures = 0
        #: DAQP's multipliers of the last solve that returned a solution ((n + n_eq + n_in,): bounds, equality rows,
        #: inequality rows; > 0 at an upper bound, < 0 at a lower one, 0 off its working set), else None.
        self.last_multipliers: np.ndarray | None = None
        #: a DAQP call of the current solve stopped at the tick work's iteration limit (:meth:`call_limit`), below
        #: the settings' own ``iter_limit``; the solve's remaining calls are then skipped (failed attempts).
        self.budget_capped = False
        self._model_limit = None  # the iteration limit set on the persistent workspace
        self._oneshot_first = False  # the last solve's workspace calls failed and its one-shot call succeeded
        #: CPU time (``time.thread_time`` of the calling thread) by which every DAQP call must end, ``math.inf``
        #: (default): none. A finite deadline lowers each call's iteration limit to the iterations that fit in the
        #: time left at ``iteration_cost`` seconds each (:meth:`call_limit`); a clock, so only a caller that accepts
        #: an answer depending on the machine's speed sets it (the inverse-dynamics clock guard).
        self.deadline = math.inf
        #: CPU time (``time.thread_time``) past which no DAQP call of this backend goes on, ``math.inf`` (default):
        #: none. A call whose iterations could reach it at :data:`SLICE_COST_FACTOR` × ``iteration_cost`` each runs in
        #: slices, the clock read between them (:meth:`call`): a bound that holds whatever an iteration costs,
        #: where ``deadline`` sizes the iteration limits at the nominal cost.
        self.stop_at = math.inf
        #: CPU time (s) of one DAQP iteration assumed by ``deadline`` (> 0).
        self.iteration_cost = DAQP_ITERATION_COST

    def solve(self, H, g, A, b, C, l, u, lb, ub, *, confirm: bool = True) -> np.ndarray:
        """:meth:`QPBackend.solve` (``budget_capped`` reset first)."""
        self.budget_capped = False
        return super().solve(H, g, A, b, C, l, u, lb, ub, confirm=confirm)

    def call_limit(self) -> int:
        """Iteration limit of the next DAQP call: the settings' ``iter_limit`` (default :data:`ITERATION_LIMIT`),
        lowered under a controller's counted tick work (``work`` with a finite cap) to the iterations left before
        ``solves`` reaches :data:`WORK_LIMIT_FACTOR` × ``cap`` (the iterations of the attempt in progress counted,
        one solve kept for the call itself), at least :data:`MIN_CALL_ITERATIONS`. A count, not a clock — unless
        ``deadline`` is finite: then also at most (deadline − CPU time now) / ``iteration_cost``, at least
        :data:`MIN_CALL_ITERATIONS`."""
        limit = int(self.settings.get("iter_limit", ITERATION_LIMIT))
        work = self.work
        if work is not None and math.isfinite(work.cap):
            left = ((WORK_LIMIT_FACTOR * work.cap - work.solves - 1.0) * ITERATIONS_PER_SOLVE
                    - self.last_iterations)
            limit = min(limit, max(MIN_CALL_ITERATIONS, int(left)))
        if self.deadline < math.inf:
            left = (self.deadline - thread_time()) / self.iteration_cost
            limit = min(limit, MIN_CALL_ITERATIONS if left < MIN_CALL_ITERATIONS else int(min(left, limit)))
        return limit

    def _note_exit(self, exitflag: int, limit: int) -> None:
        """Record a call stopped by a budget-lowered iteration limit (``budget_capped``)."""
        if exitflag == _DAQP_ITERATION_LIMIT and limit < int(self.settings.get("iter_limit", ITERATION_LIMIT)):
            self.budget_capped = True

    def call(self, H, g, G, upper, lower, settings: dict) -> tuple:
        """One DAQP solve of min ½ xᵀ H x + gᵀ x s.t. lower ≤ (x; G x) ≤ upper with this backend's sense array: DAQP's
        one-shot ``daqp.solve(..., **settings)`` (``settings["iter_limit"]`` its iteration limit, ``dual_start`` its
        warm start). Under a finite :attr:`stop_at`, a call whose iterations could reach it (at
        :data:`SLICE_COST_FACTOR` × ``iteration_cost`` each) runs in slices: the one-shot call gets the iterations
        that fit before :attr:`stop_at` at that cost (at least :data:`SLICE_ITERATIONS`); when it stops there with
        iterations and time left, a ``daqp.Model`` workspace goes on from the same warm start (the rows and bounds
        whose ``dual_start`` multiplier is non-zero, at the side of its sign: DAQP's sense flags) in slices of
        :data:`SLICE_ITERATIONS`, each resuming where the last stopped, the CPU time read between them; a call stopped
        at :attr:`stop_at` sets ``budget_capped``.

        Args:
            H (n, n), g (n,): the cost. G (m, n): the rows. upper, lower (n + m,): bounds then rows (DAQP's layout).
            settings: DAQP settings with ``iter_limit``, optionally ``dual_start`` ((n + m,) multipliers).

        Returns:
            DAQP's (x, fval, exitflag, info), ``info["iterations"]`` summed over the slices.
        """
        limit = int(settings["iter_limit"])
        first = limit if self.stop_at == math.inf else self._first_slice(limit)
        if first >= limit:
            return self._daqp.solve(H, g, G, upper, lower, self._sense, **settings)
        out = self._daqp.solve(H, g, G, upper, lower, self._sense, **{**settings, "iter_limit": first})
        done = int(out[3]["iterations"])
        if out[2] != _DAQP_ITERATION_LIMIT or done >= limit:
            return out
        if thread_time() >= self.stop_at:
            self.budget_capped = True
            return out
        sense = self._sense
        dual = settings.get("dual_start")
        if dual is not None:
            sense = sense.copy()
            free = (sense & _DAQP_IMMUTABLE) == 0
            sense[free & (dual > 0)] |= _DAQP_ACTIVE
            sense[free & (dual < 0)] |= _DAQP_ACTIVE | _DAQP_LOWER
        model = self._daqp.Model()
        model.settings = {k: v for k, v in settings.items() if k != "dual_start"}
        if model.setup(H, g, G, upper, lower, sense)[0] < 0:
            return out
        x, fval, exitflag, info = self.model_solve(model, limit - done)
        return x, fval, exitflag, {**info, "iterations": int(info["iterations"]) + done}

    def _first_slice(self, limit: int) -> int:
        """Iterations of a call's first slice: those that fit before :attr:`stop_at` at :data:`SLICE_COST_FACTOR` ×
        ``iteration_cost``, at least :data:`SLICE_ITERATIONS`, at most ``limit``."""
        fit = (self.stop_at - thread_time()) / (SLICE_COST_FACTOR * self.iteration_cost)
        if not fit > SLICE_ITERATIONS:  # (also a stop long past)
            return min(limit, SLICE_ITERATIONS)
        return limit if fit >= limit else int(fit)

    def model_solve(self, model, limit: int) -> tuple:
        """``model.solve()`` of a set-up ``daqp.Model`` with at most ``limit`` iterations (its settings' ``iter_limit``
        is set here); under a finite :attr:`stop_at` in slices, as :meth:`call`.

        Returns:
            DAQP's (x, fval, exitflag, info), ``info["iterations"]`` summed over the slices.
        """
        first = limit if self.stop_at == math.inf else self._first_slice(limit)
        if first >= limit:
            if limit != self._model_limit or model is not self._model:
                model.settings = {"iter_limit": limit}
                if model is self._model:
                    self._model_limit = limit
            return model.solve()
        self._model_limit = None  # the slices leave the workspace's limit at theirs
        done = 0
        while True:
            model.settings = {"iter_limit": first if done == 0 else min(SLICE_ITERATIONS, limit - done)}
            x, fval, exitflag, info = model.solve()
            done += int(info["iterations"])
            if exitflag != _DAQP_ITERATION_LIMIT or done >= limit:
                break
            if thread_time() >= self.stop_at:
                self.budget_capped = True
                break
        return x, fval, exitflag, {**info, "iterations": done}

    def _prepare(self, n: int, n_eq: int, n_in: int) -> None:
        self._layout = (n, n_eq, n_in)
        self._dual = None
        self._G = np.empty((n_eq + n_in, n))
        self._upper = np.empty(n + n_eq + n_in)
        self._lower = np.empty(n + n_eq + n_in)
        self._sense = np.zeros(n + n_eq + n_in, dtype=np.int32)
        self._sense[n:n + n_eq] = 5
        self._model = None

    def _solve(self, H, g, A, b, C, l, u, lb, ub):
        n, n_eq, n_in = H.shape[0], A.shape[0], C.shape[0]
        if self._layout != (n, n_eq, n_in):
            self._prepare(n, n_eq, n_in)
        G, upper, lower = self._G, self._upper, self._lower
        e = n + n_eq
        upper[:n] = ub  # DAQP reads ±inf (and |bound| ≥ 1e30) as "no bound"
        lower[:n] = lb
        upper[n:e] = b
        lower[n:e] = b
        G[:n_eq] = A
        if n_in:
            G[n_eq:] = C
            upper[e:] = u
            lower[e:] = l
        if self.warm_start == "dual":
            self._cold_outcome = None
            return self._solve_dual(H, g, G, upper, lower)
        self._cold_outcome = None  # (x,) once this call has run the cold path (_solve_cold reuses it)
        if self.budget_capped:
            return None  # the tick's work limit stopped a call of this solve: no further call
        tried_oneshot = self._oneshot_first and self.cold_retry
        if tried_oneshot:
            # the last solve's workspace calls failed where the one-shot solve then succeeded (a strict level whose
            # ±band rows make the workspace cycle, exit −2, after hundreds of iterations): the one-shot first
            x = self._solve_oneshot(H, g, G, upper, lower)
            if x is not None:
                return x
            self._oneshot_first = False
            if self.budget_capped:
                return None
        warm = self._model is not None
        if warm:
            self._model.update(H=H, f=g, A=G, bupper=upper, blower=lower)
            limit = self.call_limit()
            x, _, exitflag, info = self.model_solve(self._model, limit)
            self.last_iterations += int(info["iterations"])
            if exitflag >= 1:
                self.last_multipliers = info["lam"]
                return x
            self._note_exit(exitflag, limit)
            self.warm_failures += 1
            if not self.cold_retry or self.budget_capped:  # a trial (``cold_retry`` off), or the work limit: one
                self._model = None                         # call; the next solve starts cold
                return None
        # first solve of this size, or the warm-started one failed: fresh workspace (cold start)
        model = self._daqp.Model()
        limit = self.call_limit()
        model.settings = {**self.settings, "iter_limit": limit}
        self._model = None
        if model.setup(H, g, G, upper, lower, self._sense)[0] >= 0:
            self._model_limit = limit
            x, _, exitflag, info = self.model_solve(model, limit)
            self.last_iterations += int(info["iterations"])
            if exitflag >= 1:
                self._model = model
                self.last_multipliers = info["lam"]
                self._cold_outcome = (x, model, info["lam"])
                return x
            self._note_exit(exitflag, limit)
        if not self.cold_retry or self.budget_capped:
            return None
        if tried_oneshot:  # both cold calls ran and failed (deterministic): _solve_cold does not repeat them
            self._cold_outcome = (None, None, None)
            return None
        # DAQP's one-shot interface: measured to solve degenerate problems (e.g. the ±1e-9 bands of a priority
        # cascade) that a Model workspace reports infeasible; when it does, the next solve starts with it
        x = self._solve_oneshot(H, g, G, upper, lower)
        self._oneshot_first = x is not None
        self._cold_outcome = (x, None, self.last_multipliers)
        return x

    def _solve_oneshot(self, H, g, G, upper, lower):
        """One call of DAQP's one-shot ``daqp.solve`` (iterations bounded by :meth:`call_limit`): x or None."""
        limit = self.call_limit()
        x, _, exitflag, info = self.call(H, g, G, upper, lower, {**self.settings, "iter_limit": limit})
        self.last_iterations += int(info["iterations"])
        self._note_exit(exitflag, limit)
        self.last_multipliers = info["lam"] if exitflag >= 1 else None
        return x if exitflag >= 1 else None

    def _solve_cold(self, H, g, A, b, C, l, u, lb, ub):
        self.warm_failures += 1
        self._dual = None
        outcome = self._cold_outcome
        if outcome is not None:
            # the attempt before (QPBackend.solve: same problem) already ran the cold path — a fresh workspace,
            # then the one-shot solve (dual warm start: the one-shot solve from no dual start, which failed) —
            # whose answer is deterministic: reused, not computed twice
            x, model, multipliers = outcome
            self.last_iterations = 0  # no new solver call
            if self.warm_start != "dual":
                self._model, self.last_multipliers = model, multipliers
        else:
            self._model = None
            self._oneshot_first = False  # the workspace path first, then the one-shot
            x = self._solve(H, g, A, b, C, l, u, lb, ub)
        if x is not None and np.isfinite(x).all():
            xc = np.minimum(np.maximum(x, lb), ub)
            if self.scaled_violation(x, xc, A, b, C, l, u, lb, ub) <= self.tolerance:
                return x
        if self.budget_capped:
            return None  # the tick's work limit stopped this problem's cold solve: no retry
        # the two retries below get at most the iterations left in the tick's counted work (call_limit), so that
        # one failing solve cannot run two more DAQP calls to their full iteration cap past the tick's budget
        limit = {**self.settings, "iter_limit": self.call_limit()}
        if self.settings.get("primal_tol", DAQP_PRIMAL_TOL) < self.tolerance:
            # a primal tolerance far below the accepted violation (e.g. 1e-9 on the inverse-dynamics QP) was
            # measured to report feasible problems infeasible: once more with DAQP's primal_tol at the tolerance
            relaxed = {**limit, "primal_tol": self.tolerance}
            x2, _, exitflag, info = self.call(H, g, self._G, self._upper, self._lower, relaxed)
            self.last_iterations += int(info["iterations"])
            if exitflag >= 1:
                return x2
            self._note_exit(exitflag, relaxed["iter_limit"])
            if self.budget_capped:
                return None
            limit["iter_limit"] = self.call_limit()
        elif self.warm_start == "dual":
            # DAQP's infeasibility verdict with its primal tolerance at the accepted violation was measured wrong on
            # two G1 touch-down QPs (Hessian conditioned 5e10; HiGHS: feasible): with the verdict's tolerance at
            # DUAL_RETRY_PRIMAL_FACTOR × tolerance DAQP solves each in 9 iterations, every row met to 1e-12 (the
            # answer is held to ``tolerance`` all the same, QPBackend.solve)
            loose = {**limit, "primal_tol": DUAL_RETRY_PRIMAL_FACTOR * self.tolerance}
            x2, _, exitflag, info = self.call(H, g, self._G, self._upper, self._lower, loose)
            self.last_iterations += int(info["iterations"])
            if exitflag >= 1:
                self.last_multipliers = None
                return x2
            self._note_exit(exitflag, loose["iter_limit"])
            if self.budget_capped:
                return None
            limit["iter_limit"] = self.call_limit()
        scale = 1.0 / max(1.0, float(np.abs(g).max(initial=0.0)), float(np.abs(H).max(initial=0.0)))
        if scale < 1.0:
            # the same minimiser with the cost divided by max(1, |g|∞, |H|max): with |g| ~ 1e6 and a Hessian
            # conditioned ~1e11 (large task gains and weights against a 1e-7 force regularisation), DAQP's
            # absolute dual tolerances reported feasible inverse-dynamics QPs infeasible (cross-checked by HiGHS;
            # the scaled solve agrees with quadprog to 4e-8 in x)
            x3, _, exitflag, info = self.call(H * scale, g * scale, self._G, self._upper, self._lower, limit)
            self.last_iterations += int(info["iterations"])
            if exitflag >= 1:
                self.last_multipliers = None
                return x3
        return x

    def solve_scaled(self, H, g, A, b, C, l, u, lb, ub) -> np.ndarray | None:
        """One cold DAQP call on the QP with its cost divided by max(1, |g|∞, |H|max) (the same minimiser; the last
        retry of a failed solve, :meth:`_solve_cold`, asked on its own), its iteration limit from :meth:`call_limit`.

        A solution's multipliers (unscaled) become ``last_multipliers`` and, with ``warm_start="dual"``, the next
        solve's dual start.

        Returns:
            x (n,) within [lb, ub] meeting every row to ``tolerance`` (the check of :meth:`QPBackend.solve`), or None.
        """
        n, n_eq, n_in = H.shape[0], A.shape[0], C.shape[0]
        if self._layout != (n, n_eq, n_in):
            self._prepare(n, n_eq, n_in)
        G, upper, lower = self._G, self._upper, self._lower
        e = n + n_eq
        upper[:n], lower[:n] = ub, lb
        upper[n:e], lower[n:e] = b, b
        G[:n_eq] = A
        if n_in:
            G[n_eq:] = C
            upper[e:], lower[e:] = u, l
        scale = 1.0 / max(1.0, float(np.abs(g).max(initial=0.0)), float(np.abs(H).max(initial=0.0)))
        limit = self.call_limit()
        x, _, exitflag, info = self.call(H * scale, g * scale, G, upper, lower, {**self.settings, "iter_limit": limit})
        self.last_iterations = int(info["iterations"])
        self._note_exit(exitflag, limit)
        if exitflag < 1 or not np.isfinite(x).all():
            return None
        xc = np.minimum(np.maximum(x, lb), ub)
        if self.scaled_violation(x, xc, A, b, C, l, u, lb, ub) > self.tolerance:
            return None
        # the multipliers of the unscaled QP (the scaled cost scales them): the next solve's dual warm start
        self.last_multipliers = np.asarray(info["lam"]) / scale
        if self.warm_start == "dual":
            self._dual = self.last_multipliers.copy()
        return xc

    def _solve_dual(self, H, g, G, upper, lower):
        if self.budget_capped:
            return None  # the tick's work limit stopped a call of this solve: no further call
        limit = self.call_limit()  # the settings' iter_limit unless a work count or a deadline lowers it
        settings = self.settings if limit == self.settings.get("iter_limit") else {**self.settings,
                                                                                   "iter_limit": limit}
        kwargs = settings if self._dual is None else {**settings, "dual_start": self._dual}
        x, _, exitflag, info = self.call(H, g, G, upper, lower, kwargs)
        self._note_exit(exitflag, limit)
        if exitflag < 1 and self._dual is not None and self.cold_retry and not self.budget_capped:
            # the warm start may be what failed: once more, cold (not for a trial with ``cold_retry`` off: one call
            # per solve)
            self.warm_failures += 1
            limit = self.call_limit()
            settings = self.settings if limit == self.settings.get("iter_limit") else {**self.settings,
                                                                                       "iter_limit": limit}
            x, _, exitflag, info = self.call(H, g, G, upper, lower, settings)
            self._note_exit(exitflag, limit)
        self.last_iterations += int(info["iterations"])
        if exitflag < 1:
            self._dual = None
            self._cold_outcome = (None, None, None)  # this problem's cold solve failed (_solve_cold: not repeated)
            return None
        self._dual = np.array(info["lam"])
        self.last_multipliers = self._dual
        return x
