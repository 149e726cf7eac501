"""The compiled ID solver behind the solver protocol (:class:`wbc.solvers.compiled_id.CompiledIDSolver`):
``solve(QPData) → QPSolution`` on a block QP (dense accelerations, a diagonal force block) against quadprog
(dense Goldfarb–Idnani), its failure a SolverError naming the status, and the warm start from another answer."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import dense_quadprog
from wbc.exceptions import SolverError
from wbc.solvers.compiled_id import CompiledIDSolver
from wbc.solvers.qp_data import QPData
from wbc.solvers.status import SolverStatus


def _block_qp(seed: int, nv: int = 8, nf: int = 12, m: int = 6, p: int = 10) -> QPData:
    """H = blockdiag(dense SPD, ε_f I), equality rows, one-sided rows and bounds around a feasible x0."""
    rng = np.random.default_rng(seed)
    n = nv + nf
    B = rng.normal(size=(nv, nv))
    H = np.zeros((n, n))
    H[:nv, :nv] = B @ B.T + 0.1 * np.eye(nv)
    H[nv:, nv:] = 1e-3 * np.eye(nf)
    g = rng.normal(size=n) * 10.0
    x0 = rng.normal(size=n)
    A = rng.normal(size=(m, n))
    C = rng.normal(size=(p, n))
    Cx = C @ x0
    return QPData(H, g, A, A @ x0, C, np.full(p, -np.inf), Cx + rng.uniform(0.0, 0.5, p), x0 - 1.0, x0 + 1.0)


@pytest.mark.parametrize("seed", range(5))
def test_the_answer_is_quadprogs_optimum(seed):
    qp = _block_qp(seed)
    solver = CompiledIDSolver(qp.H.shape[0], qp.C.shape[0], qp.A.shape[0])
    x, name, step = solver.solve(qp)
    xq = dense_quadprog(*qp)
    assert name == "kernel" and step == "attempt"
    np.testing.assert_allclose(x, xq, rtol=0, atol=1e-7 * max(1.0, np.abs(xq).max()))


def test_a_capped_call_raises_and_the_next_is_short_and_warm():
    qp = _block_qp(1)
    solver = CompiledIDSolver(qp.H.shape[0], qp.C.shape[0], qp.A.shape[0])
    solver.max_iterations = 0
    with pytest.raises(SolverError, match="kernel"):
        solver.solve(qp)
    assert solver.give_up() == 0.0 and solver.fallbacks == 1 and not solver.state.any()
    xq = dense_quadprog(*qp)
    solver.warm(xq, None, qp)  # the bounds the optimum meets
    active = (xq <= qp.lb + 1e-9) | (xq >= qp.ub - 1e-9)
    assert np.array_equal(solver.state != 0, active)
    solver.max_iterations = 100
    try:
        solver.solve(qp)
    except SolverError:
        pass
    assert solver.cap == 2  # the call after a give-up is capped short


def test_status_text_names_the_kernel_status_or_the_residual():
    assert CompiledIDSolver.status_text(int(SolverStatus.ITERATION_CAP), 0.0) == "kernel status ITERATION_CAP"
    assert CompiledIDSolver.status_text(-999, 0.0) == "kernel status -999"
    assert CompiledIDSolver.status_text(5, 3.2e-4) == "kernel residual 3.2e-04 above the tolerance"
