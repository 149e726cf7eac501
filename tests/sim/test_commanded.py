"""`wbc.sim.commanded.SimCommandedWalk` (the physics walk of `wbc ros2 node --sim`): a changed velocity command and a
stop take effect at the next touch-down. Measured on MuJoCo: the feet's contact forces (both soles loaded when the
walk is re-planned), the ground-truth base heading (the turn is walked) and the fall monitor. No wall-clock
assertion."""

import math

import numpy as np

from wbc.robot import load_robot
from wbc.sim.commanded import SimCommandedWalk

STEP = 0.8  # s, the walk's default step duration


def _yaw(q):
    return math.atan2(2 * (q[6] * q[5] + q[3] * q[4]), 1 - 2 * (q[4] ** 2 + q[5] ** 2))


def test_command_change_and_stop_take_effect_at_the_next_touch_down():
    walk = SimCommandedWalk(load_robot("g1"))
    walk.set_velocity(0.3)
    t_change, t_stop = 1.7, 3.0  # mid-swing of the 2nd step; then during the new plan's 1st step
    replans, yaw_at_change, stood = [], None, None
    while walk.t < 6.0 and stood is None and not walk.fell:
        if yaw_at_change is None and walk.t >= t_change:
            walk.set_velocity(0.15, 0.0, 0.3)
            yaw_at_change = _yaw(walk.q_true)
        if walk.t >= t_stop and np.any(walk.command):
            walk.stop()
        n, walking = walk.touchdown_replans, walk.walking
        walk.tick()
        if walk.touchdown_replans != n:
            forces = walk.sim.foot_contact_forces()
            replans.append((walk.t, walk.last_replan, min(f[2] for f in forces.values())))
        if walking and not walk.walking:
            stood = walk.t
    forces = walk.sim.foot_contact_forces()
    turned = math.degrees(_yaw(walk.q_true) - yaw_at_change)
    print(f"change at {t_change} s, stop at {t_stop} s: re-plans {replans}; standing at {stood} s, turned "
          f"{turned:.1f} deg after the change, feet {[round(f[2]) for f in forces.values()]} N")
    assert not walk.fell and walk.replan_failures == 0
    assert len(replans) == 2
    (t1, what1, f1), (t2, what2, f2) = replans
    assert 0.0 < t1 - t_change <= STEP + 0.1 and what1.startswith("4 steps of 0.120 m")  # the new command
    assert 0.0 < t2 - t_stop <= STEP + 0.1 and what2 == "closing step"  # the stop
    # MuJoCo: both soles on the floor at each re-plan (double support; the DCM plan may already have shifted most
    # of the weight onto the stance foot: 13.5 N, and with the F/T touch-down 3.7 N, left on the other were seen; a
    # swinging sole carries exactly 0 N)
    assert f1 > 1.0 and f2 > 1.0
    assert stood is not None and stood - t2 <= STEP + 1.0 + 0.1  # the closing step and the final double support
    assert all(f[2] > 50.0 for f in forces.values())
    assert turned > 5.0  # one walking step of 0.24 rad (13.8 deg) at most was taken before the stop


def test_turning_past_half_a_turn_does_not_fall():
    """Walking and turning at the soak's command (0.1 m/s, 0.3 rad/s) until the base has turned 200 deg from the
    stance of the reset. The torso reference must turn with the feet: held at the reset heading, its orientation
    error flipped sign once the torso had turned half a turn, and the robot fell (pelvis tilt > 30 deg) at a
    turn of 160-165 deg. Measured: MuJoCo's ground-truth base yaw (unwrapped) and the fall monitor."""
    walk = SimCommandedWalk(load_robot("g1"))
    walk.set_velocity(0.1, 0.0, 0.3)
    prev, turned = _yaw(walk.q_true), 0.0
    while turned < math.radians(200.0) and walk.t < 20.0 and not walk.fell:
        walk.tick()
        y = _yaw(walk.q_true)
        turned += math.remainder(y - prev, 2 * math.pi)
        prev = y
    print(f"t = {walk.t:.3f} s: turned {math.degrees(turned):.1f} deg, fell {walk.fell} "
          f"({walk.monitor.fall_reason if walk.fell else ''}), replans {walk.replans}")
    assert not walk.fell
    assert walk.replan_failures == 0
    assert turned >= math.radians(200.0)  # (0.24 rad per 0.8 s step: about 12 s of walking)


def test_the_clock_guard_is_the_id_controllers_and_survives_a_reset():
    walk = SimCommandedWalk(load_robot("g1"))
    assert walk.clock_guard is False  # off by default: a run is a function of its inputs
    walk.clock_guard = True
    assert walk.controller.controller.clock_guard is True
    walk.reset()
    assert walk.clock_guard is True and walk.controller.controller.clock_guard is True
