"""The compiled principal-pivoting solver of a QP with equalities and bounds (wbc.solvers.box_eq) against quadprog,
cold and warm-started from its own working set."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import box_eq, dense_quadprog
from wbc.solvers.active_set import QPLimits
from wbc.solvers.box_eq import BoxEqArrays, BoxEqSpace, solve_box_eq_ws


@pytest.mark.parametrize("seed", range(8))
def test_box_eq_reaches_quadprogs_optimum(seed):
    rng = np.random.default_rng(4200 + seed)
    n, m = int(rng.integers(3, 12)), int(rng.integers(0, 3))
    M = rng.standard_normal((n, n))
    H = M @ M.T + 0.1 * np.eye(n)
    g = 5.0 * rng.standard_normal(n)  # optimum far outside the box: bounds active
    lb, ub = -np.ones(n), np.ones(n)
    lb[rng.random(n) < 0.2] = -np.inf
    x0 = rng.uniform(-0.5, 0.5, n)
    A = rng.standard_normal((m, n))
    b = A @ x0
    ref = dense_quadprog(H, g, A, b, np.zeros((0, n)), np.zeros(0), np.zeros(0), lb, ub)
    state, x, nu, z = np.zeros(n, np.int8), np.zeros(n), np.zeros(m), np.zeros(n)
    it = box_eq((H, g, A, b, lb, ub), (state, x, nu, z, np.empty(1)), (100, 1e-12, 1e-12, 1e-24))
    assert it >= 0, it
    np.testing.assert_allclose(x, ref, atol=1e-8 * max(1.0, np.abs(ref).max()))
    assert (x >= lb).all() and (x <= ub).all()
    x2 = np.zeros(n)
    # warm: its own set
    it2 = box_eq((H, g, A, b, lb, ub), (state, x2, nu, z, np.empty(1)), (100, 1e-12, 1e-12, 1e-24))
    assert 0 <= it2 <= 1 and np.abs(x2 - x).max() < 1e-10 * max(1.0, np.abs(x).max())


def test_solve_box_eq_ws_takes_its_namedtuples_as_plain_tuples():
    """BoxEqArrays, QPLimits and BoxEqSpace, or plain tuples in their order (the fast backend's per-call entry):
    the same bits out, and those of fresh workspaces."""
    rng = np.random.default_rng(4300)
    n, m = 9, 2
    M = rng.standard_normal((n, n))
    H, g = M @ M.T + 0.1 * np.eye(n), 5.0 * rng.standard_normal(n)
    A = rng.standard_normal((m, n))
    qp = (H, g, A, A @ rng.uniform(-0.5, 0.5, n), -np.ones(n), np.ones(n))
    answers = []
    for form in ("named", "plain", "allocating"):
        arrays = BoxEqArrays(np.zeros(n, np.int8), np.zeros(n), np.zeros(m), np.zeros(n), np.zeros(1))
        limits = QPLimits(100, 1e-12, 1e-12, 1e-24)
        space = BoxEqSpace(np.zeros(n, np.int64), np.zeros((n, n)), np.zeros((m, n)), np.zeros((m, m)), np.zeros(n),
                           np.zeros(m))
        if form == "named":
            it = solve_box_eq_ws(qp, arrays, limits, space)
        elif form == "plain":
            it = solve_box_eq_ws(qp, tuple(arrays), tuple(limits), tuple(space))
        else:
            it = box_eq(qp, tuple(arrays), tuple(limits))
        answers.append((it, *arrays))
    assert answers[0][0] > 1 and (answers[0][1] != 0).any()  # bounds entered the working set
    for other in answers[1:]:
        for a, b in zip(answers[0], other):
            assert np.array_equal(a, b)
