"""The load of a hard landing (:mod:`wbc.sim.walk_landing`): after a touch-down whose measured normal force exceeds
the robot's weight, the QP's corner forces of the landed sole are bounded below by a share of the measured force
for a while, and the sole's own bound comes back afterwards; a nominal landing changes nothing."""

import math
from types import SimpleNamespace

import numpy as np
import pinocchio as pin
import pytest

from wbc.robot import load_robot
from wbc.sim import walk_landing
from wbc.sim.walk_landing import IMPACT_LOAD, IMPACT_SHARE, IMPACT_WINDOW_S, WalkLanding


class _Switcher:
    def __init__(self):
        self.touchdown_time = {"left": None, "right": None}
        self.phases = {"left": "stance", "right": "swing"}

    def phase(self, side):
        return self.phases[side]


class _Walk(WalkLanding):
    def __init__(self, robot):
        self._model, self.robot = robot.model, robot
        self.switcher = _Switcher()
        self.measured_normal_force = None
        self.blind, self.terrain_walk = False, None
        self._setup_landing()


def _controller(f_min=0.0):
    return SimpleNamespace(contacts={s: SimpleNamespace(f_min=f_min) for s in ("left", "right")})


@pytest.fixture(scope="module")
def talos():
    return load_robot("talos")


def test_an_impact_bounds_the_landed_sole_from_below_for_its_window_then_restores_it(talos):
    walk, ctrl = _Walk(talos), _controller(f_min=2.0)
    weight = pin.computeTotalMass(talos.model) * 9.81
    assert walk._weight == pytest.approx(weight, rel=1e-3)  # (Pinocchio's gravity is 9.81 m/s²)
    sw = walk.switcher
    sw.phases["right"], sw.touchdown_time["right"] = "loading", 1.000
    walk.measured_normal_force = np.array([300.0, 2.0 * weight])
    walk._impact_load(ctrl, 1.002)
    assert ctrl.contacts["right"].f_min == pytest.approx(IMPACT_SHARE * 2.0 * weight / 4.0, rel=1e-12)
    assert ctrl.contacts["left"].f_min == 2.0  # the stance sole is not touched
    assert walk.impact_landings == 1
    walk.measured_normal_force = np.array([300.0, 0.5 * weight])  # the load falls: the bound follows it
    walk._impact_load(ctrl, 1.010)
    assert ctrl.contacts["right"].f_min == pytest.approx(IMPACT_SHARE * 0.5 * weight / 4.0, rel=1e-12)
    walk.measured_normal_force = np.array([300.0, 0.01])  # never below the sole's own bound
    walk._impact_load(ctrl, 1.012)
    assert ctrl.contacts["right"].f_min == 2.0
    walk.measured_normal_force = np.array([300.0, 0.5 * weight])
    walk._impact_load(ctrl, 1.000 + IMPACT_WINDOW_S + 0.002)  # the window is over
    assert ctrl.contacts["right"].f_min == 2.0
    assert walk.impact_landings == 1


def test_a_landing_below_the_weight_changes_nothing(talos):
    walk, ctrl = _Walk(talos), _controller()
    sw = walk.switcher
    sw.phases["right"], sw.touchdown_time["right"] = "loading", 2.000
    for k in range(30):
        walk.measured_normal_force = np.array([500.0, 0.99 * IMPACT_LOAD * walk._weight])
        walk._impact_load(ctrl, 2.000 + 0.002 * k)
        assert ctrl.contacts["right"].f_min == 0.0 and ctrl.contacts["left"].f_min == 0.0
    assert walk.impact_landings == 0
    walk.measured_normal_force = None  # ground-truth state: no force sensors, nothing to do
    walk._impact_load(ctrl, 2.004)
    assert ctrl.contacts["right"].f_min == 0.0
    walk.blind, walk.measured_normal_force = True, np.array([500.0, 3.0 * walk._weight])  # a blind walk: not here
    walk._impact_load(ctrl, 2.006)
    assert ctrl.contacts["right"].f_min == 0.0 and walk.impact_landings == 0


