"""A blind walk's landing sole that bounces off the ground during its ramp-in or just after it (``_await_rebound``
of wbc.sim.walk_contacts), against MuJoCo: a box sole dropped at 0.3 m/s onto a lightly damped floor (solref damping
ratio 0.4) leaves it again after the first impact. Fed MuJoCo's normal force as the ankle F/T, the real
:class:`~wbc.dynamics.contact_switching.ContactSwitcher` (on a stand-in controller whose QP plans on a contact sole
all its bound allows, the robot's weight when unbounded):

* bounced in its ramp-in (a ramp of 0.04 s), the sole is planned at most twice the ``contact_force`` while MuJoCo
  has it in the air; without the rule its ramp-in plans the robot's weight there;
* bounced after its ramp-in (a ramp of 0.02 s: fully loaded when it leaves the floor), the sole is released, planned
  no force while MuJoCo has it in the air, its foot reference the placement where its contact landed lowered at the
  walk's descent speed, and set down again by the switcher once MuJoCo loads it; without the rule the whole weight
  is planned on it in the air."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pinocchio as pin

from wbc.dynamics.contact_switching import ContactSwitcher
from wbc.robot import load_robot
from wbc.sim.walk_contacts import WalkContactEvents

DT = 0.002
_FOOT = f"""
<mujoco>
  <option timestep="{DT}"/>
  <default><geom solref="0.02 0.4"/></default>
  <worldbody>
    <geom name="floor" type="plane" size="2 2 0.1"/>
    <body name="foot" pos="0 0 0.035">
      <joint name="z" type="slide" axis="0 0 1"/>
      <geom name="sole" type="box" size="0.105 0.065 0.03" mass="8"/>
    </body>
  </worldbody>
