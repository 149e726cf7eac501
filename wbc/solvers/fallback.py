"""The fallback ladder of a QP (:class:`FallbackChain`): which solver is asked after which, and under what rules.

The compiled solver first when there is one (its answer stands when the caller's check accepts it), then the
backend; for a DAQP backend (``daqp``, ``fast``): 1. the **attempt**, one DAQP call capped by the tick's budget;
2. the **hard-set checks** (:func:`~wbc.solvers.independent.hard_set_check`): a set proved empty ends the ladder;
3. the **scaled call** (cost divided by max(1, |g|∞, |H|max)); 4. **quadprog** with pinned variables and equality rows
eliminated (:func:`~wbc.solvers.independent.solve_pinned_reduced`); 5. the backend's **retries** (its cold calls).
A tick whose counted work cut step 3 or 4 on a set with a point resumes there next tick (**resumed scaled call**,
**resumed quadprog**; failing, that tick checks the hard sets and ends). Any other backend gets a **second opinion**
(:meth:`FallbackChain._solve_checked`). :meth:`FallbackChain.refine` repairs an answer failing the
caller's output check; the relaxed QP has a shorter ladder (:meth:`FallbackChain.solve_relaxed`). Every step after
the attempt is bounded by the tick's counted work (DAQP iterations) or, with a clock guard, by CPU time. Rules,
factors, measurements: docs/inverse-dynamics-controller.md, "The fallback chain".
"""

from __future__ import annotations

import math
from time import thread_time
from typing import Callable

import numpy as np

from wbc.exceptions import SolverError
from wbc.solvers.base import QPBackend
from wbc.solvers.compiled_id import KERNEL_ITERATION_COST, CompiledIDSolver
from wbc.solvers.daqp import (DAQP_ITERATION_COST, ITERATION_LIMIT, MEASURED_COST_DECAY, MIN_CALL_ITERATIONS,
                              DaqpBackend)
from wbc.solvers.independent import hard_set_check, solve_pinned_reduced
from wbc.solvers.qp_data import QPData, QPSolution

__all__ = ["DAQP_CALL_WORK", "FallbackChain", "PROXIMAL_ITERATION_WORK", "QUADPROG_COST", "QUADPROG_SIZE",
           "SCALED_EPS_PROX", "daqp_attempt_iterations", "quadprog_work", "tick_work_iterations"]

#: DAQP settings of a chain built by name: primal tolerance 1e-6 (1e-9 reported "no solution" on feasible walking
#: problems, FIELD_NOTES); the dual warm start, faster than DAQP's persistent workspace on inequality-heavy QPs.
DAQP_SETTINGS = {"primal_tol": 1e-6, "warm_start": "dual"}


def daqp_attempt_iterations(budget: float) -> int:
    """Iteration cap of the DAQP attempt on a tick's full QP and of the scaled call after it, for a tick budget of
    ``budget`` s of CPU time: a third of it at :data:`~wbc.solvers.daqp.DAQP_ITERATION_COST` per iteration, within
    [:data:`~wbc.solvers.daqp.MIN_CALL_ITERATIONS`, :data:`~wbc.solvers.daqp.ITERATION_LIMIT`]. A count, not a clock."""
    if not np.isfinite(budget):
        return ITERATION_LIMIT
    return int(min(ITERATION_LIMIT, max(MIN_CALL_ITERATIONS, budget / (3.0 * DAQP_ITERATION_COST))))


