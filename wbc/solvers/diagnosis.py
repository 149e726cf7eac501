"""Infeasibility diagnosis: which hard constraints conflict, and by how much.

Run only after a failed solve. Every hard row gets a slack, penalised in L2 (an always-feasible QP, DAQP):

    min_{v, s}  ε‖v‖² + ‖s_eq‖² + ‖s_in‖² + ‖s_box‖²
    s.t.        A v − s_eq = b,    l ≤ C v − s_in ≤ u,    lb ≤ v − s_box ≤ ub     (bounded coordinates only)

Its solution v_r is the velocity closest to satisfying everything in the least-squares sense (ε = 1e-8 keeps the
Hessian definite). Each constraint's violation is evaluated on its own rows at v_r, in its units; those above ``tol``
conflict, reported largest first. L2 spreads the violation over every constraint of the conflict (L1 would hide all
but one), so both sides of a contradiction are named. Blocks with non-finite numbers are reported with ``nan``.
"""

from __future__ import annotations

import numpy as np

__all__ = ["diagnose"]


def _nonfinite(*arrays) -> bool:
    return not all(np.isfinite(a).all() for a in arrays)


def _excess(lo, x, hi) -> float:
    """Largest amount by which x leaves [lo, hi] (0 inside)."""
    return float(max(np.max(lo - x, initial=0.0), np.max(x - hi, initial=0.0)))


def diagnose(A, b, C, l, u, lb, ub, eq_blocks, in_blocks, box_blocks, *, eps: float = 1e-8,
             tol: float = 1e-6) -> tuple[list[tuple[str, float]], np.ndarray | None]:
    """Slack-relaxed solve of the hard set (module docstring).

    Args:
        A (m_e, n), b (m_e,), C (m_i, n), l, u (m_i,), lb, ub (n,): the hard set.
        eq_blocks, in_blocks: (name, first row, end row) of each equality / inequality constraint.
        box_blocks: (name, indices (k,), lo (k,), hi (k,)) of each box constraint, effective bounds.
        eps: weight of ‖v‖².
        tol: smallest violation reported (constraint units).

    Returns:
        (conflicts, v_r): [(name, violation)] largest first, and the relaxed velocity (None when the relaxed QP
        could not be solved, e.g. non-finite data).
    """
    bad = [name for name, r0, r1 in eq_blocks if _nonfinite(A[r0:r1], b[r0:r1])]
    bad += [name for name, r0, r1 in in_blocks if _nonfinite(C[r0:r1]) or np.isnan(l[r0:r1]).any()
            or np.isnan(u[r0:r1]).any()]
    bad += [name for name, _, lo, hi in box_blocks if np.isnan(lo).any() or np.isnan(hi).any()]
    if bad:
        return [(name, float("nan")) for name in bad], None
    import daqp

    n, me, mi = A.shape[1], A.shape[0], C.shape[0]
    bidx = np.flatnonzero(np.isfinite(lb) | np.isfinite(ub))
    nb = bidx.size
    ns = me + mi + nb
    G = np.zeros((ns, n + ns))
    G[:me, :n] = A
    G[me:me + mi, :n] = C
    G[me + mi:, :n][np.arange(nb), bidx] = 1.0
    G[:, n:] = -np.eye(ns)
    upper = np.concatenate([b, u, ub[bidx]])
    lower = np.concatenate([b, l, lb[bidx]])
    sense = np.zeros(ns, dtype=np.int32)
    sense[:me] = 5
    H = np.diag(np.concatenate([np.full(n, eps), np.ones(ns)]))
    x, _, exitflag, _ = daqp.solve(H, np.zeros(n + ns), G, upper, lower, sense)
    if exitflag < 1 or not np.isfinite(x).all():
        return [], None
    v = x[:n]
    out = [(name, float(np.max(np.abs(A[r0:r1] @ v - b[r0:r1]), initial=0.0))) for name, r0, r1 in eq_blocks]
    out += [(name, _excess(l[r0:r1], C[r0:r1] @ v, u[r0:r1])) for name, r0, r1 in in_blocks]
    out += [(name, _excess(lo, v[idx], hi)) for name, idx, lo, hi in box_blocks]
    conflicts = sorted(((name, viol) for name, viol in out if viol > tol), key=lambda item: -item[1])
    return conflicts, v
