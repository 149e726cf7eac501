"""The walk's contact set and force bounds following the measured contact events (opt-in ``contact_events`` of
:class:`wbc.sim.walk.WalkScenario`).

Every tick, each sole's :class:`wbc.estimation.contact_events.SoleContactEvents` reads the ankle F/T ground
reaction (``measured_wrench``, set by the closed loop on an estimated state), the sole placement from the
kinematics of the estimated state and the height of the ground under it (the contact switcher's
``ground_height``). A ``loss`` or ``late`` event (the controller's contact denied by the measurement) of a sole
the switcher holds as a contact (``stance`` or ``loading``):

* on an edge and still loaded (cause ``edge``): its QP contact and the stabilizer's support are cut to a band
  along that edge, twice the events' ``edge_margin`` wide (0.02 m by default;
  :meth:`WalkContactEvents._cut_to_edge`), until it is flat again (``touchdown``) or the plan lifts it;
* unloaded (cause ``unloaded``; not a sole cut to its edge, which keeps its band), when the other sole is a
  contact by the events: released,
  :meth:`~wbc.dynamics.contact_switching.ContactSwitcher.release` (no force on it in the QP, out of the
  stabilizer's support area, which follows the switcher), its foot task holding it flat at its sole's horizontal
  position and heading and lowering it into the estimated ground (the walk's late touch-down: ``descent_speed``, at
  most ``max_descent``) until the events see it down again (``touchdown``: flat and loaded); it is then switched
  on with the switcher's ramp-in (:meth:`~wbc.dynamics.contact_switching.ContactSwitcher.touch_down`).

A blind walk also follows a sole that left the ground while the controller held it as a contact (a landing sole
bounced off the ground, in its ramp-in or after it), with or without the events: in its ramp-in it is held at a
bounded load until it is loaded again, fully loaded it is released and lowered back where it landed
(:meth:`WalkContactEvents._await_rebound`).

The reaction's latency is the events' confirmation time (:attr:`ContactEventMonitor.latency`, 0.01 s by default):
the contact set changes on the tick the event is confirmed, before that tick's QP.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from wbc.estimation.contact_events import ContactEventMonitor, ContactEventThresholds
from wbc.exceptions import InvalidInputError

_OTHER_SOLE = {"left": "right", "right": "left"}


def contact_events_option(value) -> ContactEventThresholds | None:
    """The ``contact_events`` keyword: False/None (off), True (default thresholds) or a
    :class:`ContactEventThresholds`.

    Raises:
        InvalidInputError: anything else.
    """
    if value is None or value is False:
        return None
    if value is True:
        return ContactEventThresholds()
    if isinstance(value, ContactEventThresholds):
        return value
    raise InvalidInputError(f"contact_events must be a bool or a ContactEventThresholds, got {value!r}")


class WalkContactEvents:
    """The measured contact events of :class:`wbc.sim.walk.WalkScenario` (module docstring). Its state: the
    switcher, ``measured_wrench``, the sole placements of the tick (``_sole_views``), the active swings."""

    def _setup_contact_events(self, robot, dt: float) -> None:
        self.contact_monitor = None if self.contact_thresholds is None else \
            ContactEventMonitor(robot, dt, self.contact_thresholds)
        #: (t, sole, action): "release", "touchdown" (a released sole set down), "edge" (cut to an edge band),
        #: "whole sole" (the cut undone)
        self.contact_releases: list[tuple[float, str, str]] = []
        self._lost = {"left": False, "right": False}
        self._late = {"left": False, "right": False}  # a late event of cause unloaded not yet acted on (_late_unloaded)
        self._hold: dict = {}  # side → the flat pose a released sole is held at (world)
        self._edge = {"left": None, "right": None}  # side → the band a sole on its edge is cut to (sole frame, m)
        self._rebounding = {"left": False, "right": False}  # blind: a landing sole held for its load (_await_rebound)
        self._rebound_hold = {"left": None, "right": None}  # blind: (placement, t) of a stance sole released in the air
        #: blind: (t, sole) of each contact sole that left the ground under a planned load (:meth:`_await_rebound`)
        self.rebounds: list[tuple[float, str]] = []

    def _await_rebound(self, t: float, controller) -> None:
        """Blind walk (always, not only with ``contact_events``): a sole the switcher holds as a contact whose
        measured normal force (``measured_normal_force``, ankle F/T) falls below the switcher's ``contact_force``
        has left the ground.

        * In its ramp-in (phase ``loading``) it bounced off the ground it struck: it is touched down again with
          ``await_load`` (:meth:`~wbc.dynamics.contact_switching.ContactSwitcher.touch_down`): the QP plans at most
          2 ``contact_force`` on it until the plant loads it again, and its ramp-in starts again from there.
          Otherwise the ramp-in runs on the sole in the air: the QP plans hundreds of newtons the plant does not
          give, and the leg drives the sole sideways (benchmarks/records/47-*.md).
        * Fully loaded (phase ``stance``), rising faster than the switcher's ``touchdown_speed`` (the sole's vertical
          velocity at the tick's state, :meth:`_sole_rise_rate`: the switcher's own test of a sole that is not
          down), with more than 2 ``contact_force`` still on it in the controller's last QP
          (:meth:`~wbc.dynamics.contact_switching.ContactSwitcher.current_normal_force`) and the other sole a
          loaded contact: it bounced after its ramp-in ended, or rocked off the ground. (A low reading alone is not
          enough: the ankle F/T of a loaded sole rolling on its edge reads tens of newtons below the ground's
          reaction, benchmarks/records/50-*.md.) It is released
          (:meth:`~wbc.dynamics.contact_switching.ContactSwitcher.release`, armed for its touch-down) and its foot
          task holds it at the placement its contact had (the contact's ``reference``: where it landed) while
          lowering it from there at ``descent_speed`` for at most ``max_descent`` (:meth:`_lower_rebound`), until
          the switcher's touch-down test sets it down again (a ramp-in follows). A contact held in the air, even
          at a bounded load, is carried along by the body pivoting over the other sole: its zero-acceleration rows
          do not hold it where it landed, nor bring it back down (benchmarks/records/50-*.md). A stance sole the
          QP itself unloaded (its CoP moved to the other sole) is left alone.

        Nothing happens without the measured forces."""
        f, sw = self.measured_normal_force, self.switcher
        if f is None or sw.contact_force is None:
            return
        for j, side in enumerate(("left", "right")):
            phase = sw.phase(side)
            if self._rebound_hold[side] is not None:
                if phase == "swing":
                    self._lower_rebound(controller, side, t)
                    continue
                self._rebound_hold[side] = None  # set down again by the switcher
            if phase not in ("loading", "stance") or float(f[j]) >= sw.contact_force:
                self._rebounding[side] = False
            elif phase == "loading":
                if not self._rebounding[side]:
                    sw.touch_down(side, t, await_load=True)
                    self._rebounding[side] = True
                    self.rebounds.append((float(t), side))
            elif sw.current_normal_force(side) > 2.0 * sw.contact_force \
                    and sw.phase(_OTHER_SOLE[side]) in ("loading", "stance") \
                    and float(f[1 - j]) >= sw.contact_force and self._sole_rise_rate(side) > sw.touchdown_speed:
                ref = controller.contacts[side].reference
                sw.release(side, t)
                sw.arm(side)
                if ref is None:  # (no landing placement: hold it where it is)
                    ref = controller.feet[side].task.target
                self._rebound_hold[side] = (pin.SE3(ref.rotation, ref.translation), float(t))
                self.rebounds.append((float(t), side))
                self._lower_rebound(controller, side, t)

    def _sole_rise_rate(self, side: str) -> float:
        """Vertical velocity (m/s, world, up > 0) of the sole of ``side`` at the tick's state (``self._data``: the
        walk's forward pass with velocities of :meth:`wbc.sim.walk.WalkScenario.update`)."""
        return float(pin.getFrameVelocity(self._model, self._data, self._fid[side], pin.LOCAL_WORLD_ALIGNED).linear[2])

    def _lower_rebound(self, controller, side: str, t: float) -> None:
        """The foot reference of a stance sole released in the air (:meth:`_await_rebound`): its contact's placement,
        lowered at ``descent_speed`` for at most ``max_descent`` since the release."""
        pose, t0 = self._rebound_hold[side]
        drop = self.descent_speed * (t - t0)
        vel = np.zeros(6)
        vel[2] = -self.descent_speed if drop < self.max_descent else 0.0
        target = pin.SE3(pose.rotation, pose.translation - [0.0, 0.0, min(drop, self.max_descent)])
        controller.set_foot_reference(side, target, vel, np.zeros(6))

    def _follow_contacts(self, t: float, controller, tp: float) -> None:
        """One tick of the events; release, cut or set down soles (module docstring); nothing when off (a blind
        walk's :meth:`_await_rebound` runs first, on or off). ``tp``: the plan clock (s; a swinging sole is planned
        down once its planned touch-down has passed)."""
        if self.blind:
            self._await_rebound(t, controller)
        if self.contact_monitor is None:
            return
        landing_due = {s: tp >= a[2] * self.dt - 1e-9 for s, a in self._active.items()}
        wrench = self.measured_wrench
        if wrench is None:
            raise InvalidInputError("contact_events needs the ankle F/T wrenches (measured_wrench), set by the closed "
                                    "loop on an estimated state (--state estimated)")
        sw, mon = self.switcher, self.contact_monitor
        for j, side in enumerate(("left", "right")):
            _, R, pos = self._sole_views[side]
            det = mon.soles[side]
            planned = sw.phase(side) in ("stance", "loading") or landing_due.get(side, False)
            events = det.update(t, wrench[j], R, pos, sw.ground_height[side], planned)
            # the controller's contact denied by the measurement; a late one unloaded counts once the switcher's own
            # contact is as old as the events' timing tolerance (_late_unloaded)
            causes = {e.cause for e in events if e.kind == "loss" or (e.kind == "late" and e.cause != "unloaded")}
            if self._late_unloaded(side, any(e.kind == "late" and e.cause == "unloaded" for e in events), planned,
                                   det.in_contact, t):
                causes.add("unloaded")
            if self._edge[side] is not None and (det.in_contact or sw.phase(side) not in ("stance", "loading")):
                self._uncut(controller, side, t)  # flat again, or lifted by the plan
            other = _OTHER_SOLE[side]
            may_release = not self._lost[side] and sw.phase(side) in ("stance", "loading") \
                and sw.phase(other) in ("stance", "loading") and mon.soles[other].in_contact
            if "edge" in causes and det.loaded and self._edge[side] is None and not self.blind \
                    and sw.phase(side) in ("stance", "loading"):
                self._cut_to_edge(controller, side, det, t)
            elif may_release and "unloaded" in causes and self._edge[side] is None:
                sw.release(side, t)
                self._lost[side] = True
                yaw = math.atan2(R[1, 0], R[0, 0])
                self._hold[side] = (pin.SE3(pin.rpy.rpyToMatrix(0.0, 0.0, yaw),
                                            np.array([pos[0], pos[1], sw.ground_height[side]])), float(t))
                self.contact_releases.append((float(t), side, "release"))
            if self._lost[side] and sw.phase(side) != "swing":  # set down by the switcher's own test
                self._lost[side] = False
            if self._lost[side]:
                if det.in_contact:
                    sw.touch_down(side, t)
                    self._lost[side] = False
                    self.contact_releases.append((float(t), side, "touchdown"))
                else:  # flat, descending into the ground at descent_speed for at most max_descent
                    pose, t0 = self._hold[side]
                    drop = self.descent_speed * (t - t0)
                    target = pin.SE3(pose.rotation, pose.translation - [0.0, 0.0, min(drop, self.max_descent)])
                    vel = np.zeros(6)
                    vel[2] = -self.descent_speed if drop < self.max_descent else 0.0
                    controller.set_foot_reference(side, target, vel, np.zeros(6))

    def _lost_sole_swings(self, side: str) -> bool:
        """Whether the sole of ``side`` is one the events released (a ``loss`` or ``late`` of cause ``unloaded``)
        and still hold flat, lowering it until they see it down; if so it is handed to its planned swing, which
        starts now (:meth:`~wbc.sim.walk_steps.WalkSteps._release_next_swing`; the switcher has it in ``swing``
        already). Held on instead, it stalled the plan's next step until the events saw it loaded again, and the
        other foot carried the robot alone meanwhile (benchmarks/records/69)."""
        if not self._lost[side]:
            return False
        self._lost[side] = False
        return True

    def _late_unloaded(self, side: str, late: bool, planned: bool, in_contact: bool, t: float) -> bool:
        """Whether a ``late`` event of cause ``unloaded`` of ``side`` (``late``: one this tick) denies the
        switcher's contact now: once the switcher has held the sole as a contact (phase ``stance`` or ``loading``)
        for the events' ``timing_tolerance`` since its touch-down, plus their latency (a contact made within the
        tolerance is seen that much later), with no measured contact since the event. The event counts from the
        plan's touch-down time; a sole the switcher sets down later (a late swing) is in its ramp-in then, its load
        still rising, and releasing it there puts off the landing the switcher found (benchmarks/records/69).
        Dropped once the sole is in contact or no longer planned down."""
        if late:
            self._late[side] = True
        if not self._late[side]:
            return False
        sw = self.switcher
        if in_contact or not planned:
            self._late[side] = False
            return False
        down = sw.touchdown_time[side]
        if sw.phase(side) not in ("stance", "loading") or (
                down is not None and t - down < self.contact_thresholds.timing_tolerance
                + self.contact_monitor.latency - 1e-9):
            return False
        self._late[side] = False
        return True

    def _cut_to_edge(self, controller, side: str, det, t: float) -> None:
        """Confine a loaded sole rolled onto an edge to a band of 2 ``edge_margin`` (m) along that edge (the QP's
        corner forces, :meth:`wbc.constraints.sole_contact.SoleContact.set_support`, and the stabilizer's support,
        ``_cut``): the ankle no longer asks a CoP the ground cannot give (Wiedebach et al., "Walking on partial
        footholds including line contacts with the humanoid robot Atlas", Humanoids 2016, Sec. III)."""
        con = controller.contacts[side]
        x1, y1 = con.half_size
        band = [-x1, x1, -y1, y1]
        cx, cy = det.signals.cop
        a, b = det.half
        e = det.th.edge_margin
        if abs(cx) >= a - e:
            band[0:2] = [x1 - 2 * e, x1] if cx > 0 else [-x1, -x1 + 2 * e]
        if abs(cy) >= b - e:
            band[2:4] = [y1 - 2 * e, y1] if cy > 0 else [-y1, -y1 + 2 * e]
        con.set_support(*band)
        self._cut[side] = self._edge[side] = tuple(band)
        self.contact_releases.append((float(t), side, "edge"))

    def _uncut(self, controller, side: str, t: float) -> None:
        controller.contacts[side].reset_support()
        self._cut[side] = self._edge[side] = None
        self.contact_releases.append((float(t), side, "whole sole"))

    def contact_events_summary(self) -> dict:
        """The events and the releases for a run summary (empty when off)."""
        if self.contact_monitor is None:
            return {}
        return {"contact_events": [e.as_dict() for e in self.contact_monitor.events()],
                "contact_event_latency_s": self.contact_monitor.latency,
                "contact_releases": [{"t": t, "sole": s, "action": a} for t, s, a in self.contact_releases]}
