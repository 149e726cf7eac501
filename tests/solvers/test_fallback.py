"""The fallback chain (wbc.solvers.fallback.FallbackChain) on one QPData: which step answers, checked against an
independent optimum (quadprog's dense Goldfarb–Idnani on the QP as given, tests/conftest.dense_quadprog) and an
independent feasibility verdict (HiGHS's LP, tests/conftest.highs_feasible)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from conftest import dense_quadprog, highs_feasible

from wbc.exceptions import SolverError
from wbc.solvers import DaqpBackend, QPBackend, make_backend
from wbc.solvers.fallback import (DAQP_SETTINGS, SCALED_EPS_PROX, FallbackChain, daqp_attempt_iterations,
                                  tick_work_iterations)
from wbc.solvers.independent import solve_pinned_reduced
from wbc.solvers.qp_data import QPData


def _qp(seed: int = 0, n: int = 8) -> QPData:
    """A strictly convex QP with 2 equality rows, 3 two-sided inequality rows, a box and one pinned variable."""
    rng = np.random.default_rng(seed)
    M = rng.standard_normal((n, n))
    H = M @ M.T + n * np.eye(n)
    lb, ub = np.full(n, -1.0), np.full(n, 1.0)
    lb[-1] = ub[-1] = 0.0  # pinned (a released foot's force)
    return QPData(H, rng.standard_normal(n) * 10, rng.standard_normal((2, n)) * [[1] * (n - 1) + [0]],
                  np.zeros(2), rng.standard_normal((3, n)), np.full(3, -0.5), np.full(3, 0.5), lb, ub)


class _FailingDaqp(DaqpBackend):
    """DAQP whose every call reports no solution (its scaled call too)."""

    def solve(self, *args, **kw):
        self.last_iterations = 0
        raise SolverError("no solution (test backend)")

    def solve_scaled(self, *args, **kw):
        self.last_iterations = 0
        return None


def test_a_feasible_qp_is_answered_by_the_attempt():
    qp = _qp()
    assert highs_feasible(*qp[2:])
    x, solver, step = FallbackChain(DaqpBackend(**DAQP_SETTINGS)).solve(qp)
    assert (solver, step) == ("daqp", "attempt")
    assert np.abs(x - dense_quadprog(*qp)).max() < 1e-6


def test_a_failed_daqp_attempt_on_a_feasible_qp_is_answered_by_quadprog():
    qp = _qp(1)
    chain = FallbackChain(_FailingDaqp(**DAQP_SETTINGS))
    x, solver, step = chain.solve(qp)
    assert (solver, step) == ("quadprog", "quadprog")
    assert chain.hard_set_point and highs_feasible(*qp[2:])  # the check before quadprog found a point of the set
    assert np.abs(x - dense_quadprog(*qp)).max() < 1e-8


def test_a_failed_daqp_attempt_under_a_counted_budget_counts_its_steps():
    qp = _qp(2)
    chain = FallbackChain(_FailingDaqp(**DAQP_SETTINGS))
    chain.daqp_attempt_iterations, chain.tick_work_iterations = 50, 1000.0
    x, solver, step = chain.solve(qp)
    assert (solver, step) == ("quadprog", "quadprog")
    assert chain.hard_set_point and highs_feasible(*qp[2:])
    assert chain.tick_work > 0 and not chain.budget_cut  # the check and quadprog counted, within the budget
    assert np.abs(x - dense_quadprog(*qp)).max() < 1e-8


def test_another_backend_that_fails_gets_a_second_opinion():
    qp = _qp(3)
    backend = make_backend("proxqp")
    backend.solve = lambda *a, **k: (_ for _ in ()).throw(SolverError("no solution (test backend)"))
    chain = FallbackChain(backend)
    x, solver, step = chain.solve(qp)
    assert step == "second opinion" and solver in ("quadprog", "daqp")
    assert np.abs(x - dense_quadprog(*qp)).max() < 1e-6
    chain.second_opinion_enabled = False
    with pytest.raises(SolverError, match="test backend"):
        chain.solve(qp)


def test_an_infeasible_qp_ends_the_chain_with_the_reason():
    H, g, A, b, C, l, u, lb, ub = _qp(4)
    l, u = l.copy(), u.copy()
    l[0], u[0] = 100.0, 200.0  # a row the box cannot reach
    qp = QPData(H, g, A, b, C, l, u, lb, ub)
    assert not highs_feasible(A, b, C, l, u, lb, ub)
    chain = FallbackChain(DaqpBackend(**DAQP_SETTINGS))
    chain.daqp_attempt_iterations, chain.tick_work_iterations = 50, 1000.0
    with pytest.raises(SolverError, match="hard set is empty"):
        chain.solve(qp)
    assert chain.last_set_empty


def test_the_relaxed_qp_is_answered_and_begin_tick_resets_the_findings():
    qp = _qp(5)
    chain = FallbackChain(DaqpBackend(**DAQP_SETTINGS))
    chain.budget_cut, chain.tick_work = True, 7.0
    chain.begin_tick()
    assert not chain.budget_cut and chain.tick_work == 0.0 and chain.relaxed_bounds is None
    x, solver, step = chain.solve_relaxed(qp)
    assert (solver, step) == ("daqp", "attempt")
    assert np.abs(x - dense_quadprog(*qp)).max() < 1e-6


@pytest.mark.parametrize("name", ["id_landing_qp_g1", "id_landing_qp_g1_b"])
@pytest.mark.parametrize("budget", [math.inf, 4e-3])
def test_the_retries_after_quadprog_answer_the_recorded_g1_landing_qps(name, budget):
    """Two QPs recorded at G1 jump touch-downs (tests/fixtures, HiGHS: feasible) that DAQP's attempt, its cost-scaled
    call and quadprog (infeasibility certificate) miss: the backend's retries after quadprog answer them, at an
    unbounded budget and at 4 ms (at 2 ms quadprog's count does not fit, and the retries go with it). Oracle: every
    row and bound to 1e-6 (scaled by max(1, |rhs|), QPBackend.accepted)."""
    d = dict(np.load(Path(__file__).resolve().parents[1] / "fixtures" / f"{name}.npz"))
    qp = QPData(*(d[k] for k in ("H", "g", "A", "b", "C", "l", "u", "lb", "ub")))
    assert highs_feasible(*qp[2:])
    assert solve_pinned_reduced(*qp, 1e-6, details=True)[1] == "infeasible"
    backend = DaqpBackend(**DAQP_SETTINGS)
    backend.scaled_settings = {"eps_prox": SCALED_EPS_PROX}  # as the inverse-dynamics QP's
    chain = FallbackChain(backend)
    chain.daqp_attempt_iterations = daqp_attempt_iterations(budget)
    chain.tick_work_iterations = tick_work_iterations(budget)
    x, solver, step = chain.solve(qp)
    assert (solver, step) == ("daqp", "retries")
    assert QPBackend.accepted(x, *qp[2:], 1e-6) is not None
