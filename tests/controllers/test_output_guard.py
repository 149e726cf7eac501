"""The output guard's two functions against hand-computed cases: the QP's numbers (``qp_data_fault``) and a command
against its box and rows at a scaled tolerance (``command_fault``)."""

from __future__ import annotations

import numpy as np
import pytest

from wbc.controllers.output_guard import command_fault, qp_data_fault

TOL = 1e-6


def _qp(n=3, m=2, p=1):
    rng = np.random.default_rng(0)
    return [np.eye(n), rng.normal(size=n), rng.normal(size=(m, n)), rng.normal(size=m), rng.normal(size=(p, n)),
            -np.ones(p), np.ones(p), -np.ones(n), np.ones(n)]


def test_finite_qp_and_infinite_bounds_pass():
    qp = _qp()
    assert qp_data_fault(*qp) == ""
    qp[5][:] = -np.inf  # l: an unbounded side is legitimate
    qp[8][0] = np.inf  # ub
    assert qp_data_fault(*qp) == ""


@pytest.mark.parametrize("index, value, name", [(0, np.nan, "cost H"), (1, np.inf, "cost g"),
                                                (2, np.nan, "equality rows A"), (3, -np.inf, "equality rhs b"),
                                                (4, np.inf, "inequality rows C"), (5, np.nan, "inequality bounds"),
                                                (6, np.nan, "inequality bounds"), (7, np.nan, "box lb"),
                                                (8, np.nan, "box ub")])
def test_each_nonfinite_part_is_named(index, value, name):
    qp = _qp()
    qp[index].flat[0] = value
    assert qp_data_fault(*qp) == name


def test_two_faults_named_once_each():
    qp = _qp()
    qp[5][0] = qp[6][0] = np.nan
    qp[0][1, 1] = np.inf
    assert qp_data_fault(*qp) == "cost H, inequality bounds"


def test_box_violation_scaled_by_the_bound():
    lb, ub = np.array([-1.0, -1000.0]), np.array([1.0, 1000.0])
    none = np.zeros((0, 2))
    # 1000 + 5e-4: excess 5e-4, scaled by |ub| = 1000 → 5e-7 ≤ 1e-6 → within tolerance
    assert command_fault(np.array([0.0, 1000.0 + 5e-4]), lb, ub, none, np.zeros(0), np.zeros(0), TOL) == ""
    # 1000 + 5e-3 → 5e-6 > 1e-6
    msg = command_fault(np.array([0.0, 1000.0 + 5e-3]), lb, ub, none, np.zeros(0), np.zeros(0), TOL)
    assert msg.startswith("v[1] = ") and "outside its bounds" in msg
    # bound 1: the excess itself (2e-6 > 1e-6)
    assert command_fault(np.array([-1.0 - 2e-6, 0.0]), lb, ub, none, np.zeros(0), np.zeros(0), TOL).startswith("v[0]")
    assert command_fault(np.array([-1.0 - 5e-7, 0.0]), lb, ub, none, np.zeros(0), np.zeros(0), TOL) == ""


def test_row_violation_scaled_by_row_and_bound():
    lb, ub = -np.full(2, np.inf), np.full(2, np.inf)
    C = np.array([[1.0, 1.0], [100.0, 0.0]])
    l, u = np.array([-np.inf, -1.0]), np.array([1.0, 1.0])
    # row 0: C v = 1 + 3e-6 over u = 1; scale max(1, |C||v|) = 1 + 3e-6 → ≈ 3e-6 > 1e-6 (row 1: C v = 0)
    v = np.array([0.0, 1.0 + 3e-6])
    assert command_fault(v, lb, ub, C, l, u, TOL).startswith("inequality row 0")
    # row 1: C v = 1.0005 with |C||v| = 1.0005 → 5e-4 / 1.0005 > 1e-6; a row of |C||v| = 1e4 with the same excess
    # is within (5e-4 / 1e4 = 5e-8)
    assert command_fault(np.array([1.0005e-2, 0.0]), lb, ub, C, l, u, TOL).startswith("inequality row 1")
    C2 = np.array([[1.0, -1.0]])
    v2 = np.array([5000.0 + 2.5e-4, 5000.0 - 2.5e-4])  # C v = 5e-4 over u = 0; |C||v| = 1e4
    assert command_fault(v2, lb, ub, C2, np.array([-np.inf]), np.array([0.0]), TOL) == ""


def test_nonfinite_command():
    assert command_fault(np.array([np.nan, 0.0]), -np.ones(2), np.ones(2), np.zeros((0, 2)), np.zeros(0),
                         np.zeros(0), TOL) == "the command v is not finite"
