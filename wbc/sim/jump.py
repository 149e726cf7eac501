"""Vertical jump in MuJoCo under the inverse-dynamics controller (``wbc sim jump``; tuned and measured on G1 only).

Method: ballistic CoM plan from the take-off velocity (Wensing & Orin 2013, "High-speed humanoid running through
control with a 3D-SLIP model", IROS — the flight phase of the SLIP: the CoM is ballistic, the take-off velocity
sets the apex). For an apex CoM rise h above the take-off point, v₀ = √(2 g h). Phases:

1. crouch: CoM down by ``crouch`` (minimum jerk, ``t_crouch``);
2. push-off: constant upward CoM acceleration a = v₀² / (2 s) over the stroke s = ``crouch`` + ``extension``
   (both soles in contact; the QP keeps the corner forces in the friction pyramids and the torques in the URDF
   limits); take-off (both contacts released) when the plan reaches v₀ or, earlier, when the measured CoM vertical
   velocity reaches v₀ (measured on G1: the tracking lags, take-off at 0.76 m/s for a planned 1.25 m/s);
3. flight: both contacts released (no contact forces), the CoM reference is the ballistic parabola (its
   acceleration is −g, the only one the floating-base rows of the QP admit without contact forces: total linear
   momentum rate = m g, angular momentum rate = 0), the feet are tracked relative to the CoM and tucked by
   ``tuck``;
4. landing: touch-down detected from the plant state — each foot's MuJoCo ground contact force (> 20 N) — that
   sole's contact is re-activated (each foot on its own) with its normal-force bound ramped in over ``t_ramp``; the CoM reference
   decelerates to the stance height with a critically damped reference;
5. stance until the end; with ``count`` > 1 the next jump starts one ``period`` after the previous one
   (experimental: measured on G1, the series falls after 2–3 jumps).

Controller gains for the jump (:data:`JUMP_GAINS`): torso orientation weight 1 and posture weight 0.1 (defaults
10 and 1), so the torso and posture tasks do not hold back the push-off and the leg tuck. At the landing impact
the torque-limited QP can be infeasible for a few ticks; the controller then solves the relaxed QP without
torque limits and MuJoCo's actuators clamp the command at the URDF limits (``relaxed_qp_ticks`` in the summary).
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from wbc.exceptions import InvalidInputError
from wbc.profiles import min_jerk
from wbc.scenarios.framework import Criterion, evaluate
from wbc.sim.scenarios import FEET_STILL, NO_FALL

__all__ = ["JumpScenario", "JUMP_GAINS", "JUMP_CRITERIA", "jump_acceptance"]

#: BalanceController gain overrides used for the jump (module docstring).
JUMP_GAINS = {"torso_weight": 1.0, "posture_weight": 0.1}

G = 9.81


class JumpScenario:
    """Vertical jump (module docstring). Args: height h (m, apex CoM rise above take-off), crouch (m),
    extension (m, CoM rise above the stance height at take-off), t_crouch (s), tuck (m), t_ramp (s), settle (s).

    Summary keys (:meth:`extra_summary`, all from MuJoCo's state, not the plan): ``apex_foot_clearance_m`` (max
    over time of the lower sole's rise above its start), ``time_both_feet_5cm_s`` (longest interval with both
    soles ≥ 5 cm up; with ``count`` > 1 jumps — one every ``period`` s — the smallest over the jumps), ``flight_time_s`` (plant ground force < 1 N), ``peak_grf_n``, ``max_torque_over_limit``
    (commanded |τ| / URDF limit, with the joint), ``landing_com_min_m`` (lowest CoM relative to the start:
    landing overshoot), ``landed``, ``feet_moved_m`` (horizontal sole displacement end vs start).

    Raises:
        InvalidInputError: non-positive height / durations.
    """

    name = "jump"
    needs_id = True

    def __init__(self, height: float = 0.12, crouch: float = 0.08, extension: float = 0.02, t_crouch: float = 0.6,
                 tuck: float = 0.14, t_ramp: float = 0.03, settle: float = 1.5, t_start: float = 0.2,
                 w_land: float = 8.0, count: int = 1):
        if not (isinstance(count, int) and count >= 1):
            raise InvalidInputError(f"jump: count must be an int >= 1, got {count!r}")
        self.count = count
        if not all(np.isfinite(x) and x > 0 for x in (height, crouch, t_crouch, t_ramp, settle)):
            raise InvalidInputError("jump: height, crouch and durations must be finite and > 0")
        self.h, self.crouch, self.ext = float(height), float(crouch), float(extension)
        self.t_crouch, self.tuck, self.t_ramp, self.settle, self.t_start = t_crouch, tuck, t_ramp, settle, t_start
        self.v0 = math.sqrt(2 * G * self.h)
        s = self.crouch + self.ext
        self.a_push = self.v0**2 / (2 * s)
        self.t_push0 = t_start + t_crouch + 0.2
        self.t_takeoff = self.t_push0 + self.v0 / self.a_push
        self.t_flight = 2 * self.v0 / G
        self.period = self.t_takeoff + self.t_flight + 0.3 + settle  # one jump, s
        self.duration = count * self.period
        self.phase = "stand"
        self.w_land = float(w_land)
        self.com0 = np.zeros(3)

    def setup(self, controller, sim, q, v):
        self.robot = sim.robot
        data = self.robot.model.createData()
        self.com0 = pin.centerOfMass(self.robot.model, data, q).copy()
        pin.framesForwardKinematics(self.robot.model, data, q)
        self.soles = {s: data.oMf[self.robot.frame_id(f)].copy()
                      for s, f in (("left", self.robot.left_sole), ("right", self.robot.right_sole))}
        self.phase = "stand"
        self.t0 = 0.0
        self.jumps = []
        self._data = self.robot.model.createData()
        self.t_land = {}
        self.t_touch = None
        self._ref = (self.com0.copy(), np.zeros(3), np.zeros(3))

    def _takeoff(self, q, v, c0) -> bool:
        """Take-off from the state: measured CoM vertical velocity ≥ v₀."""
        d = self._data
        pin.centerOfMass(self.robot.model, d, q, v)
        return bool(d.vcom[0][2] >= self.v0)

    def com_reference(self, t):
        return self._ref[0]

    def update(self, t, ctrl, sim, q, v):
        if self.phase == "land" and t >= self.t0 + self.period - 1e-9:  # next jump of a series
            self.jumps.append(self.t_touch)
            self.t0 += self.period
            self.phase = "stand"
            for side in ("left", "right"):
                ctrl.contacts[side].f_max = math.inf
        c0 = self.com0
        t_abs, t = t, t - self.t0  # time within the current jump
        z_low = c0[2] - self.crouch
        if self.phase in ("stand", "push") and t < self.t_push0:
            s, ds, dds = min_jerk((t - self.t_start) / self.t_crouch)
            ref = (c0 - [0, 0, s * self.crouch], np.array([0, 0, -ds / self.t_crouch * self.crouch]),
                   np.array([0, 0, -dds / self.t_crouch**2 * self.crouch]))
        elif self.phase in ("stand", "push") and t < self.t_takeoff and not self._takeoff(q, v, c0):
            self.phase = "push"
            tau = t - self.t_push0
            ref = (c0 + [0, 0, -self.crouch + 0.5 * self.a_push * tau**2], np.array([0, 0, self.a_push * tau]),
                   np.array([0, 0, self.a_push]))
        elif self.phase in ("stand", "push", "flight"):
            if self.phase != "flight":
                self.phase = "flight"
                for side in ("left", "right"):
                    ctrl.release_foot(side)
                st = ctrl.state
                d = self.robot.model.createData()
                pin.centerOfMass(self.robot.model, d, q, v)
                self.c_to, self.v_to = d.com[0].copy(), d.vcom[0].copy()  # measured take-off state
                self.feet_to = {s: st.data.oMf[ctrl.feet[s].task.frame_id].copy() for s in ("left", "right")}
                self.t_to_actual = t
                self.takeoffs = getattr(self, "takeoffs", []) + [t_abs]
            tau = t - self.t_to_actual
            c_to, v_to = self.c_to, self.v_to  # ballistic from the measured take-off state (no task conflict)
            ref = (c_to + v_to * tau + [0, 0, -0.5 * G * tau**2], v_to + [0, 0, -G * tau], np.array([0, 0, -G]))
            s, ds, dds = min_jerk(tau / (0.5 * self.t_flight))
            if tau > 0.5 * self.t_flight:
                s, ds, dds = min_jerk(1 - (tau - 0.5 * self.t_flight) / (0.5 * self.t_flight))
                ds = -ds
            for side in ("left", "right"):
                pose = self.feet_to[side].copy()
                dz = ref[0][2] - c_to[2]
                pose.translation = pose.translation + [0, 0, dz + self.tuck * s]
                pose.translation[:2] += ref[0][:2] - c_to[:2]
                vel = np.array([ref[1][0], ref[1][1], ref[1][2] + self.tuck * ds / (0.5 * self.t_flight), 0, 0, 0])
                acc = np.array([0, 0, -G + self.tuck * dds / (0.5 * self.t_flight) ** 2, 0, 0, 0])
                ctrl.set_foot_reference(side, pose, vel, acc)
            if tau > 0.3 * self.t_flight:
                forces = sim.foot_contact_forces()
                touching = [s for s in ("left", "right") if np.linalg.norm(forces.get(s, np.zeros(3))) > 20.0]
                if touching:
                    self.phase = "land"
                    self.t_touch = t_abs
                    st = ctrl.state
                    self.c_land, self.v_land = st.com.copy(), np.zeros(3)
                    self.v_land[2] = self.v_to[2] - G * tau
        else:
            ref = None
        if self.phase == "land":
            # each sole's contact is activated when that foot's plant ground force exceeds 20 N
            forces = sim.foot_contact_forces()
            for side in ("left", "right"):
                if not ctrl.contacts[side].active and np.linalg.norm(forces.get(side, np.zeros(3))) > 20.0:
                    ctrl.contacts[side].activate(ctrl.state)
                    ctrl.contacts[side].f_max = 1.0
                    if ctrl.feet[side] in ctrl.qp.tasks:
                        ctrl.qp.remove_task(ctrl.feet[side])
            tau = t_abs - self.t_touch
            r = min(tau / self.t_ramp, 1.0)
            for side in ("left", "right"):
                if ctrl.contacts[side].active:
                    ctrl.contacts[side].f_max = max(1.0, r * 3 * self.robot.mass * G) if r < 1 else math.inf
            # critically damped reference from the touch-down state to the stance height, ω = w_land
            w = self.w_land
            x0 = self.c_land[2] - c0[2]
            v0 = self.v_land[2]
            e = math.exp(-w * tau)
            z = (x0 + (v0 + w * x0) * tau) * e
            dz = (v0 - w * (v0 + w * x0) * tau) * e
            ddz = (-2 * w * v0 - w * w * x0 + w * w * (v0 + w * x0) * tau) * e
            pos = c0.copy()
            pos[:2] = self.c_land[:2]
            pos[2] += z
            ref = (pos, np.array([0, 0, dz]), np.array([0, 0, ddz]))
        if ref is not None:
            self._ref = ref
        ctrl.set_com_reference(*self._ref)
        return None

    def criteria(self) -> list[Criterion]:
        """:data:`JUMP_CRITERIA`."""
        return JUMP_CRITERIA

    def extra_summary(self, run) -> dict:
        z = run.sole_pos[:, :, 2] - run.sole_pos[0, :, 2]
        both = z.min(axis=1)
        per_jump = []
        for k in range(self.count):  # longest run of consecutive ticks with both feet ≥ 5 cm up, per jump
            sel = (run.t >= k * self.period) & (run.t < (k + 1) * self.period)
            best = cur = 0
            for c in both[sel] >= 0.05:
                cur = cur + 1 if c else 0
                best = max(best, cur)
            per_jump.append(best * run.dt)
        best = min(per_jump) / run.dt
        fz = run.sim_wrench[:, :, 2].sum(axis=1)
        air = fz < 1.0
        moved = np.linalg.norm(run.sole_pos[-1, :, :2] - run.sole_pos[0, :, :2], axis=1).max()
        lim = np.asarray(self.robot.model.effortLimit[6:])
        ratio = np.abs(run.tau) / np.where(lim > 0, lim, np.inf)
        j = int(np.argmax(ratio.max(axis=0)))
        return {"jumps": self.count, "time_both_feet_5cm_per_jump_s": per_jump,
                "apex_foot_clearance_m": float(both.max()), "time_both_feet_5cm_s": best * run.dt,
                "flight_time_s": float(air[int(0.05 / run.dt):].sum() * run.dt),
                "peak_grf_n": float(fz.max()), "peak_grf_body_weights": float(fz.max() / (self.robot.mass * G)),
                "max_torque_over_limit": float(ratio.max()), "max_torque_joint": self.robot.joint_names[j],
                "landing_com_min_m": float(run.com[:, 2].min() - self.com0[2]) if self.t_touch else None,
                "landed": self.t_touch is not None and len(self.jumps) + 1 >= self.count, "feet_moved_m": float(moved),
                "takeoff_velocity_plan_mps": self.v0}


#: Acceptance of a jump (issue 14).
JUMP_CRITERIA = [
    NO_FALL,
    Criterion("landing detected", "landed", "==", True),
    Criterion("both feet ≥ 5 cm up for ≥ 0.1 s", "time_both_feet_5cm_s", ">=", 0.1),
    FEET_STILL,
]


def jump_acceptance(summary: dict) -> list[str]:
    """Failed criteria of a jump summary (:data:`JUMP_CRITERIA`): no fall, landed, both soles ≥ 5 cm up for
    ≥ 0.1 s, feet within 2 cm of their start at the end."""
    return evaluate(summary, JUMP_CRITERIA)[1]
