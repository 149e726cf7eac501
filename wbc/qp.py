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
from time import thread_time

import numpy as np
import qpsolvers

from wbc.exceptions import InfeasibleProblemError, InvalidInputError, SolverError

__all__ = ["QPBackend", "DaqpBackend", "ProxQPBackend", "PROXQP_MAX_ITER", "QpsolversBackend", "TickWork",
           "solve_pinned_reduced", "second_opinion", "hard_set_feasible", "DAQP_ITERATION_COST"]

_BIG = 1e10  # stands for an infinite bound where a backend needs a finite number
#: work (in :class:`TickWork` solves) an independent re-solve of :meth:`QPBackend.confirm` counts: ProxQP's cold
#: solve of an infeasible QP runs to its iteration cap (200 outer × 100 inner), ≈ 580 active-set solves of a
#: humanoid tick's QP; the others count one
_CONFIRM_WORK = {"proxqp": 580}


#: active-set iterations counted as one more :class:`TickWork` solve (a kinematic QP solve without them takes about
#: as long as this many DAQP iterations)
ITERATIONS_PER_SOLVE = 150


class TickWork:
    """Work of one control tick: the QP solves done so far, against a cap.

    A controller shares one instance with all its backends (``QPBackend.work``) and resets it at the start of each
    tick; every solve attempt (warm, cold retry) and every independent re-solve of :meth:`QPBackend.solve` adds
    one to ``solves`` (an attempt one more per :data:`ITERATIONS_PER_SOLVE` iterations its solver took). A tick
    budget counted in solves keeps a tick's answer a function of its inputs (a budget read from a clock would make
    it depend on the machine).

    Clock guard (``clock``: seconds of CPU time counted as one solve, ``math.inf`` by default: off): ``solves``
    reads max(counted solves, CPU time of the calling thread since :meth:`reset` / ``clock``)
    (``time.thread_time``: what the tick computes, not the time other processes take the core from it), so every
    limit on the count (:meth:`spent`, :meth:`DaqpBackend.call_limit`) also holds on the tick's CPU time. The
    trade-off: a tick that reaches a limit by its clock before its count has an answer that depends on the
    machine's speed and load (its optional stages stop earlier on a slower machine); a tick that stays under
    every limit by its clock answers as without the guard.

    Attributes:
        solves: work of the current tick, in solves (≥ 0; a float once the clock guard counts).
        cap: solves after which the tick's optional stages stop (≥ 0, ``math.inf``: no cap); an independent
            re-solve starts only when its count fits under it (ProxQP counts 580: off the control path at any
            budget below 580 × ``KinematicController.SOLVE_COST``).
    """

    __slots__ = ("_solves", "cap", "_clock", "_t0")

    def __init__(self, cap: float = math.inf, clock: float = math.inf):
        self._solves = 0
        self.cap = cap
        self._clock = clock
        self._t0 = thread_time()

    @property
    def solves(self) -> float:
        """Counted solves of the tick, or (clock guard) the tick's CPU time in solves when that is larger."""
        if self._clock < math.inf:
            return max(self._solves, (thread_time() - self._t0) / self._clock)
        return self._solves

    @solves.setter
    def solves(self, value: float) -> None:
        self._solves = value

    @property
    def clock(self) -> float:
        """CPU time (s) counted as one solve by the clock guard (``math.inf``: no clock guard)."""
        return self._clock

    def reset(self, cap: float, clock: float = math.inf) -> None:
        """Start a tick: no solve yet, ``cap`` solves allowed; ``clock``: seconds of CPU time counted as one solve
        (``math.inf``: counted solves only)."""
        self._solves = 0
        self.cap = cap
        self._clock = clock
        self._t0 = thread_time()

    def seconds(self) -> float:
        """CPU time (s, ``time.thread_time`` of the calling thread) since :meth:`reset`."""
        return thread_time() - self._t0

    def spent(self, factor: float = 1.0) -> bool:
        """``factor`` × cap solves are done."""
        return self.solves >= factor * self.cap


