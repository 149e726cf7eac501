"""A tick's counted work bounds the strict cascade: a level whose solve fails once the budget is spent is cut (no
retries), and an infeasible hard set is recognised in two solves. No wall-clock assertion: the counts are the
behaviour."""

from __future__ import annotations

import numpy as np
import pytest

from wbc.exceptions import SolverError
from wbc.solvers import DaqpBackend
from wbc.solvers.hierarchy import solve_lexicographic


def _levels_problem(seed: int = 5, n: int = 10):
    rng = np.random.default_rng(seed)
    A, b = rng.normal(size=(2, n)), rng.normal(size=2)
    J0, t0 = rng.normal(size=(3, n)), rng.normal(size=3)
    J1, t1 = rng.normal(size=(3, n)), rng.normal(size=3)
    H, g = np.eye(n), np.zeros(n)
    C, l, u = np.zeros((0, n)), np.zeros(0), np.zeros(0)
    lb, ub = np.full(n, -10.0), np.full(n, 10.0)
    return [(J0, t0), (J1, t1)], H, g, A, b, C, l, u, lb, ub


class _Failing(DaqpBackend):
    """A level backend whose solve fails (as a DAQP call stopped at the work limit does) and that spends the
    tick's work while failing."""

    def __init__(self, spend):
        super().__init__(eps_prox=1e-3)
        self.calls = 0
        self.spend = spend

    def solve(self, *args, **kw):
        self.calls += 1
        self.spend()
        raise SolverError("stopped at the tick's work limit")


def test_a_level_failing_after_the_budget_is_spent_is_cut_with_the_last_solved_level_and_not_retried():
    levels, H, g, A, b, C, l, u, lb, ub = _levels_problem()
    state = {"spent": False}
    lvl1 = _Failing(lambda: state.update(spent=True))
    v, _ = solve_lexicographic(levels, H, g, A, b, C, l, u, lb, ub, [DaqpBackend(eps_prox=1e-3), lvl1],
                               DaqpBackend(), stop=lambda: state["spent"])
    assert lvl1.calls == 1  # no damped or wide-band retry once the budget is spent
    assert solve_lexicographic.last_cut == 1
    # oracle: the cascade stopped before level 1 (the pre-existing cut) returns level 0's solution
    v0, _ = solve_lexicographic(levels, H, g, A, b, C, l, u, lb, ub, [DaqpBackend(eps_prox=1e-3)] * 2,
                                DaqpBackend(), stop=lambda: True)
    assert solve_lexicographic.last_cut == 1
    assert np.max(np.abs(v - v0)) < 1e-9
    # with budget left the failing level is retried (damped), as before
    lvl1b = _Failing(lambda: None)
    solve_lexicographic(levels, H, g, A, b, C, l, u, lb, ub, [DaqpBackend(eps_prox=1e-3), lvl1b], DaqpBackend(),
                        stop=lambda: False)
    assert lvl1b.calls >= 2


def test_an_infeasible_hard_set_fails_the_first_level_in_two_solves():
    levels, H, g, A, b, C, l, u, lb, ub = _levels_problem()
    n = H.shape[0]
    A = np.vstack([A, np.eye(n)[:1]])
    b = np.concatenate([b, [50.0]])  # v_0 = 50 against |v_0| ≤ 10: no point of the hard set

    class Counting(DaqpBackend):
        calls = 0

        def solve(self, *args, **kw):
            Counting.calls += 1
            return super().solve(*args, **kw)

    with pytest.raises(SolverError, match="priority level 0"):
        solve_lexicographic(levels, H, g, A, b, C, l, u, lb, ub, [Counting(eps_prox=1e-3), DaqpBackend()],
                            DaqpBackend())
    assert Counting.calls == 2  # the level, then min ‖v‖² on the hard set (not the damped retry in between)
    # a feasible hard set where the level solves: one call
    Counting.calls = 0
    levels, H, g, A, b, C, l, u, lb, ub = _levels_problem()
    solve_lexicographic(levels, H, g, A, b, C, l, u, lb, ub, [Counting(eps_prox=1e-3), DaqpBackend()],
                        DaqpBackend())
    assert Counting.calls == 1
