"""The inverse-dynamics failure path under the clock guard, ordered by cost: a cheap hard-set check
(``wbc.solvers.independent.hard_set_check``) before quadprog, DAQP calls whose iteration limit follows a CPU-time
deadline (``DaqpBackend.deadline``), the cost-scaled DAQP call before quadprog. Oracles: HiGHS (scipy ``linprog``) for
feasibility, quadprog for optima; counts of solver calls and iterations, never a wall-clock time."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import quadprog

from wbc.exceptions import InvalidInputError, SolverError
from wbc.solvers import DaqpBackend
from wbc.solvers.daqp import MIN_CALL_ITERATIONS
from wbc.solvers.independent import hard_set_check, solve_pinned_reduced

DT = 0.002
FIXTURES = Path(__file__).resolve().parents[1] / "fixtures"


def _highs_feasible(A, b, C, l, u, lb, ub) -> bool:
    import scipy.optimize as so

    fu, fl = np.isfinite(u), np.isfinite(l)
    bounds = [(lo if np.isfinite(lo) else None, hi if np.isfinite(hi) else None) for lo, hi in zip(lb, ub)]
    r = so.linprog(np.zeros(A.shape[1]), A_ub=np.vstack([C[fu], -C[fl]]), b_ub=np.concatenate([u[fu], -l[fl]]),
                   A_eq=A if A.shape[0] else None, b_eq=b if A.shape[0] else None, bounds=bounds, method="highs")
    return r.status == 0


def _fixture(name):
    d = dict(np.load(FIXTURES / f"{name}.npz"))
    return tuple(d[k] for k in ("H", "g", "A", "b", "C", "l", "u", "lb", "ub"))


def _rows_hold(x, A, b, C, l, u, lb, ub, tol=1e-6):
    assert np.abs(A @ x - b).max(initial=0.0) <= tol * max(1.0, np.abs(b).max(initial=0.0))
    cx = C @ x
    assert np.all(cx <= u + tol * np.maximum(1.0, np.abs(np.where(np.isfinite(u), u, 0.0))))
    assert np.all(cx >= l - tol * np.maximum(1.0, np.abs(np.where(np.isfinite(l), l, 0.0))))
    assert np.all(x >= lb - 1e-9) and np.all(x <= ub + 1e-9)


@pytest.mark.parametrize("name", ["id_released_foot_talos", "id_first_tick_humanoid15"])
def test_hard_set_check_finds_feasible_the_qps_daqp_calls_infeasible_and_proves_an_empty_set_empty(name):
    """Two QPs recorded from the ID fuzz that DAQP (the ID settings, one attempt: ``cold_retry`` off, as the
    controller's first call) reports infeasible although HiGHS finds their hard set feasible: the check (DAQP on the projection of the origin, identity Hessian) finds them feasible. The
    same set with one inequality row's lower bound moved past its upper one (HiGHS: infeasible) is never called
    feasible: Talos's is proved empty (False); on humanoid15's DAQP returns a point that fails the row check, which
    is reported as unknown (None: the caller goes on to quadprog)."""
    H, g, A, b, C, l, u, lb, ub = _fixture(name)
    assert _highs_feasible(A, b, C, l, u, lb, ub)
    first = DaqpBackend(primal_tol=1e-6, warm_start="dual")
    first.cold_retry = False
    with pytest.raises(SolverError):  # the false infeasibility the check must not repeat
        first.solve(H, g, A, b, C, l, u, lb, ub, confirm=False)
    assert hard_set_check(A, b, C, l, u, lb, ub)[0] is True
    l2 = l.copy()
    i = np.flatnonzero(np.isfinite(u) & np.any(C != 0, axis=1))[0]
    l2[i] = u[i] + 1.0
    assert not _highs_feasible(A, b, C, l2, u, lb, ub)
    assert hard_set_check(A, b, C, l2, u, lb, ub)[0] is (False if name == "id_released_foot_talos" else None)


def test_hard_set_check_agrees_with_highs_on_random_sets_and_reports_an_unfinished_check_as_unknown():
    """40 random sets (equalities, two-sided rows, boxes; every second one made infeasible by a row band pushed
    away from the box): the verdict equals HiGHS's on every one. One iteration on a set that needs more gives
    None (unknown), never a verdict. A bad ``iter_limit`` is a typed error."""
    rng = np.random.default_rng(29)
    verdicts = []
    for k in range(40):
        n, m, p = 12, 3, 10
        A, C = rng.normal(size=(m, n)), rng.normal(size=(p, n))
        x0 = rng.uniform(-1, 1, n)
        b = A @ x0
        l, u = C @ x0 - rng.uniform(0.01, 1, p), C @ x0 + rng.uniform(0.01, 1, p)
        lb, ub = np.full(n, -1.0), np.full(n, 1.0)
        if k % 2:
            # a row band beyond what the box allows: max |C_i x| over the box is Σ|C_ij|
            i = int(rng.integers(p))
            l[i], u[i] = np.abs(C[i]).sum() + 0.5, np.inf
        expected = _highs_feasible(A, b, C, l, u, lb, ub)
        assert expected == (k % 2 == 0)
        verdicts.append(hard_set_check(A, b, C, l, u, lb, ub)[0] is expected)
    assert all(verdicts)
    H, g, A, b, C, l, u, lb, ub = _fixture("id_released_foot_talos")
    assert hard_set_check(A, b, C, l, u, lb, ub, iter_limit=1)[0] is None
    for bad in (0, 2.5, True, "10"):
        with pytest.raises(InvalidInputError, match="iter_limit"):
            hard_set_check(A, b, C, l, u, lb, ub, iter_limit=bad)[0]


def test_daqp_dual_calls_follow_a_cpu_time_deadline_and_fail_rather_than_answer_unconverged():
    """``DaqpBackend.deadline`` (the ID settings: dual warm start): a deadline already past lowers the call to
    MIN_CALL_ITERATIONS iterations; a QP that needs more fails (``budget_capped``, SolverError, no further call)
    instead of returning an unconverged x. With no deadline the same backend solves it to quadprog's optimum."""
    rng = np.random.default_rng(0)
    n = 40
    M = rng.normal(size=(n, n))
    H, g = M @ M.T + np.eye(n), 50.0 * rng.normal(size=n)
    A, b = np.zeros((0, n)), np.zeros(0)
    C, l, u = rng.normal(size=(10, n)), np.full(10, -1.0), np.full(10, 1.0)
    lb, ub = np.full(n, -0.1), np.full(n, 0.1)
    I = np.eye(n)
    ref = quadprog.solve_qp(H, -g, np.hstack([C.T, -C.T, I, -I]), np.concatenate([l, -u, lb, -ub]), 0)[0]

    free = DaqpBackend(primal_tol=1e-6, warm_start="dual")
    x = free.solve(H, g, A, b, C, l, u, lb, ub, confirm=False)
    assert np.max(np.abs(x - ref)) <= 1e-6 and free.last_iterations > MIN_CALL_ITERATIONS

    capped = DaqpBackend(primal_tol=1e-6, warm_start="dual")
    calls = []
    solve = capped._daqp.solve
    counting = staticmethod(lambda *a, **k: calls.append(k["iter_limit"]) or solve(*a, **k))
    capped._daqp = type("CountingDaqp", (), {"solve": counting})
    capped.deadline = -math.inf  # long past
    with pytest.raises(SolverError):
        capped.solve(H, g, A, b, C, l, u, lb, ub, confirm=False)
    assert capped.budget_capped and calls == [MIN_CALL_ITERATIONS]  # one call, at the floor, then no retry
    capped.deadline = math.inf
    calls.clear()
    x = capped.solve(H, g, A, b, C, l, u, lb, ub, confirm=False)
    assert np.max(np.abs(x - ref)) <= 1e-6 and calls[0] == capped.settings["iter_limit"]


def test_cost_scaled_daqp_call_solves_a_qp_daqp_calls_infeasible_to_quadprogs_optimum():
    """A QP recorded from the ID fuzz (humanoid15, |g| ≈ 1e6, Hessian conditioned ≈ 1e11) whose plain DAQP solve
    was reported infeasible (tests/formulations/test_acceleration_faults.py): ``solve_scaled`` (one call, the cost divided by
    max(1, |g|∞, |H|max)) returns x meeting every row to 1e-6 and equal to quadprog's optimum to 1e-6 relative."""
    H, g, A, b, C, l, u, lb, ub = _fixture("id_large_cost_humanoid15")
    backend = DaqpBackend(primal_tol=1e-6, warm_start="dual")
    x = backend.solve_scaled(H, g, A, b, C, l, u, lb, ub)
    assert x is not None
    _rows_hold(x, A, b, C, l, u, lb, ub)
    ref = solve_pinned_reduced(H, g, A, b, C, l, u, lb, ub, 1e-6)
    assert np.max(np.abs(x - ref)) <= 1e-6 * max(1.0, np.max(np.abs(ref)))


def _infeasible_tick(robots, calls, **options):
    """Every joint asked v̇ = 0 (hard) with torque limits at 20 % of the URDF effort (tests/formulations/test_acceleration_faults.py):
    the full QP is infeasible, the relaxed one is not. Counts backend solves and quadprog solves in ``calls``."""
    import wbc.solvers.fallback as fallback
    from wbc.dynamics import AccelerationReference, InverseDynamicsController, InverseDynamicsQP, SoleContact
    from wbc.tasks import PostureTask

    robot = robots("talos")
    posture = AccelerationReference(PostureTask(robot), kp=0.0, kd=0.0, name="posture")
    posture.set_target(robot.q_ref)
    soles = [SoleContact(robot, robot.left_sole, name="left"), SoleContact(robot, robot.right_sole, name="right")]
    qp = InverseDynamicsQP(robot, [], soles, solver="daqp", torque_limit_scale=0.2)
    qp.add_task(posture, hard=True)
    solve = qp.backend.solve
    qp.backend.solve = lambda *a, **k: calls.append("backend") or solve(*a, **k)
    reduced = fallback.solve_pinned_reduced
    fallback.solve_pinned_reduced = lambda *a, **k: calls.append("quadprog") or reduced(*a, **k)
    try:
        ctrl = InverseDynamicsController(qp, DT, **options)
        cmd = ctrl.solve(robot.q_ref, np.zeros(robot.nv))
    finally:
        fallback.solve_pinned_reduced = reduced
    H, g, A, b, C, l, u, lb, ub = qp.build(ctrl.state, DT)
    return ctrl, cmd, (A, b, C, l, u, lb, ub)


def test_id_clock_guard_skips_quadprog_and_the_retries_on_a_hard_set_it_proves_empty(robots):
    """Without the clock guard (the default budget, the period) and with it and a budget the tick does not reach
    (10 s): the hard-set check proves the set empty (HiGHS agrees, computed here), so quadprog and the retries are
    skipped — one backend solve for the full QP, then the relaxed QP — path ``relaxed:daqp``. With a spent budget
    (1 ns) no check runs at all, with the clock guard (its clock) and without it (the tick's counted work,
    ``FallbackChain.tick_work``): the relaxed QP answers at once, path ``relaxed:daqp+budget``, the same relaxed
    command (1e-9)."""
    calls_free = []
    ctrl, cmd_free, hard = _infeasible_tick(robots, calls_free)
    assert not _highs_feasible(*hard)
    assert cmd_free.ok and cmd_free.relaxed and cmd_free.path == "relaxed:daqp"
    assert calls_free == ["backend", "backend"]  # attempt, relaxed QP
    assert "hard set is empty" in cmd_free.message and ctrl.qp.chain.relaxed_set_feasible is True
    calls_counted = []
    ctrl, cmd_counted, _ = _infeasible_tick(robots, calls_counted, budget=1e-9)
    assert cmd_counted.ok and cmd_counted.relaxed and cmd_counted.path == "relaxed:daqp+budget"
    assert calls_counted == ["backend", "backend"] and "hard set is empty" not in cmd_counted.message
    assert ctrl.qp.chain.relaxed_set_feasible is None
    np.testing.assert_allclose(cmd_counted.tau, cmd_free.tau, rtol=0, atol=1e-9)
    calls_roomy = []
    ctrl, cmd_roomy, _ = _infeasible_tick(robots, calls_roomy, budget=10.0, clock_guard=True)
    assert cmd_roomy.ok and cmd_roomy.relaxed and cmd_roomy.path == "relaxed:daqp" and not cmd_roomy.over_budget
    assert calls_roomy == ["backend", "backend"]
    assert "hard set is empty" in cmd_roomy.message
    calls_cut = []
    ctrl, cmd_cut, _ = _infeasible_tick(robots, calls_cut, budget=1e-9, clock_guard=True)
    assert cmd_cut.ok and cmd_cut.relaxed and cmd_cut.path == "relaxed:daqp+budget" and cmd_cut.over_budget
    assert calls_cut == ["backend", "backend"] and "no quadprog solve" in cmd_cut.message
    assert "hard set is empty" not in cmd_cut.message and ctrl.qp.chain.relaxed_set_feasible is None
    for cmd in (cmd_roomy, cmd_cut):
        assert np.max(np.abs(cmd.tau - cmd_free.tau)) <= 1e-9 * max(1.0, np.max(np.abs(cmd_free.tau)))
    assert ctrl.clock_guard is True
    for bad in ("yes", 0, None):
        with pytest.raises(InvalidInputError, match="clock_guard"):
            ctrl.clock_guard = bad


@pytest.mark.parametrize("clock_guard", [False, True])
def test_id_empty_relaxed_set_ends_the_failed_tick_after_one_check(robots, clock_guard):
    """A hard CoM task asking 1000 m/s² sideways on soles with μ = 0.01: no contact force can push the CoM that hard,
    so the relaxed hard set (torque and joint acceleration limits dropped, built here) is empty as well (HiGHS).
    After the full QP's one DAQP attempt the check of the relaxed set proves it empty: no quadprog, no retries and no
    relaxed solve (one backend call in the tick), the safe command (``fallback:gravity``, ok False) naming it."""
    import pinocchio as pin
    import wbc.solvers.fallback as fallback
    from wbc.dynamics import AccelerationReference, InverseDynamicsController, InverseDynamicsQP, SoleContact
    from wbc.tasks import ComTask, PostureTask

    robot = robots("talos")
    com = AccelerationReference(ComTask(), kp=1000.0, kd=0.0, name="com")
    soles = [SoleContact(robot, robot.left_sole, name="left", mu=0.01),
             SoleContact(robot, robot.right_sole, name="right", mu=0.01)]
    qp = InverseDynamicsQP(robot, [], soles, solver="daqp")
    qp.add_task(com, hard=True)
    posture = AccelerationReference(PostureTask(robot), kp=10.0, kd=1.0, name="posture")
    posture.set_target(robot.q_ref)
    qp.add_task(posture)
    com.set_target(pin.centerOfMass(robot.model, robot.model.createData(), robot.q_ref) + np.array([0.0, 1.0, 0.0]))
    calls = []
    solve = qp.backend.solve
    qp.backend.solve = lambda *a, **k: calls.append("backend") or solve(*a, **k)
    reduced = fallback.solve_pinned_reduced
    fallback.solve_pinned_reduced = lambda *a, **k: calls.append("quadprog") or reduced(*a, **k)
    try:
        ctrl = InverseDynamicsController(qp, DT, budget=10.0, clock_guard=clock_guard)
        cmd = ctrl.solve(robot.q_ref, np.zeros(robot.nv))
    finally:
        fallback.solve_pinned_reduced = reduced
    _, _, A, b, C, l, u, lb, ub = qp.build(ctrl.state, DT)
    keep = np.ones(C.shape[0], bool)
    keep[qp.torque_limits.rows] = False  # the torque limit rows, dropped in the relaxed QP
    lb, ub = lb.copy(), ub.copy()
    lb[qp.joint_acceleration_limits.iv], ub[qp.joint_acceleration_limits.iv] = -np.inf, np.inf
    assert qp.joint_speed_limits is None
    assert not _highs_feasible(A, b, C[keep], l[keep], u[keep], lb, ub)
    assert not cmd.ok and cmd.path == "fallback:gravity"
    assert calls == ["backend"]
    assert qp.chain.relaxed_set_feasible is False
    assert "relaxed hard set is empty" in cmd.message
