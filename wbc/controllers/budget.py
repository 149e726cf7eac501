"""The tick budget of a controller (:class:`TickBudget`): the tick's counted work (``TickWork``, shared with the
controller's backends: a count, not a clock), its clock guard and stage factors, and whether a stage may start.
The controller owns the numbers (its class constants, read at each :meth:`TickBudget.start`); what they mean:
``docs/kinematic-controller.md``, "tick budget"."""

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
        work: the tick's :class:`~wbc.solvers.base.TickWork`; ``seconds``: the tick's budget (s of CPU time).
        stage_factor: a solved tick starts no stage past stage_factor × cap counted solves; ``stage_deadline``:
            with the clock guard, a timed stage ends by stage_deadline budgets of CPU time.
        first_work, resolve_work, level_work: counted solves of the tick's first solve, largest re-solve and largest
            strict level so far; ``resolves``: solves of its QP so far (restarted by a cut cascade's weighted form).
        resolve_cost, level_cost, check_cost, safe_cost, safe_stage_cost: CPU time (s, clock guard) of the tick's
            longest re-solve, strict level, check of a held safe command, safe command's solve (the last tick's
            until ``safe_fresh``) and last 'constraints_only' stage; ``iteration_cost``: of a first-solve iteration.

    Args:
        timer: the CPU clock (s; default :func:`wbc.solvers.base.cpu_time`), read through ``work.timer``.
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

    def restart_resolves(self) -> None:
        """A cut cascade's weighted form answers from here: the reserve is its, and the re-solves are counted (work,
        CPU time) from its start, not the cascade's."""
        self.work.reserve = 0.0
        self.first_work = self.resolve_work = self.resolve_cost = 0.0
        self.resolves = 0

    def may_start(self, stage: str, cost: float | None = None, work: float | None = None) -> bool:
        """May a stage start now: ``"retry"``, an optional stage of a failed tick (confirmation, relaxation,
        diagnosis), when the count is below one cap, also after one more re-solve at the counted work of the tick's
        largest re-solve so far; ``"stage"``, a further stage of a solved tick (a strict level, a contact correction,
        a trust region), when it ends within ``stage_factor`` caps at that work (the larger of ``first_work`` and
        ``resolve_work``, or ``work`` counted solves when given); with ``cost`` (s of CPU time), also :meth:`fits`.

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
        return not late and (cost is None or self.fits(cost))

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