</mujoco>
"""
#: where the stand-in's contact was anchored at its touch-down (world)
_LANDED = pin.SE3(pin.rpy.rpyToMatrix(0.02, -0.03, 0.4), np.array([0.3, 0.1, 0.004]))


class _Contact:
    reference, f_max = None, math.inf

    def activate(self, state=None):
        self.reference = _LANDED


class _QP:
    tasks = ()


class _Controller:
    def __init__(self, robot):
        self.robot, self.state, self.qp = robot, None, _QP()
        self.contacts = {"left": _Contact(), "right": _Contact()}
        self.feet = {"left": None, "right": None}
        self.foot_reference = {}  # side → (pose, velocity) last set

    def set_max_normal_force(self, side, f):
        self.contacts[side].f_max = float(f)

    def release_foot(self, side):
        pass

    def set_foot_reference(self, side, pose, velocity=None, acceleration=None):
        self.foot_reference[side] = (pose, np.array(velocity))

    def planned(self, side):
        """The stand-in QP's normal force on ``side`` (N): all its bound allows (the switcher's ``f_max``; 0 once
        released), the weight when unbounded."""
        return min(self.contacts[side].f_max, self.robot.mass * self.robot.gravity)


class _Walk(WalkContactEvents):
    """The walk's state the rule reads: the switcher, the measured normal forces, the blind walk's late descent, the
    sole's vertical velocity (``rise``, m/s: MuJoCo's, fed per tick)."""

    rise = 0.0

    def __init__(self, switcher):
        self.switcher, self.measured_normal_force, self.contact_thresholds = switcher, None, None
        self.descent_speed, self.max_descent = 0.3, 0.05
        self._setup_contact_events(None, DT)  # (contact events off: only the walk's own state)

    def _sole_rise_rate(self, side):
        return self.rise


def _drop(rule: bool, ramp_time: float = 0.04):
    """Per tick: (t, MuJoCo's contact count, its normal force, the stand-in QP's normal force on the left sole after
    the tick's update (NaN before touch-down), its phase, its foot reference (pose, velocity) or None, MuJoCo's
    vertical velocity of the sole); the rebounds; the switcher."""
    robot = load_robot("talos")
    model = mujoco.MjModel.from_xml_string(_FOOT)
    data = mujoco.MjData(model)
    data.qvel[0] = -0.3  # m/s, the blind swing's late descent
    weight = robot.mass * robot.gravity
    ctl = _Controller(robot)
    sw = ContactSwitcher(ctl, ramp_time=ramp_time, touchdown_force=0.1 * weight, touchdown_force_height=0.05,
                         contact_force=0.03 * weight, confirm_when_due=True)
    sw.current_normal_force = ctl.planned  # (the last QP's force on the sole: the stand-in's)
    sw.release("left", 0.0)
    walk = _Walk(sw)
    q, v = pin.neutral(robot.model), np.zeros(robot.model.nv)  # (the switcher's state test: any valid state)
    trace, landed = [], False
    c6 = np.zeros(6)
    for k in range(int(round(0.3 / DT))):
        t = k * DT
        mujoco.mj_forward(model, data)  # contacts and forces of the state at t
        fz = 0.0
        for i in range(data.ncon):
            mujoco.mj_contactForce(model, data, i, c6)
            fz += c6[0]
        f = np.array([fz, 0.97 * weight])
        if not landed and fz >= sw.touchdown_force:  # the walk's force test of touch-down
            sw.touch_down("left", t)
            landed = True
        sw.update(t, q, v, f)  # (after the release below: its force test of touch-down)
        ctl.foot_reference.pop("left", None)
        if rule:
            walk.measured_normal_force, walk.rise = f, float(data.qvel[0])
            walk._await_rebound(t, ctl)
        trace.append((t, data.ncon, fz, ctl.planned("left") if landed else math.nan, sw.phase("left"),
                      ctl.foot_reference.get("left"), float(data.qvel[0])))
        mujoco.mj_step(model, data)
    return trace, walk.rebounds, sw


def test_a_sole_bouncing_off_the_ground_in_its_ramp_in_is_held_for_its_load_again():
    trace, rebounds, sw = _drop(rule=True)
    t_hit = next(row[0] for row in trace if not math.isnan(row[3]))
    air = [(row[0], row[3]) for row in trace if row[0] > t_hit and row[1] == 0]
    assert air  # MuJoCo: the sole left the floor after its first impact
    assert len(rebounds) >= 1 and rebounds[0][0] >= t_hit
    # from the rule's tick on, every tick MuJoCo has the sole in the air: at most 2 contact_force planned on it
    t_reb = rebounds[0][0]
    assert all(b <= 2.0 * sw.contact_force + 1e-9 for t, b in air if t > t_reb)
    # without the rule the ramp-in goes on in the air: over half the weight planned on a sole MuJoCo does not load
    trace0, _, sw0 = _drop(rule=False)
    air0 = [row[3] for row in trace0 if row[0] > t_hit and row[1] == 0]
    assert max(air0) > 0.5 * sw0.full_force


def test_a_sole_bouncing_off_the_ground_after_its_ramp_in_is_released_and_lowered_where_it_landed():
    trace, rebounds, sw = _drop(rule=True, ramp_time=0.02)
    t_hit = next(row[0] for row in trace if not math.isnan(row[3]))
    t_stance = next(row[0] for row in trace if row[0] > t_hit and row[4] == "stance")
    air = [row for row in trace if row[0] > t_stance and row[1] == 0]
    assert air  # MuJoCo: the sole left the floor after its ramp-in had ended (fully loaded)
    # released on the first tick MuJoCo's force on it is below contact_force while it rises faster than the
    # switcher's touchdown_speed, its load still planned
    t_low = next(row[0] for row in trace if row[0] > t_stance and row[2] < sw.contact_force
                 and row[6] > sw.touchdown_speed)
    assert rebounds and rebounds[0] == (t_low, "left")
    released = [row for row in trace if row[0] >= t_low and row[4] == "swing"]
    assert released and released[0][0] == t_low
    # set down again by the switcher's force test on the tick MuJoCo loads it with touchdown_force
    t_back = next(row[0] for row in trace if row[0] > t_low and row[2] >= sw.touchdown_force)
    assert next(row[0] for row in trace if row[0] > t_low and row[4] != "swing") == t_back
    # in that flight, no force planned on it on any tick MuJoCo has it in the air
    flight = [row for row in air if t_low <= row[0] < t_back]
    assert flight and all(row[3] <= 2.0 * sw.contact_force + 1e-9 for row in flight)
    # its foot reference: the contact's landing placement, lowered at the descent speed since the release
    for t, _, _, _, _, (pose, vel), _ in released:
        t_rel = max(tr for tr, _ in rebounds if tr <= t)
        assert np.allclose(pose.rotation, _LANDED.rotation) and np.allclose(pose.translation[:2],
                                                                              _LANDED.translation[:2])
        assert math.isclose(pose.translation[2], _LANDED.translation[2] - 0.3 * (t - t_rel), abs_tol=1e-12)
        assert vel[2] == -0.3 and not vel[:2].any() and not vel[3:].any()
    # without the rule: still a stance contact, the whole weight planned on it while MuJoCo has it in the air
    trace0, _, sw0 = _drop(rule=False, ramp_time=0.02)
    air0 = [row for row in trace0 if t_stance < row[0] < t_back and row[1] == 0]
    assert air0 and all(row[4] == "stance" and row[3] == sw0.full_force for row in air0)


def test_a_stance_sole_the_qp_unloaded_is_left_to_the_switcher():
    """A sole fully loaded (stance) that then reads no load and rises is released only while the QP still plans its
    load and the other sole is loaded: not when the QP moved the CoP to the other sole (no load planned on it), not
    with the other sole unloaded too, and not when it does not rise (a loaded sole rolling on an edge, whose F/T
    reads low)."""
    robot = load_robot("talos")
    weight = robot.mass * robot.gravity
    q, v = pin.neutral(robot.model), np.zeros(robot.model.nv)  # (the switcher's state test: any valid state)
    for planned, other, rise, released in ((0.0, 0.5, 0.1, False), (0.5 * weight, 0.5, 0.1, True),
                                           (0.5 * weight, 0.0, 0.1, False), (0.5 * weight, 0.5, 0.0, False)):
        ctl = _Controller(robot)
        sw = ContactSwitcher(ctl, ramp_time=0.04, contact_force=0.03 * weight)
        sw.current_normal_force = lambda side, p=planned, o=other: p if side == "left" else o * weight
        walk = _Walk(sw)
        walk.rise = rise
        sw.release("left", 0.0)
        sw.touch_down("left", 0.1)
        for k in range(50, 151):
            t = k * DT
            f = np.array([0.0 if t >= 0.2 else 0.5 * weight, other * weight])
            sw.update(t, q, v, f)
            walk.measured_normal_force = f
            walk._await_rebound(t, ctl)
        if released:
            assert sw.phase("left") == "swing" and walk.rebounds == [(0.2, "left")]
        else:
            assert sw.phase("left") == "stance" and walk.rebounds == [] and math.isinf(ctl.contacts["left"].f_max)
