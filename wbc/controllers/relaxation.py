"""The relaxation ladder of the kinematic controller, tried in turn before a tick is declared failed: dependent contact
rows' right-hand sides made consistent (least squares); the relaxable constraints (joint acceleration limits) left out
(``_relax``); the return rate of joints outside their position limits scaled by α: α = 0 first (the feasible sets are
nested: when it has no solution none has, and then J_c v = 0 is asked), then 1/1000, 1/100, 1/10, 1/2 while they solve
and the budget lasts, the largest kept; when its command's contacts cannot be held (the sole-drift bound ranks above the
return rate), the smaller α down to 0, then 0 with J_c v = 0 (``_slower_return``). The strict levels' weighted form
(level k of p scaled by ``WEIGHTED_LEVEL_RATIO`` ** (p − k)) answers a cascade the budget cut (``_weighted_answer``)."""

from __future__ import annotations

from contextlib import contextmanager

import numpy as np

from wbc.configuration import Configuration
from wbc.constraints.limits import JointPositionLimit
from wbc.exceptions import SolverError
from wbc.tick import TickResult


#: scales α of the return rate of joints outside their limits (module docstring)
_RETURN_RATE_SCALES = (0.5, 0.1, 0.01, 0.001, 0.0)


def outside_limits(config: Configuration, box: list, lb: np.ndarray, ub: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(indices into v of the joints below their lower position limit whose box asks a return (lb > 0), the same
    above the upper limit (ub < 0)), of the :class:`JointPositionLimit` objects in ``box`` at ``config``, against the
    assembled box bounds lb, ub (nv,)."""
    low, high = [np.zeros(0, int)], [np.zeros(0, int)]
    for c in box:
        if isinstance(c, JointPositionLimit):
            q, idx = config.q[c.idx_q], np.asarray(c.indices)
            low.append(idx[(q < c.q_min) & (lb[idx] > 0)])
            high.append(idx[(q > c.q_max) & (ub[idx] < 0)])
    return np.concatenate(low), np.concatenate(high)


class Relaxation:
    """The relaxation part of :class:`wbc.controllers.kinematic.KinematicController` (module docstring)."""

    def _relaxation_ladder(self, config: Configuration, dt: float,
                           first_failure: SolverError) -> tuple[np.ndarray, list[str], float | None, bool]:
        """The retries of a failed tick in turn (module docstring; trial solves unconfirmed, no cold retry): (v, what
        was relaxed, α or None, held: J_c v = 0 asked), the buffers holding v's problem; raises SolverError when none
        solved (or the clock guard left none the time)."""
        budget, v, relaxed, held = self.tick_budget, None, [], False
        self._work.reserve = 0.0  # the relaxations count as before
        # clock guard: the least-squares re-solve below (does the hard set have a solution?) by RESCUE_DEADLINE
        if not budget.fits(budget.resolve_cost, self.RESCUE_DEADLINE):
            raise SolverError(f"{first_failure}; relaxations skipped: tick budget spent (clock guard)") from None
        if self._level_order and not self._weighted_tick and not budget.may_start("retry"):
            # the failed cascade spent the tick's count: its retries are answered by the weighted form (one QP each)
            self._weighted_tick, self._weighted_qp = True, None
            self._cut.append("priority levels of the retries (their weighted form's command)")
        if self._contact_rows.size and self._consistent_contact_rhs():
            # dependent contact rows asked contradictory corrections: once more in least squares (one solve or
            # cascade, not cut by the count: a cascade that had spent it failed ticks the weighted form solves)
            v = self._try_solve()
        if v is None and self._relaxable:  # (one solve: not cut by the count)
            if not budget.fits(budget.resolve_cost):
                raise SolverError(f"{first_failure}; relaxations skipped: tick budget spent (clock guard)")
            self._relax(config, dt)
            relaxed = [c.name for c in self._relaxable]
            v = self._try_solve()
        if v is not None:
            return v, relaxed, None, False
        low, high = outside_limits(config, self._box, self._lb, self._ub)
        if not (low.size or high.size):
            raise first_failure
        if not budget.fits(budget.resolve_cost):
            raise SolverError(f"{first_failure}; return-rate relaxation skipped: tick budget spent (clock guard)")
        self._return_bounds = (low, high, self._lb[low].copy(), self._ub[high].copy())
        with self._unconfirmed() as backends:
            self._lb[low] = self._ub[high] = 0.0  # α = 0: the feasible sets are nested, none if it has none
            v = self._try_solve()
            if v is None and self._contact_rows.size and budget.fits(budget.resolve_cost):
                self._b[self._contact_rows] = 0.0  # the contacts held where they are: J_c v = 0
                v = self._try_solve()
                held = v is not None
            if v is None:
                raise SolverError(f"{first_failure}; no solution either with the joints outside their limits held "
                                  f"where they are (return rate 0)" + (", nor with the contacts held where they are"
                                                                        if self._contact_rows.size else ""))
            for b in backends:  # a failed α only sends the ladder to the next one: no cold retry either
                b.cold_retry = False
            return_rate = 0.0
            for alpha in reversed(_RETURN_RATE_SCALES[:-1]):  # from the slowest return up
                if not budget.may_start("retry", budget.resolve_cost):
                    break
                v_alpha = self._solve_returning(alpha)
                if v_alpha is None:
                    break  # (feasible sets nested: no larger α has a solution)
                v, return_rate = v_alpha, alpha
            self._solve_returning(return_rate, solve=False)  # the returned command's problem
        return v, self._returned(relaxed, return_rate, held), return_rate, held

    def _slower_return(self, config: Configuration, dt: float, relaxed: list, alpha: float,
                       result: TickResult) -> tuple[TickResult, float]:
        """After the return rate α's command failed its contact hold: the smaller scales down to 0, then 0 with
        J_c v = 0, each solved and held while the tick's stages last (module docstring). Returns (the first ok
        result, its α), else (``result``, ``alpha``) with the buffers α's again."""
        rows = self._contact_rows
        b0 = self._b[rows].copy()
        steps = [(a, False) for a in _RETURN_RATE_SCALES if a < alpha] + ([(0.0, True)] if rows.size else [])
        with self._unconfirmed():
            for a, held in steps:
                if not self.tick_budget.may_start("stage", self.tick_budget.resolve_cost):
                    self._cut.append(f"slower returns below × {alpha:g}")
                    break
                v = self._solve_returning(a, held)
                r = None if v is None else self._held_command(config, dt, v, relaxed, held=held)
                if r is not None and r.ok:
                    r.relaxed = self._returned(relaxed[:-1], a, held)
                    return r, a
            self._b[rows] = b0
            self._solve_returning(alpha, solve=False)
            return result, alpha

    def _solve_returning(self, alpha: float, held: bool = False, solve: bool = True) -> np.ndarray | None:
        """The buffers' return rate scaled by α (and J_c v = 0 when ``held``), then their command (``_try_solve``;
        None without a solve when ``solve`` is False)."""
        low, high, lb0, ub0 = self._return_bounds
        self._lb[low], self._ub[high] = alpha * lb0, alpha * ub0
        if held:
            self._b[self._contact_rows] = 0.0
        return self._try_solve() if solve else None

    @staticmethod
    def _returned(relaxed: list, alpha: float, held: bool) -> list[str]:
        """``relaxed`` and the return rate's relaxation (``TickResult.relaxed``)."""
        return relaxed + [f"joint_position_limit return rate × {alpha:g}"] + (
            ["contact drift correction × 0 (J_c v = 0)"] if held else [])

    def _try_solve(self) -> np.ndarray | None:
        """The command of the QP in the buffers (``_solve_assembled``), or None when that raises SolverError."""
        try:
            return self._solve_assembled()
        except SolverError:
            return None

    @contextmanager
    def _unconfirmed(self, backends=None):
        """``backends`` (default: the tick's QP's) unconfirmed inside the block (a failed trial only sends a ladder to
        its next step); their ``independent`` restored and ``cold_retry`` back on at its end."""
        backends = [b for b in backends or (self.backend, self._final_backend, *self._level_backends) if b is not None]
        independent = [b.independent for b in backends]
        try:
            for b in backends:
                b.independent = ()
            yield backends
        finally:
            for b, ind in zip(backends, independent):
                b.independent = ind
                b.cold_retry = True

    def _relax(self, config: Configuration, dt: float) -> None:
        """Drop the relaxable constraints from the assembled buffers by their kind (equality rows made void,
        inequality rows unbounded, boxes re-intersected without them), as the ID QP's relaxed solve does."""
        for c, r0, r1 in self._relaxable_blocks:
            if c.kind == "equality":
                self._A[r0:r1] = self._b[r0:r1] = 0.0
            elif c.kind == "inequality":
                self._l[r0:r1] = -np.inf
                self._u[r0:r1] = np.inf
        self._intersect_boxes(config, dt, skip=set(map(id, self._relaxable)))
        self._eq_rows = None

    def _weighted_answer(self, config: Configuration, dt: float, relaxed: list) -> TickResult | None:
        """The tick answered again by the weighted form of its strict levels after the budget stopped the cascade's
        contact hold short of ``sole_drift_tolerance``; None when that drifts too or fails."""
        if not self.tick_budget.fits(self.tick_budget.resolve_cost):
            return None
        self.tick_budget.restart_resolves()
        self._weighted_tick, self._weighted_qp = True, None
        cascade_cut, self._cut = self._cut, []
        v = self._try_solve()
        result = None if v is None else self._held_command(config, dt, v, relaxed)
        if result is not None and result.ok:
            self._cut = [f"the cascade's {stage}" for stage in cascade_cut] + self._cut
            return result
        self._weighted_tick, self._cut = False, cascade_cut
        return None

    def _weighted_levels(self, H, g) -> tuple[np.ndarray, np.ndarray]:
        """(H, g) of the strict levels' weighted form: the soft level's cost plus, for level k of p (0 highest),
        WEIGHTED_LEVEL_RATIO ** (p − k) × ‖J_k v − v*_k‖² (task weights applied); (nv, nv), (nv,)."""
        Hw, gw = H.copy(), g.copy()
        p = len(self._level_order)
        for i, level in enumerate(self._level_rows):  # gathered by assemble, weights applied
            c = self.WEIGHTED_LEVEL_RATIO ** (p - i)
            Hw += c * (level.wJ.T @ level.wJ)
            gw -= c * (level.wJ.T @ level.wr)
        return Hw, gw
