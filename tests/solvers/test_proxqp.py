"""The warm-started ProxQP backend (wbc.solvers.proxqp): a sequence of QPs of one size (the warm path, proxsuite's
``update``), then another size (a new workspace), each at quadprog's optimum through ``solve``; a warm call that
fails restarts cold on the next call; an infeasible QP is no solution."""

from __future__ import annotations

import numpy as np

from conftest import dense_quadprog
from test_active_set import _block_qp
from wbc.solvers.proxqp import ProxQPBackend


def test_warm_sequence_and_a_new_size_reach_quadprogs_optimum():
    rng = np.random.default_rng(77)
    backend = ProxQPBackend()
    for nv, nf, m, p in [(6, 4, 1, 5)] * 4 + [(8, 3, 2, 6)] * 2:
        qp = _block_qp(rng, nv, nf, m, p)
        ref = dense_quadprog(*qp)
        raw = backend.raw_solve(*qp)
        if raw is None:  # the warm start failed (seen on the 4th QP): the next call starts cold and solves it
            raw = backend.raw_solve(*qp)
        np.testing.assert_allclose(raw, ref, atol=1e-6 * max(1.0, np.abs(ref).max()))
        np.testing.assert_allclose(backend.solve(*qp), ref, atol=1e-6 * max(1.0, np.abs(ref).max()))


def test_an_infeasible_qp_has_no_solution():
    H, g = np.eye(2), np.zeros(2)
    C, l, u = np.array([[1.0, 0.0]]), np.array([-np.inf]), np.array([-1.0])  # x₀ ≤ −1 against x₀ ≥ 0
    lb, ub = np.zeros(2), np.ones(2)
    assert ProxQPBackend().raw_solve(H, g, np.zeros((0, 2)), np.zeros(0), C, l, u, lb, ub) is None
