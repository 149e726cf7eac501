"""The failure path of the inverse-dynamics full QP without a clock guard, after its first DAQP attempt stopped at its
count (``FallbackChain.daqp_attempt_iterations``): the full hard set is checked first
(:func:`wbc.solvers.independent.hard_set_check`) — proved empty, no cost-scaled DAQP call; found not empty, the
attempt and the cost-scaled call share ``SCALED_FEASIBLE_FACTOR`` × the attempt's count before quadprog. Two QPs recorded from
``benchmarks/fuzz_id.py`` (Talos, 62 variables, the attempt capped at 190 iterations): seed 7002 episode 108 tick 2
(full hard set empty, relaxed set not: a relaxed tick) and seed 7002 episode 158 tick 0 (feasible; DAQP's cost-scaled
call needs 271 iterations). Oracles: HiGHS (scipy ``linprog``) for feasibility, quadprog (dense Goldfarb–Idnani) for
the optimum; counts of solver calls, never a wall-clock time."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import quadprog

from conftest import highs_feasible
from wbc.solvers.qp_data import QPData
from wbc.exceptions import SolverError

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures"
KEYS = ("H", "g", "A", "b", "C", "l", "u", "lb", "ub")


def _load(name):
    d = dict(np.load(FIXTURES / name))
    return tuple(d[k] for k in KEYS), (d["rl"], d["ru"], d["rlb"], d["rub"])


def _quadprog(H, g, A, b, C, l, u, lb, ub):
    """quadprog's optimum of the QP (no pinned variable in these QPs), built here."""
    n = H.shape[0]
    fl, fu, bl, bu = np.isfinite(l), np.isfinite(u), np.isfinite(lb), np.isfinite(ub)
    eye = np.eye(n)
    Cq = np.hstack([A.T, C[fl].T, -C[fu].T, eye[:, bl], -eye[:, bu]])
    bq = np.concatenate([b, l[fl], -u[fu], lb[bl], -ub[bu]])
    return quadprog.solve_qp(H, -g, Cq, bq, A.shape[0])[0]


@pytest.fixture
def counted_qp(robots, monkeypatch):
    """An ``InverseDynamicsQP`` (DAQP backend, attempt cap 190 as a 2 ms budget gives) and a call log of its
    hard-set checks, cost-scaled DAQP calls and quadprog solves."""
    import wbc.solvers.fallback as fallback
    from wbc.dynamics import InverseDynamicsQP, SoleContact
    from wbc.solvers import DaqpBackend

    robot = robots("talos")
    qp = InverseDynamicsQP(robot, [], [SoleContact(robot, robot.left_sole, name="left")], solver="daqp")
    qp.chain.daqp_attempt_iterations = 190
    calls = []
    for name in ("hard_set_check", "solve_pinned_reduced"):
        real = getattr(fallback, name)
        monkeypatch.setattr(fallback, name,
                            lambda *a, _real=real, _name=name, **k: calls.append(_name) or _real(*a, **k))
    scaled = DaqpBackend.solve_scaled
    solve = DaqpBackend.solve
    iterations = []
    monkeypatch.setattr(DaqpBackend, "solve", lambda self, *a, **k: calls.append("daqp") or solve(self, *a, **k))

    def solve_scaled(self, *a, **k):
        calls.append("solve_scaled")
        x = scaled(self, *a, **k)
        iterations.append(self.last_iterations)
        return x

    monkeypatch.setattr(DaqpBackend, "solve_scaled", solve_scaled)
    return qp, calls, iterations


def test_capped_attempt_on_an_empty_hard_set_ends_at_the_check(counted_qp):
    """HiGHS: the full hard set is empty, the relaxed one is not. The attempt stops at its 190 iterations (a count,
    not a verdict); the check proves the set empty: the failure stands after one hard-set check, with no cost-scaled
    DAQP call (190 more iterations before the check, before) and no quadprog solve."""
    qp, calls, _ = counted_qp
    problem, relaxed = _load("id_capped_infeasible_talos.npz")
    A, b, C = problem[2:5]
    assert not highs_feasible(*problem[2:])
    assert highs_feasible(A, b, C, *relaxed)
    with pytest.raises(SolverError, match="the hard set is empty"):
        qp.chain.solve(QPData(*problem))
    assert qp.backend.iterations_capped and qp.backend.last_iterations == 190  # the attempt: stopped at its count
    assert calls == ["daqp", "hard_set_check"]  # no cost-scaled call, no quadprog


