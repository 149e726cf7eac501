"""The compiled exact backend (``fast``, :class:`wbc.solvers.fast.FastBackend`) against independent solvers (DAQP,
quadprog via qpsolvers) and the KKT conditions, and the controller's trajectories with ``solver="fast"`` against the
general DAQP path."""

from __future__ import annotations

import numpy as np
import pytest
import qpsolvers

from conftest import dense_active_set
from wbc.solvers import FastBackend, make_backend


def _random_qp(rng, n, m, box_scale):
    M = rng.standard_normal((n, n))
    H = M @ M.T + 0.1 * np.eye(n)
    g = rng.standard_normal(n) * 3.0
    A = rng.standard_normal((m, n))
    x0 = rng.uniform(-0.5, 0.5, n) * box_scale  # a feasible point inside the box
    b = A @ x0
    lb = -box_scale * np.ones(n)
    ub = box_scale * np.ones(n)
    lb[rng.random(n) < 0.1] = -np.inf
    return H, g, A, b, lb, ub


@pytest.mark.parametrize("seed", range(40))
def test_kernel_without_inequality_rows_is_the_exact_optimum(seed):
    rng = np.random.default_rng(seed)
    n, m = int(rng.integers(3, 40)), int(rng.integers(0, 4))
    H, g, A, b, lb, ub = _random_qp(rng, n, m, box_scale=float(rng.uniform(0.3, 2.0)))
    state = np.zeros(n, np.int8)
    x, nu, z = np.empty(n), np.zeros(m), np.zeros(n)
    no_rows = (np.zeros((0, n)), np.zeros(0), np.zeros(0))
    qp = (H, g, A, b, *no_rows, lb, ub)
    arrays = (state, np.zeros(0, np.int8), x, nu, np.zeros(0), z, np.empty(1))
    it = dense_active_set(qp, arrays, 200)
    assert it > 0, it
    # KKT: stationarity, primal feasibility, dual sign, complementarity (thresholds set here)
    assert np.abs(H @ x + g + A.T @ nu + z).max() < 1e-9
    assert np.abs(A @ x - b).max() < 1e-9 if m else True
    assert (x >= lb - 1e-12).all() and (x <= ub + 1e-12).all()
    at_lb, at_ub = state == -1, state == 1
    assert (z[at_lb] <= 1e-12).all() and (z[at_ub] >= -1e-12).all()
    assert (z[state == 0] == 0).all()
    assert np.abs(x[at_lb] - lb[at_lb]).max(initial=0) == 0 and np.abs(x[at_ub] - ub[at_ub]).max(initial=0) == 0
    # same x as two independent solvers
    Ae, be = (A, b) if m else (None, None)
    for solver in ("quadprog", "daqp"):
        if solver not in qpsolvers.available_solvers:
            continue
        lbf, ubf = np.where(np.isfinite(lb), lb, -1e20), ub
        ref = qpsolvers.solve_qp(H, g, A=Ae, b=be, lb=lbf, ub=ubf, solver=solver)
        assert ref is not None
        assert np.abs(x - ref).max() < 1e-9 * max(1.0, np.abs(ref).max()), solver
    # warm start from the optimal set: one iteration, the same x
    x1 = x.copy()
    it2 = dense_active_set(qp, arrays, 200)
    assert it2 == 1 and np.abs(x - x1).max() < 1e-10 * max(1.0, np.abs(x1).max())


