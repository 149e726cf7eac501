"""The inverse-dynamics failure path after DAQP's attempt on a QP whose hard set has a point, without a clock guard:
the attempt and the cost-scaled DAQP call share one count (``SCALED_FEASIBLE_FACTOR`` × the attempt's cap), then
quadprog solves the QP with its equalities eliminated (:func:`wbc.solvers.independent.solve_pinned_reduced`); the
relaxed QP gets the same quadprog solve when DAQP misses a minimiser of a relaxed set that has a point.

The QP is the slowest tick of ``benchmarks/fuzz_id.py --ticks 10000 --chunk 2500 --seed 7000`` (seed 7000 episode 14
tick 1, Talos, 62 variables, 18 equality rows, 64 inequality rows): DAQP reports it infeasible, the cost-scaled call
ends without a solution, quadprog solves it. Oracles built here: HiGHS (scipy ``linprog``) for feasibility, quadprog
on the QP as given (dense Goldfarb–Idnani) for the optimum, the rows and bounds checked here; counts of solver calls,
iterations and variables, never a wall-clock time."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import quadprog

from conftest import dense_quadprog, highs_feasible
from wbc.solvers.qp_data import QPData
from wbc.exceptions import SolverError

FIXTURE = Path(__file__).resolve().parents[1] / "fixtures" / "id_scaled_fails_talos.npz"
KEYS = ("H", "g", "A", "b", "C", "l", "u", "lb", "ub")
CAP = 190  # daqp_attempt_iterations at a 2 ms budget


def _load():
    d = dict(np.load(FIXTURE))
    return tuple(d[k] for k in KEYS), (d["rl"], d["ru"], d["rlb"], d["rub"])


def _largest_violation(x, A, b, C, l, u, lb, ub):
    """Largest violation of a row or bound by x, each relative to max(1, |its bound|)."""
    cx = C @ x
    return max(np.max(np.abs(A @ x - b) / np.maximum(1.0, np.abs(b))),
               np.max(np.maximum(l - cx, 0.0) / np.maximum(1.0, np.abs(np.nan_to_num(l, neginf=0.0)))),
               np.max(np.maximum(cx - u, 0.0) / np.maximum(1.0, np.abs(np.nan_to_num(u, posinf=0.0)))),
               np.max(np.maximum(lb - x, 0.0)), np.max(np.maximum(x - ub, 0.0)))


def _objective(H, g, x):
    return 0.5 * x @ H @ x + g @ x


@pytest.fixture
def counted_qp(robots, monkeypatch):
    """A Talos ``InverseDynamicsQP`` (DAQP backend, attempt cap 190 as a 2 ms budget gives; its layout is not the
    recorded QP's, which is passed to the solve methods directly), a log of the calls of its failure path and the
    DAQP iterations of each backend call, and the shapes of the Hessians quadprog was given."""
    import wbc.solvers.fallback as fallback
    from wbc.dynamics import InverseDynamicsQP, SoleContact
    from wbc.solvers import DaqpBackend

    robot = robots("talos")
    qp = InverseDynamicsQP(robot, [], [SoleContact(robot, robot.left_sole, name="left")], solver="daqp")
    qp.chain.daqp_attempt_iterations = CAP
    calls, iterations, hessians = [], [], []
    for name in ("hard_set_check", "solve_pinned_reduced"):
        real = getattr(fallback, name)
        monkeypatch.setattr(fallback, name,
                            lambda *a, _real=real, _name=name, **k: calls.append(_name) or _real(*a, **k))
    for name in ("solve", "solve_scaled"):
        real = getattr(DaqpBackend, name)

        def counted(self, *a, _real=real, _name=name, **k):
            calls.append("daqp" if _name == "solve" else _name)
            try:
                return _real(self, *a, **k)
            finally:
                iterations.append(self.last_iterations)

        monkeypatch.setattr(DaqpBackend, name, counted)
    real_qp = quadprog.solve_qp
    monkeypatch.setattr(quadprog, "solve_qp", lambda G, *a, **k: hessians.append(G.shape) or real_qp(G, *a, **k))
    return qp, calls, iterations, hessians


def test_the_slow_tick_is_answered_by_quadprog_at_the_optimum(counted_qp):
    """HiGHS: the hard set has a point. DAQP's attempt and the cost-scaled call find no solution; quadprog's answer
    meets every row and bound to 1e-6 and its cost equals the dense quadprog optimum's to 1e-7 relative."""
    qp, calls, _, _ = counted_qp
    problem, _ = _load()
    assert highs_feasible(*problem[2:])
    ref = dense_quadprog(*problem)
    x, who, step = qp.chain.solve(QPData(*problem))
    assert (who, step) == ("quadprog", "quadprog")
    assert calls == ["daqp", "hard_set_check", "solve_scaled", "solve_pinned_reduced"]
    assert _largest_violation(x, *problem[2:]) <= 1e-6
    H, g = problem[:2]
    assert abs(_objective(H, g, x) - _objective(H, g, ref)) <= 1e-7 * max(1.0, abs(_objective(H, g, ref)))


def test_the_attempt_and_the_scaled_call_share_one_count(counted_qp):
    """The attempt and the cost-scaled call take at most 2 × 190 DAQP iterations together (before: the scaled call
    alone had 380, and ran 249 on this QP after the attempt's 145)."""
    qp, _, iterations, _ = counted_qp
    problem, _ = _load()
    qp.chain.solve(QPData(*problem))
    attempt, scaled = iterations[:2]
    assert 0 < attempt <= CAP and attempt + scaled <= 2 * CAP


def test_quadprog_works_on_the_null_space_of_the_equalities(counted_qp):
    """quadprog is given the QP on the 62 − 18 = 44 directions the equality rows leave free (it was given all 62)."""
    qp, _, _, hessians = counted_qp
    problem, _ = _load()
    qp.chain.solve(QPData(*problem))
    n, m = problem[0].shape[0], problem[2].shape[0]
    assert hessians == [(n - m, n - m)]


def test_the_relaxed_qp_gets_quadprog_when_daqp_misses_a_minimiser(counted_qp, monkeypatch):
    """Every DAQP call of the relaxed solve made to fail (an injected fault); the relaxed hard set has a point
    (HiGHS, and the check): quadprog answers at the dense quadprog optimum of the relaxed QP (cost to 1e-7 relative,
    rows and bounds to 1e-6). The same relaxed QP on a set the check proved empty would end at the check."""
    from wbc.solvers import DaqpBackend

    qp, calls, _, _ = counted_qp
    problem, relaxed = _load()
    H, g, A, b, C = problem[:5]
    assert highs_feasible(A, b, C, *relaxed)

    def fail(self, *a, **k):
        calls.append("daqp")
        raise SolverError("injected")

    monkeypatch.setattr(DaqpBackend, "solve", fail)
    x, who, step = qp.chain.solve_relaxed(QPData(H, g, A, b, C, *relaxed), formed=False)
    assert (who, step) == ("quadprog", "quadprog")
    assert calls == ["daqp", "hard_set_check", "daqp", "solve_pinned_reduced"]
    assert _largest_violation(x, A, b, C, *relaxed) <= 1e-6
    ref = dense_quadprog(H, g, A, b, C, *relaxed)
    assert abs(_objective(H, g, x) - _objective(H, g, ref)) <= 1e-7 * max(1.0, abs(_objective(H, g, ref)))


def test_a_relaxed_set_proved_empty_gets_no_quadprog(counted_qp, monkeypatch):
    """The relaxed QP of the full bounds made empty (a torque row's lower side above its upper side would be
    rejected; here a bound lb > ub on one acceleration — HiGHS: empty): the check ends the solve, quadprog is not
    called."""
    from wbc.solvers import DaqpBackend

    qp, calls, _, _ = counted_qp
    problem, relaxed = _load()
    H, g, A, b, C = problem[:5]
    rl, ru, rlb, rub = (a.copy() for a in relaxed)
    rlb[6], rub[6] = 1.0, 0.0
    assert not highs_feasible(A, b, C, rl, ru, rlb, rub)
    monkeypatch.setattr(DaqpBackend, "solve", lambda self, *a, **k: calls.append("daqp") or (_ for _ in ()).throw(
        SolverError("injected")))
    with pytest.raises(SolverError, match="relaxed hard set is empty"):
        qp.chain.solve_relaxed(QPData(H, g, A, b, C, rl, ru, rlb, rub), formed=False)
    assert "solve_pinned_reduced" not in calls
