"""Independent re-solves and checks of a QP (:mod:`wbc.solvers.qp_data`) another backend reported infeasible: quadprog
with the pinned variables and the equality rows eliminated (:func:`solve_pinned_reduced`) and the feasibility of the
constraints alone (:func:`hard_set_check`).
"""

from __future__ import annotations

import numpy as np

from wbc.exceptions import InvalidInputError
from wbc.solvers.base import QPBackend
from wbc.solvers.daqp import DAQP_PRIMAL_TOL, ITERATION_LIMIT

__all__ = ["hard_set_check", "solve_pinned_reduced"]


def solve_pinned_reduced(H, g, A, b, C, l, u, lb, ub, tolerance: float = 1e-6, *, details: bool = False):
    """The QP with its pinned variables (lb_i = ub_i) eliminated and the rows left without a free variable dropped,
    solved by quadprog's dual active-set method (Goldfarb, Idnani, "A numerically stable dual method for solving
    strictly convex quadratic programs", Math. Programming 27, 1983) on the null space of the equality rows, else
    (none, dependent ones, or no checked answer) with the equalities as quadprog's first constraints.

    Args:
        H (n, n) positive definite on the free variables, g (n,), A (m, n), b (m,), C (p, n), l, u (p,), lb, ub (n,):
            the QP (±inf for absent bounds). tolerance: largest scaled violation accepted
            (:meth:`QPBackend.scaled_violation`). details: also return why no solution was returned.

    Returns:
        x (n,) within [lb, ub] (pinned entries exactly at their value) meeting every row to ``tolerance``, or None.
        With ``details``: (x or None, reason), reason '' for a solution, ``infeasible`` (a dropped row violated, or
        quadprog's infeasibility certificate), else ``failed``.
    """
    x, reason = _pinned_reduced(H, g, A, b, C, l, u, lb, ub, tolerance)
    return (x, reason) if details else x


def _pinned_reduced(H, g, A, b, C, l, u, lb, ub, tolerance):
    rows = (A, b, C, l, u, lb, ub)
    pinned = np.isfinite(lb) & (lb == ub)
    free = ~pinned
    xp = lb[pinned]
    Hr = H[np.ix_(free, free)]
    gr = g[free] + H[np.ix_(free, pinned)] @ xp
    Ar, br = A[:, free], b - A[:, pinned] @ xp
    Cr, shift = C[:, free], C[:, pinned] @ xp
    lr, ur = l - shift, u - shift
    empty = ~np.any(Cr != 0.0, axis=1) if C.shape[0] else np.zeros(0, bool)
    if np.any((lr[empty] > tolerance * np.maximum(1.0, np.abs(l[empty])))
              | (ur[empty] < -tolerance * np.maximum(1.0, np.abs(u[empty])))):
        return None, "infeasible"
    Cr, lr, ur = Cr[~empty], lr[~empty], ur[~empty]
    lbr, ubr = lb[free], ub[free]
    # the equalities eliminated first: about half quadprog's work on a humanoid's ID QP
    xr = _nullspace_solve(Hr, gr, Ar, br, Cr, lr, ur, lbr, ubr, tolerance)
    if xr is not None:
        x, reason = _checked(rows, pinned, xp, xr, tolerance)
        if x is not None:
            return x, reason
    xr, reason = _dense_solve(Hr, gr, Ar, br, Cr, lr, ur, lbr, ubr)
    if xr is None:
        return None, reason
    return _checked(rows, pinned, xp, xr, tolerance)


def _checked(rows: tuple, pinned, xp, xr, tolerance):
    """(x, '') from the pinned (at ``xp``) and free (``xr``) parts, clipped, when x meets the constraints ``rows``
    (A, b, C, l, u, lb, ub) to ``tolerance``; else (None, 'failed')."""
    x = np.empty(pinned.shape[0])
    x[pinned] = xp
    x[~pinned] = xr
    xc = QPBackend.accepted(x, *rows, tolerance)
    return (None, "failed") if xc is None else (xc, "")


def _dense_solve(H, g, A, b, C, l, u, lb, ub):
    """quadprog on the QP as given (equalities as its first constraints): (x, '') or (None, reason)."""
    import quadprog

    eye = np.eye(H.shape[0])
    lo, hi, blo, bhi = np.isfinite(l), np.isfinite(u), np.isfinite(lb), np.isfinite(ub)
    # quadprog: min ½xᵀGx − aᵀx s.t. Cᵀx ≥ b, the first meq columns equalities
    Cq = np.hstack([A.T, C[lo].T, -C[hi].T, eye[:, blo], -eye[:, bhi]])
    bq = np.concatenate([b, l[lo], -u[hi], lb[blo], -ub[bhi]])
    try:
        return quadprog.solve_qp(H, -g, Cq, bq, A.shape[0])[0], ""
    except ValueError as exc:
        return None, "infeasible" if "inconsistent" in str(exc) else "failed"


