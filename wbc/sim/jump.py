"""Jumps in MuJoCo under the inverse-dynamics controller (``wbc sim jump``): vertical jumps, series of jumps and
forward hops.

Method: the reference plan of :class:`~wbc.gait.jump_plan.JumpPlan` — a ballistic CoM plan from the take-off
velocity (Wensing & Orin 2013, "High-speed humanoid running through control with a 3D-SLIP model", IROS: the
flight phase of the SLIP, whose take-off velocity sets the apex and the landing point), with the feet of a
forward hop placed at the capture point of the landing (Pratt et al. 2006). Per jump:

1. **crouch** (minimum jerk) and a pause, both soles in contact;
2. **push-off**: constant CoM acceleration to the planned take-off velocity (both soles in contact; the QP keeps
   the corner forces in the friction pyramids and the torques in the URDF limits); take-off — both contacts
   released through :class:`~wbc.dynamics.contact_switching.ContactSwitcher` — when the plan reaches the
   take-off velocity or, earlier, when the measured CoM vertical velocity reaches it;
3. **flight**: no contact. The CoM reference is the ballistic parabola from the **measured** take-off state, so
   its acceleration is −g: the only one the QP's floating-base rows admit without contact forces (with no
   contact, M_u v̇ + h_u = 0 fixes the rate of the centroidal momentum: linear m g down, angular 0). The
   controller therefore never asks for a base acceleration gravity cannot give; the joints still move the feet
   (tuck, landing placement, flat orientation) and the posture, with the centroidal momentum conserved. The
   feet follow the take-off sole height plus the **measured** CoM rise (every tick), plus the plan's tuck, plus
   ``landing_crouch`` (raised over the first half of the flight and held), over a flight duration re-predicted
   every tick from the measured CoM state as the time to fall to ``landing_crouch`` below the take-off height.
   So the soles touch down with the CoM ``landing_crouch`` lower than at take-off (bent knees, room to absorb
   the impact) and later than a landing at the take-off height; and the estimated take-off velocity, which
   can be off the plant's (the leg odometry counts the soles as still while they unload at the end of the push),
   sets no fixed flight duration;
4. **landing**: touch-down of each sole detected from the state (sole height ≤ ``touchdown_height`` and not
   rising, :class:`~wbc.dynamics.contact_switching.ContactSwitcher`) and, when the closed loop gives the
   measured sole forces (attribute ``measured_normal_force``, (2,) N, from the ankle F/T sensors on an estimated
   state), confirmed by a measured normal force ≥ :data:`~wbc.sim.walk.TOUCHDOWN_CONFIRM_LOAD` m g, or from a
   measured force ≥ :data:`TOUCHDOWN_FORCE` m g alone while the estimated sole is within
   :data:`TOUCHDOWN_FORCE_HEIGHT` of the ground. In flight no sole is in contact, so the estimated height is dead reckoning from the take-off
   velocity; the load, not that height, tells when a sole is on the ground. The sole's normal-force bound is
   then ramped in over ``t_ramp`` up to ``landing_force`` (N, then unbounded), the CoM reference critically
   damped from the measured touch-down CoM state to standing height above the landed soles (rate ``w_land``);
5. stance until the end of the jump's period; :data:`RECOVER_DELAY` after the touch-down the posture task
   (weight :data:`RECOVER_POSTURE_WEIGHT`) and the torso and base orientation tasks (weight
   :data:`RECOVER_ORIENTATION_WEIGHT`) bring the robot back to its standing posture, so that with ``count`` > 1
   every jump starts from the same stance as the first.

Torque limits (landing included): when the torque-limited QP is infeasible (at a touch-down impact the contact
rows ask to stop the sole at once; so can the last ticks of a push-off), the controller's fallback
drops the torque limits (:mod:`wbc.controllers.inverse_dynamics`). This
scenario then re-solves the QP with the torque limits kept and the velocity-damping of the landing contacts
(``contact_kd``) set to 0 — the contact rows only ask for no sole acceleration beyond J̇v — and, if that fails
too, clips the relaxed torques at the URDF limits (what MuJoCo's actuators apply anyway). The counts of both
are in the summary (``landing_soft_contact_ticks``, ``torque_clipped_ticks``; ``torque_limited_ticks`` lists the
first 20 as (time s, phase, how, joint most beyond its limit in the relaxed QP, its |τ|/limit)), and ``max_torque_over_limit``
is that of the commanded, i.e. applied, torques.

Controller options for the jump (:data:`JUMP_OPTIONS`): torso orientation weight 10 (the default) and posture
weight 0.1 (default 1), so the posture task does not hold back the push-off and the leg tuck; during the jump the
centroidal angular-momentum task has weight :data:`JUMP_MOMENTUM_WEIGHT` = 50 (default 0.1; ``momentum_weight``,
``--momentum-weight``: a series of G1 vertical jumps needs 1); braking acceleration of the joint-limit viability
bound (:mod:`wbc.formulations.acceleration`) 150 rad/s² instead of 50 (with 50 a knee extending fast near its limit
must start braking during the push-off, which cuts the push-off force). A joint task holds the upper body at
``robot.q_ref`` (weight :data:`UPPER_BODY_WEIGHT`), and in flight and landing the torso and base orientation tasks
have weight :data:`FLIGHT_ORIENTATION_WEIGHT` = 10, the foot pose tasks :data:`FLIGHT_FOOT_WEIGHT` = 1000 (default
100). Landing force ramp ``t_ramp`` 0.06 s. The runs that chose each value are in ``benchmarks/README.md``
("Measurement history moved out of docstrings").
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from wbc.constants import SIDES
from wbc.dynamics.contact_switching import ContactSwitcher
from wbc.formulations.reference import AccelerationReference
from wbc.exceptions import InvalidInputError, SolverError
from wbc.gait.jump_plan import JumpPlan
from wbc.profiles import min_jerk
from wbc.scenarios.framework import Criterion, evaluate
from wbc.sim.outcome import FALL_TILT_DEG
from wbc.sim.scenarios import NO_FALL
from wbc.sim.walk import TOUCHDOWN_CONFIRM_LOAD
from wbc.tasks import OrientationTask, PostureTask

__all__ = ["JumpScenario", "JUMP_GAINS", "JUMP_OPTIONS", "jump_criteria", "jump_acceptance", "limit_landing_torques"]

#: IDBalanceController gain overrides used for the jump (module docstring).
JUMP_GAINS = {"torso_weight": 10.0, "posture_weight": 0.1, "momentum_weight": 1.0}
#: Default weight of the centroidal angular-momentum task during the jump (module docstring).
JUMP_MOMENTUM_WEIGHT = 50.0
#: Weight of the torso and base (pelvis) orientation tasks in flight and landing (module docstring).
FLIGHT_ORIENTATION_WEIGHT = 10.0
#: Weight of the joint task holding the upper body (every actuated joint not between the base and a sole) at
#: ``robot.q_ref`` during the whole jump (module docstring).
UPPER_BODY_WEIGHT = 10.0
#: Weight of the foot pose tasks in flight (default of the balance controller: 100) (module docstring).
FLIGHT_FOOT_WEIGHT = 1000.0
#: Default CoM height below the take-off height at which the feet touch down (m): the feet are raised by this much
#: relative to the CoM over the first half of the flight (module docstring).
LANDING_CROUCH = 0.04
#: After a touch-down, once this long (s) has passed, the landed robot is brought back to its standing posture for
#: the next jump: posture task weight :data:`RECOVER_POSTURE_WEIGHT`, torso and base orientation weights
#: :data:`RECOVER_ORIENTATION_WEIGHT` (module docstring).
RECOVER_DELAY = 0.3
RECOVER_POSTURE_WEIGHT = 1.0
RECOVER_ORIENTATION_WEIGHT = 10.0
#: IDBalanceController keyword options of the jump: the gains, and a braking acceleration of the joint-limit
#: viability bound of 150 rad/s² instead of 50 (module docstring).
JUMP_OPTIONS = {"gains": JUMP_GAINS, "braking_acceleration": 150.0}

#: Touch-down of a falling sole on an estimated state (measured sole forces given): the height test (sole within
#: ``touchdown_height`` of the ground by the estimate) needs a measured normal force of at least
#: :data:`wbc.sim.walk.TOUCHDOWN_CONFIRM_LOAD` m g (the walk's), and a measured force of TOUCHDOWN_FORCE m g alone is
#: a touch-down while the estimated sole is within TOUCHDOWN_FORCE_HEIGHT (m) of the ground (module docstring).
TOUCHDOWN_FORCE = 0.1
TOUCHDOWN_FORCE_HEIGHT = 0.05

#: A jump's flight counts while the lowest corner of both soles is at least this high above its start (m).
FLIGHT_CLEARANCE = 0.05
#: A jump fails with less flight than this (s) at :data:`FLIGHT_CLEARANCE`.
MIN_FLIGHT_TIME = 0.1


def limit_landing_torques(controller, cmd):
    """Replace a relaxed-QP command (``cmd.relaxed``: torque limits dropped) by one within the URDF torque limits
    (module docstring): the QP again with every active contact's ``kd`` at 0, else the relaxed torques clipped.

    Returns:
        (command, how, (joint index, |τ|/limit)) with how in ``"qp"`` (unchanged), ``"soft_contact"``,
        ``"clipped"``; the pair is the joint farthest beyond its limit in the relaxed command (before clipping).
    """
    if not cmd.relaxed:
        return cmd, "qp", None
    ctrl = controller.controller
    qp = ctrl.qp
    lim = np.where(np.isfinite(qp.tau_max) & (qp.tau_max > 0), qp.tau_max, np.inf)
    relaxed_tau = qp.solution_from(ctrl.state, np.concatenate([cmd.dv, cmd.forces])).tau  # before any clipping
    ratio = np.abs(relaxed_tau) / lim
    worst = (int(np.argmax(ratio)), float(ratio.max()))
    saved = [(c, c.kd) for c in qp.contacts if c.active]
    for c, _ in saved:
        c.kd = 0.0
    try:
        sol = qp.solve(ctrl.state, ctrl.dt)
        ctrl.last_solution = sol
        cmd.tau, cmd.dv, cmd.forces, cmd.wrenches = sol.tau, sol.dv, sol.forces, sol.wrenches
        cmd.dynamics_residual, cmd.relaxed = sol.dynamics_residual, False
        how = "soft_contact"
    except SolverError:
        cmd.tau = np.clip(relaxed_tau, -lim, lim)
        how = "clipped"
    finally:
        for c, kd in saved:
            c.kd = kd
    return cmd, how, worst


class JumpScenario:
    """``count`` jumps (module docstring), each following a :class:`~wbc.gait.jump_plan.JumpPlan`
    (attribute ``jump_plan``).

    Args (``height``, ``forward``, ``count`` positional or keyword, the others keyword-only):
        height: apex CoM rise above take-off (m). forward: foot displacement per jump along world x (m).
        count: number of jumps (int ≥ 1). crouch, extension, t_crouch, tuck, w_land: see
            :class:`~wbc.gait.jump_plan.JumpPlan`. t_ramp: landing force ramp (s). settle: stance after the
            planned landing (s). t_start: stand before the first crouch (s). touchdown_height: sole height (m,
            world) at or below which a falling sole is in contact. landing_force: end of the ramp (N; default
            4 m g). landing_crouch: CoM height below the take-off height at touch-down (m, in [0, crouch];
            module docstring). momentum_weight: weight (scalar or (3,): x, y, z rows, world) of the centroidal angular-momentum
            task during the jump (module docstring).

    Summary keys (:meth:`extra_summary`, all from MuJoCo's state, not the plan; foot heights are those of the
    lowest corner of each sole rectangle, from the logged plant configuration): ``apex_foot_clearance_m`` /
    ``max_foot_clearance_per_jump_m`` (max over time of the lower foot's rise above the ground, overall / per
    jump), ``time_both_feet_5cm_per_jump_s`` / ``time_both_feet_5cm_s`` (longest interval with both feet ≥ 5 cm
    up, per jump / smallest over the jumps), ``max_tilt_per_jump_deg`` (largest pelvis or torso tilt from its
    orientation at t = 0 during each jump's period), ``failed_jumps`` / ``failed_jump_count`` (jumps, 0-based,
    with < 0.1 s both feet ≥ 5 cm up, a tilt > 30°, or not completed), ``flight_time_per_jump_s``
    (plant ground force < 1 N), ``peak_grf_n`` (sum over both feet), ``max_torque_over_limit`` (applied |τ| / URDF
    limit, with the joint), ``landing_com_overshoot_m`` (largest drop of the CoM below standing height after a
    touch-down), ``landed`` (every jump landed), ``slide_per_jump_m`` (largest horizontal sole displacement from
    its touch-down to the end of that jump's stance: sliding), ``hop_distance_per_jump_m`` (mean x displacement
    of the soles from take-off to the end of the jump), ``feet_moved_m`` (horizontal sole displacement end vs
    start).

    Attribute ``measured_normal_force``: (2,) measured normal force (N) of the (left, right) sole, set by the closed
    loop every tick on an estimated state (None: touch-down from the state alone; module docstring, step 4).

    Raises:
        InvalidInputError: bad numbers (see :class:`~wbc.gait.jump_plan.JumpPlan`), count not an int ≥ 1,
            landing_crouch outside [0, crouch].
    """

    name = "jump"
    needs_id = True

    def __init__(self, height: float = 0.08, forward: float = 0.0, count: int = 1, *, crouch: float = 0.1,
                 extension: float = 0.0, t_crouch: float = 0.6, tuck: float = 0.14, t_ramp: float = 0.06,
                 settle: float = 1.5, t_start: float = 0.2, w_land: float = 8.0, touchdown_height: float = 0.005,
                 landing_force: float | None = None, min_hop: float | None = None,
                 momentum_weight: float = JUMP_MOMENTUM_WEIGHT, landing_crouch: float = LANDING_CROUCH):
        if min_hop is not None and not (np.isfinite(min_hop) and min_hop >= 0):
            raise InvalidInputError(f"jump: min_hop must be None or finite and >= 0 m, got {min_hop!r}")
        self.min_hop = min_hop
        if not (isinstance(count, int) and count >= 1):
            raise InvalidInputError(f"jump: count must be an int >= 1, got {count!r}")
        for value, what in ((t_ramp, "t_ramp"), (settle, "settle"), (touchdown_height, "touchdown_height")):
            if not (np.isfinite(value) and value > 0):
                raise InvalidInputError(f"jump: {what} must be finite and > 0, got {value!r}")
        if not (np.isfinite(t_start) and t_start >= 0):
            raise InvalidInputError(f"jump: t_start must be finite and >= 0 s, got {t_start!r}")
        if not (np.isfinite(landing_crouch) and 0 <= landing_crouch <= crouch):
            raise InvalidInputError(f"jump: landing_crouch must be finite, >= 0 and <= crouch = {crouch!r} m, got "
                                    f"{landing_crouch!r}")
        self.landing_crouch = float(landing_crouch)
        self.count = count
        self._plan_args = dict(height=height, forward=forward, crouch=crouch, extension=extension,
                               t_crouch=t_crouch, tuck=tuck, w_land=w_land)
        self.jump_plan = JumpPlan(**self._plan_args)  # validated now; com_height set in setup
        self.t_ramp, self.settle, self.t_start = float(t_ramp), float(settle), float(t_start)
        self.touchdown_height = float(touchdown_height)
        self.landing_force = landing_force
        w = np.asarray(momentum_weight, dtype=float)
        if w.shape not in ((), (3,)) or not (np.isfinite(w).all() and (w > 0).all()):
            raise InvalidInputError(f"jump: momentum_weight must be a finite scalar or (3,) > 0, got {momentum_weight!r}")
        self.momentum_weight = w.copy()
        self._set_period()
        self.phase = "stand"
        self.com0 = np.zeros(3)
        self._ref = (np.zeros(3), np.zeros(3), np.zeros(3))
        self.measured_normal_force = None  # (2,) N from the F/T sensors, set by the closed loop on an estimated state

    def _set_period(self):
        p = self.jump_plan
        self.t_takeoff_plan = self.t_start + p.t_push_start + p.t_push
        self.period = self.t_takeoff_plan + p.t_flight + self.settle  # one jump, s
        self.duration = self.count * self.period

    def setup(self, controller, sim, q, v):
        self.robot = robot = sim.robot
        self.gravity = robot.gravity  # m/s², the model's
        model = robot.model
        data = model.createData()
        self.com0 = pin.centerOfMass(model, data, q).copy()
        pin.framesForwardKinematics(model, data, q)
        self.soles0 = {s: data.oMf[robot.frame_id(f)].copy() for s, f in zip(SIDES, (robot.left_sole, robot.right_sole))}
        mid = 0.5 * (self.soles0["left"].translation + self.soles0["right"].translation)
        self.com_offset = self.com0 - mid  # CoM relative to the mid-sole point when standing
        self.jump_plan = JumpPlan(com_height=float(self.com_offset[2]), **self._plan_args)
        self._set_period()
        force = self.landing_force if self.landing_force is not None else 4 * robot.mass * robot.gravity
        weight = robot.mass * robot.gravity
        self.switcher = ContactSwitcher(controller, ramp_time=self.t_ramp, touchdown_height=self.touchdown_height,
                                        touchdown_speed=0.0, full_force=force,
                                        touchdown_force=TOUCHDOWN_FORCE * weight,
                                        touchdown_force_height=TOUCHDOWN_FORCE_HEIGHT,
                                        contact_force=TOUCHDOWN_CONFIRM_LOAD * weight, confirm_when_due=True)
        self._data = model.createData()
        self.phase = "stand"
        self.jump = 0
        self.t0 = 0.0
        self.c_start = self.com0.copy()
        self.takeoffs, self.touchdowns, self.takeoff_velocity, self.push_starts = [], [], [], []
        self.how = {"qp": 0, "soft_contact": 0, "clipped": 0}
        self.limited_ticks, self._t_now = [], 0.0
        self._ref = (self.com0.copy(), np.zeros(3), np.zeros(3))
        self._wrap(controller)
        base = next(f.name for f in model.frames if f.parentJoint == 1 and f.type == pin.FrameType.BODY)
        self.base_task = AccelerationReference(OrientationTask(robot, base), kp=100.0, kd=20.0,
                                               weight=FLIGHT_ORIENTATION_WEIGHT, name="base_orientation")
        self.base_task.set_target(data.oMf[robot.frame_id(base)].copy())
        self.torso_weight = np.array(controller.torso.weight, dtype=float).copy()
        self.foot_weight = np.array(controller.feet["left"].weight, dtype=float).copy()
        self.posture_weight = np.array(controller.posture.weight, dtype=float).copy()
        self._recovering = False
        controller.momentum.weight[:] = self.momentum_weight
        legs = set()
        for f in (robot.left_sole, robot.right_sole):
            legs.update(model.supports[model.frames[robot.frame_id(f)].parentJoint])
        upper = [model.names[j] for j in range(2, model.njoints) if j not in legs and model.names[j] in robot.joint_names]
        self.upper_task = AccelerationReference(PostureTask(robot, joints=upper), kp=100.0, kd=20.0,
                                                 weight=UPPER_BODY_WEIGHT, name="upper_body")
        self.upper_task.set_target(robot.q_ref)
        if self.upper_task not in controller.qp.tasks:
            controller.qp.add_task(self.upper_task)

    def _wrap(self, controller):
        """Route the controller's commands through :func:`limit_landing_torques` (instance attribute only)."""
        solve = type(controller).solve.__get__(controller)
        how = self.how

        def limited(q, v):
            cmd, h, worst = limit_landing_torques(controller, solve(q, v))
            how[h] += 1
            if h != "qp":
                self.limited_ticks.append((round(self._t_now, 6), self.phase, h, self.robot.joint_names[worst[0]],
                                           round(worst[1], 3)))
            return cmd

        controller.solve = limited

    def com_reference(self, t):
        return self._ref[0]

    def _com_state(self, q, v):
        d = self._data
        pin.centerOfMass(self.robot.model, d, q, v)
        return d.com[0].copy(), d.vcom[0].copy()

    def update(self, t, ctrl, sim, q, v):
        self._t_now = t
        p = self.jump_plan
        sw = self.switcher
        if self.phase == "land" and t >= self.t0 + self.period - 1e-9 and self.jump + 1 < self.count:
            self.jump += 1  # next jump of a series, from the landed stance
            self.t0 += self.period
            self.phase = "stand"
            self.c_start = self._target.copy()
            ctrl.torso.weight[:] = self.torso_weight
            ctrl.posture.weight[:] = self.posture_weight
            self.base_task.weight = FLIGHT_ORIENTATION_WEIGHT
            self._recovering = False
            for side in SIDES:
                ctrl.feet[side].weight[:] = self.foot_weight
            if self.base_task in ctrl.qp.tasks:
                ctrl.qp.remove_task(self.base_task)
        sw.update(t, q, v, self.measured_normal_force)
        tau = t - self.t0 - self.t_start  # time since this jump's crouch start
        if self.phase in ("stand", "push"):
            if tau < p.t_push_start:
                ref = p.crouch_reference(self.c_start, max(tau, 0.0))
            else:
                tp = tau - p.t_push_start
                c, vc = self._com_state(q, v)
                if tp < p.t_push and vc[2] < p.vz:
                    if self.phase != "push":
                        self.push_starts.append(t)
                    self.phase = "push"
                    ref = p.push_reference(self.c_start, tp)
                else:
                    self._takeoff(t, ctrl, q, v, c, vc)
        if self.phase in ("flight", "land"):
            ref = self._flight(t, ctrl, q, v) if self.phase == "flight" else None
        if self.phase == "land":
            if t - self.t_td < 2 * self.t_ramp:  # until both soles are down and loaded: measured sole positions
                self._retarget(ctrl)
            ref = p.landing_reference(self.c_td, self.v_td, self._target, t - self.t_td)
            self._swing_feet(t, ctrl, q, v)
            if t - self.t_td >= RECOVER_DELAY and not self._recovering:  # landed: back to the standing posture
                self._recovering = True
                ctrl.posture.weight[:] = RECOVER_POSTURE_WEIGHT
                ctrl.torso.weight[:] = RECOVER_ORIENTATION_WEIGHT
                self.base_task.weight = RECOVER_ORIENTATION_WEIGHT
        self._ref = ref
        ctrl.set_com_reference(*ref)
        return None

    def _takeoff(self, t, ctrl, q, v, c, vc):
        self.phase = "flight"
        for side in SIDES:
            self.switcher.release(side, t)
        ctrl.torso.weight[:] = FLIGHT_ORIENTATION_WEIGHT
        for side in SIDES:
            ctrl.feet[side].weight[:] = FLIGHT_FOOT_WEIGHT
        if self.base_task not in ctrl.qp.tasks:
            ctrl.qp.add_task(self.base_task)
        st = ctrl.state
        self.c_to, self.v_to, self.t_to = c, vc, t
        self.t_flight = 2 * max(vc[2], 0.05) / self.gravity  # measured flight time to the take-off height
        self.feet_to = {s: st.data.oMf[ctrl.feet[s].task.frame_id].translation.copy() for s in SIDES}
        self.foot_target = {s: self.jump_plan.foot_landing_target(self.feet_to[s]) for s in SIDES}
        self.foot_target.update({s: np.r_[self.foot_target[s][:2], self.soles0[s].translation[2]] for s in SIDES})
        self.takeoffs.append(t)
        self.takeoff_velocity.append(vc.copy())

    def _predict_flight(self, t, c, vc):
        """Flight duration (s) predicted from the measured CoM state (c, vc) at t: the elapsed flight plus the
        ballistic time to fall back to the take-off height, (v_z + √(v_z² + 2 g (c_z − c_z,to))) / g. The
        measured take-off velocity can be off the plant's (module docstring, step 3), so the duration is
        re-predicted every tick of the flight from the current state."""
        if t - self.t_to > 0.5 * self.t_flight and self.phase == "land":
            return self.t_flight  # frozen after the first touch-down
        rise = c[2] - self.c_to[2] + self.landing_crouch  # touch-down with the CoM landing_crouch lower
        rest = (vc[2] + np.sqrt(max(vc[2] ** 2 + 2 * self.gravity * rise, 0.0))) / self.gravity
        return max(t - self.t_to + rest, 0.05)

    def _swing_feet(self, t, ctrl, q, v):
        """Foot references of the soles still in swing (flight, or landing before their own touch-down): the
        take-off foot height plus the measured CoM rise and the tuck profile over the predicted flight."""
        tau = t - self.t_to
        c, vc = self._com_state(q, v)
        self.t_flight = self._predict_flight(t, c, vc)
        dz = c[2] - self.c_to[2]
        for side in SIDES:
            if self.switcher.phase(side) != "swing":
                continue
            pos, vel, acc = self.jump_plan.foot_flight_offset(self.feet_to[side], self.foot_target[side], dz, vc[2],
                                                         -self.gravity, tau, self.t_flight)
            if self.landing_crouch > 0:  # feet raised by landing_crouch relative to the CoM over the first half
                half = 0.5 * self.t_flight
                sl, dsl, ddsl = min_jerk(min(tau / half, 1.0))
                pos[2] += self.landing_crouch * sl
                vel[2] += self.landing_crouch * dsl / half
                acc[2] += self.landing_crouch * ddsl / half**2
            if self.phase == "land":  # the other sole is down: this one goes down to the ground
                pos[2] = min(pos[2], self.foot_target[side][2] - 0.01)
                vel[2], acc[2] = min(vel[2], -0.3), 0.0
            pose = pin.SE3(self.soles0[side].rotation, pos)  # flat, initial yaw
            ctrl.set_foot_reference(side, pose, np.r_[vel, 0, 0, 0], np.r_[acc, 0, 0, 0])
            if tau > 0.5 * self.t_flight:
                self.switcher.arm(side)

    def _flight(self, t, ctrl, q, v):
        ref = self.jump_plan.flight_reference(self.c_to, self.v_to, t - self.t_to)
        self._swing_feet(t, ctrl, q, v)
        down = [s for s in SIDES if self.switcher.phase(s) != "swing"]
        if down:  # first touch-down: landing from the measured CoM state
            self.phase = "land"
            self.t_td = t
            self.c_td, self.v_td = self._com_state(q, v)
            self.touchdowns.append(t)
            self._retarget(ctrl)
        return ref

    def _retarget(self, ctrl):
        """Landing CoM target: standing offset above the mid-point of the soles (their current positions; a sole
        still in swing counts with its landing target)."""
        st = ctrl.state
        pos = [st.data.oMf[ctrl.feet[s].task.frame_id].translation.copy() if self.switcher.phase(s) != "swing"
               else self.foot_target[s] for s in SIDES]
        mid = 0.5 * (pos[0] + pos[1])
        mid[2] = 0.5 * (self.soles0["left"].translation[2] + self.soles0["right"].translation[2])
        self._target = mid + self.com_offset

    # -- summary -------------------------------------------------------------------------------------------
    def criteria(self) -> list[Criterion]:
        """:func:`jump_criteria` with this scenario's ``min_hop``."""
        return jump_criteria(self.min_hop)

    def _plant_feet_and_tilt(self, run):
        """(N, 2) height (m) of the lowest sole corner of each foot above its height at t = 0 and (N,) the
        larger of the pelvis (root body) and torso tilts (deg) from their orientation at t = 0, both from the
        logged plant configurations ``run.q`` (MuJoCo's state, Pinocchio forward kinematics)."""
        robot = self.robot
        model, data = robot.model, self._data
        soles = [robot.frame_id(f) for f in (robot.left_sole, robot.right_sole)]
        torso = robot.frame_id(robot.torso)
        corners = robot.sole_corners_local().T  # (3, 4) sole frame
        n = len(run.t)
        low, tilt = np.empty((n, 2)), np.empty(n)
        up0 = None
        for k in range(n):
            pin.framesForwardKinematics(model, data, run.q[k])
            for i, f in enumerate(soles):
                M = data.oMf[f]
                low[k, i] = (M.rotation[2] @ corners).min() + M.translation[2]
            r_base = pin.Quaternion(run.q[k, 3:7]).toRotationMatrix()
            r_torso = data.oMf[torso].rotation
            if up0 is None:  # body-fixed axes that pointed up at t = 0 (as wbc.sim.outcome)
                up0 = (r_base[2].copy(), r_torso[2].copy())
            c = min(r_base[2] @ up0[0], r_torso[2] @ up0[1])
            tilt[k] = np.degrees(np.arccos(np.clip(c, -1.0, 1.0)))
        return low - low[0], tilt

    def extra_summary(self, run) -> dict:
        low, tilt = self._plant_feet_and_tilt(run)
        both = low.min(axis=1)  # the lower of the two feet's lowest corners
        fz = run.sim_wrench[:, :, 2].sum(axis=1)
        dt = run.dt
        per_jump, flight, slide, hop, overshoot, clear, tilt_jump, failed = [], [], [], [], [], [], [], []
        for k in range(self.count):
            sel = (run.t >= k * self.period) & (run.t < (k + 1) * self.period)
            best = cur = 0
            for c in both[sel] >= FLIGHT_CLEARANCE:  # longest run of consecutive ticks with both feet ≥ 5 cm up
                cur = cur + 1 if c else 0
                best = max(best, cur)
            per_jump.append(best * dt)
            clear.append(float(both[sel].max()) if sel.any() else 0.0)
            tilt_jump.append(float(tilt[sel].max()) if sel.any() else 0.0)
            if best * dt < MIN_FLIGHT_TIME or tilt_jump[-1] > FALL_TILT_DEG or not sel.any() \
                    or run.t[sel][-1] < (k + 1) * self.period - 2 * dt:
                failed.append(k)
            air = fz[sel] < 1.0
            air[: int(0.05 / dt)] = False
            flight.append(float(air.sum() * dt))
            if k < len(self.touchdowns) and sel.any():
                i_td = int(round(self.touchdowns[k] / dt))
                i_to = int(round(self.takeoffs[k] / dt))
                i_end = np.flatnonzero(sel)[-1]
                pos = run.sole_pos[i_td:i_end + 1, :, :2]
                slide.append(float(np.linalg.norm(pos - pos[0], axis=2).max()))
                hop.append(float(np.mean(run.sole_pos[i_end, :, 0] - run.sole_pos[i_to, :, 0])))
                overshoot.append(float(self.com0[2] - run.com[i_td:i_end + 1, 2].min()))
        moved = np.linalg.norm(run.sole_pos[-1, :, :2] - run.sole_pos[0, :, :2], axis=1).max()
        lim = np.asarray(self.robot.model.effortLimit[6:])
        ratio = np.abs(run.tau) / np.where(lim > 0, lim, np.inf)
        j = int(np.argmax(ratio.max(axis=0)))
        landed = len(self.touchdowns) == self.count and not run.fell
        push = np.zeros(len(run.t), dtype=bool)
        for a, b in zip(self.push_starts, self.takeoffs):
            push[int(round(a / dt)):int(round(b / dt))] = True
        push_ratio = ratio[push].max(axis=0) if push.any() else np.zeros(ratio.shape[1])
        jp = int(np.argmax(push_ratio))
        self.push_postures = run.q[push]
        return {"jumps": self.count, "planned_height_m": self.jump_plan.height, "planned_forward_m": self.jump_plan.forward,
                "takeoff_velocity_plan_mps": [float(x) for x in self.jump_plan.takeoff_velocity],
                "takeoff_velocity_measured_mps": [[float(x) for x in vv] for vv in self.takeoff_velocity],
                "apex_foot_clearance_m": float(both.max()), "max_foot_clearance_per_jump_m": clear,
                "time_both_feet_5cm_per_jump_s": per_jump, "time_both_feet_5cm_s": min(per_jump),
                "max_tilt_per_jump_deg": tilt_jump, "failed_jumps": failed, "failed_jump_count": len(failed),
                "flight_time_per_jump_s": flight, "peak_grf_n": float(fz.max()),
                "peak_grf_body_weights": float(fz.max() / (self.robot.mass * self.robot.gravity)),
                "max_torque_over_limit": float(ratio.max()), "max_torque_joint": self.robot.joint_names[j],
                "push_max_torque_over_limit": float(push_ratio[jp]), "push_max_torque_joint": self.robot.joint_names[jp],
                "landing_soft_contact_ticks": self.how["soft_contact"], "torque_clipped_ticks": self.how["clipped"],
                "torque_limited_ticks": self.limited_ticks[:20],
                "landing_com_overshoot_m": max(overshoot) if overshoot else None,
                "landed": landed, "slide_per_jump_m": slide, "max_slide_m": max(slide) if slide else None,
                "hop_distance_per_jump_m": hop, "feet_moved_m": float(moved)}


