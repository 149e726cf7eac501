"""Jump plan (closed-form ballistic / push / landing checks) and the kinematic preview ``wbc balance jump``."""

import math

import numpy as np
import pytest

from wbc.exceptions import InvalidInputError
from wbc.gait.jump_plan import JumpPlan
from wbc.robot import load_robot
from wbc.scenarios.balance_jump import preview_jump, preview_summary

g = 9.81


def test_plan_push_and_ballistic_apex():
    plan = JumpPlan(height=0.08, crouch=0.1, extension=0.0)
    c0 = np.array([0.0, 0.0, 0.7])
    c, v, a = plan.push_reference(c0, plan.t_push)
    assert v[2] == pytest.approx(math.sqrt(2 * g * 0.08), rel=1e-12)  # take-off velocity of an 8 cm rise
    assert c[2] == pytest.approx(c0[2], abs=1e-12)  # the stroke ends back at standing height
    t_apex = v[2] / g
    apex, vel, acc = plan.flight_reference(c, v, t_apex)
    assert apex[2] - c[2] == pytest.approx(0.08, abs=1e-12)
    assert vel[2] == pytest.approx(0.0, abs=1e-12) and acc[2] == -g
    back, _, _ = plan.flight_reference(c, v, plan.t_flight)
    assert back[2] == pytest.approx(c[2], abs=1e-12)


def test_plan_forward_hop_lands_feet_at_the_capture_point():
    plan = JumpPlan(height=0.1, forward=0.2, com_height=0.65, crouch=0.1, extension=0.0)
    c0 = np.zeros(3)
    c_to, v_to, _ = plan.push_reference(c0, plan.t_push)
    c_td, v_td, _ = plan.flight_reference(c_to, v_to, plan.t_flight)
    foot = plan.foot_landing_target(np.zeros(3))  # feet start under c0
    omega = math.sqrt(g / 0.65)
    assert foot[0] - c_td[0] == pytest.approx(v_td[0] / omega, abs=1e-12)  # ξ = c + ċ/ω on the feet


def test_plan_landing_is_critically_damped():
    plan = JumpPlan(height=0.08, w_land=8.0)
    target = np.array([0.0, 0.0, 0.7])
    c, v, _ = plan.landing_reference(target, np.array([0.0, 0.0, -1.2]), target, 0.0)
    assert np.allclose(c, target) and v[2] == -1.2
    # lowest point of x = v0 τ e^{−wτ} at τ = 1/w: v0/(w e)
    low, vel, _ = plan.landing_reference(target, np.array([0.0, 0.0, -1.2]), target, 1 / 8.0)
    assert target[2] - low[2] == pytest.approx(1.2 / (8.0 * math.e), rel=1e-12)
    assert vel[2] == pytest.approx(0.0, abs=1e-12)


def test_plan_rejects_bad_numbers():
    with pytest.raises(InvalidInputError):
        JumpPlan(height=0.0)
    with pytest.raises(InvalidInputError):
        JumpPlan(height=0.1, forward=-0.1)


def test_preview_is_ballistic_in_flight():
    robot = load_robot("g1")
    run = preview_jump(robot, height=0.08, settle=0.5)
    s = preview_summary(robot, run)
    t_f = 2 * math.sqrt(2 * g * 0.08) / g
    assert abs(s["flight_time_s"] - t_f) <= 0.01  # executed kinematics: both soles up for the planned flight
    assert s["apex_foot_clearance_m"] > 0.05
    # executed CoM in flight (central differences of the integrated motion): free fall
    air = ~run.contact_active.any(axis=1)
    acc = (run.com[2:, 2] - 2 * run.com[1:-1, 2] + run.com[:-2, 2]) / run.dt**2
    inner = air[1:-1] & air[:-2] & air[2:]
    first = int(np.argmax(inner))
    inner[first:first + 10] = False  # 20 ms after take-off: the velocity-level tracking turns from push to free fall
    assert np.abs(acc[inner[: len(acc)]] + g).max() < 1.0  # within 10 % of g (measured 0.56 m/s²)
    assert s["fell"] is False


def test_height_sweep_brackets_the_threshold():
    from wbc.sim.jump_sweep import jump_height_sweep

    def trial(h):  # a fake robot whose landing needs clipped torques above 0.0637 m
        return {"fell": False, "landed": True, "apex_foot_clearance_m": 0.05, "torque_clipped_ticks": int(h > 0.0637)}

    r = jump_height_sweep(trial, start=0.02, resolution=0.005)
    assert r["max_height_m"] <= 0.0637 < r["min_failed_m"]
    assert r["min_failed_m"] - r["max_height_m"] <= 0.005
    assert [t["success"] for t in r["trials"]] == [t["height_m"] <= 0.0637 for t in r["trials"]]
