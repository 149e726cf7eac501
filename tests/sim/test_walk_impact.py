"""The physics walk's post-impact joint speed bounds (``WalkScenario(impact_window=0.04)``, the default;
:class:`wbc.constraints.impact.ImpactSpeedBounds`, record 63).

Trial 160 of the 1000-trial push campaign 9405 (``wbc campaign run --kind push --trials 1000 --seed 9405 --robot
talos``; realistic plant, estimated state): 373 N for 0.1 s towards 252° (back-right). With the bounds off, a
touch-down drives the right hip yaw to 1.25× its URDF speed limit in the plant (MuJoCo's joint velocities; the trial
fails on it, measured); with them, the walk survives with every plant joint within its limit. The thresholds below
are written here, not read from the code under test.
"""

from __future__ import annotations

import numpy as np
import pytest

from wbc.campaign.spec import load_spec
from wbc.campaign.trials import walk_trial
from wbc.exceptions import InvalidInputError
from wbc.sim.walk import WalkScenario

SPEC = {"kind": "push", "seed": 9405, "trials": 1000,
        "factors": {"direction_deg": [0.0, 360.0], "force": [300.0, 500.0], "phase": [0.0, 1.0],
                    "push_duration": 0.1},
        "scenario": {"robot": "talos", "steps": 8, "step_length": 0.25, "step_duration": 0.6, "plant": "realistic",
                     "state": "estimated", "first_side": "random"}}
TRIAL_160 = {"trial": 160, "direction_deg": 252.24940335776566, "force": 373.22148683006856,
             "phase": 0.45177445305188757, "push_duration": 0.1, "first_side": "right"}


@pytest.fixture(scope="module")
def trial_160():
    """(with the default bounds, with ``impact_window`` 0): the campaign rows of trial 160."""
    spec = load_spec(SPEC)
    return walk_trial(spec, TRIAL_160), walk_trial(spec, {**TRIAL_160, "impact_window": 0.0})


def test_the_bounds_keep_the_landing_leg_within_its_speed_limits(trial_160):
    on, off = trial_160
    assert off["outcome"] != "fell" and off["max_joint_speed_ratio"] > 1.2, off
    assert off["max_joint_speed_joint"] == "leg_right_1_joint"
    assert on["outcome"] == "survived" and not on["fell"], on
    assert on["max_joint_speed_ratio"] <= 1.0 and on["joint_speed_exceedances"] == 0, on
    assert on["solver_failures"] == 0


def test_impact_window_must_be_a_duration():
    for bad in (-0.01, float("nan"), True, None, "0.04"):
        with pytest.raises(InvalidInputError, match="impact_window"):
            WalkScenario(4, impact_window=bad)


def test_a_walk_without_the_bounds_frees_those_an_earlier_walk_left_on_the_controller():
    from wbc.constraints.impact import ImpactSpeedBounds
    from wbc.robot import load_robot
    from wbc.sim.mujoco_model import build_mujoco_model
    from wbc.sim.scenarios import make_controller

    robot = load_robot("talos")
    sim = build_mujoco_model(robot)
    controller = make_controller(robot, "id", dt=sim.timestep)
    q, v = robot.q_ref.copy(), np.zeros(robot.model.nv)
    WalkScenario(4).setup(controller, sim, q, v)
    (con,) = [c for c in controller.qp.extra_constraints if isinstance(c, ImpactSpeedBounds)]
    con.expect("left", ("right",))  # as a walk leaves it mid-swing
    again = WalkScenario(4, impact_window=0.0)
    again.setup(controller, sim, q, v)
    assert con.landing is None
    assert [c for c in controller.qp.extra_constraints if isinstance(c, ImpactSpeedBounds)] == [con]
