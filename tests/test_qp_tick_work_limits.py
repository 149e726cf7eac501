"""A tick's counted work bounds the stage in progress, not only the start of the next one: DAQP's iterations per
call follow the work left (``DaqpBackend.call_limit``), a strict level whose solve fails once the budget is spent
is cut (no retries), an infeasible hard set is recognised in two solves, and a workspace that cycles where DAQP's
one-shot solve succeeds is not tried first again. No wall-clock assertion: the counts are the behaviour."""

from __future__ import annotations

import daqp
import numpy as np
import pytest
import quadprog

from wbc.exceptions import SolverError
from wbc.hierarchy import solve_lexicographic
from wbc.qp import DaqpBackend, TickWork

from conftest import hand_over_posture

DT = 0.002


def _box_qp(seed: int = 0, n: int = 40):
    """A strictly convex QP whose optimum has many active bounds (DAQP needs tens of iterations)."""
    rng = np.random.default_rng(seed)
    M = rng.normal(size=(n, n))
    H = M @ M.T + np.eye(n)
    g = 50.0 * rng.normal(size=n)
    A, b = np.zeros((0, n)), np.zeros(0)
    C, l, u = rng.normal(size=(10, n)), np.full(10, -1.0), np.full(10, 1.0)
    lb, ub = np.full(n, -0.1), np.full(n, 0.1)
    return H, g, A, b, C, l, u, lb, ub


def _quadprog(H, g, C, l, u, lb, ub):
    n = H.shape[0]
    I = np.eye(n)
    G = np.hstack([C.T, -C.T, I, -I])
    h = np.concatenate([l, -u, lb, -ub])
    return quadprog.solve_qp(H, -g, G, h, 0)[0]


def test_daqp_calls_stop_at_the_work_left_and_fail_rather_than_answer_unconverged():
    H, g, A, b, C, l, u, lb, ub = _box_qp()
    ref = _quadprog(H, g, C, l, u, lb, ub)  # independent solver
    free = DaqpBackend()
    x = free.solve(H, g, A, b, C, l, u, lb, ub, confirm=False)
    assert np.max(np.abs(x - ref)) < 1e-6
    assert free.last_iterations > 20  # the problem needs more iterations than the limit below allows

    spent = DaqpBackend()
    spent.work = TickWork(cap=4)
    spent.work.solves = 7  # past the stage factor: 1.9 × 4 − 7 − 1 < 0 solves left → the minimum per call
    assert spent.call_limit() == 10
    with pytest.raises(SolverError):
        spent.solve(H, g, A, b, C, l, u, lb, ub, confirm=False)
    assert spent.budget_capped
    # one capped call, then no further DAQP call in that attempt; the cold attempt is skipped the same way
    assert spent.work.solves == 7 + 2

    # with the work left, the same backend solves it to the same answer (the limit is the only difference)
    ok = DaqpBackend()
    ok.work = TickWork(cap=40)
    assert ok.call_limit() == 1000
    x2 = ok.solve(H, g, A, b, C, l, u, lb, ub, confirm=False)
    assert not ok.budget_capped and np.max(np.abs(x2 - ref)) < 1e-6


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


def _cycling_daqp(n: int, order: list, oneshot_ok: dict):
    """A shim of the daqp module: its workspace (``daqp.Model``) always reports cycling (exit −2), its one-shot
    ``daqp.solve`` is DAQP's while ``oneshot_ok["ok"]`` (else it cycles too); every call is appended to ``order``."""

    class CyclingModel:
        settings = {}

        def setup(self, *args):
            return (0,)

        def update(self, **kw):
            pass

        def solve(self):
            order.append("model")
            return np.zeros(n), 0.0, -2, {"iterations": 7, "lam": None}

    class Stub:
        Model = CyclingModel

        @staticmethod
        def solve(*args, **kw):
            order.append("oneshot")
            if oneshot_ok["ok"]:
                return daqp.solve(*args, **kw)
            return np.zeros(n), 0.0, -2, {"iterations": 9, "lam": None}

    return Stub


def test_a_workspace_that_failed_where_the_one_shot_solved_is_not_tried_first_on_the_next_solve():
    """DAQP's workspace (``daqp.Model``) replaced by one that always reports cycling (exit −2): the first solve is
    answered by the one-shot ``daqp.solve``; the next solve calls the one-shot first (one call), with the same
    answer as quadprog."""
    H, g, A, b, C, l, u, lb, ub = _box_qp(seed=1, n=12)
    ref = _quadprog(H, g, C, l, u, lb, ub)
    order = []
    backend = DaqpBackend()
    backend._daqp = _cycling_daqp(H.shape[0], order, {"ok": True})
    x = backend.solve(H, g, A, b, C, l, u, lb, ub, confirm=False)
    assert order == ["model", "oneshot"] and np.max(np.abs(x - ref)) < 1e-6
    order.clear()
    x = backend.solve(H, g + 1e-3, A, b, C, l, u, lb, ub, confirm=False)
    assert order == ["oneshot"]
    assert np.max(np.abs(x - _quadprog(H, g + 1e-3, C, l, u, lb, ub))) < 1e-6


