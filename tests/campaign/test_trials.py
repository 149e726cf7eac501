"""The campaign's trial verdict (wbc.campaign.trials.outcome_of) as an operator signs it: each criterion fails a
summary that violates only it."""

from __future__ import annotations

import pytest

from wbc.campaign.trials import outcome_of

CLEAN = {"fell": False, "fall_reason": "", "completed": True, "joint_speed_exceedances": 0,
         "max_joint_speed_ratio": 0.6, "max_joint_speed_joint": "leg_left_4_joint"}


def test_a_clean_walk_survives():
    assert outcome_of(CLEAN) == (True, "")


@pytest.mark.parametrize("change, reason", [
    ({"fell": True, "fall_reason": "tilt > 30° from nominal: torso (torso_2_link) 41.0°"}, "tilt > 30°"),
    ({"fell": True, "fall_reason": "non-foot contact with the ground: leg_left_4_link"}, "non-foot contact"),
    ({"fell": True, "fall_reason": "base height dropped by more than 0.2 m"}, "base height"),
    ({"completed": False}, "not completed"),
    ({"joint_speed_exceedances": 3, "max_joint_speed_ratio": 1.41, "max_joint_speed_joint": "leg_right_5_joint"},
     "joint speed past its limit: leg_right_5_joint at 1.41×"),
])
def test_each_criterion_alone_fails_the_trial(change, reason):
    survived, why = outcome_of({**CLEAN, **change})
    assert not survived and reason in why
