"""QP backends by name (wbc.solvers.registry): each name gives its backend class, an unknown name is a typed error
listing the valid ones, and every available backend reaches quadprog's optimum on the same QPs; any qpsolvers
backend's two-sided rows and infinite bounds are converted to qpsolvers' one-sided form (checked on OSQP against
quadprog on the QP as given). The warm-started ProxQP backend: a sequence of QPs of one size (the warm path,
proxsuite's ``update``), then another size (a new workspace), each at quadprog's optimum through ``solve``; a warm
call that fails restarts cold on the next call; an infeasible QP is no solution."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import dense_quadprog
from test_active_set import _block_qp
from wbc.exceptions import UnknownSolverError
from wbc.solvers.daqp import DaqpBackend
from wbc.solvers.fast import FastBackend
from wbc.solvers.registry import DEFAULT_SOLVER, ProxQPBackend, QpsolversBackend, available_solvers, make_backend


def test_names_give_their_backend_classes():
    assert DEFAULT_SOLVER == "fast" and "fast" in available_solvers()
    assert isinstance(make_backend("fast"), FastBackend) and isinstance(make_backend("daqp"), DaqpBackend)
    assert isinstance(make_backend("proxqp"), ProxQPBackend)
    osqp = make_backend("osqp")
    assert type(osqp) is QpsolversBackend and osqp.name == "osqp"


def test_an_unknown_name_lists_the_available_ones():
    with pytest.raises(UnknownSolverError, match="available") as err:
        make_backend("gurobi-nope")
    assert all(name in str(err.value) for name in available_solvers())


@pytest.mark.parametrize("name", ["fast", "daqp", "proxqp", "osqp", "quadprog"])
def test_every_backend_reaches_quadprogs_optimum(name):
    rng = np.random.default_rng(31)
    backend = make_backend(name)
    for _ in range(3):
        H, g, A, b, C, l, u, lb, ub = _block_qp(rng, 6, 4, 1, 5)
        ref = dense_quadprog(H, g, A, b, C, l, u, lb, ub)
        x = backend.solve(H, g, A, b, C, l, u, lb, ub)
        tol = 1e-6 if name in ("osqp", "proxqp") else 1e-8  # first-order / augmented-Lagrangian solvers
        np.testing.assert_allclose(x, ref, atol=tol * max(1.0, np.abs(ref).max()))


def test_one_sided_rows_and_free_variables_reach_quadprogs_optimum():
    rng = np.random.default_rng(12)
    n = 6
    M = rng.standard_normal((n, n))
    H, g = M @ M.T + 0.1 * np.eye(n), 4.0 * rng.standard_normal(n)
    C = rng.standard_normal((4, n))
    l = np.array([-0.5, -np.inf, -0.3, -np.inf])  # rows bounded below only, above only, both, neither
    u = np.array([np.inf, 0.4, 0.3, np.inf])
    lb, ub = np.full(n, -np.inf), np.full(n, np.inf)
    lb[:2], ub[2:4] = -0.2, 0.2
    A, b = rng.standard_normal((1, n)), np.zeros(1)
    ref = dense_quadprog(H, g, A, b, C, l, u, lb, ub)
    backend = QpsolversBackend("osqp")
    x = backend.raw_solve(H, g, A, b, C, l, u, lb, ub)
    np.testing.assert_allclose(x, ref, atol=1e-6 * max(1.0, np.abs(ref).max()))
    assert backend.settings["eps_abs"] == 1e-9  # wbc's tight default for OSQP, kept unless overridden
    assert QpsolversBackend("osqp", eps_abs=1e-7).settings["eps_abs"] == 1e-7


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
