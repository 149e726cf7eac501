"""Contact events of the soles from the measured state: touch-down, lift-off, contact loss (an unloaded sole, a sole
rolled onto an edge), early and late contact against the plan.

**Measurements** (per sole, every tick): the ground reaction on the foot at the sole origin in sole axes, force f
(N) and moment τ (N·m) (from the ankle F/T sensor, :meth:`wbc.estimation.contact.FootForceSensor.ground_wrench`),
and the sole's world placement (R, p) from the forward kinematics of the estimated state, with the height of the
terrain estimate under it (m, world z). From them:

* normal load ``f_n = (R f)_z`` (N, world vertical component);
* CoP in the sole frame ``(−τ_y / f_z, τ_x / f_z)`` (m; the sole plane is z = 0 of the sole frame);
* tilt ``θ = arccos(R_zz)`` (rad, the angle of the sole's normal to the world vertical);
* clearance: the height over the terrain of the sole rectangle's lowest corner (m); a sole rolled onto an edge
  has its lowest corner on the ground and its origin ``(L/2) sin θ`` above it.

**Instantaneous state** of a sole (before confirmation):

* ``loaded``: a Schmitt trigger on ``f_n``: on above ``load_on · m g``, off below ``load_off · m g``;
* ``edge``: loaded, the CoP within ``edge_margin`` of the sole rectangle's boundary and ``θ > edge_tilt`` (the
  sole pivots about that boundary: a foot-rotation indicator outside the support, Goswami 1999, "Postural
  stability of biped robots and the foot-rotation indicator (FRI) point", IJRR 18(6));
* ``flat_down``: ``θ < flat_tilt`` and the clearance ≤ ``touch_height``, while the plan has the sole on the ground
  (kinematic touch-down: a sole set flat on the ground while the controller puts no force on it reads no load; a
  swing sole skimming the floor is not one — an early contact is sensed by its load);
* **in contact**, for a sole not in contact: ``loaded`` with ``θ < flat_tilt``, or ``flat_down``; for a sole in contact it
  stays in contact unless ``edge``, or unloaded (``not loaded``) with its clearance above ``air_height`` or its
  tilt above ``edge_tilt`` (hysteresis on load, height and tilt: the thresholds to leave are past the thresholds
  to enter).

**Confirmation and latency**: a change of the instantaneous state becomes the sole's confirmed state when it has
held for ``confirm_time`` (s) — ``n = ceil(confirm_time / dt)`` consecutive ticks, counted from the first tick at
which it was seen. The detection latency after the measured signals cross their thresholds is therefore
``n dt`` (the default 0.01 s: 5 ticks at 500 Hz), plus the sensor's own delay (none in :mod:`wbc.sim.sensors`).

**Events** (each an :class:`ContactEvent` with its time, sole, cause and the measurements of that tick), emitted at
the confirmation tick:

* ``touchdown`` (cause ``load`` or ``kinematic``), and ``early`` beside it when the plan has the sole in the
  air;
* ``liftoff``: contact left while the plan has the sole in the air (cause ``planned``);
* ``loss``: contact left while the plan has the sole on the ground (cause ``unloaded`` or ``edge``);
* ``late``: the plan has had the sole on the ground for ``timing_tolerance`` and it has not been in contact since
  (once per planned contact); cause ``edge`` (loaded on an edge: it landed on it), ``unloaded`` or ``tilt`` (loaded,
  not flat, CoP inside).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from wbc.constants import SIDES
from wbc.exceptions import InvalidInputError

__all__ = ["ContactEventThresholds", "ContactEvent", "SoleContactEvents", "ContactEventMonitor"]


@dataclass(frozen=True)
class ContactEventThresholds:
    """Thresholds of the contact events (module docstring).

    Attributes:
        load_on: a sole becomes loaded above this normal load, as a fraction of the robot's weight m g (default
            0.05; Talos 44 N).
        load_off: a loaded sole becomes unloaded below this fraction of m g (default 0.02; Talos 18 N; about 9
            standard deviations of the default F/T force bias of :class:`wbc.sim.sensors.ForceTorqueSpec`).
        air_height: clearance (m) above which an unloaded sole is in the air (default 0.003).
        touch_height: clearance (m) at or below which a flat sole is down (default 0.0015).
        edge_margin: distance (m) of the CoP to the sole rectangle's boundary within which it is at the edge
            (default 0.01).
        edge_tilt: sole tilt (rad) above which a sole with its CoP at the edge is rolled onto it (default 3°).
        flat_tilt: tilt (rad) below which a sole is flat (default 2°).
        confirm_time: s a new state must hold before it is confirmed (default 0.01).
        timing_tolerance: s the plan has had a sole on the ground without a measured contact before it is
            ``late`` (default 0.03).

    Raises:
        InvalidInputError: a non-finite or negative value, ``load_off ≥ load_on``, ``touch_height > air_height``
            or ``flat_tilt > edge_tilt``.
    """

    load_on: float = 0.05
    load_off: float = 0.02
    air_height: float = 0.003
    touch_height: float = 0.0015
    edge_margin: float = 0.01
    edge_tilt: float = math.radians(3.0)
    flat_tilt: float = math.radians(2.0)
    confirm_time: float = 0.01
    timing_tolerance: float = 0.03

    def __post_init__(self):
        for name in ("load_on", "load_off", "air_height", "touch_height", "edge_margin", "edge_tilt", "flat_tilt",
                     "confirm_time", "timing_tolerance"):
            val = getattr(self, name)
            if not (isinstance(val, (int, float)) and math.isfinite(val) and val >= 0):
                raise InvalidInputError(f"ContactEventThresholds.{name} must be a finite number ≥ 0, got {val!r}")
        if not self.load_off < self.load_on:
            raise InvalidInputError(f"ContactEventThresholds needs load_off < load_on (fractions of m g), got "
                                    f"load_off={self.load_off!r}, load_on={self.load_on!r}")
        if self.touch_height > self.air_height:
            raise InvalidInputError(f"ContactEventThresholds needs touch_height ≤ air_height (m), got "
                                    f"touch_height={self.touch_height!r}, air_height={self.air_height!r}")
        if self.flat_tilt > self.edge_tilt:
            raise InvalidInputError(f"ContactEventThresholds needs flat_tilt ≤ edge_tilt (rad), got "
                                    f"flat_tilt={self.flat_tilt!r}, edge_tilt={self.edge_tilt!r}")


@dataclass(frozen=True)
class ContactEvent:
    """One event (module docstring, **Events**).

    Attributes:
        t: s (the confirmation tick).
        sole: ``"left"`` / ``"right"``.
        kind: ``touchdown``, ``liftoff``, ``loss``, ``early``, ``late``.
        cause: ``load``, ``kinematic``, ``planned``, ``unloaded``, ``edge``, ``tilt``, ``plan``.
        normal_force: N.
        cop: (x, y) m, sole frame (NaN unloaded).
        tilt: rad.
        clearance: m, the lowest corner over the terrain.
        height: m, the sole origin over the terrain.
    """

    t: float
    sole: str
    kind: str
    cause: str
    normal_force: float
    cop: tuple[float, float]
    tilt: float
    clearance: float
    height: float

    def as_dict(self) -> dict:
        """A JSON-ready dict of the fields."""
        return {"t": self.t, "sole": self.sole, "kind": self.kind, "cause": self.cause,
                "normal_force_n": self.normal_force, "cop_m": list(self.cop), "tilt_deg": math.degrees(self.tilt),
                "clearance_m": self.clearance, "height_m": self.height}


@dataclass
class _Measured:
    normal_force: float = 0.0
    cop: tuple[float, float] = (math.nan, math.nan)
    tilt: float = 0.0
    clearance: float = 0.0
    height: float = 0.0


class SoleContactEvents:
    """The contact state and events of one sole (module docstring).

    Args:
        sole: ``"left"`` or ``"right"`` (the name in the events).
        length, width: the sole rectangle (m, sole frame x and y, centred on the sole origin).
        weight: m g (N), the scale of the load thresholds.
        dt: tick (s).
        thresholds: :class:`ContactEventThresholds` (default: its defaults).
        in_contact: the confirmed state at the start (default True: standing).

    Attributes:
        in_contact: the confirmed contact state.
        loaded: the load trigger's state.
        cause: why the last confirmed change happened.
        events: list of :class:`ContactEvent`.
        signals: the last tick's normal force, CoP, tilt, clearance and height.
        latency: the confirmation delay (s).

    Raises:
        InvalidInputError: a non-positive size, weight or dt, an unknown sole.
    """

    def __init__(self, sole: str, length: float, width: float, weight: float, dt: float,
                 thresholds: ContactEventThresholds | None = None, in_contact: bool = True):
        if sole not in SIDES:
            raise InvalidInputError(f"sole must be one of {SIDES}, got {sole!r}")
        for val, what in ((length, "length (m)"), (width, "width (m)"), (weight, "weight (N)"), (dt, "dt (s)")):
            if not (math.isfinite(val) and val > 0):
                raise InvalidInputError(f"SoleContactEvents {what} must be finite and > 0, got {val!r}")
        self.sole = sole
        self.th = ContactEventThresholds() if thresholds is None else thresholds
        if not isinstance(self.th, ContactEventThresholds):
            raise InvalidInputError(f"thresholds must be a ContactEventThresholds, got {thresholds!r}")
        self.dt = float(dt)
        self.half = (0.5 * float(length), 0.5 * float(width))
        self.corners = np.array([[sx * self.half[0], sy * self.half[1], 0.0]
                                 for sx, sy in ((1, 1), (-1, 1), (-1, -1), (1, -1))])
        self.f_on, self.f_off = self.th.load_on * weight, self.th.load_off * weight
        self.n_confirm = max(1, math.ceil(self.th.confirm_time / self.dt - 1e-9))
        self.latency = self.n_confirm * self.dt
        self.in_contact = bool(in_contact)
        self.loaded = bool(in_contact)
        self.cause = "initial"
        self.events: list[ContactEvent] = []
        self.signals = _Measured()
        self._pending = 0  # ticks the instantaneous state has differed from the confirmed one
        self._pending_cause = ""
        self._planned_since: float | None = 0.0 if in_contact else None  # plan: on the ground since (s)
        self._late_sent = bool(in_contact)

    def continue_from(self, other: "SoleContactEvents") -> None:
        """Take over the confirmed state (in contact, loaded, cause) of ``other``, the same sole's detector of a plan
        that hands over to a new one on its own clock (the walk's capture walk,
        :meth:`wbc.sim.walk_steps.WalkSteps._start_recovery`): a sole the old plan's events saw leave the ground is not
        taken as standing again. A change pending there starts again; the plan's timing (early/late) starts with the
        new plan's first tick.

        Args:
            other: a :class:`SoleContactEvents` of the same sole.

        Raises:
            InvalidInputError: ``other`` is not a :class:`SoleContactEvents`, or is another sole's.
        """
        if not isinstance(other, SoleContactEvents) or other.sole != self.sole:
            raise InvalidInputError(f"continue_from needs the {self.sole} sole's SoleContactEvents, got {other!r}")
        self.in_contact, self.loaded, self.cause = other.in_contact, other.loaded, other.cause
        self._pending = 0
        self._planned_since = 0.0 if self.in_contact else None
        self._late_sent = self.in_contact

    def _measure(self, wrench: np.ndarray, rotation: np.ndarray, position: np.ndarray, ground: float) -> _Measured:
        f = np.asarray(wrench, dtype=float)
        R = np.asarray(rotation, dtype=float)
        m = self.signals
        m.normal_force = float(R[2] @ f[:3])
        fz = float(f[2])
        m.cop = (-float(f[4]) / fz, float(f[3]) / fz) if fz > 1e-6 else (math.nan, math.nan)
        m.tilt = math.acos(min(1.0, max(-1.0, float(R[2, 2]))))
        z = self.corners @ R[2] + float(position[2]) - float(ground)
        m.clearance = float(z.min())
        m.height = float(position[2]) - float(ground)
        return m

    def _at_edge(self, m: _Measured) -> bool:
        cx, cy = m.cop
        if not (math.isfinite(cx) and math.isfinite(cy)):
            return False
        a, b = self.half
        e = self.th.edge_margin
        return (abs(cx) >= a - e or abs(cy) >= b - e) and m.tilt > self.th.edge_tilt

    def update(self, t: float, wrench: np.ndarray, rotation: np.ndarray, position: np.ndarray, ground: float = 0.0,
               planned_contact: bool | None = None) -> list[ContactEvent]:
        """One tick.

        Args:
            t: time (s).
            wrench: (6,) ground reaction on the foot at the sole origin, sole axes: force (N), moment (N·m).
            rotation: (3, 3) world ← sole rotation. position: (3,) sole origin (m, world).
            ground: terrain height under the sole (m, world z).
            planned_contact: whether the plan has the sole on the ground (None: no plan, no early/late events;
                a lost contact is then a ``loss``).

        Returns:
            The events of this tick (also appended to :attr:`events`).
        """
        th, m = self.th, self._measure(wrench, rotation, position, ground)
        f = m.normal_force
        self.loaded = f >= self.f_off if self.loaded else f > self.f_on
        edge = self.loaded and self._at_edge(m)
        if self.in_contact:
            up = (not self.loaded) and (m.clearance > th.air_height or m.tilt > th.edge_tilt)
            change, cause = edge or up, "edge" if edge else "unloaded"
        else:
            flat_down = m.tilt < th.flat_tilt and m.clearance <= th.touch_height and planned_contact is not False
            flat_loaded = self.loaded and m.tilt < th.flat_tilt
            change = flat_loaded or flat_down
            cause = "load" if flat_loaded else "kinematic"
        out: list[ContactEvent] = []
        if change:
            if self._pending == 0:
                self._pending_cause = cause
            self._pending += 1
            if self._pending >= self.n_confirm:
                self._pending = 0
                self.in_contact = not self.in_contact
                self.cause = self._pending_cause
                out += self._switch_events(t, planned_contact)
        else:
            self._pending = 0
        out += self._plan_events(t, planned_contact)
        self.events += out
        return out

    def _event(self, t: float, kind: str, cause: str) -> ContactEvent:
        m = self.signals
        return ContactEvent(float(t), self.sole, kind, cause, m.normal_force, m.cop, m.tilt, m.clearance, m.height)

    def _switch_events(self, t: float, planned: bool | None) -> list[ContactEvent]:
        if self.in_contact:
            ev = [self._event(t, "touchdown", self.cause)]
            if planned is False:
                ev.append(self._event(t, "early", "plan"))
            return ev
        if planned is False:
            return [self._event(t, "liftoff", "planned")]
        return [self._event(t, "loss", self.cause)]

    def _plan_events(self, t: float, planned: bool | None) -> list[ContactEvent]:
        if planned is None:
            return []
        if planned:
            if self._planned_since is None:
                self._planned_since, self._late_sent = float(t), False
            if self.in_contact:  # landed in this planned contact: a later loss is a loss, not a late landing
                self._late_sent = True
            elif not self._late_sent \
                    and t - self._planned_since >= self.th.timing_tolerance - 1e-9:
                self._late_sent = True
                m = self.signals
                cause = "edge" if self.loaded and self._at_edge(m) else ("unloaded" if not self.loaded else "tilt")
                return [self._event(t, "late", cause)]
        else:
            self._planned_since = None
        return []


@dataclass
class ContactEventMonitor:
    """The two soles' :class:`SoleContactEvents` of a robot.

    Args:
        robot: the :class:`~wbc.robot.Robot` (its sole rectangle and weight).
        dt: tick (s).
        thresholds: :class:`ContactEventThresholds`.

    Attributes:
        soles: side → :class:`SoleContactEvents`.
    """

    robot: object
    dt: float
    thresholds: ContactEventThresholds | None = None
    soles: dict = field(init=False)

    def __post_init__(self):
        r = self.robot
        w = float(r.mass * r.gravity)
        self.soles = {s: SoleContactEvents(s, r.sole_length, r.sole_width, w, self.dt, self.thresholds) for s in SIDES}

    @property
    def latency(self) -> float:
        """Detection latency (s) after the signals cross their thresholds (module docstring)."""
        return self.soles["left"].latency

    def events(self) -> list[ContactEvent]:
        """Every event of both soles, in time order."""
        return sorted(self.soles["left"].events + self.soles["right"].events, key=lambda e: e.t)