class QPBackend(ABC):
    """Common interface. ``tolerance`` is the largest constraint violation accepted (in constraint units)."""

    name: str = ""
    tolerance: float = 1e-6

    @abstractmethod
    def _solve(self, H, g, A, b, C, l, u, lb, ub) -> np.ndarray | None:
        """Raw solution, or None on failure."""

    #: active-set iterations of the last solver call (0 for a backend that does not report them).
    last_iterations: int = 0
    #: tick solutions rescued by the independent re-solve (the backend's own solve failed or violated a row).
    rescues: int = 0
    #: how the last failure was confirmed ('' until one): the independent solvers that also found no solution.
    last_confirmation: str = ""
    #: the counted work of the current control tick (:class:`TickWork`, shared by a controller's backends), or None:
    #: every solve attempt and independent re-solve adds one; once it reaches its cap a failed solve is not
    #: confirmed by the independent solvers (:meth:`solve`). None (default): no count, no limit.
    work: "TickWork | None" = None
    #: retry a failed solve (from a cold start, :meth:`_solve_cold`, and a backend's own fallbacks) before declaring
    #: it failed; a caller trying a sequence of problems where a failure only sends it to the next one (one scale of
    #: a relaxation ladder) may turn it off for those solves: then one solver call per solve.
    cold_retry: bool = True
    #: names of the independent solvers of :meth:`confirm`, in the order they are tried.
    independent: tuple[str, ...] = ("proxqp", "quadprog", "daqp")

    def solve(self, H, g, A, b, C, l, u, lb, ub, *, confirm: bool = True) -> np.ndarray:
        """Solve the QP (module docstring). A/C may have 0 rows; lb/ub are (n,) with ±inf for free entries.

        Tolerance policy (the same for every backend and both controller levels): the solution is checked row
        by row in the max-norm, each row against ``tolerance · max(1, |rhs|, Σ_j |a_ij x_j|)`` (its own units
        and scale: a 1e6 m target row gets a relative tolerance); bound excess within tolerance is projected onto [lb, ub], so integrating
        x never crosses a joint limit. Before a failure is declared, the problem is re-solved by an independent
        backend (ProxQP, then quadprog/DAQP through qpsolvers; :meth:`confirm`); its solution, if it passes the
        same check, is returned. ``confirm=False`` skips that re-solve (the inverse-dynamics controller: its time is
        unbounded); otherwise, once the tick's counted work (``work``) has reached its cap, the independent solvers
        not yet run are skipped (the failure is then reported unconfirmed). The limit is a count of solves, not a
        clock: the answer is a function of the problem alone.

        Returns:
            x (n,), within [lb, ub] exactly.

        Raises:
            SolverError: no backend found an x meeting every row to tolerance; the message gives the largest
                scaled row violation (the number that was tested) and the independent solvers that confirmed.
        """
        # a warm start can mislead an active-set solver: once more from scratch before declaring failure (unless
        # ``cold_retry`` is off: a trial whose failure is an answer, e.g. one scale of a relaxation ladder)
        for attempt in (self._solve, self._solve_cold) if self.cold_retry else (self._solve,):
            self.last_iterations = 0
            x = attempt(H, g, A, b, C, l, u, lb, ub)
            if self.work is not None:
                # one, plus one per ITERATIONS_PER_SOLVE iterations the attempt took (a DAQP call that ran to its
                # iteration cap costs several solves' time: counted so, the tick's later stages stop sooner)
                self.work.solves += 1 + int(self.last_iterations) // ITERATIONS_PER_SOLVE
            worst = math.inf
            if x is not None and np.isfinite(x).all():
                xc = np.minimum(np.maximum(x, lb), ub)
                worst = self.scaled_violation(x, xc, A, b, C, l, u, lb, ub)
                if worst <= self.tolerance:
                    return xc
                if worst <= _POLISH_RANGE:
                    if self.work is not None:
                        self.work.solves += 1  # the polish: a least-squares correction, then a projection QP
                    xp = self.polish(x, A, b, C, l, u, lb, ub)
                    if xp is not None:
                        self.polished += 1
                        return xp
        x_ind, confirmed = (self.confirm(H, g, A, b, C, l, u, lb, ub) if confirm
                            else (None, "nobody (independent re-solve skipped: confirm=False)"))
        if x_ind is not None:
            self.rescues += 1
            return x_ind
        self.last_confirmation = confirmed
        what = ("found no solution" if not math.isfinite(worst) else
                f"returned a solution violating constraints by {worst:.3g} (largest row violation, max-norm, "
                f"scaled by max(1, |rhs|); tolerance {self.tolerance:.3g})")
        if confirm:
            raise InfeasibleProblemError(f"QP backend {self.name!r} {what}; infeasibility confirmed by {confirmed}")
        raise SolverError(f"QP backend {self.name!r} {what} (not confirmed by an independent solver)")

    #: solutions accepted after :meth:`polish` (the solver's answer was within 1e-3 but above ``tolerance``).
    polished: int = 0

    def polish(self, x, A, b, C, l, u, lb, ub) -> np.ndarray | None:
        """Primal polish of a near-feasible solution: bounds within 1e-6 (scaled) of x or crossed are fixed at the
        bound, violated or active inequality rows at the crossed/active side, and the smallest correction of the
        free entries (least squares, ``numpy.linalg.lstsq``) makes the equality and those rows hold; then
        clipped to the bounds and checked like :meth:`solve`. With |g| ~ 1e9 (a 1e6 m target) every solver
        tried stopped 1.5e-6 – 1.3e-5 off the rows (cancellation in H⁻¹(g + Aᵀλ)); the correction is of that
        size, so the cost changes at second order.

        When that correction cannot hold the rows (the free entries do not span them: the feasible set is thin
        and some entry must leave the bound the solver put it on, e.g. under a 1e6 m hand target), x is projected
        onto the hard set instead: min ½‖y − x‖² subject to every row and bound, a well-conditioned QP (identity
        Hessian, |gradient| ~ |x|) solved by DAQP's one-shot interface. The projection moves x by about the
        solver's error, so the answer stays that solution up to its error.

        Returns:
            the polished x (within [lb, ub], every row to ``tolerance``), or None.
        """
        x0 = x
        x = self._polish_lstsq(x, A, b, C, l, u, lb, ub)
        if x is not None:
            return x
        return self._project(x0, A, b, C, l, u, lb, ub)

    def _project(self, x, A, b, C, l, u, lb, ub) -> np.ndarray | None:
        """x projected onto the hard set (:meth:`polish`), or None when that fails the check of :meth:`solve`."""
        n = x.shape[0]
        try:
            y = DaqpBackend(tolerance=self.tolerance)._solve(np.eye(n), -np.where(np.isfinite(x), x, 0.0), A, b, C,
                                                             l, u, lb, ub)
        except Exception:  # noqa: BLE001 — a failed projection polishes nothing
            return None
        if y is None or not np.isfinite(y).all():
            return None
        yc = np.minimum(np.maximum(y, lb), ub)
        return yc if self.scaled_violation(y, yc, A, b, C, l, u, lb, ub) <= self.tolerance else None

    def _polish_lstsq(self, x, A, b, C, l, u, lb, ub) -> np.ndarray | None:
        """Least-squares stage of :meth:`polish`."""
        x = np.minimum(np.maximum(x, lb), ub)
        for _ in range(2):
            near = 1e-6 * np.maximum(1.0, np.abs(x))
            fixed = (x <= lb + near) | (x >= ub - near)
            free = ~fixed
            rows, rhs = [A], [b]
            if C.shape[0]:
                cx = C @ x
                with np.errstate(invalid="ignore"):  # an infinite bound: inf - inf = nan compares False (inactive)
                    act_l = cx <= l + 1e-6 * np.maximum(1.0, np.abs(l))
                    act_u = cx >= u - 1e-6 * np.maximum(1.0, np.abs(u))
                act = act_l | act_u
                rows.append(C[act])
                rhs.append(np.where(act_l, l, u)[act])
            M = np.vstack(rows)
            if M.shape[0] == 0 or not free.any():
                break
            r = np.concatenate(rhs) - M @ x
            dx = np.linalg.lstsq(M[:, free], r, rcond=None)[0]
            x = x.copy()
            x[free] += dx
            x = np.minimum(np.maximum(x, lb), ub)
            if self.scaled_violation(x, x, A, b, C, l, u, lb, ub) <= self.tolerance:
                return x
        return None

    def _solve_cold(self, H, g, A, b, C, l, u, lb, ub) -> np.ndarray | None:
        """Solve without any warm start (default: the same as ``_solve``)."""
        return self._solve(H, g, A, b, C, l, u, lb, ub)

    def confirm(self, H, g, A, b, C, l, u, lb, ub) -> tuple[np.ndarray | None, str]:
        """Independent re-solve: ProxQP (cold, eps_abs 1e-9) and one qpsolvers backend that is not this one
        (quadprog when H is positive definite, else DAQP one-shot with a relaxed primal tolerance).

        Returns:
            (x, '') with x projected onto the bounds when one of them meets every row to ``tolerance``
            (the check of :meth:`solve`), else (None, 'names of the solvers that failed').
        """
        tried = []
        for name in self.independent:
            if name == self.name or name not in qpsolvers.available_solvers:
                continue
            if self.work is not None:
                cost = _CONFIRM_WORK.get(name, 1)
                if self.work.solves + cost > self.work.cap:
                    return None, (", ".join(tried) + " (then the tick's solve count was spent)" if tried else
                                  "no independent solver (tick budget spent: infeasibility not confirmed)")
                self.work.solves += cost
            try:
                if name == "proxqp":
                    backend = ProxQPBackend(tolerance=self.tolerance, max_iter=200)
                elif name == "quadprog":
                    if np.linalg.eigvalsh(H)[0] <= 1e-12 * max(1.0, np.abs(H).max()):
                        continue  # quadprog needs H positive definite
                    backend = QpsolversBackend("quadprog", tolerance=self.tolerance)
                else:
                    backend = QpsolversBackend(name, tolerance=self.tolerance)
                x = backend._solve(H, g, A, b, C, l, u, lb, ub)
            except Exception:  # noqa: BLE001 — a crashing independent solver confirms nothing either way
                x = None
            tried.append(name)
            if x is not None and np.isfinite(x).all():
                xc = np.minimum(np.maximum(x, lb), ub)
                worst = self.scaled_violation(x, xc, A, b, C, l, u, lb, ub)
                if worst <= self.tolerance:
                    return xc, ""
                if worst <= _POLISH_RANGE:
                    xp = self.polish(x, A, b, C, l, u, lb, ub)
                    if xp is not None:
                        return xp, ""
        return None, ", ".join(tried) or "no independent solver installed"

    @staticmethod
    def scaled_violation(x, xc, A, b, C, l, u, lb=None, ub=None) -> float:
        """Largest row violation of x in the max-norm, each row divided by max(1, |its right-hand side|,
        Σ_j |a_ij x_j|) (the row's own scale: the size of the terms whose sum is compared).

        Bounds are measured on x (excess over [lb, ub], scaled by the bound), the equality and inequality rows
        on its projection ``xc`` onto the bounds (the point that is returned). NaN/inf give inf."""
        worst = 0.0
        d = np.abs(x - xc)
        if d.size and d.max() > 0:
            ref = np.abs(np.where(x > xc, ub, lb)) if lb is not None else 0.0
            worst = float(np.max(d / np.maximum(1.0, ref)))
        if A.shape[0] or C.shape[0]:
            ax = np.abs(xc)
        if A.shape[0]:
            # row scale: max(1, |b_i|, Σ_j |A_ij x_j|) — the magnitude of the terms summed (floating-point error
            # of a_i·x is relative to it; measured: a 1e6 m target gave |g| 2e9 and every solver 1.7e-6 off)
            r = np.abs(A @ xc - b) / np.maximum(np.maximum(1.0, np.abs(b)), np.abs(A) @ ax)
            worst = max(worst, float(r.max()))
        if C.shape[0]:
            cx = C @ xc
            ex = np.maximum(l - cx, cx - u)
            ref = np.where(l - cx > cx - u, np.abs(l), np.abs(u))
            ref = np.maximum(np.where(np.isfinite(ref), ref, 1.0), np.abs(C) @ ax)
            ex = np.where(ex > 0, ex, 0.0) / np.maximum(1.0, ref)
            worst = max(worst, float(ex.max()))
        return worst if math.isfinite(worst) else math.inf

    @staticmethod
    def violation(x, A, b, C, l, u, lb, ub) -> float:
        """Largest violation of any constraint by x (0 when feasible)."""
        worst = max((lb - x).max(initial=0.0), (x - ub).max(initial=0.0))
        if A.shape[0]:
            r = A @ x
            r -= b
            worst = max(worst, r.max(), -r.min())
        if C.shape[0]:
            cx = C @ x
            worst = max(worst, (l - cx).max(), (cx - u).max())
        return float(worst)


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
#: DAQP's default primal tolerance (its settings' ``primal_tol``)
_DAQP_PRIMAL_TOL = 1e-6


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
            if limit != self._model_limit:
                self._model.settings = {"iter_limit": limit}
                self._model_limit = limit
            x, _, exitflag, info = self._model.solve()
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
            x, _, exitflag, info = model.solve()
            self.last_iterations += int(info["iterations"])
            if exitflag >= 1:
                self._model = model
                self._model_limit = limit
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
        x, _, exitflag, info = self._daqp.solve(H, g, G, upper, lower, self._sense,
                                                **{**self.settings, "iter_limit": limit})
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
        if self.settings.get("primal_tol", _DAQP_PRIMAL_TOL) < self.tolerance:
            # a primal tolerance far below the accepted violation (e.g. 1e-9 on the inverse-dynamics QP) was
            # measured to report feasible problems infeasible: once more with DAQP's primal_tol at the tolerance
            relaxed = {**limit, "primal_tol": self.tolerance}
            x2, _, exitflag, info = self._daqp.solve(H, g, self._G, self._upper, self._lower, self._sense, **relaxed)
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
            x2, _, exitflag, info = self._daqp.solve(H, g, self._G, self._upper, self._lower, self._sense, **loose)
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
            x3, _, exitflag, info = self._daqp.solve(H * scale, g * scale, self._G, self._upper, self._lower,
                                                     self._sense, **limit)
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
        x, _, exitflag, info = self._daqp.solve(H * scale, g * scale, G, upper, lower, self._sense,
                                                **{**self.settings, "iter_limit": limit})
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
        x, _, exitflag, info = self._daqp.solve(H, g, G, upper, lower, self._sense, **kwargs)
        self._note_exit(exitflag, limit)
        if exitflag < 1 and self._dual is not None and self.cold_retry and not self.budget_capped:
            # the warm start may be what failed: once more, cold (not for a trial with ``cold_retry`` off: one call
            # per solve)
            self.warm_failures += 1
            limit = self.call_limit()
            settings = self.settings if limit == self.settings.get("iter_limit") else {**self.settings,
                                                                                       "iter_limit": limit}
            x, _, exitflag, info = self._daqp.solve(H, g, G, upper, lower, self._sense, **settings)
            self._note_exit(exitflag, limit)
        self.last_iterations += int(info["iterations"])
        if exitflag < 1:
            self._dual = None
            self._cold_outcome = (None, None, None)  # this problem's cold solve failed (_solve_cold: not repeated)
            return None
        self._dual = np.array(info["lam"])
        self.last_multipliers = self._dual
        return x


