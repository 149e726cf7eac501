"""The block strategy of the dual active-set solver (:mod:`wbc.solvers.active_set_block`, H = blockdiag(dense,
diagonal)) warm-started from working sets that are not the optimum's, against quadprog (via qpsolvers)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import dense_quadprog
from test_active_set import _block_qp, _block_solve


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
    it, x, *_ = _block_solve(H, g, A, b, C, l, u, lb, ub, nv, state, rstate)
    assert it > 0, it
    assert np.abs(x - ref).max() < 1e-8 * max(1.0, np.abs(ref).max())
    cx = C @ x
    assert (cx >= l - 1e-9).all() and (cx <= u + 1e-9).all() and (x >= lb - 1e-12).all() and (x <= ub + 1e-12).all()
