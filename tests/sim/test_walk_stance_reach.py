"""The stance leg's reach bounds the step time (wbc.gait.stance_reach in WalkScenario's step timing), closed loop in
MuJoCo on the push campaign's realistic plant and estimated state: trial 10 of the default push campaign with seed
9408 (429 N for 0.1 s towards 333°). Without the bound the right knee passes its URDF speed limit (1.155× with the
post-impact excess cost off, benchmarks/records/67; 1.009× at its default weight 10, which pulls part of the landing's
post-impact rate back, record 71); with it the step lands before the stance leg is stretched and no joint passes its
limit (the largest ratio 0.953×).
The speed ratios are the plant's joint velocities over the URDF limits, read here from the run's log."""

import numpy as np
import pytest

from wbc.campaign.spec import default_spec, trial_params
from wbc.campaign.trials import walk_trial
import wbc.sim.scenarios as scenarios
from wbc.exceptions import InvalidInputError
from wbc.sim.walk import WalkScenario
from wbc.sim.walk_steps import WalkSteps


@pytest.mark.parametrize("bad", [0.0, -0.5, 1.01, float("nan"), float("inf"), True, "0.9"])
def test_reach_ratio_must_be_in_zero_one(bad):
    with pytest.raises(InvalidInputError, match="reach_ratio"):
        WalkScenario(2, 0.2, 0.6, reach_ratio=bad)
    assert WalkScenario(2, 0.2, 0.6, reach_ratio=None).reach_ratio is None
    assert WalkScenario(2, 0.2, 0.6, reach_ratio=1).reach_ratio == 1.0


def _trial(monkeypatch, reach_ratio):
    monkeypatch.setattr(WalkSteps, "swing_ramp", None)  # the minimum-jerk re-plan this case was found with (records/79)
    monkeypatch.setitem(WalkScenario.__init__.__kwdefaults__, "reach_ratio", reach_ratio)
    runs = []
    original = scenarios.run_scenario

    def keep(sim, controller, scenario, **kw):
        run, summary = original(sim, controller, scenario, **kw)
        runs.append((run, scenario, controller))
        return run, summary

    monkeypatch.setattr(scenarios, "run_scenario", keep)
    spec = default_spec("push", seed=9408, trials=1000)
    out = walk_trial(spec, trial_params(spec, 10))
    run, scenario, controller = runs[0]
    model = controller.robot.model
    ratio = np.abs(run.v[:, 6:]).max(axis=0) / model.velocityLimit[6:]
    knees = [model.joints[model.getJointId(f"leg_{s}_4_joint")].idx_v - 6 for s in ("left", "right")]
    return out, scenario, ratio, knees


def test_without_the_reach_bound_the_landing_knee_passes_its_speed_limit(monkeypatch):
    """On the common braking acceleration of every joint (``BRAKING_SHARE`` off, as before record 75): with the
    drives' braking the knee of this trial stays at 0.947× its limit without the reach bound too (measured)."""
    from wbc.sim import actuators

    monkeypatch.setattr(actuators, "BRAKING_SHARE", None)
    out, scenario, ratio, knees = _trial(monkeypatch, None)
    assert scenario.reach_cuts == 0
    assert ratio[knees].max() > 1.0
    assert not out["survived"]


def test_with_it_the_step_lands_before_the_stance_leg_is_stretched(monkeypatch):
    out, scenario, ratio, knees = _trial(monkeypatch, 0.97)
    assert scenario.reach_cuts >= 1
    assert ratio.max() < 1.0
    assert out["survived"] and not out["fell"]