#: CPU time (s) of quadprog's solve of a failed ID QP of :data:`QUADPROG_SIZE` variables, assumed before one ran
#: (clock guard, :attr:`FallbackChain.quadprog_cost`; benchmarks/README.md)
QUADPROG_COST = 2.5e-3
QUADPROG_SIZE = 60
#: work counted for one DAQP call besides its iterations (its set-up), in iterations
DAQP_CALL_WORK = 30
#: work counted for one proximal outer iteration of a DAQP call beyond its first (DAQP's ``nodes`` − 1), in
#: iterations: each redoes the work of several iterations (the near-singular Hessian of the cost-scaled QP)
PROXIMAL_ITERATION_WORK = 5
#: DAQP's ``eps_prox`` on the ID's cost-scaled QP (negative: only when the Hessian is found singular): the scaled
#: force regularisation (~1e-13) is dominated by DAQP's default 1e-6, and a smaller one keeps the proximal outer
#: iterations few. The answer is checked to the backend's tolerance either way.
SCALED_EPS_PROX = -1e-8


def tick_work_iterations(budget: float) -> float:
    """A tick budget of ``budget`` s of CPU time (> 0; ``math.inf``: unbounded) in DAQP iterations (at
    :data:`~wbc.solvers.daqp.DAQP_ITERATION_COST` s each), the unit of :attr:`FallbackChain.tick_work`."""
    return budget / DAQP_ITERATION_COST if np.isfinite(budget) else math.inf


def quadprog_work(n: int) -> float:
    """Work counted for quadprog's solve of a QP of ``n`` variables, in DAQP iterations: :data:`QUADPROG_COST` ×
    (n / :data:`QUADPROG_SIZE`)³ (its dense factorisations, Goldfarb & Idnani 1983) / DAQP_ITERATION_COST."""
    return QUADPROG_COST * (n / QUADPROG_SIZE) ** 3 / DAQP_ITERATION_COST


