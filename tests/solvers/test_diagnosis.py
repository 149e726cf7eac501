"""Infeasibility diagnosis (wbc.solvers.diagnosis): both sides of a contradiction named with the violation the L2
slack problem gives in closed form, a satisfied constraint left out, a block with NaN named with NaN."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wbc.solvers.diagnosis import diagnose


def test_an_equality_against_a_bound_splits_the_violation_in_half():
    # x₀ = 1 (equality) against x₀ ≤ 0 (box): min s_eq² + s_box² gives x₀ = 0.5, each violated by 0.5;
    # the row 0 ≤ x₁ ≤ 1 holds at x₁ = 0 and is not named
    A, b = np.array([[1.0, 0.0]]), np.array([1.0])
    C, l, u = np.array([[0.0, 1.0]]), np.array([0.0]), np.array([1.0])
    lb, ub = np.array([-np.inf, -np.inf]), np.array([0.0, np.inf])
    conflicts, v = diagnose(A, b, C, l, u, lb, ub, [("hold", 0, 1)], [("band", 0, 1)],
                            [("limit", np.array([0]), np.array([-np.inf]), np.array([0.0]))])
    assert sorted(name for name, _ in conflicts) == ["hold", "limit"]
    assert all(viol == pytest.approx(0.5, abs=1e-6) for _, viol in conflicts)
    assert v[0] == pytest.approx(0.5, abs=1e-6)


def test_a_block_with_nan_is_named_with_nan():
    A, b = np.array([[1.0, np.nan]]), np.array([1.0])
    C, l, u = np.zeros((0, 2)), np.zeros(0), np.zeros(0)
    conflicts, v = diagnose(A, b, C, l, u, np.full(2, -np.inf), np.full(2, np.inf), [("broken", 0, 1)], [], [])
    assert v is None and len(conflicts) == 1 and conflicts[0][0] == "broken" and math.isnan(conflicts[0][1])
