"""The general route of a kinematic tick: the assembled QP on the controller's backend (flat, with band rows for
nearly dependent equalities) or the strict levels' lexicographic cascade (:mod:`wbc.solvers.hierarchy`), and the
backends these solves use (``docs/kinematic-controller.md``)."""

from __future__ import annotations

import numpy as np

from wbc.exceptions import SolverError
from wbc.solvers import DaqpBackend, QPBackend, make_backend
from wbc.solvers.hierarchy import band_rows, independent_rows, solve_lexicographic
from wbc.solvers.qp_data import QPData


#: independent solvers confirming a failed QP inside a tick (``QPBackend.independent``) while the tick's budget
#: lasts: the dual active-set methods first (quadprog, DAQP), ProxQP last (tens of ms on an infeasible problem, but
#: it solves the semidefinite levels of a hierarchy that the others refuse)
CONFIRM_ORDER = ("quadprog", "daqp", "proxqp")


class GeneralRoute:
    """The general-route part of :class:`wbc.controllers.kinematic.KinematicController` (module docstring)."""

    def _solve_assembled(self) -> np.ndarray:
        """Solve the QP held in the controller's buffers (flat, or the hierarchy when levels exist); with the clock
        guard its CPU time is recorded (the cost of the tick's next re-solve, ``TickBudget.fits``)."""
        solves = self._work.solves
        t = self._work.seconds() if self.clock_guard else 0.0
        self._weighted_from = None
        try:
            return self._solve_levels(*self._qp) if self._level_order else self._solve_flat(*self._qp)
        finally:
            # the counted work of the largest re-solve so far: the stages after it start only when one more fits
            # (after a cascade the budget cut, the tick's re-solves are its weighted form's: counted from its start)
            if self._weighted_from is not None:
                solves, t = self._weighted_from
            budget = self.tick_budget
            if budget.resolves:
                budget.resolve_work = max(budget.resolve_work, self._work.solves - solves)
            else:
                budget.first_work = self._work.solves - solves
            budget.resolves += 1
            if self.clock_guard:
                budget.resolve_cost = max(budget.resolve_cost, self._work.seconds() - t)

    def _solve_flat(self, H, g, A, b, C, l, u, lb, ub) -> np.ndarray:
        fresh = self._eq_rows is None
        if fresh:
            self._eq_rows = independent_rows(A, self.rank_rtol)
        elif self._banded is self._eq_rows and np.array_equal(self._banded_A, A):
            # a re-solve of this tick's A (only b or the box changed) whose dropped rows needed band rows: those bands
            # at once, not a solve whose residual sends it there (as the cascade's BAND_KEY); failed: forgotten
            try:
                return self._solve_banded(H, g, A, b, C, l, u, lb, ub)
            except SolverError:
                self._banded = None
        while True:
            full_rank = self._eq_rows.size == A.shape[0]
            A_kept, b_kept = (A, b) if full_rank else (A[self._eq_rows], b[self._eq_rows])
            v = self.backend.solve(H, g, A_kept, b_kept, C, l, u, lb, ub)
            self.dependent_residual = 0.0 if full_rank else float(np.max(np.abs(A @ v - b)))
            if self.dependent_residual <= self.dependent_row_tolerance:
                return v
            rows = None if fresh else independent_rows(A, self.rank_rtol)
            if rows is None or np.array_equal(rows, self._eq_rows):
                # the dropped rows are only nearly dependent (or their right-hand sides disagree): solve again
                # with them as band rows |A_d v − b_d| ≤ dependent_row_tolerance / 2 (a well-posed inequality
                # for the active-set solver); if that has no solution the hard equalities contradict each other
                return self._solve_banded(H, g, A, b, C, l, u, lb, ub)
            # the dropped rows have become independent since the rank was computed: solve again with them
            fresh = True
            self._eq_rows = rows

    def _cap_calls(self, cap: int | None) -> None:
        """At most ``cap`` DAQP iterations per call of the flat QP's backends (the tick's, its band rows'), within a
        cap the caller set on the tick's backend (``_caller_calls``, read at the tick's start); None: the caller's."""
        own = self._caller_calls
        for backend in (self.backend, self._band_backend):
            if isinstance(backend, DaqpBackend):
                backend.call_iterations = own if cap is None or (own is not None and own < cap) else cap

    def _solve_banded(self, H, g, A, b, C, l, u, lb, ub) -> np.ndarray:
        """Flat solve with the dropped dependent equality rows as band inequalities (``_solve_flat``)."""
        half = 0.5 * self.dependent_row_tolerance
        if self._band_backend is None:
            self._band_backend = self._new_backend()
            self._band_backend.call_iterations = getattr(self.backend, "call_iterations", None)
        try:
            v = self._band_backend.solve(H, g, *band_rows(A, b, C, l, u, self._eq_rows, half), lb, ub)
        except SolverError as exc:
            raise SolverError(f"dependent equality rows violated by {self.dependent_residual:.3g} after the solve, and "
                              f"no solution holds them within ±{half:.3g} (contradictory hard equalities): {exc}") \
                from None
        self.dependent_residual = float(np.max(np.abs(A @ v - b)))
        self._banded, self._banded_A = self._eq_rows, A.copy()
        return v

    def _new_backend(self, **daqp_settings) -> QPBackend:
        """A fresh backend of the same kind as ``self.backend`` (own warm start)."""
        if isinstance(self.backend, DaqpBackend):
            backend = DaqpBackend(tolerance=self.backend.tolerance, **{**self.backend.settings, **daqp_settings})
        else:
            backend = make_backend(self.backend.name)
        backend.work = self._work
        backend.independent = CONFIRM_ORDER
        return backend

    def _plan_levels(self) -> None:
        """Before the tick's first solve: strict levels whose cascade (and contact correction) cannot fit as a 'stage'
        at its least work are answered by their weighted form from the start (``docs/kinematic-controller.md``)."""
        if not self._level_order or self._weighted_tick:
            return
        runs = 2 if self.contact_correction > 0 and self._contacts else 1
        least = runs * len(self._level_order) * (1.0 + self.LEVEL_WORK)
        if self.tick_budget.may_start("stage", work=least):
            return
        self._work.reserve = 0.0  # the weighted form's: all of it
        self._weighted_tick, self._weighted_qp = True, None
        self._cut.append(f"the cascade of {len(self._level_order)} priority levels ("
                         + ("with its contact correction, " if runs > 1 else "")
                         + f"at least {least:g} counted solves: their weighted form's command)")

    def _solve_levels(self, H, g, A, b, C, l, u, lb, ub) -> np.ndarray:
        if self._weighted_tick and self._in_solve:
            if self._weighted_qp is None:
                self._weighted_qp = self._weighted_levels(H, g)
            return self._solve_flat(*self._weighted_qp, A, b, C, l, u, lb, ub)
        levels = [(level.wJ, level.wr) for level in self._level_rows]  # gathered by assemble
        while len(self._level_backends) < len(levels):
            # semidefinite J_kᵀJ_k: DAQP's proximal-point iterations; a weight of 1e-3 on the proximal term was
            # reliable where the default (1e-6) reported degenerate feasible levels as infeasible
            self._level_backends.insert(0, self._new_backend(eps_prox=1e-3))
        if self._final_backend is None:
            self._final_backend = self._new_backend()
        self.tick_budget.level_mark, self.tick_budget.level_count = self._work.seconds(), self._work.solves
        v, self.level_residuals = solve_lexicographic(
            levels, QPData(H, g, A, b, C, l, u, lb, ub), self._level_backends[:len(levels)], self._final_backend,
            rank_rtol=self.rank_rtol, dependent_row_tolerance=self.dependent_row_tolerance,
            stop=self.tick_budget.level_stop if self._in_solve else None,
            memo=self._level_memo if self._in_solve else None, level_work=self.LEVEL_WORK)
        cut = solve_lexicographic.last_cut
        if cut is not None:
            if self._in_solve and self.tick_budget.fits(self.tick_budget.level_cost):
                # the cascade does not fit the tick (its count, or the clock guard's CPU time); the weighted form of
                # the levels (one QP, with the reserve the cascade left: WEIGHTED_RESERVE) answers this tick and its
                # re-solves instead of the last solved level's command (which ignores the levels below it)
                self.tick_budget.restart_resolves()
                self._weighted_from = (self._work.solves, self._work.seconds() if self.clock_guard else 0.0)
                try:
                    qp = self._weighted_levels(H, g)
                    v = self._solve_flat(*qp, A, b, C, l, u, lb, ub)
                    self._weighted_tick, self._weighted_qp = True, qp
                except SolverError:
                    pass  # the last solved level's command (a point of the hard set)
            self._cut.append(f"priority levels after the first {cut} of {len(levels) + 1} (" + (
                "their weighted form's command)" if self._weighted_tick else "the last solved level's command)"))
        return v
