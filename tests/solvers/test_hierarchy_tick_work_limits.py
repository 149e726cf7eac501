"""A tick's counted work bounds the strict cascade: a level whose solve fails once the budget is spent is cut (no
retries), and an infeasible hard set is recognised in two solves. No wall-clock assertion: the counts are the
behaviour."""

from __future__ import annotations

import numpy as np
import pytest

from wbc.exceptions import SolverError
from wbc.solvers import DaqpBackend
from wbc.solvers.hierarchy import solve_lexicographic
from wbc.solvers.qp_data import QPData


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
    v, _ = solve_lexicographic(levels, QPData(H, g, A, b, C, l, u, lb, ub), [DaqpBackend(eps_prox=1e-3), lvl1],
                               DaqpBackend(), stop=lambda: state["spent"])
    assert lvl1.calls == 1  # no damped or wide-band retry once the budget is spent
    assert solve_lexicographic.last_cut == 1
    # oracle: the cascade stopped before level 1 (the pre-existing cut) returns level 0's solution
    v0, _ = solve_lexicographic(levels, QPData(H, g, A, b, C, l, u, lb, ub), [DaqpBackend(eps_prox=1e-3)] * 2,
                                DaqpBackend(), stop=lambda: True)
    assert solve_lexicographic.last_cut == 1
    assert np.max(np.abs(v - v0)) < 1e-9
    # with budget left the failing level is retried (damped), as before
    lvl1b = _Failing(lambda: None)
    solve_lexicographic(levels, QPData(H, g, A, b, C, l, u, lb, ub), [DaqpBackend(eps_prox=1e-3), lvl1b], DaqpBackend(),
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
        solve_lexicographic(levels, QPData(H, g, A, b, C, l, u, lb, ub), [Counting(eps_prox=1e-3), DaqpBackend()],
                            DaqpBackend())
    assert Counting.calls == 2  # the level, then min ‖v‖² on the hard set (not the damped retry in between)
    # a feasible hard set where the level solves: one call
    Counting.calls = 0
    levels, H, g, A, b, C, l, u, lb, ub = _levels_problem()
    solve_lexicographic(levels, QPData(H, g, A, b, C, l, u, lb, ub), [Counting(eps_prox=1e-3), DaqpBackend()],
                        DaqpBackend())
    assert Counting.calls == 1


def test_independent_rows_reuses_a_factorisation_only_for_an_equal_matrix(monkeypatch):
    """The memo of independent_rows: an entry-for-entry equal matrix is not factorised again, and returns the rows
    an uncached QR with column pivoting (scipy.linalg.qr, written here) picks; a matrix that differs in one entry
    is factorised again."""
    import scipy.linalg
    from scipy.linalg import lapack

    from wbc.solvers.hierarchy import independent_rows

    calls = {"n": 0}
    real = lapack.dgeqp3

    def counting(*args, **kwargs):
        if kwargs.get("lwork", 0) != -1:
            calls["n"] += 1
        return real(*args, **kwargs)

    monkeypatch.setattr(lapack, "dgeqp3", counting)

    def reference(M, rtol=1e-3):
        _, R, piv = scipy.linalg.qr(M.T, mode="economic", pivoting=True)
        d = np.abs(np.diag(R))
        return np.sort(piv[:int(np.sum(d > rtol * max(d[0], 1.0)))])

    rng = np.random.default_rng(3)
    A = rng.normal(size=(6, 9))
    A[4] = A[0] + A[1]  # a dependent row
    first = independent_rows(A)
    np.testing.assert_array_equal(first, reference(A))
    n = calls["n"]
    again = independent_rows(A.copy())  # equal entries, another array
    assert calls["n"] == n
    np.testing.assert_array_equal(again, reference(A))
    B = A.copy()
    B[4, 2] += 0.5  # the row becomes independent
    rows = independent_rows(B)
    assert calls["n"] == n + 1
    np.testing.assert_array_equal(rows, reference(B))
    assert rows.size == 6 and first.size == 5
    assert independent_rows(A, 0.5).size <= first.size and calls["n"] == n + 2  # another rtol: factorised
    with pytest.raises(ValueError):
        first[0] = 1  # the shared result is read-only



def test_band_memo_starts_with_the_bands_on_equal_rows_only():
    """A cascade whose dropped (nearly dependent) equality row had to be held as a band row: with a memo, the next
    cascade on equal equality rows (a re-solve of the same tick: only b changed) starts with that band — one
    cascade, one solve per level, not two — and its answer meets the kept row, holds the dropped one within
    ±tolerance/2 and meets the level (checked on the rows); on other rows the full sequence runs again."""

    class Counting(DaqpBackend):
        solves = 0

        def solve(self, *args, **kwargs):
            Counting.solves += 1
            return super().solve(*args, **kwargs)

    n = 4
    H, g = np.eye(n), np.zeros(n)
    # row 1 = row 0 + 1e-5 e_1: one of them dropped at rank_rtol 1e-3; together they ask v_0 = 0, v_1 = 5
    A = np.array([[1.0, 0.0, 0.0, 0.0], [1.0, 1e-5, 0.0, 0.0]])
    C, l, u = np.zeros((0, n)), np.zeros(0), np.zeros(0)
    lb, ub = -np.full(n, 10.0), np.full(n, 10.0)
    levels = [(np.array([[0.0, 0.0, 1.0, 0.0]]), np.array([2.0]))]
    tol = 1e-5
    memo: dict = {}
    backends, final = [Counting(eps_prox=1e-3)], Counting()
    counts = []
    for A_k, b_k in ((A, np.array([0.0, 5e-5])), (A.copy(), np.array([0.0, 4e-5])),
                     (A + np.array([[0.0, 0.0, 0.0, 0.0], [0.0, 1e-6, 0.0, 0.0]]), np.array([0.0, 5e-5]))):
        Counting.solves = 0
        v, _ = solve_lexicographic(levels, QPData(H, g, A_k, b_k, C, l, u, lb, ub), backends, final,
                                   dependent_row_tolerance=tol, memo=memo)
        counts.append(Counting.solves)
        r = np.abs(A_k @ v - b_k)
        assert r.min() <= 1e-9  # the kept row (QR with pivoting keeps one of the two)
        assert r.max() <= 0.5 * tol + 1e-9  # the dropped one, held as a band
        assert abs(v[2] - 2.0) <= 1e-6  # the level
    # the cascade without the band, then with it; equal rows: only with it; other rows: both again
    assert counts == [4, 2, 4]


def test_level_work_is_counted_per_level_started_and_reserve_stops_the_cascade_earlier():
    """``level_work``: each level started adds it to the backends' shared TickWork on top of the counts of its QP
    solves (the same cascade with level_work 0 is the oracle: the difference is level_work × 3 levels, the soft
    level included; the answer is bitwise the same). ``TickWork.reserve``: counted as done by ``spent``, so a stop at
    ``spent(factor)`` cuts the cascade that many solves earlier."""
    from wbc.solvers.base import TickWork

    def run(level_work, reserve=0.0, factor=None):
        work = TickWork(cap=100.0)
        work.reserve = reserve
        backends = [DaqpBackend(eps_prox=1e-3), DaqpBackend(eps_prox=1e-3)]
        final = DaqpBackend()
        for backend in (*backends, final):
            backend.work = work
        stop = None if factor is None else (lambda: work.spent(factor))
        levels, H, g, A, b, C, l, u, lb, ub = _levels_problem()
        v, _ = solve_lexicographic(levels, QPData(H, g, A, b, C, l, u, lb, ub), backends, final, stop=stop,
                                   level_work=level_work)
        return v, work.solves, solve_lexicographic.last_cut

    v0, n0, cut0 = run(0.0)
    v1, n1, cut1 = run(0.5)
    assert cut0 is None and cut1 is None
    assert n1 - n0 == pytest.approx(0.5 * 3)
    assert v0.tobytes() == v1.tobytes()
    # stop once n0 + 1 solves are counted: without a reserve every level starts (the cascade counts n0 in all);
    # with a reserve of n0 + 1 solves the stop holds before level 1, and the cascade returns level 0's answer
    _, _, cut_free = run(0.0, reserve=0.0, factor=(n0 + 1) / 100.0)
    _, _, cut_reserved = run(0.0, reserve=n0 + 1.0, factor=(n0 + 1) / 100.0)
    assert cut_free is None and cut_reserved == 1
    work = TickWork(cap=8.0)
    work.reserve = 6.0
    assert not work.spent(1.75)  # 0 + 6 < 14
    work.solves = 8  # 8 + 6 ≥ 14
    assert work.spent(1.75)
    work.reset(8.0)
    assert work.reserve == 0.0 and not work.spent(1.75)
