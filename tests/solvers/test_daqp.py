"""A tick's counted work bounds the DAQP call in progress, not only the start of the next one: DAQP's iterations per
call follow the work left (``DaqpBackend.call_limit``), on the counted solves or (clock guard) the tick's CPU time
(``TickWork``), and a workspace that cycles where DAQP's one-shot solve succeeds is not tried first again. No
wall-clock assertion: the counts are the behaviour."""

from __future__ import annotations

import daqp
import numpy as np
import pytest
import quadprog

from wbc.exceptions import SolverError
from wbc.solvers import DaqpBackend, TickWork


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


@pytest.mark.parametrize("warm_start", ["workspace", "dual"])
def test_calls_under_a_deadline_are_sized_at_the_measured_cost_per_iteration(monkeypatch, warm_start):
    """An iteration that costs far more than the nominal ``iteration_cost`` (DAQP's proximal iterations on an
    ill-conditioned Hessian: ~5 × it) sizes the next calls under a deadline: the CPU clock here advances 1 ms per
    DAQP iteration done (~300 × the nominal); after one solve of ~70 iterations the measured cost is 1 ms and the
    next call's limit is the iterations that fit at it, not at the nominal cost. Without a deadline nothing is
    measured (the calls are those of an unguarded tick)."""
    import wbc.solvers.daqp as daqp_module

    H, g, A, b, C, l, u, lb, ub = _box_qp(n=60)
    done = [0]
    one_shot, model_class = daqp.solve, daqp.Model

    class Model(model_class):
        def solve(self):
            out = super().solve()
            done[0] += int(out[3]["iterations"])
            return out

    def solve(*args, **kwargs):
        out = one_shot(*args, **kwargs)
        done[0] += int(out[3]["iterations"])
        return out

    monkeypatch.setattr(daqp, "solve", solve)
    monkeypatch.setattr(daqp, "Model", Model)
    monkeypatch.setattr(daqp_module, "thread_time", lambda: 1e-3 * done[0])
    free = DaqpBackend(warm_start=warm_start)
    free.solve(H, g, A, b, C, l, u, lb, ub, confirm=False)
    assert free.measured_iteration_cost == 0.0
    guarded = DaqpBackend(warm_start=warm_start)
    guarded.deadline = daqp_module.thread_time() + 0.5  # 0.5 s of the fake clock: the settings' cap at 3.5 µs
    assert guarded.call_limit() == guarded.settings["iter_limit"]
    guarded.solve(H, g, A, b, C, l, u, lb, ub, confirm=False)
    assert 0.99e-3 <= guarded.measured_iteration_cost <= 1.01e-3
    left = guarded.deadline - daqp_module.thread_time()  # ~0.43 s: ~430 iterations at 1 ms
    assert guarded.call_limit() == int(left / guarded.measured_iteration_cost) < 500


def test_tick_work_reads_the_clock_at_reset_only_with_a_clock_guard(monkeypatch):
    """Without a clock guard a tick's start does not read the CPU clock (a system call); ``seconds`` then measures
    from its first call in the tick, so the difference of two calls is the CPU time between them, as with a guard."""
    from wbc.solvers import base as solver_base

    reads = []
    clock = [10.0]

    def fake_thread_time():
        reads.append(clock[0])
        return clock[0]

    monkeypatch.setattr(solver_base, "thread_time", fake_thread_time)
    counted = TickWork(cap=4)
    counted.reset(4)
    assert reads == []  # neither the construction nor the reset read the clock
    assert counted.solves == 0 and reads == []
    start = counted.seconds()
    clock[0] += 0.25
    assert counted.seconds() - start == pytest.approx(0.25, abs=1e-12)
    clocked = TickWork(cap=4, clock=0.1)
    n = len(reads)
    clocked.reset(4, 0.1)
    assert len(reads) == n + 1  # the guard's reference time
    clock[0] += 0.5
    assert clocked.seconds() == pytest.approx(0.5, abs=1e-12)  # since the reset
    assert clocked.solves == pytest.approx(5.0, abs=1e-9) and clocked.spent()


def _scaled_qp_of_the_id_fuzz():
    """The cost-scaled call's QP of a G1 tick of the ID fuzz (seed 540009 episode 331, 59 variables, |g|∞ 8e5:
    the scaled Hessian's smallest entries ~1e-13), on which DAQP's default proximal regularisation ran 108 outer
    iterations besides its 165 iterations."""
    from pathlib import Path

    d = np.load(Path(__file__).resolve().parents[1] / "fixtures" / "id_scaled_proximal_g1.npz")
    return tuple(d[k] for k in ("H", "g", "A", "b", "C", "l", "u", "lb", "ub"))


def _daqp_direct(H, g, A, b, C, l, u, lb, ub, **settings):
    """DAQP's one-shot solve of the cost-scaled QP, called here (the reference for the backend's counts)."""
    n, m = H.shape[0], A.shape[0]
    scale = 1.0 / max(1.0, float(np.abs(g).max()), float(np.abs(H).max()))
    sense = np.zeros(n + m + C.shape[0], dtype=np.int32)
    sense[n:n + m] = 5
    return daqp.solve(H * scale, g * scale, np.vstack([A, C]), np.concatenate([ub, b, u]),
                      np.concatenate([lb, b, l]), sense, primal_tol=1e-6, **settings)


