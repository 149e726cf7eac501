"""The second-order barrier (wbc.constraints.barrier): its row is ḧ ≥ −Ġv − 2γ ḣ − γ² h on x = [v̇; f], and
driving h at that lowest acceleration keeps it ≥ 0 from h₀ ≥ 0, ḣ₀ ≥ −γ h₀, following the critically damped
solution (h₀ + (ḣ₀ + γ h₀) t) e^{−γt} (closed form); an unused row (h = inf) is free; constraints without a barrier
form and bad gains are typed errors."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from wbc.constraints.barrier import AccelerationBarrier
from wbc.constraints.base import IDContext, InequalityConstraint
from wbc.exceptions import InvalidInputError


class _Gap(InequalityConstraint):
    """h = (x₀, +inf) on a 1-dof "robot" (G = [[1], [0]]), drift 0."""

    name = "gap"
    dim = 2

    def compute(self, config, dt):
        raise AssertionError("not used at the acceleration level")

    def barrier(self, state, dt):
        return np.array([state.q[0], np.inf]), np.array([[1.0], [0.0]]), np.zeros(2)


class _NoBarrier(_Gap):
    barrier = InequalityConstraint.barrier


def test_the_lowest_acceleration_follows_the_critically_damped_solution():
    gamma, dt = 4.0, 1e-4
    con = AccelerationBarrier(_Gap(), gain=gamma)
    h0, hd0 = 0.3, -1.1  # ḣ₀ = −1.1 ≥ −γ h₀ = −1.2: allowed
    h, hd = h0, hd0
    C, l, u = np.zeros((2, 3)), np.zeros(2), np.zeros(2)  # x = [v̇ (1,); f (2,)]
    low = math.inf
    for k in range(int(2.0 / dt)):
        state = SimpleNamespace(q=np.array([h]), v=np.array([hd]))
        con.write(IDContext(state, dt, 1, np.zeros((1, 2)), {}), C, l, u)
        assert C[0].tolist() == [1.0, 0.0, 0.0] and l[1] == -np.inf and (u == np.inf).all()
        hdd = l[0]  # the lowest acceleration the row allows
        hd += hdd * dt
        h += hd * dt
        low = min(low, h)
        t = (k + 1) * dt
        assert h == pytest.approx((h0 + (hd0 + gamma * h0) * t) * math.exp(-gamma * t), abs=2e-4)
    assert low >= 0.0


def test_typed_errors():
    with pytest.raises(InvalidInputError, match="barrier"):
        AccelerationBarrier(_NoBarrier())
    for bad in (0.0, -1.0, math.nan, math.inf):
        with pytest.raises(InvalidInputError, match="gain"):
            AccelerationBarrier(_Gap(), gain=bad)
