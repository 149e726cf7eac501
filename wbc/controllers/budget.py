"""The tick budget of a controller (:class:`TickBudget`): one object that owns the tick's counted work, its clock
guard and the stage factors, and answers whether a stage may start.

A tick of budget B seconds (CPU time; default the tick's dt) may do cap = ⌊B / solve_cost⌋ QP solves, counted by
the :class:`wbc.solvers.base.TickWork` it shares with the controller's backends (a count, not a clock: the same
inputs give the same answers). With the clock guard on, one budget of CPU time also counts as clock_weight × cap
solves, so every limit on the count also holds on the clock, and a stage given its ``cost`` (its CPU time as timed
in this tick) starts only when it ends by ``stage_deadline`` budgets (:meth:`TickBudget.fits`); the first solve's
iteration cap is the CPU time left until one budget over the CPU time per iteration of the recent first solves
(:meth:`TickBudget.iteration_cap`). The controller owns the numbers (its class constants, read at each
:meth:`TickBudget.start`); the decisions are these methods'. The same object serves a controller of either level.
"""

from __future__ import annotations

import math

from wbc.exceptions import InvalidInputError
from wbc.solvers import TickWork

__all__ = ["STAGES", "TickBudget", "COST_DECAY"]

#: the stages :meth:`TickBudget.may_start` answers for
STAGES = ("retry", "stage")
#: per tick, the CPU time per iteration of the first solve (``TickBudget.iteration_cost``) decays by this factor
COST_DECAY = 0.9