def _max_row_violation(x, A, b, C, l, u, lb, ub):
    r = [np.abs(A @ x - b) / np.maximum(1.0, np.abs(b)),
         np.maximum(C @ x - u, 0) / np.maximum(1.0, np.abs(np.where(np.isfinite(u), u, 0))),
         np.maximum(l - C @ x, 0) / np.maximum(1.0, np.abs(np.where(np.isfinite(l), l, 0))),
         np.maximum(x - ub, 0), np.maximum(lb - x, 0)]
    return max(float(v.max(initial=0.0)) for v in r)


def test_proximal_outer_iterations_are_counted_and_the_scaled_settings_reach_the_scaled_call():
    """``DaqpBackend.proximal_iterations`` adds DAQP's outer iterations beyond the first (its ``nodes`` − 1, read
    here from DAQP called directly on the same scaled QP); ``scaled_settings`` reach the cost-scaled call: with
    ``eps_prox`` −1e-8 the call has at most one outer iteration per five iterations (the share the inverse-dynamics
    count assumes) and its answer meets every row to 1e-6."""
    qp = _scaled_qp_of_the_id_fuzz()
    ref = _daqp_direct(*qp, iter_limit=1000)
    assert ref[2] == 1 and ref[3]["nodes"] > 50  # DAQP's default regularisation: many outer iterations
    backend = DaqpBackend(primal_tol=1e-6, warm_start="dual")
    x = backend.solve_scaled(*qp)
    assert x is not None and backend.last_iterations == ref[3]["iterations"]
    assert backend.proximal_iterations == ref[3]["nodes"] - 1
    ref8 = _daqp_direct(*qp, iter_limit=1000, eps_prox=-1e-8)
    backend.scaled_settings = {"eps_prox": -1e-8}
    before = backend.proximal_iterations
    x8 = backend.solve_scaled(*qp)
    assert x8 is not None and backend.last_iterations == ref8[3]["iterations"]
    outer = backend.proximal_iterations - before
    assert outer == ref8[3]["nodes"] - 1 and 5 * outer <= backend.last_iterations
    assert _max_row_violation(x8, *qp[2:]) <= 1e-6


def test_proximal_iterations_count_twice_the_work_of_plain_ones():
    """DAQP with a proximal term (``eps_prox``, the strict cascade's levels) costs about twice as much per iteration
    (the kinematic fuzz, g1 levels of 35 variables: 3.2 µs per proximal iteration, 1.5–2.3 µs per plain one): a
    solve counts one plus one per 75 of its iterations (150 without the term), and a call under a tick's count gets
    half the iterations: (1.9 × 4 − 1) × 75 = 495 of a cap of 4 solves (990 without)."""
    n = 60
    H, g, A, b, C, l, u, lb, ub = _box_qp(0, n)
    J = np.random.default_rng(0).normal(size=(n // 3, n))
    H = J.T @ J  # semidefinite: the proximal iterations' case
    prox = DaqpBackend(eps_prox=1e-3)
    prox.work = TickWork()
    x = prox.solve(H, g, A, b, C, l, u, lb, ub, confirm=False)
    assert prox.last_iterations >= 75, prox.last_iterations
    assert prox.work.solves == 1 + prox.last_iterations // 75
    assert np.all(x >= lb - 1e-9) and np.all(x <= ub + 1e-9)
    assert np.all(C @ x >= l - 1e-6) and np.all(C @ x <= u + 1e-6)
    plain = DaqpBackend()
    plain.work = TickWork()
    plain.solve(*_box_qp(0, n), confirm=False)
    assert plain.work.solves == 1 + plain.last_iterations // 150
    fresh_prox, fresh_plain = DaqpBackend(eps_prox=1e-3), DaqpBackend()  # no iterations of an attempt in progress
    fresh_prox.work, fresh_plain.work = TickWork(cap=4), TickWork(cap=4)
    assert fresh_prox.call_limit() == 495
    assert fresh_plain.call_limit() == 990


def test_tick_work_add_counts_as_solves_plus_n_with_and_without_a_clock_guard(monkeypatch):
    """``add(n)`` leaves the count where ``solves += n`` leaves it: without a clock guard the count plus n; with one
    the larger of the count and the CPU time in solves, plus n (a fake CPU clock: 0.35 s at 0.1 s per solve)."""
    from wbc.solvers import base as solver_base

    clock = [0.0]
    monkeypatch.setattr(solver_base, "thread_time", lambda: clock[0])
    counted = TickWork(cap=8)
    counted.add(1)
    counted.add(2.5)
    assert counted.solves == 3.5
    clocked, reference = TickWork(cap=8, clock=0.1), TickWork(cap=8, clock=0.1)
    clock[0] = 0.35  # 3.5 solves of CPU time, none counted
    clocked.add(1)
    reference.solves += 1
    assert clocked.solves == reference.solves == pytest.approx(4.5, abs=1e-12)
    clock[0] = 0.2  # a clock below the count: the count stands
    clocked.add(1)
    assert clocked.solves == pytest.approx(5.5, abs=1e-12)
