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


def test_trailing_release_defaults_and_refuses_values_outside_its_range():
    from wbc.sim.walk_steps import TRAILING_RELEASE

    assert WalkScenario(2).trailing_release == TRAILING_RELEASE == 0.8
    assert WalkScenario(2, trailing_release=None).trailing_release is None  # off
    assert WalkScenario(2, trailing_release=1).trailing_release == 1.0
    sc = WalkScenario(2)
    for bad in (0, 0.0, -0.5, 1.01, float("nan"), float("inf"), True, "0.8"):
        with pytest.raises(InvalidInputError, match="trailing_release"):
            WalkScenario(2, trailing_release=bad)
        with pytest.raises(InvalidInputError, match="trailing_release"):
            sc.trailing_release = bad  # on assignment too, the value left as it was
        with pytest.raises(InvalidInputError, match="reach_ratio"):
            sc.reach_ratio = bad
    assert sc.trailing_release == TRAILING_RELEASE and sc.reach_ratio == WalkScenario(2).reach_ratio
    sc.trailing_release = None
    assert sc.trailing_release is None


def test_trailing_release_on_the_command_line(cli):
    for bad, why in (("0", "out of range"), ("1.5", "out of range"), ("nan", "not a finite number"),
                     ("x", "not a number")):
        code, err, _ = cli(["sim", "walk", "--trailing-release", bad])
        assert code == 2 and "--trailing-release" in err and why in err, err