class FallbackChain:
    """The fallback ladder (module docstring) over one backend, with its per-tick budget and counters.

    Args:
        backend: a :class:`~wbc.solvers.base.QPBackend`, or any object with a ``solve`` method (its failure stands).
        compiled: the :class:`~wbc.solvers.compiled_id.CompiledIDSolver` asked before it, or None.

    Attributes (the tick's budget, set by the controller):
        tick_work_iterations: the tick budget in DAQP iterations (:func:`tick_work_iterations`; ``math.inf``).
        daqp_attempt_iterations: iteration cap of the attempt and the scaled call (:func:`daqp_attempt_iterations`).
        tick_clock: (CPU time ``time.thread_time`` at the tick's start, budget in s), or None: no clock guard.
        tick_work: work counted in the current tick, in DAQP iterations (reset by :meth:`begin_tick`).

    Attributes (the current tick's findings, reset by :meth:`begin_tick`):
        budget_cut: the counted work or the clock cut a step. hard_set_point: a check found a point of the full hard
        set, ``hard_set_x`` (n,). relaxed_set_feasible: the relaxed hard set's verdict (True, False, None: not
        checked). relaxed_bounds: (l, u, lb, ub) of the relaxed QP formed by that check, else None.
        compiled_reason: why the compiled solver did not answer the last full QP ('' when it did, or there is none).
    """

    def __init__(self, backend, compiled: CompiledIDSolver | None = None):
        self.backend = backend
        self.compiled = compiled
        self.compiled_reason = ""
        self.second_opinion_enabled = True  # :meth:`_solve_checked`
        self.daqp_attempt_iterations = ITERATION_LIMIT
        self.tick_work_iterations = math.inf
        self.tick_clock: tuple[float, float] | None = None
        #: CPU time (s) quadprog's solve is expected to take (clock guard): raised at once to a solve's, lowered by
        #: :data:`~wbc.solvers.daqp.MEASURED_COST_DECAY` per cheaper one
        self.quadprog_cost = QUADPROG_COST
        #: the last failed full QP's hard set was proved empty: the next full QP's is checked before the attempt
        self.last_set_empty = False
        #: the counted work cut a failed full QP whose hard set has a point: the next ones start with the scaled call
        self.resume_scaled = False
        self.hard_set_x = np.zeros(0)
        self._daqp_check: DaqpBackend | None = None
        self.begin_tick()

    def begin_tick(self) -> None:
        """Reset the current tick's work and findings (class docstring)."""
        self.tick_work = 0.0
        self.budget_cut = False
        self.hard_set_point = False
        self.relaxed_set_feasible: bool | None = None
        self.relaxed_bounds: tuple | None = None
        # this tick's check of the relaxed hard set ended before its iteration limit (solve_relaxed does not repeat it)
        self._relaxed_check_final = False

    def solve_relaxed(self, qp: QPData, *, same_tick: bool = False, formed: bool = True) -> QPSolution:
        """The relaxed QP ``qp`` (the caller dropped its relaxable rows). ``same_tick``: of this tick's failed full QP
        (a relaxed hard set proved empty raises at once); ``formed``: its bounds are not :attr:`relaxed_bounds`.
        Raises SolverError: no step found a solution."""
        if formed:
            self._relaxed_check_final = False
        if same_tick and self.relaxed_set_feasible is False:
            raise SolverError("the relaxed hard set is empty (DAQP on the projection of the origin onto it, checked "
                              "after the full QP failed): no relaxed solve")
        if not isinstance(self.backend, DaqpBackend):
            return self._solve_checked(qp)
        # a DAQP backend: docs/inverse-dynamics-controller.md, "The relaxed QP"
        backend = self.backend
        backend.deadline = self._deadline(self.RELAXED_END)  # math.inf without a clock guard
        try:
            # the attempt's iterations and its DAQP_CALL_WORK within what is left for the relaxed QP
            left = self._left("RELAXED")
            sol, first = self._call(qp, "attempt", max(MIN_CALL_ITERATIONS, int(min(
                left - DAQP_CALL_WORK, ITERATION_LIMIT))) if math.isfinite(left) else None)
            if sol is not None:
                return sol
            if not backend.budget_capped and self._left("RELAXED") >= MIN_CALL_ITERATIONS:
                # the relaxed hard set, unless this tick checked it to a verdict or ended undecided before its limit
                feasible = self.relaxed_set_feasible
                if feasible is None and not self._relaxed_check_final:
                    feasible = self._set_check(*qp[2:], "RELAXED")
                if feasible is False:
                    raise SolverError(f"{first}; the relaxed hard set is empty (DAQP on the projection of the origin "
                                      f"onto it): the backend's retries skipped")
                sol, exc = self._retries(qp, first, "RELAXED")
                if sol is not None:
                    return sol
                if backend.budget_capped or feasible is not True:
                    raise exc
                # the relaxed hard set has a point, so a minimiser that DAQP missed: quadprog, when it fits
                x, skipped = self._quadprog_within(qp, "RELAXED")
                if x is None:
                    raise SolverError(f"{exc}; " + (f"no quadprog solve of the relaxed QP: {skipped}" if skipped else
                                                    "quadprog found no solution either"))
                return QPSolution(x, "quadprog", "quadprog")
        except SolverError as exc:
            if backend.budget_capped:
                self.budget_cut = True
                raise SolverError(f"{exc} (a DAQP call stopped at the tick's deadline: clock guard)") from exc
            raise
        finally:
            backend.deadline = math.inf
        self.budget_cut = True  # the first call stopped at the deadline, or no time/work left for the check
        raise SolverError(f"{first} (a DAQP call stopped at the tick's deadline, or no time or counted work left for "
                          f"the relaxed hard-set check and the backend's retries)")

    # The rules' factors, in tick budgets (:meth:`_left`; docs/inverse-dynamics-controller.md, "The fallback chain").
    #: the attempt's DAQP calls end by this many budgets (clock guard)
    ATTEMPT_END = 1.25
    #: the hard-set checks, the scaled call and the retries
    FAILURE_WORK = 1.0
    FAILURE_END = 1.4
    #: quadprog runs only when its work fits (:meth:`_quadprog_within`)
    QUADPROG_WORK = 1.25
    QUADPROG_END = 1.55
    #: the relaxed QP's calls
    RELAXED_WORK = 1.1
    RELAXED_END = 1.75
    #: the attempt and the scaled call on a set found not empty take this many attempt caps together
    SCALED_FEASIBLE_FACTOR = 2
    #: DAQP calls of the backend's retries (each capped at this fraction of the work left)
    RETRY_CALLS = 4

    def _counting(self) -> bool:
        """No clock guard and a finite :attr:`tick_work_iterations`."""
        return self.tick_clock is None and math.isfinite(self.tick_work_iterations)

    def _factors(self, stage: str) -> tuple[float, float]:
        """(_WORK, _END) factors of ``stage``: ``"FAILURE"``, ``"QUADPROG"`` or ``"RELAXED"``."""
        return getattr(self, f"{stage}_WORK"), getattr(self, f"{stage}_END")

    def _left(self, stage: str) -> float:
        """DAQP iterations left for ``stage`` (``math.inf``: no limit): :attr:`tick_work` below its _WORK factor of
        budgets, or (clock guard) the CPU time before its _END factor at DAQP_ITERATION_COST per iteration."""
        work, end = self._factors(stage)
        if self.tick_clock is None:
            return work * self.tick_work_iterations - self.tick_work
        return (self._deadline(end) - thread_time()) / DAQP_ITERATION_COST

    def _quadprog_within(self, qp: QPData, stage: str) -> tuple[np.ndarray | None, str]:
        """(solve_pinned_reduced's x or None, '') of ``qp`` when its work (:func:`quadprog_work`; clock guard:
        :attr:`quadprog_cost`) fits what :meth:`_left` leaves ``stage``, counted; else (None, why not), a budget cut."""
        work = quadprog_work(qp.H.shape[0]) if self.tick_clock is None else self.quadprog_cost / DAQP_ITERATION_COST
        if work > self._left(stage):
            self.budget_cut = True
            return None, (f"the tick's counted work ({self.tick_work:.0f} DAQP iterations) and quadprog's ({work:.0f}) "
                          f"would pass {self._factors(stage)[0]} budgets")
        c0 = thread_time()
        x = solve_pinned_reduced(*qp, self.backend.tolerance)
        self.tick_work += work
        cost = thread_time() - c0
        self.quadprog_cost = cost if cost > self.quadprog_cost else MEASURED_COST_DECAY * self.quadprog_cost
        return x, ""

    def _set_check(self, A, b, C, l, u, lb, ub, stage: str) -> bool | None:
        """:func:`~wbc.solvers.independent.hard_set_check` within what :meth:`_left` leaves ``stage``, counted; None
        (not asked) when fewer than MIN_CALL_ITERATIONS are left."""
        left = self._left(stage)
        if left < MIN_CALL_ITERATIONS:
            return None
        if self.hard_set_x.shape != lb.shape:  # a QP handed over by a caller, not this formulation's
            self.hard_set_x = np.zeros(lb.shape)
        limit = int(min(left, ITERATION_LIMIT))
        verdict, iterations = hard_set_check(A, b, C, l, u, lb, ub, self.backend.tolerance, iter_limit=limit,
                                             out=self.hard_set_x)
        self.tick_work += iterations + DAQP_CALL_WORK
        self._check_final = iterations < limit  # ended before its iteration limit
        return verdict

    def _retries(self, qp: QPData, first: SolverError, stage: str, done: str = "") -> tuple:
        """:meth:`_call` of the backend's retries (``first`` raised when it has none), each of their RETRY_CALLS calls
        capped at its share of what :meth:`_left` leaves ``stage``; too little left: a budget cut, SolverError."""
        if not self.backend.cold_retry:
            raise first
        left = self._left(stage)
        calls = None
        if math.isfinite(left):
            if left < self.RETRY_CALLS * (MIN_CALL_ITERATIONS + DAQP_CALL_WORK):  # their least counted work
                self.budget_cut = True
                raise SolverError(f"{first}{done}; the backend's retries skipped: the tick's counted work "
                                  f"({self.tick_work:.0f} DAQP iterations) reached {self._factors(stage)[0]} budgets")
            calls = max(MIN_CALL_ITERATIONS, int(left) // self.RETRY_CALLS - DAQP_CALL_WORK)
        return self._call(qp, "retries", calls, self._deadline(self._factors(stage)[1]))

    def _call(self, qp: QPData, step: str, calls: int | None, deadline: float | None = None) -> tuple:
        """``backend.solve`` of ``qp`` (``solve_scaled`` for a ``... scaled call``; cold retries only in ``retries``),
        its calls capped at ``calls`` (None: no cap) and ending by ``deadline`` (None: as set), its work counted.
        (QPSolution, None), (None, SolverError) or, for a scaled call that found no solution, (None, None)."""
        backend = self.backend
        retry = backend.cold_retry
        backend.cold_retry = retry and step == "retries"
        if deadline is not None:
            backend.deadline = deadline
        backend.call_iterations = calls
        proximal = backend.proximal_iterations
        try:
            if step.endswith("scaled call"):
                x = backend.solve_scaled(*qp)
                return (None if x is None else QPSolution(x, backend.name, step)), None
            return QPSolution(backend.solve(*qp, confirm=False), backend.name, step), None  # no confirm: _solve_checked
        except SolverError as exc:
            return None, exc
        finally:
            backend.cold_retry = retry
            backend.call_iterations = None
            if deadline is not None:
                backend.deadline = math.inf
            proximal = PROXIMAL_ITERATION_WORK * (backend.proximal_iterations - proximal)
            if step != "retries":
                self.tick_work += backend.last_iterations + proximal + DAQP_CALL_WORK
            elif calls is not None:
                self.tick_work += self.RETRY_CALLS * (calls + DAQP_CALL_WORK) + proximal

    @property
    def retry_deadline(self) -> float:
        """CPU time after which an answer failing the output check is not refined (:meth:`refine`; ``math.inf``: no
        clock guard)."""
        return self._deadline(self.ATTEMPT_END)

    def _deadline(self, factor: float) -> float:
        """start + factor × budget of :attr:`tick_clock` (``math.inf`` without one)."""
        clock = self.tick_clock
        return math.inf if clock is None else clock[0] + factor * clock[1]

    def solve(self, qp: QPData, relax: Callable | None = None, check: Callable | None = None,
              skip_compiled: str = "") -> QPSolution:
        """The full QP ``qp``: the compiled solver first (unless ``skip_compiled`` says why not), its answer returned
        when ``check(x)`` returns ''; else that text or its failure is :attr:`compiled_reason`, and the ladder's
        answer warm-starts its next call. ``relax(l, u, lb, ub)``: copies of the relaxed QP's bounds (for the check of
        its hard set). Raises SolverError: no step found a solution (the message says why)."""
        compiled = self.compiled
        self.compiled_reason = ""
        if compiled is None:
            return self._ladder(qp, relax)
        if skip_compiled:
            compiled.clear()
            self.compiled_reason = skip_compiled
            return self._ladder(qp, relax)
        compiled.tolerance = self.backend.tolerance
        try:
            sol = compiled.solve(qp)
            why = check(sol.x) if check is not None else ""
            if not why:
                compiled.solves += 1
                return sol
        except SolverError as exc:
            why = str(exc)
        self.compiled_reason = why
        # the compiled call's work: its iteration cap at its per-iteration cost, in DAQP iterations
        self.tick_work += compiled.give_up() * KERNEL_ITERATION_COST / DAQP_ITERATION_COST
        sol = self._ladder(qp, relax)
        backend = self.backend  # the next compiled call starts from the working set of the ladder's answer
        compiled.warm(sol.x, getattr(backend, "last_multipliers", None) if sol.solver == backend.name else None, qp)
        return sol

    def _ladder(self, qp: QPData, relax: Callable | None) -> QPSolution:
        """The ladder (module docstring), or its resumption (:attr:`resume_scaled`). Raises SolverError."""
        if self.resume_scaled and self._counting() and isinstance(self.backend, DaqpBackend):
            # one scaled call of at most SCALED_FEASIBLE_FACTOR × daqp_attempt_iterations iterations, then quadprog
            cap = min(self.SCALED_FEASIBLE_FACTOR * self.daqp_attempt_iterations, self._left("FAILURE"))
            sol = self._call(qp, "resumed scaled call", int(max(MIN_CALL_ITERATIONS, cap)))[0]
            if sol is not None:
                return sol
            x, skipped = self._quadprog_within(qp, "QUADPROG")
            if x is not None:
                return QPSolution(x, "quadprog", "resumed quadprog")  # the next ticks resume the same way
            # not DAQP's attempt again (the last tick's failed; its iterations would leave the check none): the
            # hard-set checks, then the cut; the next tick starts the ladder afresh
            self.resume_scaled = False
            self.budget_cut = True
            first = SolverError("the resumed scaled call found no solution")
            self._check_hard_sets(first, qp, relax, self._set_check(*qp[2:], "FAILURE"))
            raise SolverError(f"{first}; quadprog: {skipped or 'no solution either'}")
        try:
            return self._stages(qp, relax)
        except SolverError:
            self.resume_scaled = self.budget_cut and self.hard_set_point and self._counting()
            raise

    def _stages(self, qp: QPData, relax: Callable | None) -> QPSolution:
        """The ladder's steps on the full QP ``qp`` (``relax``: as :meth:`solve`). Raises SolverError: the backend's,
        extended with why the ladder ended."""
        backend = self.backend
        if not isinstance(backend, DaqpBackend):
            return self._solve_checked(qp)
        known = None  # the full hard set's check before DAQP's attempt, when made
        checked = self.last_set_empty
        if checked:
            # the last failed full QP's hard set was proved empty: this one is checked first (a failing run of ticks
            # skips DAQP's attempt, which could only fail)
            self.last_set_empty = False
            known = self._set_check(*qp[2:], "FAILURE")
            if known is False:
                self._check_hard_sets(SolverError("DAQP not asked: the last failed full QP's hard set was empty"), qp,
                                      relax, known)
        # the first attempt and the cost-scaled call get the budget's iteration count
        cap = None if self.daqp_attempt_iterations >= ITERATION_LIMIT else self.daqp_attempt_iterations
        sol, first = self._call(qp, "attempt", cap, self._deadline(self.ATTEMPT_END))
        if sol is not None:
            return sol
        attempted = backend.last_iterations  # the attempt's DAQP iterations
        if backend.budget_capped:
            self.budget_cut = True
        feasible = self._check_hard_sets(first, qp, relax, known if checked else self._set_check(*qp[2:], "FAILURE"))
        if cap is not None:
            # a set not proved empty (DAQP cycles or misjudges ill-scaled costs): the cost-scaled call, on a set with
            # a point with what the attempt left of SCALED_FEASIBLE_FACTOR × cap, within the work left
            scaled_cap = max(MIN_CALL_ITERATIONS, self.SCALED_FEASIBLE_FACTOR * cap - attempted) if feasible else cap
            left = self._left("FAILURE")
            if left < MIN_CALL_ITERATIONS:
                self.budget_cut = True
            else:
                sol = self._call(qp, "scaled call", int(min(scaled_cap, left)), self._deadline(self.FAILURE_END))[0]
                if sol is not None:
                    return sol
        x, skipped = self._quadprog_within(qp, "QUADPROG")
        if skipped:
            # too little work left for quadprog's solve (which cannot be stopped once started), and so for the
            # retries after it
            raise SolverError(f"{first}; no quadprog solve: {skipped}"
                              + ("; the backend's retries skipped with it" if backend.cold_retry else ""))
        if x is not None:
            return QPSolution(x, "quadprog", "quadprog")
        sol, exc = self._retries(qp, first, "FAILURE", "; quadprog found no solution either")
        if sol is not None:
            return sol
        if backend.budget_capped or backend.iterations_capped:
            self.budget_cut = True
        raise exc

    def _check_hard_sets(self, first: SolverError, qp: QPData, relax: Callable | None, full: bool | None) -> bool:
        """The hard-set checks of a failed full QP after the full set's (its verdict ``full``, :meth:`_set_check`): the
        relaxed one. A set proved empty raises SolverError (``first`` extended). True: the full set has a point."""
        if full is True:
            self.hard_set_point = True
            return True
        self.last_set_empty = full is False
        if relax is not None and self._left("FAILURE") >= MIN_CALL_ITERATIONS:
            self.relaxed_bounds = relax(qp.l, qp.u, qp.lb, qp.ub)  # the caller's relaxed QP of this tick reuses them
            self.relaxed_set_feasible = self._set_check(qp.A, qp.b, qp.C, *self.relaxed_bounds, "FAILURE")
            self._relaxed_check_final = self._check_final
            if self.relaxed_set_feasible is False:
                self.last_set_empty = True
                raise SolverError(f"{first}; the relaxed hard set is empty, so is the full one (DAQP on the projection "
                                  f"of the origin onto it): quadprog, the backend's retries and the relaxed QP skipped")
        if full is False:
            raise SolverError(f"{first}; the hard set is empty (DAQP on the projection of the origin onto it): "
                              f"quadprog and the backend's retries skipped")
        return False

    def _solve_checked(self, qp: QPData) -> QPSolution:
        """A backend other than DAQP on the QP; when a :class:`~wbc.solvers.base.QPBackend` fails (unless
        :attr:`second_opinion_enabled` is False), a second opinion of two active-set solvers: quadprog
        (:func:`~wbc.solvers.independent.solve_pinned_reduced`), then one DAQP call. A proximal method's infeasibility
        test (ProxQP: Bambade et al., "PROX-QP: Yet another quadratic programming solver for robotics and beyond", RSS
        2022) can fire on feasible QPs with nearly dependent equality rows, where an active-set factorisation answers
        exactly. Raises the backend's SolverError when neither answers."""
        backend = self.backend
        qp_backend = isinstance(backend, QPBackend)
        try:
            # no independent re-solve (QPBackend.confirm) on the control path: it costs many control periods
            return QPSolution(backend.solve(*qp, **({"confirm": False} if qp_backend else {})), backend.name, "attempt")
        except SolverError as exc:
            if not (self.second_opinion_enabled and qp_backend):
                raise
            first = exc
        if self._daqp_check is None:
            self._daqp_check = DaqpBackend(tolerance=backend.tolerance, **DAQP_SETTINGS)
            self._daqp_check.cold_retry = False
        x, solver = solve_pinned_reduced(*qp, backend.tolerance), "quadprog"
        if x is None:
            try:
                x, solver = self._daqp_check.solve(*qp, confirm=False), "daqp"
            except SolverError:
                raise first from None
        return QPSolution(x, solver, "second opinion")

    def refine(self, x: np.ndarray, qp: QPData, accept: Callable, answered_by: str):
        """Refine a full-QP answer ``x`` that failed the caller's output check: polished
        (:meth:`wbc.solvers.base.QPBackend.polish`), else quadprog's (unless ``answered_by`` is quadprog) while the
        clock or count leaves room. ``accept(x, solver)``: the caller's solution of a candidate that passes its check
        (``solver`` None: the polished one), else None. Returns the first accepted candidate, or None."""
        backend = self.backend
        xp = backend.polish(x, *qp[2:]) if isinstance(backend, QPBackend) else None
        cand = None if xp is None else accept(xp, None)
        if cand is not None or answered_by == "quadprog":
            return cand
        xq = self._quadprog_within(qp, "QUADPROG")[0]  # the same gate as the failure path's quadprog (_stages)
        return None if xq is None else accept(xq, "quadprog")
