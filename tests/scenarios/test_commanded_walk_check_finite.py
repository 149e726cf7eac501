"""check_finite, the number check of both commanded walks (kinematic and MuJoCo)."""

import math

import numpy as np
import pytest

from wbc.exceptions import InvalidInputError
from wbc.scenarios.commanded_walk import check_finite


def test_accepts_numbers_in_range():
    assert check_finite(1, "x") == 1.0 and type(check_finite(np.int64(2), "x")) is float
    assert check_finite(0.4, "T", 0.4, 3.0) == 0.4 and check_finite(3.0, "T", 0.4, 3.0) == 3.0


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf, True, "1", None, [1.0]])
def test_refuses_non_numbers(bad):
    with pytest.raises(InvalidInputError, match="x must be a finite number"):
        check_finite(bad, "x")


def test_refuses_out_of_range():
    with pytest.raises(InvalidInputError, match=r"max_velocity \(m/s\) = 2.5 is out of range: valid is \[0.001, 2\]"):
        check_finite(2.5, "max_velocity (m/s)", 1e-3, 2.0)
