"""The relaxation ladder of the kinematic controller, tried before a tick is declared failed.

Relaxable constraints (joint acceleration limits) are left out of a tick that is infeasible with them
(``_relax``). Then, when joints are outside their position limits, their return rate is scaled by α: α = 0 first,
then 1/1000, 1/100, 1/10, 1/2 while they solve and the budget lasts (``_relaxation_ladder``, ``_slower_return``);
when even α = 0 has no solution the contacts' drift corrections rank below it (J_c v = 0). The strict levels'
weighted form (level k of p scaled by ``WEIGHTED_LEVEL_RATIO`` ** (p − k)) answers a cascade the budget cut
(``_weighted_answer``)."""

from __future__ import annotations

from contextlib import contextmanager

import numpy as np

from wbc.configuration import Configuration
from wbc.constraints.limits import JointPositionLimit
from wbc.exceptions import SolverError
from wbc.tick import TickResult


#: scales α of the return rate of joints outside their limits tried in turn when the tick is infeasible
#: (``Relaxation._relaxation_ladder``)
_RETURN_RATE_SCALES = (0.5, 0.1, 0.01, 0.001, 0.0)


def outside_limits(config: Configuration, box: list, lb: np.ndarray, ub: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(indices into v of the joints below their lower position limit whose box asks a return (lb > 0), the same
    above the upper limit (ub < 0)), of the :class:`JointPositionLimit` objects in ``box`` at ``config``, against the
    assembled box bounds lb, ub (nv,)."""
    entries = []
    for c in box:
        if isinstance(c, JointPositionLimit):
            q = config.q[c.idx_q]
            idx = np.asarray(c.indices)
            entries.append(idx[(q < c.q_min) & (lb[idx] > 0)])
            entries.append(idx[(q > c.q_max) & (ub[idx] < 0)])
    if not entries:
        return np.zeros(0, int), np.zeros(0, int)
    return np.concatenate(entries[0::2]), np.concatenate(entries[1::2])


class Relaxation:
    """The relaxation part of :class:`wbc.controllers.kinematic.KinematicController` (module docstring)."""

    def _relaxation_ladder(self, config: Configuration, dt: float,
                           first_failure: SolverError) -> tuple[np.ndarray, list[str], float | None, bool]:
        """The retries of a tick whose QP failed (``first_failure``), in turn (module docstring): dependent contact
        rows made consistent, the relaxable constraints left out, the return rate of the joints outside their limits
        scaled by α: α = 0 first (the feasible sets are nested: when it has no solution no α has; then also
        J_c v = 0), then from 1/1000 up while they solve and the tick's count lasts, the largest kept (trial solves
        unconfirmed, no cold retry). Returns (v, what was relaxed, α or None, held: J_c v = 0 asked), the buffers
        holding v's problem; raises SolverError when no retry solved (or the clock guard left none the time)."""
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
            v = self._try_solve(config)
        if v is None and self._relaxable:  # (one solve: not cut by the count)
            if not budget.fits(budget.resolve_cost):
                raise SolverError(f"{first_failure}; relaxations skipped: tick budget spent (clock guard)")
            self._relax(config, dt)
            relaxed = [c.name for c in self._relaxable]
            v = self._try_solve(config)
        if v is not None:
            return v, relaxed, None, False
        low, high = outside_limits(config, self._box, self._lb, self._ub)
        if not (low.size or high.size):
            raise first_failure
        if not budget.fits(budget.resolve_cost):
            raise SolverError(f"{first_failure}; return-rate relaxation skipped: tick budget spent (clock guard)")
        lb0, ub0 = self._lb[low].copy(), self._ub[high].copy()
        with self._unconfirmed() as backends:
            self._lb[low] = 0.0
            self._ub[high] = 0.0
            v = self._try_solve(config)
            if v is None and self._contact_rows.size and budget.fits(budget.resolve_cost):
                self._b[self._contact_rows] = 0.0  # the contacts held where they are: J_c v = 0
                v = self._try_solve(config)
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
                self._lb[low], self._ub[high] = alpha * lb0, alpha * ub0
                v_alpha = self._try_solve(config)
                if v_alpha is None:
                    break  # (feasible sets nested: no larger α has a solution)
                v, return_rate = v_alpha, alpha
            self._lb[low], self._ub[high] = return_rate * lb0, return_rate * ub0  # the returned command's problem
            self._return_bounds = (low, high, lb0, ub0)
        relaxed.append(f"joint_position_limit return rate × {return_rate:g}")
        if held:
            relaxed.append("contact drift correction × 0 (J_c v = 0)")
        return v, relaxed, return_rate, held

    def _slower_return(self, config: Configuration, dt: float, relaxed: list, alpha: float,
                       result: TickResult) -> tuple[TickResult, float]:
        """After the return-rate ladder kept α but no trust region held the contacts: the smaller scales down to 0,
        each solved and held, while the tick's stages last (the sole-drift bound of an ok tick ranks above the return
        rate); last α = 0 with J_c v = 0 (its drift from where the full correction sends a frame: K dt e plus second
        order in v dt). Returns (the first ok result, its α), else (``result``, ``alpha``), the buffers α's again."""
        low, high, lb0, ub0 = self._return_bounds
        rows = self._contact_rows
        b0 = self._b[rows].copy()
        steps = [(a, False) for a in _RETURN_RATE_SCALES if a < alpha] + ([(0.0, True)] if rows.size else [])
        with self._unconfirmed():
            for a, held in steps:
                if not self.tick_budget.may_start("stage", self.tick_budget.resolve_cost):
                    self._cut.append(f"slower returns below × {alpha:g}")
                    break
                self._lb[low], self._ub[high] = a * lb0, a * ub0
                if held:
                    self._b[rows] = 0.0
                v = self._try_solve(config)
                if v is None:
                    continue
                r = self._held_command(config, dt, v, relaxed, held=held)
                if r.ok:
                    relaxed[-1] = f"joint_position_limit return rate × {a:g}"
                    if held:
                        relaxed.append("contact drift correction × 0 (J_c v = 0)")
                    return r, a
            self._b[rows] = b0
            self._lb[low], self._ub[high] = alpha * lb0, alpha * ub0
            return result, alpha

    def _try_solve(self, config: Configuration) -> np.ndarray | None:
        """The command of the QP in the buffers (``_solve_assembled``), or None when that raises SolverError."""
        try:
            return self._solve_assembled(config)
        except SolverError:
            return None

    @contextmanager
    def _unconfirmed(self, backends=None):
        """``backends`` (default: those of the tick's QP; None entries left out) as a list, unconfirmed inside the block
        (a failed trial only sends a ladder to its next step); their ``independent`` restored and ``cold_retry`` back
        on at its end."""
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
                self._A[r0:r1] = 0.0
                self._b[r0:r1] = 0.0
            elif c.kind == "inequality":
                self._l[r0:r1] = -np.inf
                self._u[r0:r1] = np.inf
        self._intersect_boxes(config, dt, skip=set(map(id, self._relaxable)))
        self._eq_rows = None

    def _weighted_answer(self, config: Configuration, dt: float, relaxed: list) -> TickResult | None:
        """The tick answered again by the weighted form of its strict levels (with the reserve the cascade left)
        after the budget stopped the cascade's contact hold short of ``sole_drift_tolerance``; None when that answer
        drifts too or fails: the cascade's failure stands."""
        if not self.tick_budget.fits(self.tick_budget.resolve_cost):
            return None
        self._work.reserve = 0.0
        # its re-solves are the weighted form's (one QP), not the cascade's: their work and time counted from here
        budget = self.tick_budget
        budget.first_work = budget.resolve_work = budget.resolve_cost = 0.0
        budget.resolves = 0
        self._weighted_tick, self._weighted_qp = True, None
        cascade_cut, self._cut = self._cut, []
        v = self._try_solve(config)
        result = None if v is None else self._held_command(config, dt, v, relaxed)
        if result is not None and result.ok:
            self._cut = [f"the cascade's {stage}" for stage in cascade_cut] + self._cut
            return result
        self._weighted_tick, self._cut = False, cascade_cut
        return None

    def _weighted_levels(self, config, H, g) -> tuple[np.ndarray, np.ndarray]:
        """(H, g) of the strict levels' weighted form: the soft level's cost plus, for level k of p (0 highest),
        WEIGHTED_LEVEL_RATIO ** (p − k) × ‖J_k v − v*_k‖² (task weights applied); (nv, nv), (nv,)."""
        Hw, gw = H.copy(), g.copy()
        p = len(self._level_order)
        for i, level in enumerate(self._level_rows):  # gathered by assemble, weights applied
            c = self.WEIGHTED_LEVEL_RATIO ** (p - i)
            Hw += c * (level.wJ.T @ level.wJ)
            gw -= c * (level.wJ.T @ level.wr)
        return Hw, gw