def jump_criteria(min_hop: float | None = None) -> list[Criterion]:
    """Acceptance of a jump series: no fall, every jump landed, both feet (lowest sole corners) ≥ 5 cm up for
    ≥ 0.1 s in every jump, no failed jump (:class:`JumpScenario`'s ``failed_jumps``: also a pelvis or torso tilt
    > 30° during the jump), no sole slid > 2 cm after a touch-down; with ``min_hop`` (m) every measured hop (mean x
    displacement of the soles, take-off to end of the jump) ≥ min_hop, else (vertical jumps) the feet within 2 cm
    per jump of their start at the end."""
    out = [
        NO_FALL,
        Criterion("every jump landed", "landed", "==", True),
        Criterion("both feet ≥ 5 cm up for ≥ 0.1 s in every jump", "time_both_feet_5cm_s", ">=", MIN_FLIGHT_TIME),
        Criterion("no failed jump (each: both feet ≥ 5 cm up for ≥ 0.1 s, pelvis/torso tilt ≤ 30°, completed)",
                  "failed_jump_count", "==", 0),
        Criterion("no sole slid > 2 cm after a touch-down", "max_slide_m", "<=", 0.02),
    ]
    if min_hop is not None:
        out.append(Criterion(f"every hop ≥ {min_hop} m", "hop_distance_per_jump_m", ">=", min_hop, reduce="min"))
    else:
        out.append(Criterion("feet within 2 cm per jump of their start", "feet_moved_m", "<=", 0.02,
                             scale_by="jumps"))
    return out


def jump_acceptance(summary: dict, *, min_hop: float | None = None) -> list[str]:
    """Failed criteria of a jump summary (:func:`jump_criteria`)."""
    return evaluate(summary, jump_criteria(min_hop))[1]
