"""Contact switching for the inverse-dynamics controller: force ramp-out before lift-off, ramp-in after
touch-down, touch-down detected from the measured state.

A foot goes through four phases, driven by :class:`ContactSwitcher`:

``stance`` → (:meth:`~ContactSwitcher.unload`) → ``unloading`` → ``swing`` → (touch-down) → ``loading`` → ``stance``

* **unloading** (ramp-out): the bound on the sole's total normal force falls linearly from ``F₀`` (the sole's
  normal force in the controller's last QP solution when the ramp starts) to 0 over ``ramp_time``,
  ``F_max(t) = F₀ (1 − (t − t₀)/T_ramp)``; the QP moves the weight to the other foot
  continuously (no force jump), and when the bound reaches 0 the contact is released (its forces are then
  bounded to 0 and the foot is tracked by a frame task, :meth:`IDBalanceController.release_foot`). So no weight is
  left on a released foot: at release the QP's normal force of that sole is 0 by construction.
* **swing**: the caller sets the foot reference (pose, velocity and acceleration feed-forward). Touch-down
  detection is armed by :meth:`~ContactSwitcher.arm` (e.g. after mid-swing, so lift-off is not mistaken for
  touch-down).
* **touch-down** is detected **from the state** (q, v): the sole frame height ``z ≤ touchdown_height`` (m, world)
  **and** its vertical velocity ``ż ≤ touchdown_speed`` (m/s; not rising) — **or**, when the caller passes the
  measured normal force of the soles (ankle force/torque sensors) and ``touchdown_force`` is set, from that force:
  ``f_z ≥ touchdown_force`` with the sole below ``touchdown_force_height`` (a gate against the swinging foot's own
  inertia, which a static F/T compensation reads as force). The force test does not depend on the estimated base pose: with an estimated state
  a tilt error of the base of δ rad puts a swing sole that is on the floor ``δ·d`` high (d: its distance to the
  stance sole), e.g. 3.4 mm for 0.8° over 0.25 m, which alone delays a 3 mm height test.
  This handles early touch-down (the foot meets the floor before the plan says so: the contact is switched on
  at once) and late touch-down (the plan's double support began but the foot is still above ``z``: the
  contact stays off — the caller keeps pushing the foot down, see :meth:`~ContactSwitcher.phase`).
* **loading** (ramp-in): the contact is activated with its total normal-force bound rising linearly from 0 to
  ``F_full`` over ``ramp_time``, then unbounded; the foot task is removed. No force jump at the switch. With
  ``await_load``, a sole set down by the state test after its planned landing time while its measured normal
  force is still below ``contact_force`` (:meth:`~ContactSwitcher.set_landing_due`: it hovers a millimetre or two
  over the floor) is a contact whose bound stays at ``2 contact_force`` until the measured force reaches
  ``contact_force`` (twice: a sole resting on the floor at the bound reads above the threshold despite the
  sensor's bias); its ramp starts then. The QP then plans little load the plant does not carry: a ramp run on a
  sole in the air leaves the QP's forces on it unrealised, and the leg's joints accelerate by M⁻¹Jᵀf. Off by
  default: the unrealised ramp also presses a hovering sole onto the floor, and a G1 stair climb that passes
  without the wait falls with it. With the
  measured normal force of the soles given to :meth:`~ContactSwitcher.update`, the bound is never below the
  sole's measured force ``F_meas``: ``F_max(t) = max(F_full (t − t₀)/T_ramp, F_meas(t))``. A foot that lands
  under a pushed robot can take most of the weight from the plant in its first tick; a QP holding the sole's
  force on the ramp meanwhile computes the leg's joint torques for a fraction of that load, and the loaded leg
  folds (its knee driven past the joint speed limit).

``F_full`` defaults to m g (the robot weight): the QP's normal force of a switching sole changes by at most
``F_full dt / ramp_time`` per tick (5 % of the weight per 2 ms tick with the default 0.04 s). This is the force-ramp approach of TSID's ``removeRigidContact(transition_time)`` /
``ContactTransition`` made explicit with the sole's corner-force bounds (:mod:`wbc.constraints.sole_contact`).

The switcher works on a :class:`~wbc.dynamics.balance.IDBalanceController` (its ``contacts``, ``feet``, ``qp``,
``set_max_normal_force`` and ``release_foot``). Call :meth:`~ContactSwitcher.update` once per control tick,
before the controller's ``solve``.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from wbc.constants import SIDES
from wbc.exceptions import InvalidInputError

__all__ = ["ContactSwitcher", "PHASES"]

#: The phases of a foot.
PHASES = ("stance", "unloading", "swing", "loading")


class ContactSwitcher:
    """Force ramps and state-based touch-down detection for the two soles of a balance controller.

    Args:
        controller: a :class:`~wbc.dynamics.balance.IDBalanceController` (both feet in stance after ``reset``).
        ramp_time: duration of the ramp-out and ramp-in (s, > 0; default 0.04 s = 20 ticks at 500 Hz).
        touchdown_height: sole height (m, world z of the sole frame) at or below which an armed swing foot is
            in contact (default 3 mm).
        touchdown_speed: the sole's vertical velocity (m/s) must be ≤ this (not rising) (default 0.05 m/s).
        full_force: F_full (N), end value of the ramp-in (default m g).
        touchdown_force: measured normal force (N, > 0) at or above which an armed swing foot is in contact,
            when :meth:`update` is given the measured forces (default None: the state test alone).
        touchdown_force_height: sole height (m, ≥ touchdown_height) below which the force test applies (default
            2 cm).
        contact_force: with a measured force given to :meth:`update`, the least normal force (N, ≥ 0) that must
            confirm the state test (default None: the state test alone suffices). A walk with measured sole
            forces sets it: a sole at its planned height over ground lower than planned (blind walk), or a sole
            following its planned descent within the height threshold, is still in the air. Once the swing's
            planned landing time has passed (:meth:`set_landing_due`), the state test alone suffices again unless
            ``confirm_when_due`` (a blind walk, whose ground may be lower than planned).
        confirm_when_due: keep asking ``contact_force`` after the planned landing time (default False).
        await_load: a sole the state test sets down after its planned landing time with a measured force below
            ``contact_force`` waits for that load before its ramp-in (module docstring, **loading**; default
            False: its ramp starts at once).

    Attributes:
        events: list of ``(t, side, event)`` with event in ``unload``, ``release``, ``touchdown``, ``load`` (the
            measured load of a sole set down without it reached ``contact_force``: its ramp-in starts), ``loaded``.
        touchdown_time: side → time (s) of the last touch-down (None before).

    Raises:
        InvalidInputError: non-positive ramp_time / full_force / touchdown_force, non-finite thresholds.
    """


    def __init__(self, controller, *, ramp_time: float = 0.04, touchdown_height: float = 0.003,
                 touchdown_speed: float = 0.05, full_force: float | None = None,
                 touchdown_force: float | None = None, touchdown_force_height: float = 0.02,
                 contact_force: float | None = None, confirm_when_due: bool = False, await_load: bool = False):
        if not (np.isfinite(ramp_time) and ramp_time > 0):
            raise InvalidInputError(f"ramp_time must be finite and > 0 s, got {ramp_time!r}")
        for val, what in ((touchdown_height, "touchdown_height"), (touchdown_speed, "touchdown_speed")):
            if not np.isfinite(val):
                raise InvalidInputError(f"{what} must be finite, got {val!r}")
        self.controller = controller
        robot = controller.robot
        self.full_force = robot.mass * robot.gravity if full_force is None else float(full_force)
        if not (np.isfinite(self.full_force) and self.full_force > 0):
            raise InvalidInputError(f"full_force must be finite and > 0 N, got {full_force!r}")
        if touchdown_force is not None and not (np.isfinite(touchdown_force) and touchdown_force > 0):
            raise InvalidInputError(f"touchdown_force must be finite and > 0 N (or None), got {touchdown_force!r}")
        self.touchdown_force = None if touchdown_force is None else float(touchdown_force)
        if not (np.isfinite(touchdown_force_height) and touchdown_force_height >= touchdown_height):
            raise InvalidInputError(f"touchdown_force_height must be finite and ≥ touchdown_height "
                                    f"({touchdown_height!r} m), got {touchdown_force_height!r}")
        self.touchdown_force_height = float(touchdown_force_height)
        if contact_force is not None and not (np.isfinite(contact_force) and contact_force >= 0):
            raise InvalidInputError(f"contact_force must be finite and ≥ 0 N (or None), got {contact_force!r}")
        self.contact_force = None if contact_force is None else float(contact_force)
        self.confirm_when_due = bool(confirm_when_due)
        self.await_load = bool(await_load)
        self._due = {s: False for s in SIDES}
        self.ramp_time = float(ramp_time)
        self.touchdown_height = float(touchdown_height)
        #: side -> world height (m) of the ground the swing foot lands on (terrain; 0 on flat ground):
        #: touch-down is ``z − ground_height ≤ touchdown_height``
        self.ground_height = {"left": 0.0, "right": 0.0}
        self.touchdown_speed = float(touchdown_speed)
        self._model = robot.model
        self._data = robot.model.createData()
        self._kinematics = self._data  # the Data of the last update's sole placements and velocities
        self._fid = {s: robot.frame_id(robot.left_sole if s == "left" else robot.right_sole) for s in SIDES}
        self._phase = {s: "stance" for s in SIDES}
        self._t0 = {s: 0.0 for s in SIDES}
        self._armed = {s: False for s in SIDES}
        self._f0 = {s: self.full_force for s in SIDES}
        self._await_load = {s: False for s in SIDES}
        self.touchdown_time: dict[str, float | None] = {s: None for s in SIDES}
        self.events: list[tuple[float, str, str]] = []

    def _side(self, side: str) -> str:
        if side not in SIDES:
            raise InvalidInputError(f"side must be 'left' or 'right', got {side!r}")
        return side

    def phase(self, side: str) -> str:
        """Current phase of ``side`` (one of :data:`PHASES`)."""
        return self._phase[self._side(side)]

    def in_contact(self, side: str) -> bool:
        """The sole's contact is active (stance, unloading or loading)."""
        return self._phase[self._side(side)] != "swing"

    def unload(self, side: str, t: float) -> None:
        """Start the ramp-out of ``side`` at time t (s); it is released ``ramp_time`` later by :meth:`update`.

        Raises:
            InvalidInputError: bad side, or the foot is not in stance/loading.
        """
        self._side(side)
        if self._phase[side] not in ("stance", "loading"):
            raise InvalidInputError(f"cannot unload the {side} foot in phase {self._phase[side]!r}")
        self._phase[side] = "unloading"
        self._t0[side] = float(t)
        self._f0[side] = self.current_normal_force(side)
        self._armed[side] = False
        self.events.append((float(t), side, "unload"))

    def release(self, side: str, t: float) -> None:
        """Release ``side`` now (no ramp): contact off, foot task on at the current pose."""
        self._side(side)
        self.controller.set_max_normal_force(side, 0.0)
        self.controller.release_foot(side)
        self._phase[side] = "swing"
        self._armed[side] = False
        self.events.append((float(t), side, "release"))

    def set_landing_due(self, side: str, due: bool) -> None:
        """Tell the switcher whether the swing of ``side`` has reached its planned landing time (bool). Before it,
        a state test (sole within ``touchdown_height``) needs the ``contact_force`` confirmation; from it on, a
        sole still within the height threshold is set down by the state test alone (it would otherwise hover at
        the end of its planned descent, over ground a few mm lower than its estimated height); its ramp-in then
        waits for the measured load (module docstring, **loading**)."""
        self._due[self._side(side)] = bool(due)

    def arm(self, side: str) -> None:
        """Enable touch-down detection of a swinging foot (call after lift-off, e.g. past mid-swing)."""
        self._armed[self._side(side)] = True

    def touch_down(self, side: str, t: float, await_load: bool = False) -> None:
        """Switch ``side``'s contact on now and start its ramp-in (called by :meth:`update` on detection);
        ``await_load``: the ramp starts when :meth:`update` is given a measured normal force ≥ ``contact_force``
        (the bound holds at ``2 contact_force`` until then)."""
        self._side(side)
        self._await_load[side] = bool(await_load) and self.contact_force is not None
        c = self.controller
        c.contacts[side].activate(c.state)
        c.set_max_normal_force(side, 0.0)
        foot = c.feet[side]
        if foot in c.qp.tasks:
            c.qp.remove_task(foot)
        self._phase[side] = "loading"
        self._t0[side] = float(t)
        self._armed[side] = False
        self.touchdown_time[side] = float(t)
        self.events.append((float(t), side, "touchdown"))

    def current_normal_force(self, side: str) -> float:
        """Total normal force (N) of ``side`` in the controller's last QP solution (``full_force`` if none)."""
        c = self.controller
        sol = c.controller.last_solution
        if sol is None:
            return self.full_force
        i = c.qp.contacts.index(c.contacts[side])
        return float(sol.forces[12 * i + 2:12 * i + 12:3].sum())

    def sole_height_velocity(self, side: str) -> tuple[float, float]:
        """(z (m), ż (m/s)) of the sole frame at the last :meth:`update` state (world)."""
        fid = self._fid[self._side(side)]
        data = self._kinematics
        z = float(data.oMf[fid].translation[2])
        vz = float(pin.getFrameVelocity(self._model, data, fid, pin.LOCAL_WORLD_ALIGNED).linear[2])
        return z, vz

    def update(self, t: float, q: np.ndarray, v: np.ndarray, normal_force=None, kinematics=None) -> None:
        """Advance the ramps and detect touch-down at time t (s) from the measured (q (nq,), v (nv,)) and, with
        ``touchdown_force`` set, the measured normal force of each sole ``normal_force`` ((2,) N, (left, right),
        e.g. from the ankle F/T sensors; None: the state test alone). The measured force also floors the ramp-in
        bound of a loading sole (module docstring).

        ``kinematics``: None, or a Pinocchio Data of the robot's model holding ``pin.forwardKinematics`` at this
        (q, v) (e.g. after ``pin.centerOfMass(model, data, q, v)``, whose forward pass gives the same numbers), read
        for the armed soles' placements and velocities instead of a forward pass of the switcher's own (the
        caller keeps it unchanged until the next update).

        Call once per tick before the controller computes.
        """
        if self._armed["left"] or self._armed["right"]:
            data = self._data if kinematics is None else kinematics
            if kinematics is None:
                pin.forwardKinematics(self._model, data, q, v)
            for s in SIDES:
                if self._armed[s]:
                    pin.updateFramePlacement(self._model, data, self._fid[s])
            self._kinematics = data
        c = self.controller
        for s in SIDES:
            ph = self._phase[s]
            if ph == "unloading":
                a = (t - self._t0[s]) / self.ramp_time
                if a >= 1.0 - 1e-9:
                    self.release(s, t)
                else:
                    c.set_max_normal_force(s, self._f0[s] * (1.0 - a))
            elif ph == "loading":
                if self._await_load[s]:
                    f = None if normal_force is None else float(normal_force[0 if s == "left" else 1])
                    if f is None or f < self.contact_force:
                        c.set_max_normal_force(s, 2.0 * self.contact_force)
                        continue
                    self._await_load[s] = False  # ramp on from the bound held so far (no force jump)
                    self._t0[s] = float(t) - self.ramp_time * min(1.0, 2.0 * self.contact_force / self.full_force)
                    self.events.append((float(t), s, "load"))
                a = (t - self._t0[s]) / self.ramp_time
                if a >= 1.0:
                    c.contacts[s].f_max = math.inf
                    self._phase[s] = "stance"
                    self.events.append((float(t), s, "loaded"))
                else:
                    f_max = self.full_force * a
                    if normal_force is not None:  # never below the load the plant already puts on the sole
                        f_max = max(f_max, float(normal_force[0 if s == "left" else 1]))
                    c.set_max_normal_force(s, f_max)
            elif ph == "swing" and self._armed[s]:
                z, vz = self.sole_height_velocity(s)
                dz = z - self.ground_height[s]
                f = None if normal_force is None else float(normal_force[0 if s == "left" else 1])
                hit = dz <= self.touchdown_height and vz <= self.touchdown_speed
                unloaded = hit and f is not None and self.contact_force is not None and f < self.contact_force
                if unloaded and (self.confirm_when_due or not self._due[s]):
                    hit = False  # the state test needs the confirmation of a load on the sole
                    unloaded = False
                if not hit and f is not None and self.touchdown_force is not None:
                    hit = dz <= self.touchdown_force_height and f >= self.touchdown_force
                if hit:
                    self.touch_down(s, t, await_load=unloaded and self.await_load)