def test_a_new_touch_down_is_judged_anew(talos):
    walk, ctrl = _Walk(talos), _controller()
    sw = walk.switcher
    sw.phases["right"], sw.touchdown_time["right"] = "loading", 1.0
    walk.measured_normal_force = np.array([0.0, 3.0 * walk._weight])
    walk._impact_load(ctrl, 1.002)
    assert ctrl.contacts["right"].f_min > 0.0
    walk._impact_load(ctrl, 1.2)  # out of the window
    assert ctrl.contacts["right"].f_min == 0.0
    sw.touchdown_time["right"] = 1.8  # the next landing of that sole, soft
    walk.measured_normal_force = np.array([0.0, 0.3 * walk._weight])
    walk._impact_load(ctrl, 1.802)
    assert ctrl.contacts["right"].f_min == 0.0 and walk.impact_landings == 1


CAMPAIGN_7401 = {"kind": "push", "seed": 7401, "trials": 100,
                 "factors": {"direction_deg": [0.0, 360.0], "force": [300.0, 500.0], "phase": [0.0, 1.0],
                             "push_duration": 0.1},
                 "scenario": {"first_side": "random", "plant": "realistic", "robot": "talos", "sole_margin": None,
                              "solver": "fast", "state": "estimated", "step_adjust": True, "step_duration": 0.6,
                              "step_length": 0.25, "steps": 8, "zmp_feedback": None},
                 "metrics": {"keep": []}}


def _trial_93(monkeypatch, share):
    """Campaign 7401 (development seed) trial 93: a 433 N push at 31°, the left leg landing nearly straight."""
    from wbc.campaign.spec import load_spec, trial_params
    from wbc.campaign.trials import walk_trial
    from wbc.sim import scenarios

    monkeypatch.setattr(walk_landing, "IMPACT_SHARE", share)
    runs = []
    real = scenarios.run_scenario

    def keep(*a, **k):
        runs.append(real(*a, **k))
        return runs[-1]

    monkeypatch.setattr(scenarios, "run_scenario", keep)
    spec = {**CAMPAIGN_7401, "scenario": {k: v for k, v in CAMPAIGN_7401["scenario"].items() if v is not None}}
    row = walk_trial(load_spec(spec), trial_params(load_spec(spec), 93))
    return row, runs[-1][0]


def test_after_a_far_landing_the_knee_is_braked_against_the_load(monkeypatch, talos):
    """With the rule the QP plans the landed sole's load and the knee's torque resists the flexion in the 20 ms
    after the impact (the plant's knee speed peaks lower); with the share 0 (the rule off) the QP plans tens of
    newtons against the plant's hundreds and commands no resisting knee torque."""
    model = talos.model
    knee = model.joints[model.getJointId("leg_left_4_joint")].idx_v

    def after_impact(run):
        fz = run.sim_wrench[:, 0, 2]
        k0 = next(k for k in range(int(3.0 / run.dt), len(fz)) if fz[k] > 1.0 and fz[k - 1] <= 1.0)
        w = slice(k0 + 1, k0 + 11)
        qp = run.qp_forces[w, :12].reshape(-1, 4, 3)[:, :, 2].sum(axis=1).mean()
        return qp, fz[w].mean(), run.tau[w, knee - 6].mean(), float(np.abs(run.v[k0:k0 + 15, knee]).max() / 7.0)

    _, off = _trial_93(monkeypatch, 0.0)
    qp0, plant0, tau0, peak0 = after_impact(off)
    assert qp0 < 0.25 * plant0 and tau0 > -20.0  # the mechanism: the QP's load a fraction of the plant's
    _, on = _trial_93(monkeypatch, IMPACT_SHARE)
    qp1, plant1, tau1, peak1 = after_impact(on)
    assert qp1 > 0.4 * plant1
    assert tau1 < -20.0  # N·m, knee extension torque against the flexion
    assert peak1 < peak0 - 0.03 and math.isfinite(peak1)
