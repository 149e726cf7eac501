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


def test_a_trial_stops_at_its_first_tick_once_a_stop_was_requested():
    """A signal the campaign's watch saw (STOP_REQUESTED) ends the running trial at its next tick with
    KeyboardInterrupt — not at the trial's end (a SIGTERM deferred while numba loaded a kernel waited a whole trial).
    The controller's tick is counted: none runs."""
    from wbc.campaign.spec import default_spec, trial_params
    from wbc.campaign.trials import STOP_REQUESTED, walk_trial
    from wbc.dynamics.balance import IDBalanceController

    spec = default_spec("push")
    spec.scenario["robot"] = "humanoid15"
    ticks = []
    original = IDBalanceController.solve

    def counted(self, *args, **kwargs):
        ticks.append(1)
        return original(self, *args, **kwargs)

    STOP_REQUESTED.set()
    try:
        with pytest.MonkeyPatch.context() as mp:
            mp.setattr(IDBalanceController, "solve", counted)
            with pytest.raises(KeyboardInterrupt):
                walk_trial(spec, trial_params(spec, 0))
    finally:
        STOP_REQUESTED.clear()
    assert len(ticks) <= 1, len(ticks)
