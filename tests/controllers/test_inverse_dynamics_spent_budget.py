"""A spent tick budget on a feasible full QP: the tick holds the last solved command and the next ticks resume the
stages the budget cut (``FallbackChain.resume_scaled``), never the gravity-compensation fallback. The episode is
the ID fuzz's (``benchmarks/fuzz_id.py``, seed 8302, episode 84, Talos, |g| ≈ 7e6 from a stiff CoM gain); HiGHS
(scipy ``linprog``) is the independent feasibility oracle, as in the fuzz."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from conftest import highs_feasible
from wbc.dynamics.balance import IDBalanceController

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
import fuzz_id  # noqa: E402

#: the longest run of fallback ticks on a problem HiGHS finds feasible that the controller may take (a number of
#: the acceptance, not of the code)
LONGEST_FALLBACK_RUN = 5


def _replayed(monkeypatch, seed: int, episode: int, on_tick=None) -> list[tuple[str, bool, bool, float]]:
    """The episode's ticks: (path, ok, HiGHS finds the full QP's hard set feasible, the command's largest violation
    of the hard rows and bounds, relative to max(1, |bound|)). ``on_tick(i)``: called before tick i."""
    ticks = []
    solve = IDBalanceController.solve

    def recorded(self, q, v):
        if on_tick is not None:
            on_tick(len(ticks))
        cmd = solve(self, q, v)
        _, _, A, b, C, l, u, lb, ub = self.qp.build(self.state, fuzz_id.DT)
        x = np.concatenate([cmd.dv, cmd.forces])
        worst = max(np.max(np.abs(A @ x - b) / np.maximum(1, np.abs(b)), initial=0),
                    np.max((C @ x - u) / np.maximum(1, np.abs(u)), initial=0),
                    np.max((l - C @ x) / np.maximum(1, np.abs(l)), initial=0),
                    np.max((x - ub) / np.maximum(1, np.abs(ub)), initial=0),
                    np.max((lb - x) / np.maximum(1, np.abs(lb)), initial=0))
        ticks.append((str(cmd.path), cmd.ok, highs_feasible(A, b, C, l, u, lb, ub), float(worst)))
        return cmd

    monkeypatch.setattr(IDBalanceController, "solve", recorded)
    fuzz_id.run_chunk(5000, seed, replay=episode, warm=False, quiet=True)
    return ticks


def test_a_first_tick_whose_budget_was_spent_commands_a_point_of_the_hard_set(monkeypatch):
    """Seed 8301 episode 40 (Talos): tick 0's full QP is cut by the counted work on a feasible set and there is no
    solved command to hold: the command is the hard set's point (``fallback:feasible``), which meets every hard row
    and bound to 1e-6 (relative), checked here on build()'s QP."""
    ticks = _replayed(monkeypatch, 8301, 40)
    path, ok, feasible, worst = ticks[0]
    assert feasible and not ok and path == "fallback:feasible", ticks[0]
    assert worst <= 1e-6
    assert [t[0] for t in ticks if t[0] == "fallback:gravity" and t[2]] == []


def test_a_feasible_problem_whose_budget_was_spent_never_takes_gravity_compensation(monkeypatch):
    ticks = [t[:3] for t in _replayed(monkeypatch, 8302, 84)]
    assert len(ticks) == 50
    # the episode is the one that took 32 gravity-only ticks in a row while feasible: its hard set is feasible on
    # most ticks
    assert sum(f for _, _, f in ticks) >= 40
    gravity_on_feasible = [i for i, (path, _, f) in enumerate(ticks) if path == "fallback:gravity" and f]
    assert gravity_on_feasible == []
    run = longest = 0
    for path, ok, feasible in ticks:
        run = run + 1 if (not ok and feasible) else 0
        longest = max(longest, run)
    assert longest <= LONGEST_FALLBACK_RUN


def test_a_commanded_point_of_the_hard_set_is_held_when_the_next_tick_finds_none(monkeypatch):
    """Seed 8433 episode 46 (G1; the one gravity-only tick on a feasible problem of the 10⁶-tick ID fuzz at
    67ee7a6): tick 0 commands the hard set's point (no solved command to hold). Tick 1 is made to find no point and
    no relaxed answer (its hard-set checks end undecided, its relaxed QP fails), as at 67ee7a6: tick 0's point is
    held for tick 1 (``fallback:hold``) instead of gravity compensation."""
    import wbc.solvers.fallback as fallback
    from wbc.exceptions import SolverError
    from wbc.solvers.fallback import FallbackChain

    now = [0]
    check, relaxed = fallback.hard_set_check, FallbackChain.solve_relaxed

    def undecided(*args, **kw):
        verdict, iterations = check(*args, **kw)
        return (None if now[0] == 1 else verdict), iterations

    def failing(self, *args, **kw):
        if now[0] == 1:
            raise SolverError("the relaxed QP made to fail (test)")
        return relaxed(self, *args, **kw)

    monkeypatch.setattr(fallback, "hard_set_check", undecided)
    monkeypatch.setattr(FallbackChain, "solve_relaxed", failing)
    ticks = _replayed(monkeypatch, 8433, 46, lambda i: now.__setitem__(0, i))
    assert ticks[0][:3] == ("fallback:feasible", False, True), ticks[0]
    assert ticks[1][:3] == ("fallback:hold", False, True), ticks[1]
    assert [i for i, t in enumerate(ticks) if t[0] == "fallback:gravity" and t[2]] == []
