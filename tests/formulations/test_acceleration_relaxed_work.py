"""The work of a failed inverse-dynamics tick without a clock guard, from its full QP's failure through its relaxed QP,
counted against DAQP's own report of every call (``iterations``, ``nodes``: the tick counts each call as its
iterations + 5 per proximal outer iteration beyond the first + 30). Two Talos ticks (62 variables) recorded from
``benchmarks/fuzz_id.py`` at a 2 ms budget, each with the work the compiled tick's give-up had counted before the
backend was asked (``kernel_work``) and whether the previous tick's full hard set had been proved empty
(``last_set_empty``): seed 540020 episode 456 tick 42 (both hard sets empty by HiGHS; DAQP's check of the relaxed one
ends undecided, exit -2, before its iteration limit) and seed 540011 episode 218 tick 0 (both sets feasible by HiGHS;
the attempt and the cost-scaled call stop at their counts, quadprog's count does not fit). Oracles: HiGHS (scipy
``linprog``) for feasibility, DAQP's reports for the work; no clock."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from conftest import highs_feasible
from wbc.solvers.qp_data import QPData
from wbc.exceptions import SolverError

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures"
KEYS = ("H", "g", "A", "b", "C", "l", "u", "lb", "ub")
BUDGET = 0.002 / 3.5e-6  # a 2 ms budget in DAQP iterations of 3.5 µs (the unit of the controller's count)
WORST = 1.2  # the tick's DAQP work stays within this many budgets


def _load(name):
    d = dict(np.load(FIXTURES / name))
    return (tuple(d[k] for k in KEYS), (d["rl"], d["ru"], d["rlb"], d["rub"]), float(d["kernel_work"]),
            bool(d["last_set_empty"]))


@pytest.fixture
def failed_tick(robots, monkeypatch):
    """Runs a recorded failed tick's QP stages as the controller does (the full QP's backend path, then the relaxed
    QP's), counted at a 2 ms budget; returns the QP object, the hard-set checks asked, DAQP's report per call and the
    outcome ("relaxed" or the SolverError)."""
    import daqp

    import wbc.solvers.fallback as fallback
    from wbc.dynamics import InverseDynamicsQP, SoleContact

    robot = robots("talos")
    checks, reports = [], []
    real_check = fallback.hard_set_check
    monkeypatch.setattr(fallback, "hard_set_check", lambda *a, **k: checks.append(k["iter_limit"])
                        or real_check(*a, **k))
    real_solve = daqp.solve

    def recorded(*a, **k):
        out = real_solve(*a, **k)
        reports.append((int(out[2]), int(out[3]["iterations"]), int(out[3].get("nodes", 1)), int(k["iter_limit"])))
        return out

    monkeypatch.setattr(daqp, "solve", recorded)

    def run(name):
        problem, relaxed, kernel_work, last_set_empty = _load(name)
        qp = InverseDynamicsQP(robot, [], [SoleContact(robot, robot.left_sole, name="left")], solver="daqp")
        qp.chain.daqp_attempt_iterations = 190  # as a 2 ms budget sets them (InverseDynamicsController.budget)
        qp.chain.tick_work_iterations = BUDGET
        qp.chain.tick_work = kernel_work
        qp.chain.last_set_empty = last_set_empty
        # the relaxed bounds the tick formed at its state (joint speed bounds included), recorded
        monkeypatch.setattr(qp, "_relax", lambda l, u, lb, ub, state=None, dt=0.0: tuple(x.copy() for x in relaxed))
        with pytest.raises(SolverError):
            qp.chain.solve(QPData(*problem), lambda *bounds: qp._relax(*bounds))
        try:
            qp.chain.solve_relaxed(QPData(*problem[:5], *relaxed), formed=False)
            outcome = "relaxed"
        except SolverError as exc:
            outcome = exc
        return qp, problem, relaxed, kernel_work, outcome

    return run, checks, reports


def _daqp_work(kernel_work, reports):
    return kernel_work + sum(it + 5 * (nodes - 1) + 30 for _, it, nodes, _ in reports)


def test_an_undecided_check_of_the_relaxed_set_is_not_asked_again(failed_tick):
    """540020/456/42: the full set is checked first (the last one was empty) and proved empty; the relaxed set's check
    ends undecided (exit -2) before its limit. The relaxed QP's attempt fails and the retries follow without a
    second check of the same set (main asked it again: 126 more iterations, the same verdict), and the tick's DAQP
    work — every call as DAQP reports it — stays within 1.2 budgets, all of it counted."""
    run, checks, reports = failed_tick
    qp, problem, relaxed, kernel_work, outcome = run("id_relaxed_check_undecided_talos.npz")
    A, b, C = problem[2:5]
    assert not highs_feasible(*problem[2:]) and not highs_feasible(A, b, C, *relaxed)
    assert isinstance(outcome, SolverError)
    assert len(checks) == 2  # the full set's, the relaxed set's: once each
    flag, iterations, _, limit = reports[1]
    assert flag not in (1, -1) and iterations < limit  # undecided, not stopped by its limit
    work = _daqp_work(kernel_work, reports)
    assert work <= WORST * BUDGET
    assert qp.chain.tick_work >= work - 1e-9  # the retries are counted at their caps, at least what they ran


def test_the_relaxed_stage_ends_within_the_count_and_counts_its_attempt(failed_tick, monkeypatch):
    """540011/218/0: the attempt (190) and the cost-scaled call stop at their counts on a feasible set; quadprog's
    count does not fit. The relaxed QP's attempt gets what is left below 1.2 budgets (main gave it at least the
    attempt's 190, and the tick ran 1.27 budgets of DAQP work): the tick's work, counted call by call as DAQP reports
    it (the last attempt included), ends within 1.2 budgets, and the tick is marked cut by its budget."""
    import wbc.solvers.fallback as fallback

    run, checks, reports = failed_tick
    monkeypatch.setattr(fallback, "solve_pinned_reduced", lambda *a, **k: pytest.fail("quadprog's count fitted"))
    qp, problem, relaxed, kernel_work, outcome = run("id_relaxed_after_scaled_talos.npz")
    A, b, C = problem[2:5]
    assert highs_feasible(*problem[2:]) and highs_feasible(A, b, C, *relaxed)
    assert checks
    work = _daqp_work(kernel_work, reports)
    assert abs(qp.chain.tick_work - work) <= 1e-9 * work  # no retry: the count is exactly DAQP's reports
    assert work <= WORST * BUDGET
    assert isinstance(outcome, SolverError) and qp.chain.budget_cut
