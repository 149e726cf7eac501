"""The load of a hard landing in a physics walk (:class:`wbc.sim.walk.WalkScenario`, :class:`WalkLanding`): after a
touch-down whose measured normal force exceeds the robot's weight (an impact), the controller's QP is made to
carry at least a share of that force on the landed sole.

At a touch-down the force ramp-in of :class:`~wbc.dynamics.contact_switching.ContactSwitcher` bounds the QP's normal
force of the landed sole from above (never below the measured force), but the QP is free to plan less, and after
an impact it does: the plant's floor stops the sole within a tick or two with a force of several times the weight,
while the QP, seeing the CoM rebound, plans a fraction of it on that sole. Its joint torques are those of a leg
carrying the QP's force, not the plant's: a nearly straight knee under the plant's load folds with the small knee
torque the QP commands, past the joint's speed limit (a leg landing far out on a push).

Here, from a touch-down whose measured normal force (ankle force/torque sensors: the attribute
``measured_normal_force``, (2,) N, set by the closed loop with an estimated state) exceeds
:data:`IMPACT_LOAD` × the robot's weight, for :data:`IMPACT_WINDOW_S` s after that touch-down, every corner of the
landed sole gets the QP lower bound ``f_min`` = :data:`IMPACT_SHARE` × (measured normal force) / 4 (N; the sole's
own ``f_min`` again afterwards). The torques then hold the leg against the load it has. A touch-down of a nominal
walk reads a few hundred newtons: no impact, nothing changes. Flat walks only: a walk on terrain or a blind one
(their own landing handling: the stance sole's rebound hold, force-confirmed contacts) is left as it is.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

__all__ = ["WalkLanding", "IMPACT_LOAD", "IMPACT_SHARE", "IMPACT_WINDOW_S"]

#: Measured normal force of a landing sole, as a multiple of the robot's weight, above which a touch-down is an impact.
IMPACT_LOAD = 1.0
#: Share of the measured normal force the QP must plan on the landed sole after an impact.
IMPACT_SHARE = 0.7
#: Time after the touch-down (s) over which the lower bound applies.
IMPACT_WINDOW_S = 0.05


class WalkLanding:
    """The load of a hard landing of :class:`wbc.sim.walk.WalkScenario` (module docstring; its state: the switcher,
    the measured normal forces)."""

    def _setup_landing(self) -> None:
        """Per walk: the robot's weight (N) and the per-side state (time of the impact, the sole's own f_min)."""
        self._weight = float(pin.computeTotalMass(self._model)) * float(self.robot.gravity)
        self._impact = {"left": None, "right": None}  # time (s) of the touch-down found to be an impact
        self._own_f_min = {"left": None, "right": None}  # the contact's f_min while it is raised here
        self.impact_landings = 0  # touch-downs found to be impacts

    def _impact_load(self, controller, t: float) -> None:
        """Set or restore the landed soles' corner-force lower bounds for time ``t`` (s) (module docstring)."""
        force = self.measured_normal_force
        if force is None or self.blind or self.terrain_walk is not None:
            return
        sw = self.switcher
        for i, side in enumerate(("left", "right")):
            contact = controller.contacts[side]
            td = sw.touchdown_time[side]
            if td is not None and t - td <= IMPACT_WINDOW_S and sw.phase(side) in ("loading", "stance"):
                if (self._impact[side] is None or self._impact[side] < td) and force[i] > IMPACT_LOAD * self._weight:
                    self._impact[side] = t
                    self.impact_landings += 1
                if self._impact[side] is not None and self._impact[side] >= td:
                    if self._own_f_min[side] is None:
                        self._own_f_min[side] = contact.f_min
                    contact.f_min = max(self._own_f_min[side], IMPACT_SHARE * max(float(force[i]), 0.0) / 4.0)
                    continue
            if self._own_f_min[side] is not None:
                contact.f_min = self._own_f_min[side]
                self._own_f_min[side] = None
