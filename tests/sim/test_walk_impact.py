"""The physics walk's post-impact joint speed bounds (``WalkScenario(impact_window=0.04)``, the default;
:class:`wbc.constraints.impact.ImpactSpeedBounds`, record 63).

Trial 160 of the 1000-trial push campaign 9405 (``wbc campaign run --kind push --trials 1000 --seed 9405 --robot
talos``; realistic plant, estimated state): 373 N for 0.1 s towards 252° (back-right). With the bounds off, a
touch-down drives the right hip yaw to 1.25× its URDF speed limit in the plant (MuJoCo's joint velocities; the trial
fails on it, measured); with them, the walk survives with every plant joint within its limit. The thresholds below
are written here, not read from the code under test.

Trial 206 of campaign 9409 (same spec and seed scheme; 347 N for 0.1 s towards 245°): the right sole lands on its
outer edge while the pelvis turns, and the heel corners' impact models predict the right hip yaw past its limit from
the window's first tick, so the bounds free those rows. Without their soft form
(:class:`wbc.constraints.impact.ImpactSpeedExcess`, ``WalkSteps.impact_excess_weight``) the hip yaw passed its
limit at the impact (1.30×, record 68; 1.025× with the drives' braking of record 75); with the ID kernel's dense
active set (record 86) it peaks at 0.854× without the excess cost and 0.726× with it, and the trial survives both
ways. With it no plant joint passes its limit. The walk's default weight is 10 (record 71; off by default in record
68, when walking push 9813 fell with it).
"""

from __future__ import annotations

import numpy as np
import pytest

from wbc.campaign.spec import load_spec, trial_params
from wbc.campaign.trials import walk_trial
import wbc.sim.scenarios as scenarios
from wbc.constraints.impact import ImpactSpeedExcess
from wbc.exceptions import InvalidInputError
from wbc.sim.walk import WalkScenario
from wbc.sim.walk_steps import WalkSteps

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
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(WalkSteps, "swing_ramp", None)  # the minimum-jerk re-plan this case was found with (records/79)
        return walk_trial(spec, TRIAL_160), walk_trial(spec, {**TRIAL_160, "impact_window": 0.0})


def test_the_bounds_keep_the_landing_leg_within_its_speed_limits(trial_160):
    on, off = trial_160
    assert off["outcome"] != "fell" and off["max_joint_speed_ratio"] > 1.2, off
    assert off["max_joint_speed_joint"] == "leg_right_1_joint"
    assert on["outcome"] == "survived" and not on["fell"], on
    assert on["max_joint_speed_ratio"] <= 1.0 and on["joint_speed_exceedances"] == 0, on
    assert on["solver_failures"] == 0


def _trial_206(monkeypatch, weight):
    """(row, (nv − 6,) largest plant speed ratios, the right hip yaw's index, per tick the excess rows pulled)."""
    monkeypatch.setattr(WalkSteps, "impact_excess_weight", weight)
    monkeypatch.setattr(WalkSteps, "swing_ramp", None)  # the minimum-jerk re-plan this case was found with (records/79)
    runs, pulled = [], []
    original, rows = scenarios.run_scenario, ImpactSpeedExcess.compute_with_drift_into

    def keep(sim, controller, scenario, **kw):
        run, summary = original(sim, controller, scenario, **kw)
        runs.append((run, controller))
        return run, summary

    def count(task, state, *out):
        rows(task, state, *out)
        pulled.append(int(task.past.sum()))

    monkeypatch.setattr(scenarios, "run_scenario", keep)
    monkeypatch.setattr(ImpactSpeedExcess, "compute_with_drift_into", count)
    spec = load_spec({**SPEC, "seed": 9409})
    row = walk_trial(spec, trial_params(spec, 206))
    run, controller = runs[0]
    model = controller.robot.model
    ratio = np.abs(run.v[:, 6:]).max(axis=0) / model.velocityLimit[6:]
    return row, ratio, model.joints[model.getJointId("leg_right_1_joint")].idx_v - 6, pulled


@pytest.fixture(scope="module")
def trial_206():
    """{impact_excess_weight: :func:`_trial_206`'s answer} for the weights 0 (off) and 10 (the default)."""
    out = {}
    for weight in (0.0, 10.0):
        with pytest.MonkeyPatch.context() as mp:
            out[weight] = _trial_206(mp, weight)
    return out


def test_without_the_excess_cost_the_landing_hip_yaw_turns_faster(trial_206):
    """Off, no excess row exists and the right hip yaw's peak is higher than with it (measured 0.854× against 0.726×
    of its limit)."""
    row, ratio, hip_yaw, pulled = trial_206[0.0]
    assert pulled == []  # (no such task in the QP)
    assert ratio[hip_yaw] > trial_206[10.0][1][hip_yaw] + 0.05, (ratio[hip_yaw], trial_206[10.0][1][hip_yaw])


def test_with_it_no_joint_passes_its_limit(trial_206):
    row, ratio, hip_yaw, pulled = trial_206[10.0]
    assert sum(n > 0 for n in pulled) >= 10  # ticks with a post-impact rate past its bound, pulled back
    assert ratio.max() < 1.0
    assert row["survived"] and not row["fell"]


def test_impact_window_must_be_a_duration():
    for bad in (-0.01, float("nan"), True, None, "0.04"):
        with pytest.raises(InvalidInputError, match="impact_window"):
            WalkScenario(4, impact_window=bad)


def test_a_walk_without_the_bounds_frees_those_an_earlier_walk_left_on_the_controller(monkeypatch):
    from wbc.constraints.impact import ImpactSpeedBounds
    from wbc.robot import load_robot
    from wbc.sim.mujoco_model import build_mujoco_model
    from wbc.sim.scenarios import make_controller

    monkeypatch.setattr(WalkSteps, "impact_excess_weight", 10.0)
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
    excess = [t for t in controller.qp.tasks if isinstance(t.task, ImpactSpeedExcess)]
    assert len(excess) == 1 and excess[0].task.bounds is con  # (added once, with the bounds)