def test_a_failing_solve_that_starts_with_the_one_shot_runs_each_cold_call_once():
    """After a solve answered by the one-shot call (the workspace cycling), a problem that neither solves runs the
    one-shot, the fresh workspace and the scaled one-shot once each (3 DAQP calls), not the workspace and the
    one-shot a second time in the cold retry (5 calls). Counted with the same shim of the daqp module."""
    H, g, A, b, C, l, u, lb, ub = _box_qp(seed=2, n=12)
    order = []
    oneshot_ok = {"ok": True}
    backend = DaqpBackend()
    backend._daqp = _cycling_daqp(H.shape[0], order, oneshot_ok)
    backend.solve(H, g, A, b, C, l, u, lb, ub, confirm=False)
    assert order == ["model", "oneshot"]
    order.clear()
    oneshot_ok["ok"] = False
    with pytest.raises(SolverError):
        backend.solve(H, g, A, b, C, l, u, lb, ub, confirm=False)
    assert np.abs(g).max() > 1.0  # so the scaled one-shot is tried
    assert order == ["oneshot", "model", "oneshot"]


# -- clock guard (the tick's CPU time counted as work) ------------------------------------------------------------

def _spin_cpu(seconds: float) -> None:
    """Use ``seconds`` of this thread's CPU time (time.thread_time)."""
    import time

    start = time.thread_time()
    x = 0.0
    while time.thread_time() - start < seconds:
        x += 1.0


def test_tick_work_counts_cpu_time_only_with_a_clock_and_daqp_calls_follow_it():
    """Without a clock the work is the count alone, whatever CPU time passes; with one (seconds per solve), CPU
    time spent without any solve reaches the cap, and DAQP's next call gets the minimum iterations and fails
    rather than answering unconverged (the oracle for the unbounded call: quadprog)."""
    H, g, A, b, C, l, u, lb, ub = _box_qp()
    counted = TickWork(cap=4)
    clocked = TickWork(cap=4, clock=1e-5)
    _spin_cpu(2e-4)  # 20 solves' worth at 1e-5 s per solve
    assert counted.solves == 0 and not counted.spent()
    assert clocked.solves >= 20 and clocked.spent() and clocked.spent(1.9)
    backend = DaqpBackend()
    backend.work = clocked
    assert backend.call_limit() == 10  # MIN_CALL_ITERATIONS: the work left is none
    with pytest.raises(SolverError):
        backend.solve(H, g, A, b, C, l, u, lb, ub, confirm=False)
    assert backend.budget_capped
    clocked.reset(4, 1e-5)  # a new tick: the clock restarts
    assert clocked.solves < 4
    backend.work = counted
    x = backend.solve(H, g, A, b, C, l, u, lb, ub, confirm=False)
    assert np.max(np.abs(x - _quadprog(H, g, C, l, u, lb, ub))) < 1e-6


def test_kinematic_clock_guard_cuts_the_stages_of_a_tick_by_its_cpu_time(robots):
    """Strict levels (a hand target at level 0, the posture at level 1) with a budget of 1 s (4000 counted solves:
    never reached). Without the clock guard the tick solves every level (path 'levels'). With it, and the CPU
    time weighted so that any time at all exceeds the budget (``CLOCK_WEIGHT`` = 1e12), the cascade starts no
    level after the first and no contact correction, and the weighted form of the levels answers (one QP; its
    command checked against quadprog in tests/formulations/test_velocity_weighted_levels.py): ok, 'levels+budget+weighted',
    over_budget. Oracles: the soles move ≤ 0.05 mm over the tick by forward kinematics; the command is not the
    cascade's. With the class's weight the 1 s budget is not reached: bitwise the unguarded tick."""
    import pinocchio as pin

    from wbc.exceptions import InvalidInputError

    robot, config, ctrl, (hand, _) = hand_over_posture(robots, budget=1.0)
    assert ctrl.clock_guard is False  # the default: nothing decided by a clock
    full = ctrl.solve(config, DT)
    assert full.ok and full.path == "levels" and not full.over_budget
    _, _, guarded, _ = hand_over_posture(robots, budget=1.0, clock_guard=True)
    same = guarded.solve(config, DT)
    assert same.ok and same.path == "levels" and not same.over_budget
    assert same.v.tobytes() == full.v.tobytes()
    _, _, cutting, _ = hand_over_posture(robots, budget=1.0, clock_guard=True, CLOCK_WEIGHT=1e12)
    cut = cutting.solve(config, DT)
    assert cut.ok and cut.over_budget and cut.path == "levels+budget+weighted", (cut.path, cut.message)
    assert "priority levels after the first 1 of 3 (their weighted form's command)" in cut.message
    assert np.linalg.norm(cut.v - full.v) > 1e-6  # not the cascade's command
    model, data = robot.model, robot.model.createData()
    pin.framesForwardKinematics(model, data, pin.integrate(model, config.q, cut.v * DT))
    for frame in (robot.left_sole, robot.right_sole):
        fid = model.getFrameId(frame)
        assert np.linalg.norm(data.oMf[fid].translation - config.frame_placement(fid).translation) <= 5e-5
    for bad in ("yes", 1, None):
        with pytest.raises(InvalidInputError, match="clock_guard"):
            ctrl.clock_guard = bad