#: ``DaqpBackend(warm_start="dual")``: after a failed cold solve, DAQP is asked once more with its primal tolerance
#: (the feasibility threshold of its infeasibility verdict) at this multiple of the backend's ``tolerance``.
DUAL_RETRY_PRIMAL_FACTOR = 10.0

#: Default iteration cap of :class:`ProxQPBackend` (proxsuite ``max_iter``; ``max_iter_in`` min(cap, 100)).
PROXQP_MAX_ITER = 1000


class ProxQPBackend(QPBackend):
    """proxsuite's dense ProxQP, warm-started from the previous tick's solution and dual variables.

    Args:
        eps_abs: absolute stopping tolerance of ProxQP (primal and dual residuals).
        tolerance: largest scaled row violation of an accepted answer (:meth:`QPBackend.solve`).
        max_iter: iteration cap (proxsuite ``max_iter``; its inner loop ``max_iter_in`` is min(max_iter, 100)),
            an integer ≥ 1, default :data:`PROXQP_MAX_ITER`. A call that reaches it returns no solution (a failed
            solve: the caller's fallbacks take over), never the unconverged iterate. Without a cap proxsuite's own
            (10 000 outer × 1 500 inner iterations) let one walking QP run for minutes.

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


class QpsolversBackend(QPBackend):
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
            np.maximum(lb, -_BIG), np.minimum(ub, _BIG), solver=self.name, **self.settings,
        )


#: Largest scaled violation of a solver's answer that :meth:`QPBackend.polish` tries to repair.
_POLISH_RANGE = 1e-3

#: Tight settings per qpsolvers backend so that joint limits hold to solver precision.
_SETTINGS = {
    "osqp": {"eps_abs": 1e-9, "eps_rel": 0.0, "polishing": True, "max_iter": 20000},
}




def solve_pinned_reduced(H, g, A, b, C, l, u, lb, ub, tolerance: float = 1e-6, *, details: bool = False):
    """The QP of the module docstring with its pinned variables (lb_i = ub_i) eliminated and the inequality rows
    left without a free variable dropped, solved by quadprog's Goldfarb–Idnani dual active-set method (Goldfarb,
    Idnani, "A numerically stable dual method for solving strictly convex quadratic programs", Math. Programming
    27, 1983): a second solver for a problem a backend reported infeasible (e.g. DAQP on the inverse-dynamics
    QP of a released foot, whose 12 forces are pinned at 0 and whose optimum has nearly as many active
    constraints as free variables).

    Args:
        H (n, n) positive definite on the free variables, g (n,), A (m, n), b (m,), C (p, n), l, u (p,), lb, ub (n,):
            the QP (±inf for absent bounds). tolerance: largest scaled violation accepted
            (:meth:`QPBackend.scaled_violation`).

        details: also return why no solution was returned.

    Returns:
        x (n,) within [lb, ub] (pinned entries exactly at their value) meeting every row to ``tolerance``, or None
        (a dropped row violated, quadprog's failure — infeasible, dependent equalities, H not positive definite —
        or a solution that fails the check). With ``details``: (x or None, reason), reason '' for a solution,
        ``infeasible`` (a dropped row violated, or quadprog found the constraints inconsistent: the dual
        unbounded, Goldfarb–Idnani's infeasibility certificate), else ``failed``.
    """
    x, reason = _pinned_reduced(H, g, A, b, C, l, u, lb, ub, tolerance)
    return (x, reason) if details else x


def _pinned_reduced(H, g, A, b, C, l, u, lb, ub, tolerance):
    import quadprog

    n = H.shape[0]
    pinned = np.isfinite(lb) & (lb == ub)
    free = ~pinned
    xp = lb[pinned]
    Hr = H[np.ix_(free, free)]
    gr = g[free] + H[np.ix_(free, pinned)] @ xp
    Ar, br = A[:, free], b - A[:, pinned] @ xp
    Cr, shift = C[:, free], C[:, pinned] @ xp
    lr, ur = l - shift, u - shift
    empty = ~np.any(Cr != 0.0, axis=1) if C.shape[0] else np.zeros(0, bool)
    if np.any((lr[empty] > tolerance * np.maximum(1.0, np.abs(l[empty])))
              | (ur[empty] < -tolerance * np.maximum(1.0, np.abs(u[empty])))):
        return None, "infeasible"
    Cr, lr, ur = Cr[~empty], lr[~empty], ur[~empty]
    lbr, ubr = lb[free], ub[free]
    eye = np.eye(Hr.shape[0])
    lo, hi, blo, bhi = np.isfinite(lr), np.isfinite(ur), np.isfinite(lbr), np.isfinite(ubr)
    # quadprog: min ½xᵀGx − aᵀx s.t. Cᵀx ≥ b, the first meq columns equalities
    Cq = np.hstack([Ar.T, Cr[lo].T, -Cr[hi].T, eye[:, blo], -eye[:, bhi]])
    bq = np.concatenate([br, lr[lo], -ur[hi], lbr[blo], -ubr[bhi]])
    try:
        xr = quadprog.solve_qp(Hr, -gr, Cq, bq, Ar.shape[0])[0]
    except ValueError as exc:
        return None, "infeasible" if "inconsistent" in str(exc) else "failed"
    x = np.empty(n)
    x[pinned] = xp
    x[free] = xr
    if not np.isfinite(x).all():
        return None, "failed"
    xc = np.minimum(np.maximum(x, lb), ub)
    if QPBackend.scaled_violation(x, xc, A, b, C, l, u, lb, ub) > tolerance:
        return None, "failed"
    return xc, ""


def second_opinion(H, g, A, b, C, l, u, lb, ub, tolerance: float = 1e-6, *, daqp_backend: "DaqpBackend | None" = None
                   ) -> tuple[np.ndarray | None, str]:
    """Two active-set solvers asked about a QP another backend reported infeasible: quadprog with the pinned
    variables eliminated (:func:`solve_pinned_reduced`), then one call of ``daqp_backend`` (no confirmation; a
    cold :class:`DaqpBackend` with the given ``tolerance`` when None). A proximal or ADMM method declares a QP
    primal infeasible when its primal residual stops decreasing (ProxQP: Bambade et al., "PROX-QP: Yet another
    quadratic programming solver for robotics and beyond", RSS 2022, its infeasibility criterion with
    ``eps_primal_inf``); that test can fire on feasible QPs with nearly dependent equality rows, where an
    active-set solver's factorisation answers exactly.

    Args:
        H, g, A, b, C, l, u, lb, ub: the QP of the module docstring (shapes as in :meth:`QPBackend.solve`).
        tolerance: largest scaled row violation accepted (:meth:`QPBackend.scaled_violation`).
        daqp_backend: the DAQP backend of the second attempt.

    Returns:
        (x (n,) within [lb, ub] meeting every row to ``tolerance``, name of the solver: ``quadprog`` or ``daqp``),
        or (None, '') when neither found one.
    """
    x = solve_pinned_reduced(H, g, A, b, C, l, u, lb, ub, tolerance)
    if x is not None:
        return x, "quadprog"
    daqp_backend = daqp_backend if daqp_backend is not None else DaqpBackend(tolerance=tolerance)
    try:
        return daqp_backend.solve(H, g, A, b, C, l, u, lb, ub, confirm=False), "daqp"
    except SolverError:
        return None, ""


def hard_set_feasible(A, b, C, l, u, lb, ub, tolerance: float = 1e-6, *,
                      iter_limit: int = ITERATION_LIMIT) -> bool | None:
    """Whether the constraints of a QP (module docstring) have a common point, by one cold DAQP call on the
    projection of the origin onto them: min ½‖x‖² s.t. A x = b, l ≤ C x ≤ u, lb ≤ x ≤ ub. Its Hessian is the
    identity, so DAQP's dual (whose infeasibility test is a dual ray) is as well conditioned as the rows are, unlike
    the inverse-dynamics QP's (Hessian eigenvalues 1e-7 to 1e3: the force regularisation against the task weights),
    where DAQP was seen to report feasible problems infeasible. A cheap question asked before a costly solve whose
    outcome it decides (:meth:`wbc.formulations.acceleration.InverseDynamicsQP.solve` with a clock guard).

    Args:
        A (m, n), b (m,), C (p, n), l, u (p,), lb, ub (n,): the constraints (±inf for absent bounds).
        tolerance: largest scaled violation (:meth:`QPBackend.scaled_violation`) of a point that shows feasibility.
        iter_limit: DAQP's iteration limit (an integer ≥ 1).

    Returns:
        True: a point meeting every row and bound to ``tolerance`` was found; False: DAQP proved the set empty
        (exit flag −1: infeasible); None: neither (iteration limit, or a point that fails the check).

    Raises:
        InvalidInputError: an ``iter_limit`` that is not an integer ≥ 1.
    """
    import daqp

    if isinstance(iter_limit, bool) or not isinstance(iter_limit, (int, np.integer)) or iter_limit < 1:
        raise InvalidInputError(f"iter_limit must be an integer ≥ 1 (iterations), got {iter_limit!r}")
    n, m, p = lb.shape[0], A.shape[0], C.shape[0]
    G = np.empty((m + p, n))
    G[:m], G[m:] = A, C
    upper = np.concatenate([ub, b, u])
    lower = np.concatenate([lb, b, l])
    sense = np.zeros(n + m + p, dtype=np.int32)
    sense[n:n + m] = 5
    x, _, exitflag, _ = daqp.solve(np.eye(n), np.zeros(n), G, upper, lower, sense, primal_tol=_DAQP_PRIMAL_TOL,
                                   iter_limit=int(iter_limit))
    if exitflag == -1:
        return False
    if exitflag < 1 or not np.isfinite(x).all():
        return None
    xc = np.minimum(np.maximum(x, lb), ub)
    return True if QPBackend.scaled_violation(x, xc, A, b, C, l, u, lb, ub) <= tolerance else None
