"""A blind walk's landing sole that bounces off the ground during its ramp-in (``_await_rebound`` of
wbc.sim.walk_contacts), against MuJoCo: a box sole dropped at 0.3 m/s onto a lightly damped floor (solref damping
ratio 0.4) leaves it again after the first impact. Fed MuJoCo's normal force as the ankle F/T, the real
:class:`~wbc.dynamics.contact_switching.ContactSwitcher` (on a stand-in controller) plans at most twice its
``contact_force`` on the sole while MuJoCo has it in the air; without the rule its ramp-in plans the robot's
weight there."""

from __future__ import annotations

import math

import mujoco
import numpy as np

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


class _Contact:
    def activate(self, state=None):
        pass


class _QP:
    tasks = ()


class _Controller:
    def __init__(self, robot):
        self.robot, self.state, self.qp = robot, None, _QP()
        self.contacts = {"left": _Contact(), "right": _Contact()}
        self.feet = {"left": None, "right": None}
        self.bound = {"left": math.inf, "right": math.inf}

    def set_max_normal_force(self, side, f):
        self.bound[side] = float(f)

    def release_foot(self, side):
        pass


class _Walk(WalkContactEvents):
    """The walk's state the rule reads: the switcher and the measured normal forces."""

    def __init__(self, switcher):
        self.switcher, self.measured_normal_force, self.contact_thresholds = switcher, None, None
        self._setup_contact_events(None, DT)  # (contact events off: only the walk's own state)


def _drop(rule: bool):
    """(per tick: MuJoCo's contact count and the bound on the left sole after the tick's update; the rebounds)."""
    robot = load_robot("talos")
    model = mujoco.MjModel.from_xml_string(_FOOT)
    data = mujoco.MjData(model)
    data.qvel[0] = -0.3  # m/s, the blind swing's late descent
    weight = robot.mass * robot.gravity
    ctl = _Controller(robot)
    sw = ContactSwitcher(ctl, ramp_time=0.04, touchdown_force=0.1 * weight, touchdown_force_height=0.05,
                         contact_force=0.03 * weight, confirm_when_due=True)
    sw.release("left", 0.0)
    walk = _Walk(sw)
    q, v = np.zeros(robot.model.nq), np.zeros(robot.model.nv)
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
        sw.update(t, q, v, f)
        if rule:
            walk.measured_normal_force = f
            walk._await_rebound(t)
        trace.append((t, data.ncon, ctl.bound["left"] if landed else math.nan, sw.phase("left")))
        mujoco.mj_step(model, data)
    return trace, walk.rebounds, sw


def test_a_sole_bouncing_off_the_ground_in_its_ramp_in_is_held_for_its_load_again():
    trace, rebounds, sw = _drop(rule=True)
    t_hit = next(t for t, n, b, _ in trace if not math.isnan(b))
    air = [(t, b) for t, n, b, ph in trace if t > t_hit and n == 0]
    assert air  # MuJoCo: the sole left the floor after its first impact
    assert len(rebounds) >= 1 and rebounds[0][0] >= t_hit
    # from the rule's tick on, every tick MuJoCo has the sole in the air: at most 2 contact_force planned on it
    t_reb = rebounds[0][0]
    assert all(b <= 2.0 * sw.contact_force + 1e-9 for t, b in air if t > t_reb)
    # without the rule the ramp-in goes on in the air: over half the weight planned on a sole MuJoCo does not load
    trace0, _, sw0 = _drop(rule=False)
    air0 = [b for t, n, b, ph in trace0 if t > t_hit and n == 0]
    assert max(air0) > 0.5 * sw0.full_force



def test_a_stance_sole_that_loses_its_load_is_left_to_the_switcher():
    """Only a sole in its ramp-in is held: a sole fully loaded (stance) that then reads no load (the QP moving the
    CoP to the other sole) keeps its phase and its unbounded contact."""
    robot = load_robot("talos")
    weight = robot.mass * robot.gravity
    q, v = np.zeros(robot.model.nq), np.zeros(robot.model.nv)
    ctl = _Controller(robot)
    sw = ContactSwitcher(ctl, ramp_time=0.04, contact_force=0.03 * weight)
    walk = _Walk(sw)
    sw.release("left", 0.0)
    sw.touch_down("left", 0.1)
    for k in range(50, 151):
        t = k * DT
        f = np.array([0.0 if t >= 0.2 else 0.5 * weight, 0.5 * weight])
        sw.update(t, q, v, f)
        walk.measured_normal_force = f
        walk._await_rebound(t)
    assert sw.phase("left") == "stance" and walk.rebounds == [] and math.isinf(ctl.contacts["left"].f_max)
