"""The walk's contact set and force bounds following the measured contact events (opt-in ``contact_events`` of
:class:`wbc.sim.walk.WalkScenario`).

Every tick, each sole's :class:`wbc.estimation.contact_events.SoleContactEvents` reads the ankle F/T ground
reaction (``measured_wrench``, set by the closed loop on an estimated state), the sole placement from the
kinematics of the estimated state and the height of the ground under it (the contact switcher's
``ground_height``). A ``loss`` event (an unloaded sole in the air, a sole rolled onto an edge) of a sole the
switcher holds as a contact (``stance`` or ``loading``) releases it, when the other sole is a measured contact:
:meth:`~wbc.dynamics.contact_switching.ContactSwitcher.release` (no force on it in the QP, out of the stabilizer's
support area, which follows the switcher) and its foot task holds it flat at its sole's horizontal position and
heading, on the ground, until the events see it down again (``touchdown``); it is then switched on with the
switcher's ramp-in (:meth:`~wbc.dynamics.contact_switching.ContactSwitcher.touch_down`). The reaction's latency is
the events' confirmation time (:attr:`ContactEventMonitor.latency`, 10 ms by default) plus one tick.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from wbc.estimation.contact_events import ContactEventMonitor, ContactEventThresholds
from wbc.exceptions import InvalidInputError

_OTHER = {"left": "right", "right": "left"}


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
        self.contact_releases: list[tuple[float, str, str]] = []  # (t, sole, "release" | "touchdown")
        self._lost = {"left": False, "right": False}
        self._hold: dict = {}  # side → the flat pose a released sole is held at (world)

    def _follow_contacts(self, t: float, controller, landing_due: dict) -> None:
        """One tick of the events; release / set down soles (module docstring). ``landing_due``: side → whether
        the plan has that sole on the ground (its swing's planned touch-down has passed)."""
        wrench = self.measured_wrench
        if wrench is None:
            raise InvalidInputError("contact_events needs the ankle F/T wrenches (measured_wrench), set by the closed "
                                    "loop on an estimated state (--state estimated)")
        sw, mon = self.switcher, self.contact_monitor
        for j, side in enumerate(("left", "right")):
            _, R, pos = self._sole_views[side]
            planned = sw.phase(side) in ("stance", "loading") or landing_due.get(side, False)
            events = mon.soles[side].update(t, wrench[j], R, pos, sw.ground_height[side], planned)
            kinds = {e.kind for e in events}
            other = _OTHER[side]
            if "loss" in kinds and not self._lost[side] and sw.phase(side) in ("stance", "loading") \
                    and sw.phase(other) in ("stance", "loading") and mon.soles[other].in_contact:
                sw.release(side, t)
                self._lost[side] = True
                yaw = math.atan2(R[1, 0], R[0, 0])
                self._hold[side] = pin.SE3(pin.rpy.rpyToMatrix(0.0, 0.0, yaw),
                                           np.array([pos[0], pos[1], sw.ground_height[side]]))
                self.contact_releases.append((float(t), side, "release"))
            if self._lost[side] and sw.phase(side) != "swing":  # set down by the switcher's own test
                self._lost[side] = False
            if self._lost[side]:
                if mon.soles[side].in_contact:
                    sw.touch_down(side, t)
                    self._lost[side] = False
                    self.contact_releases.append((float(t), side, "touchdown"))
                else:
                    controller.set_foot_reference(side, self._hold[side], np.zeros(6), np.zeros(6))

    def contact_events_summary(self) -> dict:
        """The events and the releases for a run summary (empty when off)."""
        if self.contact_monitor is None:
            return {}
        return {"contact_events": [e.as_dict() for e in self.contact_monitor.events()],
                "contact_event_latency_s": self.contact_monitor.latency,
                "contact_releases": [{"t": t, "sole": s, "action": a} for t, s, a in self.contact_releases]}
