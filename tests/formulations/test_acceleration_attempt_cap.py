"""The first DAQP attempt on the inverse-dynamics full QP capped by a count from the tick budget
(``FallbackChain.daqp_attempt_iterations``, :func:`wbc.solvers.fallback.daqp_attempt_iterations`) and the
cost-scaled DAQP call before quadprog. Oracles: quadprog (dense Goldfarb–Idnani) for the optimum, HiGHS (scipy
``linprog``) for feasibility; counts of iterations and solver calls, never a wall-clock time."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import quadprog

from conftest import highs_feasible
from wbc.solvers.qp_data import QPData
from wbc.exceptions import SolverError
from wbc.solvers import DaqpBackend
from wbc.solvers.daqp import ITERATION_LIMIT

DT = 0.002
FIXTURE = Path(__file__).resolve().parents[1] / "fixtures" / "id_large_cost_humanoid15.npz"


def _qp():
    d = dict(np.load(FIXTURE))
    return tuple(d[k] for k in ("H", "g", "A", "b", "C", "l", "u", "lb", "ub"))


def _quadprog(H, g, A, b, C, l, u, lb, ub):
    """quadprog's optimum of the QP, pinned variables (lb = ub) as equalities, built here."""
    n = H.shape[0]
    pin = np.isfinite(lb) & (lb == ub)
    E = np.vstack([A, np.eye(n)[pin]])
    e = np.concatenate([b, lb[pin]])
    fl, fu = np.isfinite(l), np.isfinite(u)
    bl, bu = np.isfinite(lb) & ~pin, np.isfinite(ub) & ~pin
    I = np.eye(n)
    Cq = np.hstack([E.T, C[fl].T, -C[fu].T, I[:, bl], -I[:, bu]])
    bq = np.concatenate([e, l[fl], -u[fu], lb[bl], -ub[bu]])
    return quadprog.solve_qp(H, -g, Cq, bq, E.shape[0])[0]


def test_daqp_call_iterations_caps_each_call_and_is_told_apart_from_the_budget():
    """``DaqpBackend.call_iterations`` = 20 on a QP recorded from the ID fuzz (humanoid15, |g| ≈ 1e6; HiGHS:
    feasible) that DAQP's plain call needs ~100 iterations for: the attempt stops after at most 20 iterations,
    ``iterations_capped`` set and ``budget_capped`` not; the cost-scaled call under the same cap stops too
    (None). With a cap of 190 the plain attempt ends by itself (its false infeasibility verdict: not capped) and
    the cost-scaled call returns quadprog's optimum to 1e-6 relative in at most 190 iterations."""
    H, g, A, b, C, l, u, lb, ub = _qp()
    assert highs_feasible(A, b, C, l, u, lb, ub)
    ref = _quadprog(H, g, A, b, C, l, u, lb, ub)
    backend = DaqpBackend(primal_tol=1e-6, warm_start="dual")
    backend.cold_retry = False
    backend.call_iterations = 20
    with pytest.raises(SolverError):
        backend.solve(H, g, A, b, C, l, u, lb, ub, confirm=False)
    assert 0 < backend.last_iterations <= 20 and backend.iterations_capped and not backend.budget_capped
    assert backend.solve_scaled(H, g, A, b, C, l, u, lb, ub) is None and backend.last_iterations <= 20
    backend.call_iterations = 190
    with pytest.raises(SolverError):
        backend.solve(H, g, A, b, C, l, u, lb, ub, confirm=False)
    assert 20 < backend.last_iterations < 190 and not backend.iterations_capped and not backend.budget_capped
    x = backend.solve_scaled(H, g, A, b, C, l, u, lb, ub)
    assert x is not None and backend.last_iterations <= 190
    assert np.max(np.abs(x - ref)) <= 1e-6 * max(1.0, np.max(np.abs(ref)))


@pytest.mark.parametrize("cap, solver, scaled, quadprog_calls", [
    (190, "daqp", 1, 0),  # the cost-scaled call answers before quadprog
    (20, "quadprog", 0, 1),  # the capped calls do not: quadprog answers, as without a cap
    (ITERATION_LIMIT, "quadprog", 0, 1),  # no cap (an unbounded budget): no cost-scaled call, quadprog answers
])
def test_id_full_qp_failure_path_takes_the_cost_scaled_call_within_the_cap(robots, cap, solver, scaled,
                                                                           quadprog_calls):
    """The recorded QP above through ``InverseDynamicsQP``'s full-QP solve with ``daqp_attempt_iterations`` =
    ``cap``: the answer meets quadprog's optimum to 1e-6 relative on every route; which solver answered, the
    cost-scaled solves and the quadprog calls are counted."""
    import wbc.solvers.fallback as fallback
    from wbc.dynamics import InverseDynamicsQP, SoleContact

    robot = robots("talos")
    qp = InverseDynamicsQP(robot, [], [SoleContact(robot, robot.left_sole, name="left")], solver="daqp")
    qp.chain.daqp_attempt_iterations = cap
    problem = _qp()
    ref = _quadprog(*problem)
    calls = []
    reduced = fallback.solve_pinned_reduced
    fallback.solve_pinned_reduced = lambda *a, **k: calls.append("quadprog") or reduced(*a, **k)
    try:
        x, who, step = qp.chain.solve(QPData(*problem))
    finally:
        fallback.solve_pinned_reduced = reduced
    assert who == solver and (step == "scaled call") == scaled and calls.count("quadprog") == quadprog_calls
    assert np.max(np.abs(x - ref)) <= 1e-6 * max(1.0, np.max(np.abs(ref)))


def test_controller_budget_sets_the_attempt_cap(robots):
    """A 2 ms budget gives the first DAQP attempt 190 iterations (a third of the budget at 3.5 µs each); an
    unbounded budget leaves the backend's own limit (1000); a 1 µs budget the floor of 10."""
    from wbc.dynamics import InverseDynamicsController, InverseDynamicsQP, SoleContact
    from wbc.solvers.fallback import daqp_attempt_iterations

    robot = robots("talos")
    qp = InverseDynamicsQP(robot, [], [SoleContact(robot, robot.left_sole, name="left")])
    ctrl = InverseDynamicsController(qp, DT)
    assert qp.chain.daqp_attempt_iterations == daqp_attempt_iterations(DT) == 190
    ctrl.budget = math.inf
    assert qp.chain.daqp_attempt_iterations == 1000
    ctrl.budget = 1e-6
    assert qp.chain.daqp_attempt_iterations == 10
