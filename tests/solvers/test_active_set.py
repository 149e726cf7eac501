"""The Goldfarb–Idnani dual active set (:func:`wbc.solvers.active_set.dual_active_set`, the dense range space
:class:`~wbc.solvers.active_set.DenseSpace`) with the kinematic tick's settings (both through
:func:`~wbc.solvers.active_set.solve_qp_into`) and with the inverse-dynamics tick's (held fixed bounds, x refreshed,
the KKT check), on block-structured QPs like the ID tick's, cold and wrongly warm-started, against quadprog (via
qpsolvers) and the KKT conditions."""

from __future__ import annotations

import numpy as np
import pytest
import qpsolvers

from conftest import dense_active_set, dense_quadprog
from wbc.solvers.active_set import ActiveSetSettings, QPWarmArrays, kinematic_settings, qp_ws_sizes, solve_qp_into
from wbc.solvers.qp_data import QPData
from wbc.solvers.status import ITERATION_CAP


def _block_qp(rng, nv, nf, m, p):
    """H = blockdiag(dense SPD, diagonal > 0), equality rows, two-sided rows and bounds around a feasible x0; a
    third of the diagonal block's variables fixed (lb = ub = 0, as the forces of an inactive contact)."""
    n = nv + nf
    M = rng.standard_normal((nv, nv))
    H = np.zeros((n, n))
    H[:nv, :nv] = M @ M.T + 0.1 * np.eye(nv)
    H[nv:, nv:] = np.diag(rng.uniform(0.5, 2.0, nf))
    g = rng.standard_normal(n) * 10.0  # an unconstrained optimum far outside: many constraints active
    lb, ub = -np.ones(n), np.ones(n)
    lb[rng.random(n) < 0.2] = -np.inf
    fixed = nv + np.flatnonzero(rng.random(nf) < 0.33)
    lb[fixed] = ub[fixed] = 0.0
    x0 = rng.uniform(-0.5, 0.5, n)
    x0[fixed] = 0.0
    A = rng.standard_normal((m, n))
    b = A @ x0
    C = rng.standard_normal((p, n))
    l, u = C @ x0 - rng.uniform(0.0, 0.3, p), C @ x0 + rng.uniform(0.0, 0.3, p)
    l[rng.random(p) < 0.3] = -np.inf
    return H, g, A, b, C, l, u, lb, ub


def _id_solve(H, g, A, b, C, l, u, lb, ub, state, rstate):
    """solve_qp_into with the ID tick's settings (those of ``CompiledIDSolver.settings``, written out), warm-started
    from (state, rstate), in place: (steps, x, nu, mu, z, state, rstate)."""
    n, m, p = H.shape[0], A.shape[0], C.shape[0]
    x, nu, mu, z = np.zeros(n), np.zeros(m), np.zeros(p), np.zeros(n)
    it = dense_active_set((H, g, A, b, C, l, u, lb, ub), (state, rstate, x, nu, mu, z, np.zeros(1)), 200,
                          ActiveSetSettings(200, 1e-11, 0.0, 1e-10, 0.0, True, True, 1, 1e-9, 1e-24))
    return it, x, nu, mu, z, state, rstate


@pytest.mark.parametrize("seed", range(30))
def test_both_settings_give_the_exact_optimum(seed):
    rng = np.random.default_rng(7000 + seed)
    nv, nf = int(rng.integers(4, 14)), int(rng.integers(2, 14))
    m, p = int(rng.integers(0, 4)), int(rng.integers(1, 12))
    H, g, A, b, C, l, u, lb, ub = _block_qp(rng, nv, nf, m, p)
    n = nv + nf
    G, h = np.vstack([C, -C]), np.concatenate([u, -l])
    fin = np.isfinite(h)
    ref = qpsolvers.solve_qp(H, g, G=G[fin], h=h[fin], A=A if m else None, b=b if m else None,
                             lb=np.where(np.isfinite(lb), lb, -1e20), ub=ub, solver="quadprog")
    assert ref is not None  # x0 is feasible
    scale = max(1.0, np.abs(ref).max())
    # the ID tick's settings: the optimum, and every KKT condition (multipliers of the held bounds from lam_b)
    state, rstate = np.zeros(n, np.int8), np.zeros(len(l), np.int8)
    it, x, nu, mu, zb, state, rstate = _id_solve(H, g, A, b, C, l, u, lb, ub, state, rstate)
    assert it > 0, it
    assert np.abs(x - ref).max() < 1e-8 * scale
    assert (zb[state == 0] == 0).all()
    assert np.abs(H @ x + g + A.T @ nu + C.T @ mu + zb).max() < 1e-8 * max(1.0, np.abs(g).max())
    free_bound = (state != 0) & (lb != ub)
    assert (state[free_bound] * zb[free_bound] >= -1e-9).all()
    assert (mu[rstate == -1] <= 1e-9).all() and (mu[rstate == 1] >= -1e-9).all() and (mu[rstate == 0] == 0).all()
    cx = C @ x
    assert (cx >= l - 1e-9).all() and (cx <= u + 1e-9).all() and (x >= lb).all() and (x <= ub).all()
    # the kinematic tick's settings on the same QP: the same optimum
    st, rst = np.zeros(n, np.int8), np.zeros(len(l), np.int8)
    xd, nud, mud, zd, res = np.zeros(n), np.zeros(m), np.zeros(len(l)), np.zeros(n), np.zeros(1)
    itd = dense_active_set((H, g, A, b, C, l, u, lb, ub), (st, rst, xd, nud, mud, zd, res), 200)
    assert itd > 0, itd
    assert np.abs(xd - ref).max() < 1e-8 * scale
    assert np.abs(xd - x).max() < 1e-8 * scale
    # warm-started from its own working set, the ID tick's solve ends at once with the same x
    it2, x2, *_ = _id_solve(H, g, A, b, C, l, u, lb, ub, state.copy(), rstate.copy())
    assert it2 == 1 and np.abs(x2 - x).max() < 1e-12 * scale



