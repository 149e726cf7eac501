"""The clip of a box into the running box (:func:`wbc.solvers.linalg.clip_entry_into`): the intersection where the
two overlap, else the running box's end nearest the new one (it yields, never empties)."""

import numpy as np

from wbc.solvers.linalg import clip_entry_into

# (running lb, ub), new (lo, hi) -> expected (lb, ub): written by hand from the rule of the module docstring
CASES = [
    ((-1.0, 1.0), (-0.5, 2.0), (-0.5, 1.0)),  # overlap: the intersection
    ((-1.0, 1.0), (-3.0, -2.0), (-1.0, -1.0)),  # below: pinned at the running lower end
    ((-1.0, 1.0), (2.0, 3.0), (1.0, 1.0)),  # above: pinned at the running upper end
    ((-np.inf, np.inf), (0.25, 0.5), (0.25, 0.5)),  # a free entry takes the new box
    ((0.0, 0.0), (-1.0, 1.0), (0.0, 0.0)),  # a locked entry stays locked
]


def test_clip_entry_into_follows_the_rule():
    for (lb0, ub0), (lo, hi), expected in CASES:
        lb, ub = np.array([7.0, lb0]), np.array([8.0, ub0])
        clip_entry_into(lb, ub, 1, lo, hi)
        assert (lb[1], ub[1]) == expected
        assert (lb[0], ub[0]) == (7.0, 8.0)  # the other entries untouched


def _scaled_violation_reference(x, xc, A, b, C, l, u, lb, ub) -> float:
    """The scaled violation written out here row by row (numpy, independent of wbc): bound excess over
    max(1, |crossed bound|); equality rows |a·xc − b| over max(1, |b|, Σ|a_j xc_j|); inequality rows' excess over
    max(1, |nearer bound| (1 if infinite), Σ|c_j xc_j|)."""
    worst = 0.0
    for j in range(x.size):
        if x[j] != xc[j]:
            bound = ub[j] if x[j] > xc[j] else lb[j]
            worst = max(worst, abs(x[j] - xc[j]) / max(1.0, abs(bound)))
    for a, bi in zip(A, b):
        worst = max(worst, abs(float(np.dot(a, xc)) - bi) / max(1.0, abs(bi), float(np.sum(np.abs(a * xc)))))
    for c, lo, hi in zip(C, l, u):
        s = float(np.dot(c, xc))
        ex = max(lo - s, s - hi)
        if ex > 0:
            near = lo if lo - s > s - hi else hi
            near = abs(near) if np.isfinite(near) else 1.0
            worst = max(worst, ex / max(1.0, near, float(np.sum(np.abs(c * xc)))))
    return worst


def test_scaled_row_violation_matches_a_row_by_row_reference():
    """The compiled scaled violation (:func:`wbc.solvers.linalg.scaled_row_violation`, the body of
    ``QPBackend.scaled_violation``) equals the reference above to 1e-12 relative on random QPs with infinite
    bounds and rows, points outside their bounds and rows violated by 1e-9 to 1e3 (1e-15 absolute where the
    violation is a rounding error: a feasible point)."""
    from wbc.solvers.base import QPBackend
    from wbc.solvers.linalg import scaled_row_violation

    rng = np.random.default_rng(26)
    for trial in range(200):
        n, m, p = int(rng.integers(1, 40)), int(rng.integers(0, 8)), int(rng.integers(0, 30))
        A = rng.normal(size=(m, n)) * 10.0 ** rng.uniform(-3, 3)
        C = rng.normal(size=(p, n)) * 10.0 ** rng.uniform(-3, 3)
        x0 = rng.normal(size=n) * 10.0 ** rng.uniform(-2, 4)
        b = A @ x0 + rng.normal(size=m) * 10.0 ** rng.uniform(-9, 3) * (trial % 3 != 0)
        cx = C @ x0
        l = np.where(rng.random(p) < 0.3, -np.inf, cx - rng.uniform(-1e-3, 1.0, p) * (trial % 3 != 0))
        u = np.where(rng.random(p) < 0.3, np.inf, cx + rng.uniform(-1e-3, 1.0, p) * (trial % 3 != 0))
        lb = np.where(rng.random(n) < 0.4, -np.inf, x0 - rng.uniform(-1.0, 1.0, n))
        ub = np.where(rng.random(n) < 0.4, np.inf, np.maximum(lb, x0 + rng.uniform(-1.0, 1.0, n)))
        if trial % 3 == 0:  # a feasible point: bounds widened to hold it, rows through it
            lb, ub = np.minimum(lb, x0), np.maximum(ub, x0)
        x = x0
        xc = np.minimum(np.maximum(x, lb), ub)
        ref = _scaled_violation_reference(x, xc, A, b, C, l, u, lb, ub)
        got = scaled_row_violation(x, xc, A, b, C, l, u, lb, ub)
        assert abs(got - ref) <= 1e-12 * ref + 1e-15, (trial, got, ref)  # 1e-15 absolute: rounding at ~0
        assert QPBackend.scaled_violation(x, xc, A, b, C, l, u, lb, ub) == got
        if trial % 3 == 0:
            assert got <= 1e-12  # a point meeting every row and bound (up to rounding of the rows' sums)
