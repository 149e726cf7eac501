"""The time profiles of wbc.profiles: the minimum-jerk blend and the ramped trapezoid. References: finite differences
and closed forms written here."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wbc.gait import min_jerk


def test_min_jerk_profile():
    s = np.linspace(0, 1, 11)
    b, db, _ = min_jerk(s)
    assert b[0] == 0.0 and b[-1] == 1.0 and db[0] == 0.0 and db[-1] == 0.0
    assert b[5] == pytest.approx(0.5)


@pytest.mark.parametrize("ramp", [0.05, 0.3, 0.5])
def test_ramped_trapezoid_against_finite_differences_and_closed_forms(ramp):
    from wbc.profiles import ramped_trapezoid

    s = np.linspace(0.0, 1.0, 40001)
    h = s[1] - s[0]
    b, db, d2 = ramped_trapezoid(s, ramp)
    assert b[0] == 0.0 and b[-1] == pytest.approx(1.0, abs=1e-15) and db[0] == 0.0 and db[-1] == pytest.approx(0.0)
    assert d2[0] == 0.0 and d2[-1] == pytest.approx(0.0, abs=1e-12)
    # b' and b'' are the derivatives of b and b' (central differences; b'' jumps in slope only at s = r, 1 − r)
    assert np.abs((b[2:] - b[:-2]) / (2 * h) - db[1:-1]).max() < 1e-6
    assert np.abs((db[2:] - db[:-2]) / (2 * h) - d2[1:-1]).max() < 1e-3 * d2.max()
    # b(s) + b(1 − s) = 1 (a move forward is a move back, reversed); flat top 1/(1 − r), peak b'' π/(2 r (1 − r))
    assert b + b[::-1] == pytest.approx(np.ones_like(s), abs=1e-12)
    assert db.max() == pytest.approx(1.0 / (1.0 - ramp), rel=1e-12)
    assert d2.max() == pytest.approx(math.pi / (2 * ramp * (1 - ramp)), rel=1e-6)
    # the average speed is 1: b(1) − b(0) integrates b' (trapezoid rule)
    assert np.sum(0.5 * (db[1:] + db[:-1])) * h == pytest.approx(1.0, abs=1e-8)


def test_ramped_trapezoid_at_half_is_the_cosine_bell_and_rejects_other_ramps():
    from wbc.profiles import ramped_trapezoid

    s = np.linspace(0.0, 1.0, 101)
    b, db, _ = ramped_trapezoid(s, 0.5)
    # r = ½: b' = 1 − cos 2πs, b = s − sin(2πs)/(2π) (integrated by hand)
    assert b == pytest.approx(s - np.sin(2 * np.pi * s) / (2 * np.pi), abs=1e-12)
    assert db == pytest.approx(1.0 - np.cos(2 * np.pi * s), abs=1e-12)
    from wbc.exceptions import InvalidInputError

    for bad in (0.0, -0.1, 0.51, float("nan"), "0.3", True, None):
        with pytest.raises(InvalidInputError, match="ramp"):
            ramped_trapezoid(s, bad)