#: relative size (to the largest) of a diagonal entry of R in Aᵀ = QR below which the equality rows count as
#: dependent (:func:`_nullspace_solve` then leaves the QP to the dense solve)
_RANK_TOL = 1e-10


def _nullspace_solve(H, g, A, b, C, l, u, lb, ub, tolerance):
    """quadprog with the equality rows eliminated (null-space method, Nocedal & Wright 2006, §16.2: x = x₀ + Z y,
    Aᵀ = [Y Z] [R; 0], A x₀ = b), bounds becoming rows in y, rows the equalities fix dropped. x (n,), or None (no
    or dependent equality rows, a dropped row violated, quadprog failed)."""
    n, m = H.shape[0], A.shape[0]
    if m == 0 or m >= n:
        return None
    Q, R = np.linalg.qr(A.T, mode="complete")
    d = np.abs(np.diag(R))
    if not np.isfinite(d).all() or d.min() <= _RANK_TOL * d.max():
        return None
    Z = Q[:, m:]
    x0 = Q[:, :m] @ np.linalg.solve(R[:m].T, b)
    bounded = np.isfinite(lb) | np.isfinite(ub)
    Ry = np.vstack([C @ Z, Z[bounded]])  # the rows of C, then the unit rows of the bounds, in y
    shift = np.concatenate([C @ x0, x0[bounded]])
    lo = np.concatenate([l, lb[bounded]])
    hi = np.concatenate([u, ub[bounded]])
    norms = np.concatenate([np.linalg.norm(C, axis=1), np.ones(int(bounded.sum()))])
    fixed = np.linalg.norm(Ry, axis=1) <= 1e-12 * np.maximum(1.0, norms)
    if fixed.any() and np.any((shift[fixed] < lo[fixed] - tolerance * np.maximum(1.0, np.abs(lo[fixed])))
                              | (shift[fixed] > hi[fixed] + tolerance * np.maximum(1.0, np.abs(hi[fixed])))):
        return None
    keep = ~fixed
    Hz = Z.T @ H @ Z
    free = np.full(n - m, np.inf)
    y = _dense_solve(0.5 * (Hz + Hz.T), Z.T @ (g + H @ x0), np.zeros((0, n - m)), np.zeros(0), Ry[keep],
                     lo[keep] - shift[keep], hi[keep] - shift[keep], -free, free)[0]
    return None if y is None else x0 + Z @ y


def hard_set_check(A, b, C, l, u, lb, ub, tolerance: float = 1e-6, *, iter_limit: int = ITERATION_LIMIT,
                   out: np.ndarray | None = None) -> tuple[bool | None, int]:
    """Whether the constraints of a QP have a common point, by one cold DAQP call on the projection of the origin onto
    them (min ½‖x‖²): with an identity Hessian DAQP's dual infeasibility test is as well conditioned as the rows,
    unlike on the inverse-dynamics QP (Hessian eigenvalues 1e-7 to 1e3), where it was seen wrong.

    Args:
        A (m, n), b (m,), C (p, n), l, u (p,), lb, ub (n,): the constraints (±inf for absent bounds).
        tolerance: largest scaled violation (:meth:`QPBackend.scaled_violation`) of a point that shows feasibility.
        iter_limit: DAQP's iteration limit (an integer ≥ 1). out (n,): the point found is written there on True.

    Returns:
        (verdict, the DAQP call's iterations). Verdict True: a point meeting every row and bound to ``tolerance`` was
        found; False: DAQP proved the set empty (exit flag −1: infeasible); None: neither (iteration limit, or a
        point that fails the check).

    Raises:
        InvalidInputError: an ``iter_limit`` that is not an integer ≥ 1.
    """
    import daqp

    if isinstance(iter_limit, bool) or not isinstance(iter_limit, (int, np.integer)) or iter_limit < 1:
        raise InvalidInputError(f"iter_limit must be an integer ≥ 1 (iterations), got {iter_limit!r}")
    n, m, p = lb.shape[0], A.shape[0], C.shape[0]
    G = np.empty((m + p, n))
    G[:m], G[m:] = A, C
    upper = np.concatenate([ub, b, u])
    lower = np.concatenate([lb, b, l])
    sense = np.zeros(n + m + p, dtype=np.int32)
    sense[n:n + m] = 5
    x, _, exitflag, info = daqp.solve(np.eye(n), np.zeros(n), G, upper, lower, sense, primal_tol=DAQP_PRIMAL_TOL,
                                      iter_limit=int(iter_limit))
    iterations = int(info["iterations"])
    if exitflag == -1:
        return False, iterations
    if exitflag < 1 or QPBackend.accepted(x, A, b, C, l, u, lb, ub, tolerance) is None:
        return None, iterations
    if out is not None:
        out[:] = x
    return True, iterations