def test_capped_attempt_on_a_feasible_set_leaves_the_scaled_call_the_rest_of_one_count(counted_qp):
    """HiGHS: the hard set is not empty. The attempt stops at 190 iterations; the check finds a point; the
    cost-scaled call gets the rest of 2 × 190 (190: it needs 271 on this QP and stops), and quadprog answers at its
    own dense optimum to 1e-6 relative."""
    qp, calls, iterations = counted_qp
    problem, _ = _load("id_capped_feasible_talos.npz")
    assert highs_feasible(*problem[2:])
    ref = _quadprog(*problem)
    x, who, step = qp.chain.solve(QPData(*problem))
    assert calls == ["daqp", "hard_set_check", "solve_scaled", "solve_pinned_reduced"]
    assert iterations[0] == 190
    assert (who, step) == ("quadprog", "quadprog")
    assert np.max(np.abs(x - ref)) <= 1e-6 * max(1.0, np.max(np.abs(ref)))


def test_a_failing_run_checks_the_hard_set_before_the_attempt(counted_qp):
    """After a full QP whose hard set was proved empty, the next full QP's hard set is checked first: the same empty
    set (HiGHS: empty) fails at that check with no DAQP call; then the feasible QP (HiGHS: feasible) is checked once,
    before the attempt (not again after it), and answered at quadprog's optimum to 1e-6 relative."""
    qp, calls, _ = counted_qp
    empty, _ = _load("id_capped_infeasible_talos.npz")
    feasible, _ = _load("id_capped_feasible_talos.npz")
    assert not highs_feasible(*empty[2:]) and highs_feasible(*feasible[2:])
    with pytest.raises(SolverError):
        qp.chain.solve(QPData(*empty))
    assert calls == ["daqp", "hard_set_check"] and qp.chain.last_set_empty
    calls.clear()
    with pytest.raises(SolverError, match="DAQP not asked"):
        qp.chain.solve(QPData(*empty))
    assert calls == ["hard_set_check"]
    calls.clear()
    x, _, _ = qp.chain.solve(QPData(*feasible))
    assert calls == ["hard_set_check", "daqp", "solve_scaled", "solve_pinned_reduced"] and not qp.chain.last_set_empty
    ref = _quadprog(*feasible)
    assert np.max(np.abs(x - ref)) <= 1e-6 * max(1.0, np.max(np.abs(ref)))


@pytest.mark.parametrize("scaled_settings", [None, {}])
def test_counted_work_includes_the_scaled_calls_proximal_iterations(counted_qp, monkeypatch, scaled_settings):
    """The cost-scaled call's QP of a G1 fuzz tick (``id_scaled_proximal_g1.npz``; HiGHS: feasible), counted at a
    2 ms budget: the attempt fails, the check finds a point, the cost-scaled call answers. The tick's counted work is,
    per DAQP call, its iterations + 5 per proximal outer iteration beyond the first + 30 — read here from DAQP's own
    report of each call (``iterations``, ``nodes``). With DAQP's default regularisation on the scaled call
    (``scaled_settings={}``) that call runs > 100 outer iterations (main counted none of them); with the ID's own
    (-1e-8) it runs fewer than one per five iterations."""
    import daqp

    qp, calls, _ = counted_qp
    qp.chain.tick_work_iterations = 0.002 / 3.5e-6
    if scaled_settings is not None:
        qp.backend.scaled_settings = scaled_settings
    d = dict(np.load(FIXTURES / "id_scaled_proximal_g1.npz"))
    problem = tuple(d[k] for k in KEYS)
    assert highs_feasible(*problem[2:])
    reports = []
    real = daqp.solve

    def recorded(*a, **k):
        out = real(*a, **k)
        reports.append(out[2:])
        return out

    monkeypatch.setattr(daqp, "solve", recorded)
    x, who, step = qp.chain.solve(QPData(*problem))
    assert (who, step) == ("daqp", "scaled call") and calls == ["daqp", "hard_set_check", "solve_scaled"]
    assert len(reports) == 3 and reports[0][0] < 1 and reports[2][0] == 1
    expected = sum(info["iterations"] + 5 * (info["nodes"] - 1) + 30 for _, info in reports)
    assert qp.chain.tick_work == expected
    scaled = reports[2][1]
    if scaled_settings == {}:
        assert scaled["nodes"] - 1 > 100
    else:
        assert 5 * (scaled["nodes"] - 1) <= scaled["iterations"]
