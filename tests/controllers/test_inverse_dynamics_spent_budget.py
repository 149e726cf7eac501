"""A spent tick budget on a feasible full QP: the tick holds the last solved command and the next ticks resume the
stages the budget cut (``InverseDynamicsQP.resume_scaled``), never the gravity-compensation fallback. The episode is
the ID fuzz's (``benchmarks/fuzz_id.py``, seed 8302, episode 84, Talos, |g| ≈ 7e6 from a stiff CoM gain); HiGHS
(scipy ``linprog``) is the independent feasibility oracle, as in the fuzz."""

from __future__ import annotations

import sys
from pathlib import Path

from conftest import highs_feasible
from wbc.dynamics.balance import IDBalanceController

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
import fuzz_id  # noqa: E402

#: the longest run of fallback ticks on a problem HiGHS finds feasible that the controller may take (a number of
#: the acceptance, not of the code)
LONGEST_FALLBACK_RUN = 5


def test_a_feasible_problem_whose_budget_was_spent_never_takes_gravity_compensation(monkeypatch):
    ticks = []  # (path, ok, HiGHS finds the full QP's hard set feasible)
    solve = IDBalanceController.solve

    def recorded(self, q, v):
        cmd = solve(self, q, v)
        _, _, A, b, C, l, u, lb, ub = self.qp.build(self.state, fuzz_id.DT)
        ticks.append((str(cmd.path), cmd.ok, highs_feasible(A, b, C, l, u, lb, ub)))
        return cmd

    monkeypatch.setattr(IDBalanceController, "solve", recorded)
    fuzz_id.run_chunk(5000, 8302, replay=84, warm=False, quiet=True)
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