@pytest.mark.parametrize("seed", range(10))
def test_a_wrong_warm_start_still_ends_at_the_optimum(seed):
    """Random bounds held at either side and random rows held (a working set of another QP): the exact optimum
    all the same, feasible to 1e-9."""
    rng = np.random.default_rng(9100 + seed)
    nv, nf = int(rng.integers(4, 12)), int(rng.integers(2, 10))
    m, p = int(rng.integers(0, 3)), int(rng.integers(1, 10))
    H, g, A, b, C, l, u, lb, ub = _block_qp(rng, nv, nf, m, p)
    ref = dense_quadprog(H, g, A, b, C, l, u, lb, ub)
    state = np.zeros(nv + nf, np.int8)
    held = (rng.random(nv + nf) < 0.3) & np.isfinite(lb)
    state[held] = rng.choice(np.array([-1, 1], np.int8), held.sum())
    state[lb == ub] = 1
    rstate = np.zeros(p, np.int8)
    rheld = (rng.random(p) < 0.3) & np.isfinite(l)
    rstate[rheld] = -1
    it, x, *_ = _id_solve(H, g, A, b, C, l, u, lb, ub, state, rstate)
    assert it > 0, it
    assert np.abs(x - ref).max() < 1e-8 * max(1.0, np.abs(ref).max())
    cx = C @ x
    assert (cx >= l - 1e-9).all() and (cx <= u + 1e-9).all() and (x >= lb - 1e-12).all() and (x <= ub + 1e-12).all()


def _into(qp, fw, iw, max_iter):
    """solve_qp_into from a cold working set in the given workspaces: every output, copied."""
    H, g, A, b, C, l, u, lb, ub = qp
    n, m, p = H.shape[0], A.shape[0], C.shape[0]
    state, rstate = np.zeros(n, np.int8), np.zeros(p, np.int8)
    x, nu, mu, z, res = np.zeros(n), np.zeros(m), np.zeros(p), np.zeros(n), np.zeros(1)
    it = solve_qp_into(tuple(qp), (state, rstate, x, nu, mu, z, res), kinematic_settings(max_iter), fw, iw)
    return it, x, nu, mu, z, state, rstate, res


@pytest.mark.parametrize("seed", range(12))
def test_solve_qp_into_ignores_what_its_workspace_holds(seed):
    """The answer (every output, the residual of an exit code included) is a function of the QP: the same bits from
    a fresh (zeroed) workspace, from one dirtied by solving a different QP of the same size, and from one filled
    with arbitrary numbers; on success it is quadprog's optimum."""
    rng = np.random.default_rng(9100 + seed)
    nv, nf = int(rng.integers(4, 14)), int(rng.integers(2, 14))
    m, p = int(rng.integers(0, 4)), int(rng.integers(1, 12))
    qp = _block_qp(rng, nv, nf, m, p)
    other = _block_qp(rng, nv, nf, m, p)
    n = nv + nf
    fsize, isize = qp_ws_sizes(n, m, p)
    answers = {}
    for max_iter in (200, 1):  # 1: an exit on the iteration cap (the QPs need more steps)
        fresh = answers[max_iter] = _into(qp, np.zeros(fsize), np.zeros(isize, np.int64), max_iter)
        fw, iw = np.zeros(fsize), np.zeros(isize, np.int64)
        assert _into(other, fw, iw, 200)[0] > 0
        dirtied = _into(qp, fw, iw, max_iter)
        garbage = _into(qp, rng.uniform(-1e3, 1e3, fsize), rng.integers(0, n, isize), max_iter)
        for out in (dirtied, garbage):
            assert out[0] == fresh[0]
            for a, b in zip(out[1:], fresh[1:]):
                assert np.array_equal(a, b)
        if max_iter == 1:
            assert fresh[0] == ITERATION_CAP and fresh[-1][0] == np.inf
    H, g, A, b, C, l, u, lb, ub = qp
    it, x = answers[200][:2]
    assert it > 0, it
    G, h = np.vstack([C, -C]), np.concatenate([u, -l])
    fin = np.isfinite(h)
    ref = qpsolvers.solve_qp(H, g, G=G[fin], h=h[fin], A=A if m else None, b=b if m else None,
                             lb=np.where(np.isfinite(lb), lb, -1e20), ub=ub, solver="quadprog")
    assert ref is not None  # x0 is feasible
    assert np.abs(x - ref).max() < 1e-9 * max(1.0, np.abs(ref).max())


def test_solve_qp_into_takes_its_namedtuples_as_plain_tuples():
    """QPData, QPWarmArrays and ActiveSetSettings, or plain tuples in their order (the fast backend's per-call entry):
    the same bits out."""
    rng = np.random.default_rng(9200)
    qp = QPData(*_block_qp(rng, 8, 6, 2, 7))
    n, m, p = qp.H.shape[0], qp.A.shape[0], qp.C.shape[0]
    answers = []
    for named in (True, False):
        arrays = QPWarmArrays(np.zeros(n, np.int8), np.zeros(p, np.int8), np.zeros(n), np.zeros(m), np.zeros(p),
                              np.zeros(n), np.zeros(1))
        settings = ActiveSetSettings(*kinematic_settings(200))
        it = dense_active_set(qp, arrays, 0, settings) if named else dense_active_set(tuple(qp), tuple(arrays), 0,
                                                                                       tuple(settings))
        answers.append((it, *arrays))
    assert answers[0][0] > 0
    for a, b in zip(*answers):
        assert np.array_equal(a, b)
