"""Any qpsolvers backend by name (wbc.solvers.by_name): the two-sided rows and the infinite bounds converted to
qpsolvers' one-sided form, checked on OSQP against quadprog on the QP as given."""

from __future__ import annotations

import numpy as np

from conftest import dense_quadprog
from wbc.solvers.by_name import QpsolversBackend


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
