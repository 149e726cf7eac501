"""QP backends by name (wbc.solvers.registry): each name gives its backend class, an unknown name is a typed error
listing the valid ones, and every available backend reaches quadprog's optimum on the same QPs."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import dense_quadprog
from test_active_set import _block_qp
from wbc.exceptions import UnknownSolverError
from wbc.solvers.by_name import QpsolversBackend
from wbc.solvers.daqp import DaqpBackend
from wbc.solvers.fast import FastBackend
from wbc.solvers.proxqp import ProxQPBackend
from wbc.solvers.registry import DEFAULT_SOLVER, available_solvers, make_backend


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
