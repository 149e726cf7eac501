"""``CaptureStepScenario``: the robot stands, is pushed at the torso, and takes a step when its measured DCM leaves
the support area (push recovery by stepping, MuJoCo, inverse-dynamics controller).

While standing the controller holds its standing posture (as in :class:`wbc.sim.scenarios.PushScenario`). Every
tick the DCM ``ξ = c + ċ/ω`` (Englsberger et al. 2015, eq. 3; c, ċ from the measured state) is compared with the
convex hull of both soles shrunk by ``trigger_margin``: when ξ is outside, the robot can no longer be captured by
its CoP alone (the capture point lies outside the support polygon: Pratt, Carff, Drakunov, Goswami, "Capture
point: a step toward humanoid push recovery", Humanoids 2006) and a two-step walk starts at once
(:class:`wbc.sim.walk.WalkScenario` with ``from_state=True``): the first step lands where the measured DCM says
(eq. 1 of :mod:`wbc.gait.step_adjustment`, time left = time to the touch-down), re-adjusted during the swing; the
second step closes the feet. The stepping foot is the one on the side the DCM moved to (left when it moved left
or straight forward/back).

With ``contact_events`` the soles follow the measured contact events while the robot stands too (the walk's
:class:`wbc.sim.walk_contacts.WalkContactEvents` on a :class:`~wbc.dynamics.contact_switching.ContactSwitcher` of
the standing phase): a sole the push unloads and lifts above the events' ``air_height`` (``loss``, cause
``unloaded``) while the other sole is in contact is released (no force on it in the QP), held flat at its
horizontal position and heading and lowered into the floor at 0.1 m/s, at most 2 cm (the flat walk's late
touch-down), until the events see it down (flat and loaded), then ramped in. A QP that keeps such a sole a contact
plans force the plant cannot give and spins the leg (Romeo: RHipYaw 1.29× its limit, record 46). The capture step
is not started while a sole is released or ramping in.

When the recovery walk cannot be planned at the trigger (:class:`~wbc.exceptions.GaitError`, e.g. a sole already
rolled onto its edge), the robot keeps balancing on its soles, no step is tried again, and the summary's
``step_refused`` gives the planner's message.

Summary: trigger time (s), stepping side, landing shift of the first step (m, vs a step in place), feet moved (m),
step adjustments during the swing, why a step was refused (or None), completed (no fall, run to the end); the
push's angular momentum about the CoM measured just after it (N·m·s, about e_z × push direction), the pushed
point's height above the CoM (m) and the capture-point bounds on the push (N, linear and with the push's moment:
:func:`wbc.sim.scenarios.capture_point_bound`) — a push above the second cannot be absorbed by the CoP alone;
per sole, the longest time it was a contact of the controller while the plant did not load it
(:func:`wbc.sim.scenarios.unloaded_contacts`: the robot pivoting on the other sole's edge); with
``contact_events``, the events and releases (``contact_events``, ``contact_releases``; those of the standing phase
as ``standing_contact_releases`` when the recovery walk's replace them).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pinocchio as pin

from wbc.exceptions import GaitError, InvalidInputError
from wbc.gait import convex_hull, lipm_omega, sole_polygon
from wbc.scenarios.framework import Criterion
from wbc.sim.scenarios import NO_FALL, capture_point_bound, timed_push, unloaded_contacts
from wbc.geometry import polygon_margin
from wbc.sim.walk import WalkScenario
from wbc.dynamics.contact_switching import ContactSwitcher
from wbc.sim.walk_contacts import WalkContactEvents, contact_events_option

#: m, the air height of the standing phase's contact events with ``contact_events=True`` (the walk keeps
#: :class:`~wbc.estimation.contact_events.ContactEventThresholds`'s): standing, a push lifts a sole by a few
#: millimetres and the estimate of that lift errs by about as much, so the walk's threshold is crossed on some
#: sensor-noise draws and not on others (record 46); an unloaded sole read that high while it is down is only set
#: down again.
STANDING_AIR_HEIGHT = 0.002

__all__ = ["CaptureStepScenario"]


def _hull_of_soles(data, fids, length, width):
    pts = []
    for fid in fids:
        M = data.oMf[fid]
        yaw = math.atan2(M.rotation[1, 0], M.rotation[0, 0])
        pts.append(sole_polygon(M.translation[0], M.translation[1], yaw, length, width))
    return convex_hull(np.vstack(pts))


class CaptureStepScenario(WalkContactEvents):
    """Standing push, recovered by a capture step (module docstring). Needs the ID controller.

    Args:
        force: push (N, ≥ 0) at the torso origin for ``push_duration`` (s) from ``t_push`` (s), horizontal
            direction ``push_dir`` (deg, world: 0 = +x, 90 = +y).
        step_duration: s per step of the recovery walk (single + double support).
        trigger_margin: the soles are shrunk by this (m) for the trigger test.
        settle: s after the push when no step is triggered; the run lasts ``t_push + push_duration + settle`` at
            least, and until the recovery walk has finished.
        contact_events: the contacts follow the measured contact events, standing (module docstring) and in the
            recovery walk (its ``contact_events``, :class:`~wbc.sim.walk.WalkScenario`): False (default), True
            (default thresholds, standing with :data:`STANDING_AIR_HEIGHT`; ``wbc sim push-step``'s default on
            estimated state) or a :class:`~wbc.estimation.contact_events.ContactEventThresholds`; fed with the
            ankle F/T wrenches the closed loop sets as ``measured_wrench``.

    Raises:
        InvalidInputError: negative or non-finite numbers.
    """

    name = "push-step"
    needs_id = True

    def __init__(self, force: float = 450.0, push_duration: float = 0.1, t_push: float = 0.5, push_dir: float = 0.0,
                 *, step_duration: float = 0.5, trigger_margin: float = 0.02, settle: float = 3.5,
                 contact_events=False):
        for val, what in ((force, "force"), (push_duration, "push_duration"), (t_push, "t_push"),
                          (trigger_margin, "trigger_margin"), (settle, "settle")):
            if not (np.isfinite(val) and val >= 0):
                raise InvalidInputError(f"{what} must be finite and ≥ 0, got {val!r}")
        self.force, self.push_duration, self.t_push = float(force), float(push_duration), float(t_push)
        a = math.radians(push_dir)
        self.push_vec = np.array([math.cos(a), math.sin(a), 0.0])
        self.push_dir = float(push_dir)
        self.step_duration, self.trigger_margin = float(step_duration), float(trigger_margin)
        self.duration = self.t_push + self.push_duration + float(settle)
        self.walk: WalkScenario | None = None
        self.t_trigger: float | None = None
        self.contact_events = contact_events_option(contact_events)
        standing = self.contact_events
        if contact_events is True:  # the default thresholds, with the standing air height
            standing = dataclasses.replace(standing, air_height=STANDING_AIR_HEIGHT)
        if self.contact_events is not None:  # the closed loop then sets it from the F/T sensors; the walk reads it
            self.measured_wrench = None
        # standing with contact events: the contacts follow them as in the walk (wbc.sim.walk_contacts), the
        # released sole held flat and set down as the flat walk's late touch-down
        self.contact_thresholds, self.blind = standing, False
        self.descent_speed, self.max_descent = 0.1, 0.02

    def setup(self, controller, sim, q, v):
        robot = sim.robot
        self._model, self._data = robot.model, robot.model.createData()
        pin.centerOfMass(self._model, self._data, q)
        self.com0 = self._data.com[0].copy()
        self.omega = lipm_omega(float(self.com0[2]))
        pin.framesForwardKinematics(self._model, self._data, q)
        self._fids = [robot.frame_id(robot.left_sole), robot.frame_id(robot.right_sole)]
        self._hull = _hull_of_soles(self._data, self._fids, robot.sole_length - 2 * self.trigger_margin,
                                    robot.sole_width - 2 * self.trigger_margin)
        self._body = robot.torso
        sim.body_id(self._body)
        self._weight = robot.mass * robot.gravity
        self._bound = capture_point_bound(robot, max(self.push_duration, 1e-3), self.push_vec, push_body=self._body)
        self._on = False
        self._sim = sim
        self.walk, self.t_trigger = None, None
        self.step_refused: str | None = None  # why no capture step could be planned (GaitError), once triggered
        self.dt = sim.timestep
        self._setup_contact_events(robot, self.dt)
        if self.contact_monitor is not None:  # standing: the soles' contacts follow the events (module docstring)
            self.switcher = ContactSwitcher(controller)
            self._active, self._cut = {}, {"left": None, "right": None}
            oMf = {s: self._data.oMf[f] for s, f in zip(("left", "right"), self._fids)}
            self._sole_views = {s: (oMf[s], oMf[s].rotation, oMf[s].translation) for s in ("left", "right")}

    def com_reference(self, t):
        if self.walk is None:
            return self.com0
        return self.walk.com_reference(t - self.t_trigger)

    def update(self, t, controller, sim, q, v):
        if self.walk is None and self.step_refused is None:
            pin.centerOfMass(self._model, self._data, q, v)
            c, cd = self._data.com[0], self._data.vcom[0]
            xi = c[:2] + cd[:2] / self.omega
            if self.contact_monitor is not None:
                self._stand_on_events(t, controller, q, v)
            if polygon_margin(xi, self._hull) < 0.0 and self._both_soles_down():
                e = xi - self.com0[:2]
                side = "right" if e[1] < 0 else "left"
                # reach and dead band of the capture step: measured (Talos, 450 N from behind) to fall with the walk
                # defaults (forward reach 0.65 z_c, dead band 2 cm), to recover with 0.55 z_c and 3 cm.
                self.walk = WalkScenario(2, 0.0, self.step_duration, t_init=0.06, settle=1.0, from_state=True,
                                         first_side=side, forward_reach=0.55, lateral_reach=0.5,
                                         adjust_dead_band=0.03, adjust_timing=False,
                                         contact_events=self.contact_events or False)
                try:
                    self.walk.setup(controller, sim, q, v)
                except GaitError as exc:  # e.g. a sole already tilted off the floor: no step can be planned from
                    # here; the robot stays on its soles (no second attempt) and the summary says why
                    self.walk, self.step_refused = None, f"t = {t:.3f} s: {exc}"
                else:
                    self.t_trigger = float(t)
        if self.walk is not None:
            if self.contact_events is not None:
                self.walk.measured_wrench = self.measured_wrench
            self.walk.update(t - self.t_trigger, controller, sim, q, v)
        active = self.t_push <= t < self.t_push + self.push_duration - 1e-9
        f, self._on = timed_push(sim, self._body, self.force * self.push_vec if active else None, active, self._on)
        return f

    def _stand_on_events(self, t, controller, q, v) -> None:
        """Standing, one tick of the contact events (``self._data`` holds the forward kinematics of (q, v)): the
        switcher's ramps, then :meth:`WalkContactEvents._follow_contacts` (an unloaded sole in the air released,
        held flat and lowered until it is measured down, then ramped in)."""
        for f in self._fids:
            pin.updateFramePlacement(self._model, self._data, f)
        wrench = self.measured_wrench
        self.switcher.update(t, q, v, None if wrench is None else np.asarray(wrench)[:, 2], self._data)
        self._follow_contacts(float(t), controller, float(t))

    def _both_soles_down(self) -> bool:
        """No sole released or ramping in by the standing events (always True without them): the capture step
        starts from two soles in contact."""
        sw = getattr(self, "switcher", None)
        return sw is None or (sw.phase("left") == "stance" and sw.phase("right") == "stance")

    def criteria(self) -> list[Criterion]:
        """Pass: no fall, the run completed, no solver failure (a step is allowed, not required)."""
        return [NO_FALL, Criterion("run completed", "completed", "==", True),
                Criterion("no solver failure", "solver_failures", "==", 0)]

    def extra_summary(self, run) -> dict:
        moved = np.linalg.norm(run.sole_pos[-1, :, :2] - run.sole_pos[0, :, :2], axis=1)
        out = {"push_force_n": self.force, "push_duration_s": self.push_duration, "push_dir_deg": self.push_dir,
               "stepped": self.walk is not None, "trigger_time_s": self.t_trigger,
               "step_refused": self.step_refused,
               "feet_moved_m": [float(m) for m in moved],
               "completed": bool(run.t[-1] >= self.duration - 2 * run.dt) and not run.fell}
        # the push's angular momentum about the CoM, measured (Pinocchio, the plant's q, v) just after the push,
        # about the horizontal axis e_z × push direction (positive: a rotation towards the push)
        k = min(int(round((self.t_push + self.push_duration) / run.dt)), len(run.t) - 1)
        h = pin.computeCentroidalMomentum(self._model, self._data, run.q[k], run.v[k])
        axis = np.cross([0.0, 0.0, 1.0], self.push_vec)
        out.update({"push_angular_momentum_nms": float(np.asarray(h.angular) @ axis),
                    "capture_point_bound_n": {"linear": round(self._bound["f_max_impulse_n"], 1),
                                              "with_push_moment": round(self._bound["f_max_impulse_moment_n"], 1)},
                    "push_height_above_com_m": self._bound["push_height_above_com_m"],
                    "unloaded_contact_s": unloaded_contacts(run.contact_active, run.sim_wrench[:, :, 2], run.dt,
                                                            self._weight, run.fall_time if run.fell else None)})
        if self.contact_monitor is not None:  # standing's events (the recovery walk's replace them, if any)
            standing = self.contact_events_summary()
            out.update(standing if self.walk is None else {"standing_contact_releases": standing["contact_releases"]})
        if self.walk is not None:
            out.update({"stepping_side": self.walk.first_side,
                        "first_step_shift_m": list(getattr(self.walk, "capture_landing", (0.0, 0.0))),
                        "step_adjustments": len(self.walk.adjustments), **self.walk.contact_events_summary()})
        return out