class TickBudget:
    """Counted work, clock guard and stage factors of one controller's ticks (module docstring).

    Attributes:
        work: the tick's :class:`~wbc.solvers.base.TickWork` (shared with the controller's backends).
        clock_guard: the tick's CPU time also counts as work (set by the controller).
        seconds: the current tick's budget (s of CPU time; NaN before the first tick).
        stage_factor: a solved tick starts no stage past stage_factor × cap counted solves.
        stage_deadline: with the clock guard, a timed stage ends by stage_deadline budgets of CPU time.
        first_work, resolve_work, level_work: counted solves of the tick's first solve of its QP, of its largest
            re-solve and of its largest strict level so far; ``resolves``: solves of its QP so far (from the start
            of the form that answers it: a cut cascade's weighted form restarts them).
        resolve_cost, level_cost, check_cost: CPU time (s) of the tick's longest re-solve, strict level and check
            of a held safe command so far (clock guard).
        safe_cost: CPU time (s) of the longest solve of the safe command in this tick, else the last tick's;
            ``safe_fresh``: it was timed in this tick; ``safe_stage_cost``: the last 'constraints_only' stage.
        level_mark, level_count: CPU time and counted solves of the tick at the last level boundary of a cascade.
        iteration_cost: CPU time (s) per iteration of the first solve (clock guard; :meth:`note_first_solve`).

    Args:
        timer: the CPU clock (s; default :func:`wbc.solvers.base.cpu_time`, the calling thread's), read through
            ``work.timer`` (a test injects a fake one).
    """

    def __init__(self, timer=None) -> None:
        self.work = TickWork(timer=timer)
        self.clock_guard = False
        self.seconds = math.nan
        self.stage_factor = self.stage_deadline = 1.0
        self.resolve_cost = self.level_cost = self.check_cost = self.safe_cost = 0.0
        self.safe_fresh = False
        self.safe_stage_cost = self.level_mark = self.level_count = self.resolve_work = self.level_work = 0.0
        self.iteration_cost = self.first_work = 0.0
        self.resolves = 0

    def start(self, seconds: float, solve_cost: float, clock_weight: float) -> None:
        """Start a tick of ``seconds`` of budget: cap ⌊seconds / solve_cost⌋ counted solves (``math.inf`` when
        ``seconds`` is), with the clock guard seconds / (clock_weight × cap) of CPU time counted as one solve; the
        tick's stage costs start at 0 (the safe command's from the last tick stays, not fresh)."""
        self.seconds = seconds
        cap = math.floor(seconds / solve_cost) if math.isfinite(seconds) else math.inf
        clock = seconds / (clock_weight * max(cap, 1)) if self.clock_guard and math.isfinite(cap) else math.inf
        self.work.reset(cap, clock)
        self.resolve_cost = self.level_cost = self.check_cost = 0.0
        self.first_work = self.resolve_work = self.level_work = 0.0
        self.safe_fresh, self.resolves = False, 0

    def may_start(self, stage: str, cost: float | None = None, deadline: float | None = None,
                  work: float | None = None) -> bool:
        """May a stage start now: ``"retry"``, an optional stage of a failed tick (confirmation, relaxation,
        diagnosis), when the count is below one cap, also after one more re-solve at the counted work of the tick's
        largest re-solve so far; ``"stage"``, a further stage of a solved tick (a strict level, a contact correction,
        a trust region), when it ends within ``stage_factor`` caps at that work (the larger of ``first_work`` and
        ``resolve_work``, or ``work`` counted solves when given); with ``cost`` (s of CPU time), also :meth:`fits`
        (cost, deadline).

        Raises:
            InvalidInputError: ``stage`` not one of :data:`STAGES`.
        """
        ahead = max(self.first_work, self.resolve_work) if work is None else work
        work = self.work
        if stage == "retry":
            late = work.spent() or work.spent(1.0, ahead)
        elif stage == "stage":
            late = work.spent(self.stage_factor, ahead)
        else:
            raise InvalidInputError(f"stage must be one of {', '.join(STAGES)}, got {stage!r}")
        return not late and (cost is None or self.fits(cost, deadline))

    def fits(self, cost: float, deadline: float | None = None) -> bool:
        """A stage of ``cost`` seconds of CPU time (as timed in this tick) started now ends by ``deadline``
        (default ``stage_deadline``) times the tick's budget (clock guard; always True without it)."""
        factor = self.stage_deadline if deadline is None else deadline
        return not self.clock_guard or self.work.seconds() + cost <= factor * self.seconds

    def safe_estimate(self) -> float:
        """CPU time (s) expected of one solve of the safe command: this tick's longest, else the last tick's, else
        the longest re-solve of this tick's QP."""
        return self.safe_cost or self.resolve_cost

    def level_stop(self) -> bool:
        """``stop`` of a strict cascade (:func:`wbc.solvers.hierarchy.solve_lexicographic`): stage_factor × cap
        counted solves spent, or would be by the next level at the counted work of the largest level so far, or
        (clock guard) the next level, at the CPU time of the longest level so far, would not end by
        ``stage_deadline`` budgets."""
        work = self.work
        solves = work.solves
        self.level_work = max(self.level_work, solves - self.level_count)
        self.level_count = solves
        late = work.spent(self.stage_factor, self.level_work)
        if self.clock_guard:
            now = work.seconds()
            self.level_cost = max(self.level_cost, now - self.level_mark)
            self.level_mark = now
            return late or not self.fits(self.level_cost)
        return late

    def cascade_may_start(self, levels: int, level_work: float, runs: int = 1) -> bool:
        """May a strict cascade of ``levels`` levels start as the tick's first solve: ``runs`` cascades (its solve and
        the re-solves the tick plans after it, e.g. one contact correction) at their least counted work, levels ×
        (1 + ``level_work``) each (one QP solve per level and the work around it), end within stage_factor caps
        beside the work already counted (a new layout's, the clock's) and the reserve (``TickWork.spent``)."""
        return not self.work.spent(self.stage_factor, runs * levels * (1.0 + level_work))

    def cascade_fits(self, levels: int, share: float) -> bool:
        """After a tick answered by the weighted form of ``levels`` strict levels: its counted solves times levels + 1
        fit in ``share`` caps, and (clock guard) its CPU time times 2 (levels + 1) in one budget."""
        n, work = levels + 1, self.work
        if n * work.solves > share * work.cap:
            return False
        return not self.clock_guard or 2 * n * work.seconds() <= self.seconds

    def iteration_cap(self, max_iter: int) -> int:
        """The iteration cap of the tick's first solve: ``max_iter`` without the clock guard (a count: reproducible);
        with it ⌊(seconds − CPU time so far) / iteration_cost⌋ clamped to [1, max_iter] (``max_iter`` while no cost
        is known)."""
        if not self.clock_guard or not self.iteration_cost > 0.0 or not math.isfinite(self.seconds):
            return max_iter
        left = self.seconds - self.work.seconds()
        return int(min(max_iter, max(1.0, left // self.iteration_cost)))

    def note_first_solve(self, iterations: int, seconds: float) -> None:
        """The tick's first solve took ``iterations`` (≥ 0) in ``seconds`` of CPU time: ``iteration_cost`` becomes
        the larger of COST_DECAY × itself and seconds / max(iterations, 1) (a slow sample bounds the next ticks)."""
        self.iteration_cost = max(COST_DECAY * self.iteration_cost, seconds / max(iterations, 1))
