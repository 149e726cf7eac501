"""Exit codes of the in-house kernels (wbc.solvers.status): distinct negative codes, and the compiled dense solver
returning the one that names what is wrong with a QP (a bound and a row that exclude each other; a Hessian that is not positive definite)."""

from __future__ import annotations

import numpy as np

from conftest import dense_active_set
from wbc.solvers.status import INFEASIBLE, NOT_POSITIVE_DEFINITE, SolverStatus


def _solve(H, lb, ub, row_max=np.inf):
    """The kernel on min ½xᵀHx + 1ᵀx, lb ≤ x ≤ ub, x₀ ≤ ``row_max`` (one row of C)."""
    n = H.shape[0]
    x, z = np.zeros(n), np.zeros(n)
    A, C = np.zeros((0, n)), np.eye(1, n)
    return dense_active_set((H, np.ones(n), A, np.zeros(0), C, np.array([-np.inf]), np.array([row_max]), lb, ub),
                            (np.zeros(n, np.int8), np.zeros(1, np.int8), x, np.zeros(0), np.zeros(1), z, np.zeros(1)),
                            50)


def test_codes_are_distinct_and_negative():
    values = [int(s) for s in SolverStatus]
    assert len(set(values)) == len(values) and max(values) < 0


def test_the_kernel_names_an_empty_feasible_set_and_an_indefinite_hessian():
    box_lo, box_hi = np.array([1.0, -1.0]), np.array([2.0, 1.0])
    assert _solve(np.eye(2), box_lo, box_hi, row_max=0.0) == INFEASIBLE  # x₀ ≥ 1 (bound) and x₀ ≤ 0 (row)
    assert _solve(np.eye(2), box_lo, box_hi, row_max=1.5) > 0  # the row loosened: solved
    assert _solve(np.diag([1.0, -1.0]), box_lo, box_hi) == NOT_POSITIVE_DEFINITE
