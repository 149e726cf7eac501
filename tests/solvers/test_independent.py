""":func:`wbc.solvers.independent.solve_pinned_reduced` (quadprog on the null space of the equality rows, pinned
variables eliminated) against quadprog on the whole QP built here (pinned variables as equality rows, the equalities
as quadprog's first constraints) and HiGHS (scipy ``linprog``) for feasibility, on seeded random strictly convex QPs
with equality rows, two-sided rows, bounds and pinned variables."""

from __future__ import annotations

import numpy as np
import pytest
import quadprog

from conftest import highs_feasible
from wbc.solvers.independent import solve_pinned_reduced


def _random_qp(rng, n=30, m=8, p=20, pinned=3, cond=1e6):
    """A feasible QP: H with eigenvalues from 1 to 1/cond, rows and bounds around a point x* (so x* meets them)."""
    Q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    H = Q @ np.diag(np.logspace(0, -np.log10(cond), n)) @ Q.T
    H = 0.5 * (H + H.T)
    g = rng.normal(size=n) * 100
    xs = rng.normal(size=n)
    A = rng.normal(size=(m, n))
    b = A @ xs
    C = rng.normal(size=(p, n))
    cx = C @ xs
    l = cx - rng.uniform(0, 1, p)
    u = cx + rng.uniform(0, 1, p)
    l[rng.random(p) < 0.3] = -np.inf
    lb, ub = np.full(n, -np.inf), np.full(n, np.inf)
    idx = rng.choice(n, 12, replace=False)
    lb[idx[:6]] = xs[idx[:6]] - rng.uniform(0, 0.5, 6)
    ub[idx[3:9]] = xs[idx[3:9]] + rng.uniform(0, 0.5, 6)
    pin = idx[9:9 + pinned]
    lb[pin] = ub[pin] = xs[pin]
    return H, g, A, b, C, l, u, lb, ub


def _whole_quadprog(H, g, A, b, C, l, u, lb, ub):
    """quadprog on all n variables; pinned variables as equality rows (built here)."""
    n = H.shape[0]
    eye = np.eye(n)
    pinned = np.isfinite(lb) & (lb == ub)
    fl, fu = np.isfinite(l), np.isfinite(u)
    bl, bu = np.isfinite(lb) & ~pinned, np.isfinite(ub) & ~pinned
    Cq = np.hstack([A.T, eye[:, pinned], C[fl].T, -C[fu].T, eye[:, bl], -eye[:, bu]])
    bq = np.concatenate([b, lb[pinned], l[fl], -u[fu], lb[bl], -ub[bu]])
    return quadprog.solve_qp(H, -g, Cq, bq, A.shape[0] + int(pinned.sum()))[0]


@pytest.mark.parametrize("seed", range(12))
def test_matches_quadprog_on_the_whole_qp(seed):
    """Cost equal to the whole-QP quadprog optimum's to 1e-5 relative (Hessians conditioned up to 1e8, rows met to
    1e-6: the two active-set runs stop at different points of that tolerance); rows, bounds and pinned values met
    to 1e-6."""
    rng = np.random.default_rng(seed)
    H, g, A, b, C, l, u, lb, ub = _random_qp(rng, cond=10.0 ** rng.uniform(2, 8))
    assert highs_feasible(A, b, C, l, u, lb, ub)
    x, reason = solve_pinned_reduced(H, g, A, b, C, l, u, lb, ub, 1e-6, details=True)
    assert x is not None and reason == ""
    ref = _whole_quadprog(H, g, A, b, C, l, u, lb, ub)
    f = lambda z: 0.5 * z @ H @ z + g @ z  # noqa: E731
    assert abs(f(x) - f(ref)) <= 1e-5 * max(1.0, abs(f(ref)))
    assert np.max(np.abs(A @ x - b)) <= 1e-6 * max(1.0, np.max(np.abs(b)))
    cx = C @ x
    assert np.all(cx >= l - 1e-6 * np.maximum(1.0, np.abs(np.nan_to_num(l, neginf=0.0))))
    assert np.all(cx <= u + 1e-6 * np.maximum(1.0, np.abs(u)))
    assert np.all(x >= lb) and np.all(x <= ub)
    pinned = np.isfinite(lb) & (lb == ub)
    assert np.array_equal(x[pinned], lb[pinned])


def test_an_empty_set_is_not_answered():
    """Two inequality rows that contradict each other under the equalities (HiGHS: empty): no answer."""
    rng = np.random.default_rng(99)
    H, g, A, b, C, l, u, lb, ub = _random_qp(rng)
    C = np.vstack([C, C[0], -C[0]])
    l = np.concatenate([l, [10.0, 10.0]])
    u = np.concatenate([u, [np.inf, np.inf]])
    assert not highs_feasible(A, b, C, l, u, lb, ub)
    assert solve_pinned_reduced(H, g, A, b, C, l, u, lb, ub, 1e-6) is None
