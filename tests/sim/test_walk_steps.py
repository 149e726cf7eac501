"""The step adjustment of the physics walk (wbc.sim.walk_steps): its options, validated on assignment."""

from __future__ import annotations

import pytest

from wbc.exceptions import InvalidInputError
from wbc.sim.walk import WalkScenario
from wbc.sim.walk_steps import SWING_RAMP


def test_swing_ramp_defaults_and_is_validated_on_assignment():
    sc = WalkScenario(2)
    assert sc.swing_ramp == SWING_RAMP == 0.3
    sc.swing_ramp = None  # the minimum-jerk blend
    assert sc.swing_ramp is None
    sc.swing_ramp = 0.5
    assert sc.swing_ramp == 0.5 and isinstance(sc.swing_ramp, float)
    for bad in (0, 0.0, -0.2, 0.51, float("nan"), float("inf"), True, "0.3", [0.3]):
        with pytest.raises(InvalidInputError, match=r"swing_ramp must be None .* \(0, 0.5\]"):
            sc.swing_ramp = bad
    assert sc.swing_ramp == 0.5  # a refused value leaves the option as it was
    assert WalkScenario(2).swing_ramp == SWING_RAMP  # (an instance's value is its own)
