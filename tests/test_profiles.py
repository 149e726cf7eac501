"""The minimum-jerk profile (wbc.profiles)."""

from __future__ import annotations

import numpy as np
import pytest

from wbc.gait import min_jerk


def test_min_jerk_profile():
    s = np.linspace(0, 1, 11)
    b, db, _ = min_jerk(s)
    assert b[0] == 0.0 and b[-1] == 1.0 and db[0] == 0.0 and db[-1] == 0.0
    assert b[5] == pytest.approx(0.5)