@pytest.mark.parametrize("seed", range(40))
def test_kernel_with_inequality_rows_is_the_exact_optimum(seed):
    rng = np.random.default_rng(1000 + seed)
    n, m = int(rng.integers(8, 40)), int(rng.integers(0, 4))
    p = int(rng.integers(1, n // 2))
    H, g, A, b, lb, ub = _random_qp(rng, n, m, box_scale=1.0)
    x0 = np.linalg.lstsq(A, b, rcond=None)[0] if m else np.zeros(n)
    C = rng.standard_normal((p, n))
    l, u = C @ x0 - rng.uniform(0.0, 0.5, p), C @ x0 + rng.uniform(0.0, 0.5, p)
    l[rng.random(p) < 0.3] = -np.inf
    fast = make_backend("fast")
    x = fast.solve(H, g, A, b, C, l, u, lb, ub)
    if fast.kernel_solves == 0:  # degenerate (e.g. x0 outside the box): answered by DAQP, still the optimum
        assert fast.fallbacks == 1
    else:
        st = H @ x + g + A.T @ fast._nu + C.T @ fast._mu + fast._z
        assert np.abs(st).max() < 1e-9
        cx = C @ x
        assert (fast._mu[fast._rstate == -1] <= 1e-12).all() and (fast._mu[fast._rstate == 1] >= -1e-12).all()
        assert (fast._mu[fast._rstate == 0] == 0).all()
        assert (cx >= l - 1e-9).all() and (cx <= u + 1e-9).all()
    G, h = np.vstack([C, -C]), np.concatenate([u, -l])
    fin = np.isfinite(h)
    ref = qpsolvers.solve_qp(H, g, G=G[fin], h=h[fin], A=A if m else None, b=b if m else None,
                             lb=np.where(np.isfinite(lb), lb, -1e20), ub=ub, solver="quadprog")
    if ref is None:  # infeasible draw: the backend must have said so too
        return
    assert np.abs(x - ref).max() < 1e-9 * max(1.0, np.abs(ref).max())


@pytest.mark.parametrize("seed", range(30))
def test_kernel_with_dependent_inequality_rows_is_the_exact_optimum(seed):
    """Rows of C that are repeated, scaled, combinations of each other or of the equality rows, and bounds they
    compete with (the self-collision case: nearly parallel rows at their floor next to joints at velocity bounds):
    the dual active set answers them itself (no DAQP fallback) with every KKT condition, and quadprog agrees."""
    rng = np.random.default_rng(5000 + seed)
    n, m = int(rng.integers(6, 30)), int(rng.integers(0, 3))
    H, g, A, b, lb, ub = _random_qp(rng, n, m, box_scale=1.0)
    g = g * 10.0  # an unconstrained optimum far outside: many constraints active
    x0 = np.linalg.lstsq(A, b, rcond=None)[0] if m else np.zeros(n)
    x0 = np.clip(x0, 0.5 * lb, 0.5 * ub)
    base = rng.standard_normal((3, n))
    rows = [base[0], base[0], 2.0 * base[1], base[0] + base[1], base[2] - base[1]]
    if m:
        rows.append(A[0] + 0.5 * base[2])
        rows.append(A[0])
    C = np.array(rows)
    cx0 = C @ x0
    l = cx0 - rng.uniform(0.0, 0.2, len(rows))
    u = cx0 + rng.uniform(0.0, 0.2, len(rows))
    if m:  # the row equal to an equality row: consistent with it
        l[-1], u[-1] = b[0] - 0.1, b[0] + 0.1
    fast = FastBackend()
    x = fast.solve(H, g, A, b, C, l, u, lb, ub)
    assert fast.kernel_solves == 1 and fast.fallbacks == 0, fast.last_kernel_iterations
    st = H @ x + g + A.T @ fast._nu + C.T @ fast._mu + fast._z
    assert np.abs(st).max() < 1e-8 * max(1.0, np.abs(g).max())
    assert (fast._mu[fast._rstate == -1] <= 1e-12).all() and (fast._mu[fast._rstate == 1] >= -1e-12).all()
    assert (fast._z[fast._state == -1] <= 1e-12).all() and (fast._z[fast._state == 1] >= -1e-12).all()
    assert (fast._mu[fast._rstate == 0] == 0).all() and (fast._z[fast._state == 0] == 0).all()
    cx = C @ x
    assert (cx >= l - 1e-9).all() and (cx <= u + 1e-9).all() and (x >= lb).all() and (x <= ub).all()
    G, h = np.vstack([C, -C]), np.concatenate([u, -l])
    ref = qpsolvers.solve_qp(H, g, G=G, h=h, A=A if m else None, b=b if m else None,
                             lb=np.where(np.isfinite(lb), lb, -1e20), ub=ub, solver="quadprog")
    assert ref is not None
    assert np.abs(x - ref).max() < 1e-8 * max(1.0, np.abs(ref).max())
    # warm-started from its own working set: the same x in one step
    x2 = fast.solve(H, g, A, b, C, l, u, lb, ub)
    assert fast.last_kernel_iterations == 1 and np.abs(x2 - x).max() < 1e-12 * max(1.0, np.abs(x).max())


def test_kernel_reports_infeasible_rows():
    """Two rows that cannot both hold (c·x ≥ 1 and the same c·x ≤ 0): the dual active set stops with INFEASIBLE,
    and the backend, after DAQP and the independent solvers, raises SolverError."""
    from wbc.exceptions import SolverError
    from wbc.solvers.status import INFEASIBLE

    n = 5
    H, g = np.eye(n), np.ones(n)
    c = np.arange(1.0, n + 1.0)
    C = np.array([c, c])
    l, u = np.array([1.0, -np.inf]), np.array([np.inf, 0.0])
    lb, ub = -np.ones(n), np.ones(n)
    A, b = np.zeros((0, n)), np.zeros(0)
    state, rstate = np.zeros(n, np.int8), np.zeros(2, np.int8)
    it = dense_active_set((H, g, A, b, C, l, u, lb, ub), (state, rstate, np.empty(n), np.zeros(0), np.zeros(2),
                                                          np.zeros(n), np.zeros(1)), 100)
    assert it == INFEASIBLE
    with pytest.raises(SolverError):
        FastBackend().solve(H, g, A, b, C, l, u, lb, ub)


def test_backend_falls_back_on_dependent_equalities():
    rng = np.random.default_rng(3)
    n = 6
    H, g, A, b, lb, ub = _random_qp(rng, n, 2, 1.0)
    fast, daqp = make_backend("fast"), make_backend("daqp")
    assert isinstance(fast, FastBackend)
    A2, b2 = np.vstack([A, A[:1]]), np.concatenate([b, b[:1]])  # a repeated row: Schur complement singular
    empty = np.zeros((0, n))
    x = fast.solve(H, g, A2, b2, empty, np.zeros(0), np.zeros(0), lb, ub)
    assert fast.last_kernel_iterations < 0 and fast.fallbacks == 1 and fast.kernel_solves == 0
    assert np.abs(x - daqp.solve(H, g, A, b, empty, np.zeros(0), np.zeros(0), lb, ub)).max() < 1e-9


def _count_fast_backends(monkeypatch) -> list:
    made = []
    init = FastBackend.__init__

    def counting(self, *a, **k):
        init(self, *a, **k)
        made.append(self)

    monkeypatch.setattr(FastBackend, "__init__", counting)
    return made


def _catalog():
    from wbc.robot import catalog

    return catalog()


def _behaviours():
    from wbc.scenarios.balance import BEHAVIOURS

    return sorted(BEHAVIOURS)


@pytest.mark.parametrize("name", _catalog())
def test_walk_matches_the_daqp_path(robots, monkeypatch, name):
    """Issue 10: the compiled path's walk is the general (DAQP) path's walk to 1e-9, on every catalog robot."""
    from wbc.scenarios.walk import plan_default_walk, run_walk

    made = _count_fast_backends(monkeypatch)
    robot = robots(name)
    plan = plan_default_walk(robot, n_steps=2)
    ref, fast = run_walk(robot, plan, solver="daqp"), run_walk(robot, plan, solver="fast")
    assert ref.solver_ok.all() and fast.solver_ok.all()
    assert np.abs(ref.q - fast.q).max() < 1e-9
    assert np.abs(ref.v - fast.v).max() < 1e-9 / plan.dt  # v = Δq/dt
    assert sum(b.kernel_solves for b in made) > 0.9 * len(plan.t)  # the compiled path did the work


@pytest.mark.parametrize("behaviour", _behaviours())
@pytest.mark.parametrize("name", _catalog())
def test_balance_matches_the_daqp_path(robots, monkeypatch, name, behaviour):
    """Issue 10: every catalog balance behaviour on every catalog robot, compiled path = DAQP path to 1e-9."""
    from wbc.scenarios.balance import run_balance

    made = _count_fast_backends(monkeypatch)
    robot = robots(name)
    ref, fast = run_balance(robot, behaviour, solver="daqp"), run_balance(robot, behaviour, solver="fast")
    assert ref.solver_ok.all() and fast.solver_ok.all()
    assert np.abs(ref.q - fast.q).max() < 1e-9
    assert sum(b.kernel_solves for b in made) > 0.9 * len(fast.q)  # CoM-polygon rows solved by the kernel


def test_strict_hierarchy_takes_the_general_path(robots):
    """Strict levels are semidefinite QPs: with ``fast`` they are solved by DAQP backends, same result as daqp."""
    import sys
    from pathlib import Path

    from wbc.configuration import Configuration

    sys.path.insert(0, str(Path(__file__).parent))
    from test_hierarchy import build

    robot = robots("talos")
    vs = {}
    for solver in ("daqp", "fast"):
        config = Configuration(robot)
        ctrl, _, _ = build(robot, config, hand_level=0, com_level=1)
        ctrl.backend = make_backend(solver)
        out = []
        for _ in range(10):
            r = ctrl.solve(config, 0.002)
            assert r.ok, r.message
            out.append(r.v)
            config.step(r.v, 0.002)
        vs[solver] = np.array(out)
    assert np.abs(vs["daqp"] - vs["fast"]).max() < 1e-9


def test_after_a_failed_kernel_call_with_rows_the_next_goes_to_daqp():
    """A kernel call with inequality rows that ends without a KKT point (here: its iteration cap of 1 on a problem
    that needs more) is answered by DAQP, and so is the next call with rows, without running the kernel; the call
    after tries the kernel again. Every answer is the optimum (quadprog)."""
    rng = np.random.default_rng(7)
    n = 12
    H, g, A, b, lb, ub = _random_qp(rng, n, 2, 0.2)
    g = g * 20.0  # an unconstrained optimum far outside the box: several bounds and rows active
    C = rng.standard_normal((4, n))
    x0 = np.linalg.lstsq(A, b, rcond=None)[0]
    l, u = C @ x0 - 0.05, C @ x0 + 0.05
    G, h = np.vstack([C, -C]), np.concatenate([u, -l])
    ref = qpsolvers.solve_qp(H, g, G=G, h=h, A=A, b=b, lb=lb, ub=ub, solver="quadprog")
    assert ref is not None
    fast = FastBackend(max_iter=1)
    seen = []
    for _ in range(3):
        fast.last_kernel_iterations = 0
        x = fast.solve(H, g, A, b, C, l, u, lb, ub)
        assert np.abs(x - ref).max() < 1e-6 * max(1.0, np.abs(ref).max())
        seen.append((fast.last_kernel_iterations, fast.kernel_solves, fast.fallbacks))
    assert seen[0][0] < 0 and seen[0][2] == 1  # the kernel ran out of iterations: DAQP
    assert seen[1] == (0, 0, 2)  # kernel not run: DAQP
    assert seen[2][0] != 0  # the kernel ran again


def test_a_kernel_solve_counts_one_solve_of_the_tick_work():
    """Every solve attempt adds one to the tick's counted work (``TickWork``), the kernel's too: uncounted, a re-solve
    loop on the kernel (a kinematic tick's contact corrections and trust regions, each a kernel solve) never reached
    the count that stops it (kinematic fuzz seed 100011 episode 14 tick 40: 9 trust-region radii, 3.5 ms)."""
    from wbc.solvers.base import TickWork

    rng = np.random.default_rng(3)
    H, g, A, b, lb, ub = _random_qp(rng, 12, 2, box_scale=0.5)
    backend = FastBackend()
    backend.work = TickWork(cap=8)
    C, l, u = np.zeros((0, 12)), np.zeros(0), np.zeros(0)
    for k in range(1, 4):
        x = backend.solve(H, g, A, b, C, l, u, lb, ub)
        assert backend.fallbacks == 0  # the kernel answered
        assert backend.work.solves == k
    ref = qpsolvers.solve_qp(H, g, A=A, b=b, lb=lb, ub=ub, solver="quadprog")
    assert np.abs(x - ref).max() < 1e-9 * max(1.0, np.abs(ref).max())


def test_a_kernel_that_gives_up_counts_one_solve_and_its_shape_goes_to_daqp_for_the_rest_of_the_tick():
    """With ``count_give_ups``, under a tick's counted work (``TickWork``) a kernel attempt that gives up (dependent
    equality rows) counts one solve like any other attempt, and the tick's later problems of that shape go to DAQP at
    once (the kernel is not run again); a problem of another shape still tries the kernel, and so does the same
    problem on the next tick (``TickWork.reset``). Without it (the default) the give-up is not counted and the kernel
    is tried on every call. Every answer is the optimum of the independent rows (quadprog)."""
    from wbc.solvers.base import TickWork

    rng = np.random.default_rng(3)
    n = 6
    H, g, A, b, lb, ub = _random_qp(rng, n, 2, 1.0)
    A2, b2 = np.vstack([A, A[:1]]), np.concatenate([b, b[:1]])  # a repeated row: the kernel gives up
    empty, none = np.zeros((0, n)), np.zeros(0)
    ref = qpsolvers.solve_qp(H, g, A=A, b=b, lb=lb, ub=ub, solver="quadprog")
    plain = FastBackend()
    plain.work = TickWork()
    plain.work.reset(8)
    for k in (1, 2):
        plain.last_kernel_iterations = 0
        plain.solve(H, g, A2, b2, empty, none, none, lb, ub)
        assert plain.last_kernel_iterations < 0 and plain.work.solves == k  # DAQP's attempts only
    fast = FastBackend()
    fast.count_give_ups = True
    work = _same_shape_after_a_give_up(fast, (H, g, A, b, lb, ub), A2, b2, counted=1)
    x = fast.solve(H, g, A, b, empty, none, none, lb, ub)  # another shape: the kernel answers
    assert fast.kernel_solves == 1 and fast.fallbacks == 2
    assert np.abs(x - ref).max() < 1e-9 * max(1.0, np.abs(ref).max())
    work.reset(8)  # the next tick: the kernel is tried again
    fast.solve(H, g, A2, b2, empty, none, none, lb, ub)
    assert fast.last_kernel_iterations < 0 and fast.fallbacks == 3 and work.solves == 2


def _same_shape_after_a_give_up(fast, qp, A2, b2, counted: int):
    """Under a fresh tick's work: ``fast`` solves the QP with the repeated rows (A2, b2; the kernel gives up), then
    the same shape again; checks that the kernel ran once, the counted solves (``counted``: 1 when the give-up is
    counted, else 0, plus DAQP's) and each answer against quadprog on the independent rows. Returns the work."""
    from wbc.solvers.base import TickWork

    H, g, A, b, lb, ub = qp
    empty, none = np.zeros((0, H.shape[0])), np.zeros(0)
    fast.work = work = TickWork()
    work.reset(8)
    for k, gk in enumerate((g, g + 1e-3)):  # the second: the same tick, the same shape
        fast.last_kernel_iterations = 0
        x = fast.solve(H, gk, A2, b2, empty, none, none, lb, ub)
        assert (fast.last_kernel_iterations < 0) == (k == 0)  # the kernel not run again
        assert fast.fallbacks == k + 1 and work.solves == counted + k + 1  # DAQP's attempts (+ the give-up)
        ref = qpsolvers.solve_qp(H, gk, A=A, b=b, lb=lb, ub=ub, solver="quadprog")
        assert np.abs(x - ref).max() < 1e-6 * max(1.0, np.abs(ref).max())
    return work


def test_skip_give_ups_sends_the_shape_to_daqp_for_the_rest_of_the_tick_uncounted():
    """With ``skip_give_ups`` (``count_give_ups`` off), under a tick's counted work a kernel attempt that gives up
    is not counted, and the tick's later problems of that shape go to DAQP at once (the kernel not run again); the
    next tick tries the kernel again. Every answer is the optimum of the independent rows (quadprog)."""
    rng = np.random.default_rng(3)
    n = 6
    H, g, A, b, lb, ub = _random_qp(rng, n, 2, 1.0)
    A2, b2 = np.vstack([A, A[:1]]), np.concatenate([b, b[:1]])  # a repeated row: the kernel gives up
    fast = FastBackend()
    fast.skip_give_ups = True
    work = _same_shape_after_a_give_up(fast, (H, g, A, b, lb, ub), A2, b2, counted=0)
    work.reset(8)  # the next tick: the kernel is tried again
    fast.solve(H, g, A2, b2, np.zeros((0, n)), np.zeros(0), np.zeros(0), lb, ub)
    assert fast.last_kernel_iterations < 0 and fast.fallbacks == 3 and work.solves == 1
