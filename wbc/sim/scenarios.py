"""Closed-loop MuJoCo scenarios (``wbc sim SCENARIO``), their summaries and acceptance criteria.

Scenarios (all start from ``robot.q_ref`` at rest on both feet; the CoM reference starts at the initial CoM c₀):

* ``stand``: hold the reference posture for ``duration`` s. Pass: no fall, CoM drift < 5 mm.
* ``sway``: CoM reference c₀ + (0, A e(t) sin 2πft, 0), A = 3 cm, f = 0.5 Hz, with velocity and acceleration
  feed-forward; e(t) ramps 0 → 1 (minimum jerk) over the first period so the reference starts at rest.
  Pass: no fall, max CoM tracking error < 1 cm.
* ``one-leg``: shift the CoM over the support sole (minimum-jerk, 1.5 s), unload the other foot (its normal force
  bound ramps to 0 in 0.3 s), release it and lift it by ``lift`` = 5 cm (minimum-jerk, 0.8 s), hold ``hold`` = 3 s.
  Pass: no fall, lifted sole ≥ 4 cm above the floor during the whole hold (MuJoCo ground truth).
* ``push``: stand 0.5 s, then a horizontal lateral force ``force`` N (+y, world) for ``push_duration`` s at the
  torso link origin (``apply_external_force``), then ``settle`` s more. Pass: no fall and the feet did not move
  (each sole stays within 2 cm of its start: no stepping/sliding).

Every scenario (:data:`OUTCOME`, checked every tick by :mod:`wbc.sim.outcome` from MuJoCo's data, added to the
scenario's own criteria by :func:`acceptance`): no fall (base drop > 0.2 m, pelvis or torso tilt > 30° from its
nominal orientation, a non-foot body touching the floor, or a foot strike on a riser or nosing), no joint above its URDF velocity limit (0
exceedances), landing slide (travel of the soles' contact points, while touching, from first contact to lift-off)
≤ 10 mm.

Capture-point bound of a push (linear inverted pendulum of height z_c, ω = √(g/z_c), support polygon edge at
distance d from the CoM projection in the push direction; Pratt et al. 2006 "Capture point: a step toward
humanoid push recovery", Humanoids; Englsberger et al. 2015): the divergent component of motion ξ = c + ċ/ω must
stay inside the polygon. An impulse J = F Δt gives Δċ = J/m, hence ξ − c = Δċ/ω ≤ d, i.e.

    F_max,impulse = m ω d / Δt.

For a push of finite duration during which the controller already holds the ZMP at the edge (p = c + d),
ξ̇ = ω (ξ − p) + F/(mω) integrated over Δt gives the slightly larger

    F_max,finite = m ω² d · e^{ωΔt} / (e^{ωΔt} − 1).

Neither accounts for centroidal angular momentum (upper-body rotation), which can add to both — nor for the
angular momentum the push itself gives: pushed at a point ``h`` above the CoM, the robot also receives
L = h J about the CoM (a whole-body rotation towards the push, L/I_G rad/s). It cannot keep rotating (the tilt
criterion), and removing L with the contact forces moves the centroidal moment pivot from the CoP by L̇/(m g)
towards the push (r_CMP = p − (L̇ × e_z)_xy / F_z; Popovic, Goswami, Herr, "Ground reference points in legged
locomotion", IJRR 24(12), 2005), which with ξ̇ = ω (ξ − r_CMP) (Englsberger et al. 2015, the CMP in place of the
CoP) costs at least ω L/(m g) of DCM travel (removal at once; any slower removal costs more). With ω² = g/z_c the
DCM travel is J/(m ω) · (1 + h/z_c), so

    F_max,moment = m ω d / Δt · z_c / (z_c + h),

the bound ``wbc sim push-step`` uses by default (``f_max_impulse_moment_n`` of :func:`capture_point_bound`).
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from wbc.dynamics.balance import IDBalanceController
from wbc.exceptions import InvalidInputError
from wbc.profiles import min_jerk
from wbc.tick import count_paths
from wbc.scenarios.framework import Criterion, evaluate

__all__ = [
    "StandScenario", "SwayScenario", "OneLegScenario", "PushScenario", "SCENARIOS", "summarize",
    "acceptance", "capture_point_bound", "min_jerk", "run_scenario", "push_sweep", "largest_passing",
    "make_controller", "default_push_force", "effort_saturation", "unloaded_contacts",
    "DEFAULT_PUSH_FORCE", "NO_FALL", "JOINT_SPEED", "LANDING_SLIDE", "OUTCOME",
]

#: Push force (N) of the acceptance criteria per catalog robot (0.1 s, lateral, at the torso link origin).
DEFAULT_PUSH_FORCE = {"talos": 450.0, "g1": 120.0}


#: Every physics scenario: the robot did not fall (:mod:`wbc.sim.outcome`).
NO_FALL = Criterion("no fall (base drop > 0.2 m, pelvis/torso tilt > 30°, a non-foot body on the floor, or a foot "
                    "strike on a riser or nosing)",
                    "fell", "==", False)
#: Every physics scenario: no joint of the plant above its URDF velocity limit (MuJoCo qvel, every tick).
JOINT_SPEED = Criterion("no joint above its URDF velocity limit", "joint_speed_exceedances", "==", 0,
                        detail="worst {max_joint_speed_joint} at {max_joint_speed_ratio:.5g}× its limit")
#: Every physics scenario: the soles' contact points travel ≤ 10 mm, while touching, from first contact to lift-off.
LANDING_SLIDE = Criterion("landing slide ≤ 10 mm", "max_landing_slide_m", "<=", 0.010)
#: The operator's outcome criteria, added to every scenario's own (:func:`acceptance`).
OUTCOME = (NO_FALL, JOINT_SPEED, LANDING_SLIDE)

#: A push or a wave must not make the robot step or slide.
FEET_STILL = Criterion("feet moved ≤ 2 cm (no stepping/sliding)", "feet_moved_m", "<=", 0.02)


def timed_push(sim, body: str, force: np.ndarray, active: bool, pushing: bool) -> tuple[np.ndarray | None, bool]:
    """One tick of a push: while ``active``, apply ``force`` (3,) N, world, at the origin of ``body`` (re-applied
    every tick); at the first inactive tick after a push, clear the external forces.

    Returns:
        (force applied this tick or None, whether a push is on) — pass the latter back as ``pushing``.
    """
    if active:
        sim.apply_external_force(body, force)
        return force, True
    if pushing:
        sim.clear_external_forces()
    return None, False


class _Base:
    name = "base"
    needs_id = False

    def __init__(self, duration: float):
        if not (np.isfinite(duration) and duration > 0):
            raise InvalidInputError(f"duration must be finite and > 0 s, got {duration!r}")
        self.duration = float(duration)
        self.com0 = np.zeros(3)

    def setup(self, controller, sim, q, v) -> None:
        data = sim.robot.model.createData()
        self.com0 = pin.centerOfMass(sim.robot.model, data, q).copy()

    def com_reference(self, t: float) -> np.ndarray:
        return self.com0

    def update(self, t, controller, sim, q, v):
        return None

    def extra_summary(self, run) -> dict:
        return {}

    def criteria(self) -> list[Criterion]:
        """Acceptance criteria of the scenario (module docstring)."""
        return [NO_FALL]


class StandScenario(_Base):
    """Hold the reference posture (module docstring)."""

    name = "stand"

    def __init__(self, duration: float = 10.0):
        super().__init__(duration)

    def criteria(self) -> list[Criterion]:
        return [NO_FALL, Criterion("CoM drift < 5 mm", "com_drift_m", "<", 0.005)]


class SwayScenario(_Base):
    """Lateral CoM sway (module docstring). Needs the ID controller."""

    name = "sway"
    needs_id = True

    def criteria(self) -> list[Criterion]:
        return [NO_FALL, Criterion("CoM tracking error < 1 cm", "max_com_error_m", "<", 0.01)]

    def __init__(self, duration: float = 10.0, amplitude: float = 0.03, frequency: float = 0.5):
        super().__init__(duration)
        self.amplitude, self.frequency = float(amplitude), float(frequency)

    def _ref(self, t):
        """Sway with its amplitude ramped in by a minimum-jerk envelope over the first period (no velocity step)."""
        w = 2 * math.pi * self.frequency
        T = 1.0 / self.frequency
        e, de, dde = min_jerk(t / T)
        de, dde = de / T, dde / T**2
        a = self.amplitude
        sn, cs = math.sin(w * t), math.cos(w * t)
        y = a * e * sn
        yd = a * (de * sn + e * w * cs)
        ydd = a * (dde * sn + 2 * de * w * cs - e * w * w * sn)
        return self.com0 + [0.0, y, 0.0], np.array([0.0, yd, 0.0]), np.array([0.0, ydd, 0.0])

    def com_reference(self, t):
        return self._ref(t)[0]

    def update(self, t, controller, sim, q, v):
        controller.set_com_reference(*self._ref(t))
        return None


class OneLegScenario(_Base):
    """Stand on one foot and lift the other (module docstring). Needs the ID controller."""

    name = "one-leg"
    needs_id = True

    def __init__(self, support: str = "left", lift: float = 0.05, hold: float = 3.0, t_shift: float = 1.5,
                 t_unload: float = 0.3, t_lift: float = 0.8, t_start: float = 0.2, t_end: float = 0.5):
        if support not in ("left", "right"):
            raise InvalidInputError(f"support must be 'left' or 'right', got {support!r}")
        self.support = support
        self.swing = "right" if support == "left" else "left"
        self.lift, self.hold = float(lift), float(hold)
        self.t_start, self.t_shift, self.t_unload, self.t_lift = t_start, t_shift, t_unload, t_lift
        self.t_release = t_start + t_shift + t_unload
        self.t_hold = self.t_release + t_lift
        super().__init__(self.t_hold + hold + t_end)
        self._released = False

    def setup(self, controller, sim, q, v):
        super().setup(controller, sim, q, v)
        robot = sim.robot
        data = robot.model.createData()
        pin.framesForwardKinematics(robot.model, data, q)
        sole = robot.left_sole if self.support == "left" else robot.right_sole
        swing = robot.left_sole if self.swing == "left" else robot.right_sole
        self.target = self.com0.copy()
        self.target[:2] = data.oMf[robot.frame_id(sole)].translation[:2]
        self.swing_start = data.oMf[robot.frame_id(swing)].copy()
        self._released = False

    def com_reference(self, t):
        return self._com(t)[0]

    def _com(self, t):
        T = self.t_shift
        s, ds, dds = min_jerk((t - self.t_start) / T)
        d = self.target - self.com0
        return self.com0 + s * d, ds / T * d, dds / T**2 * d

    def update(self, t, controller, sim, q, v):
        controller.set_com_reference(*self._com(t))
        t_unload0 = self.t_start + self.t_shift
        if t_unload0 <= t < self.t_release:
            total = controller.robot.mass * controller.robot.gravity
            controller.set_max_normal_force(self.swing, total * (1.0 - (t - t_unload0) / self.t_unload))
        elif t >= self.t_release:
            if not self._released:
                controller.release_foot(self.swing)
                self._released = True
            s, ds, dds = min_jerk((t - self.t_release) / self.t_lift)
            pose = self.swing_start.copy()
            pose.translation = pose.translation + [0.0, 0.0, s * self.lift]
            vel = np.array([0, 0, ds / self.t_lift * self.lift, 0, 0, 0])
            acc = np.array([0, 0, dds / self.t_lift**2 * self.lift, 0, 0, 0])
            controller.set_foot_reference(self.swing, pose, vel, acc)
        return None

    def extra_summary(self, run) -> dict:
        i = 0 if self.swing == "left" else 1
        z = run.sole_pos[:, i, 2]
        hold = (run.t >= self.t_hold) & (run.t < self.t_hold + self.hold)
        complete = run.t[-1] >= self.t_hold + self.hold - 1.5 * run.dt
        return {
            "support_foot": self.support,
            "lift_target_m": self.lift,
            "lifted_foot_min_height_m": float(z[hold].min()) if hold.any() else 0.0,
            "lifted_foot_max_height_m": float(z[hold].max()) if hold.any() else 0.0,
            "hold_s": self.hold,
            "hold_completed": bool(complete and hold.any()),
        }

    def criteria(self) -> list[Criterion]:
        return [NO_FALL, Criterion(f"the {self.hold:g} s hold was completed", "hold_completed", "==", True),
                Criterion("lifted foot ≥ 4 cm above the floor during the hold", "lifted_foot_min_height_m", ">=", 0.04)]


class PushScenario(_Base):
    """Lateral push at the torso link origin (module docstring)."""

    name = "push"

    def __init__(self, force: float = 450.0, push_duration: float = 0.1, t_push: float = 0.5,
                 settle: float = 2.5, direction=(0.0, 1.0, 0.0), body: str | None = None):
        if not (np.isfinite(force) and force >= 0):
            raise InvalidInputError(f"force must be finite and ≥ 0 N, got {force!r}")
        if not (np.isfinite(push_duration) and push_duration > 0):
            raise InvalidInputError(f"push_duration must be finite and > 0 s, got {push_duration!r}")
        u = np.asarray(direction, dtype=float)
        if u.shape != (3,) or not np.isfinite(u).all() or np.linalg.norm(u) == 0:
            raise InvalidInputError(f"direction must be a non-zero (3,) vector, got {direction!r}")
        super().__init__(t_push + push_duration + settle)
        self.force, self.push_duration, self.t_push = float(force), float(push_duration), float(t_push)
        self.direction = u / np.linalg.norm(u)
        self.body = body

    def setup(self, controller, sim, q, v):
        super().setup(controller, sim, q, v)
        self._body = self.body or sim.robot.torso
        sim.body_id(self._body)
        self._weight = sim.robot.mass * sim.robot.gravity
        self._on = False

    def update(self, t, controller, sim, q, v):
        f, self._on = timed_push(sim, self._body, self.force * self.direction,
                                 self.t_push <= t < self.t_push + self.push_duration - 1e-9, self._on)
        return f

    def extra_summary(self, run) -> dict:
        moved = np.linalg.norm(run.sole_pos[:, :, :2] - run.sole_pos[0, :, :2], axis=2).max()
        lift = float((run.sole_pos[:, :, 2] - run.sole_pos[0, :, 2]).max())
        impulse = float(np.sum(np.linalg.norm(run.ext_force, axis=1)) * run.dt)
        weight = self._weight
        return {"push_force_n": self.force, "push_duration_s": self.push_duration, "push_body": self._body,
                "push_impulse_ns": impulse, "feet_moved_m": float(moved), "max_sole_lift_m": lift,
                "unloaded_contact_s": unloaded_contacts(run.contact_active, run.sim_wrench[:, :, 2], run.dt, weight,
                                                        run.fall_time if run.fell else None)}

    def criteria(self) -> list[Criterion]:
        return [NO_FALL, FEET_STILL]


SCENARIOS = {"stand": StandScenario, "sway": SwayScenario, "one-leg": OneLegScenario, "push": PushScenario}


def capture_point_bound(robot, push_duration: float, direction=(0.0, 1.0, 0.0), g: float | None = None, *,
                        push_body: str | None = None) -> dict:
    """Capture-point bounds on a horizontal push at ``robot.q_ref`` (module docstring).

    Args:
        robot: the robot. push_duration: Δt (s, > 0). direction: horizontal push direction (3,) or (2,), world.
        g: gravity (m/s²; default None: ``robot.gravity``).
        push_body: frame whose origin is pushed (default ``robot.torso``), for the push's moment about the CoM.

    Returns:
        dict with ``omega`` (1/s), ``com_height_m``, ``edge_distance_m`` (d: CoM projection to the support
        polygon edge along ``direction``, the polygon being the convex hull of both sole rectangles),
        ``f_max_impulse_n``, ``f_max_finite_n``, ``push_height_above_com_m`` (h: the pushed point's height above
        the CoM) and ``f_max_impulse_moment_n`` (``f_max_impulse_n · z_c / (z_c + h)``: the push's angular
        momentum h J counted).

    Raises:
        UnknownFrameError: ``push_body`` is not a frame of the robot.
    """
    model = robot.model
    data = model.createData()
    q = robot.q_ref
    com = pin.centerOfMass(model, data, q)
    pin.framesForwardKinematics(model, data, q)
    pts = []
    for frame in (robot.left_sole, robot.right_sole):
        oMf = data.oMf[robot.frame_id(frame)]
        pts.extend((oMf.act(c))[:2] for c in robot.sole_corners_local())
    u = np.asarray(direction, dtype=float)[:2]
    u = u / np.linalg.norm(u)
    # Support function of the convex hull along u (the hull's extent in direction u from the CoM).
    d = float(max((p - com[:2]) @ u for p in pts))
    w = math.sqrt((robot.gravity if g is None else g) / com[2])
    m = robot.mass
    e = math.exp(w * push_duration)
    h = float(data.oMf[robot.frame_id(push_body or robot.torso)].translation[2] - com[2])
    f_imp = m * w * d / push_duration
    # (a push point at or below -z_c/2 would make the factor > 2: a push near the feet, not a torso push)
    factor = com[2] / max(com[2] + h, 0.5 * com[2])
    return {"omega": w, "com_height_m": float(com[2]), "edge_distance_m": d,
            "f_max_impulse_n": f_imp, "f_max_finite_n": m * w * w * d * e / (e - 1.0),
            "push_height_above_com_m": h, "f_max_impulse_moment_n": float(f_imp * factor)}


def default_push_force(robot, scenario: str, push_duration: float, push_dir: float) -> float:
    """Default push (N) of ``wbc sim push`` / ``wbc sim push-step`` on ``robot``, along the push's own direction.

    Args:
        robot: the robot (its ``q_ref`` stance is used).
        scenario: ``"push"`` (standing push: :data:`DEFAULT_PUSH_FORCE` for a catalog robot that has one, else half
            the capture-point impulse bound) or ``"push-step"`` (Talos 450 N, else the capture-point bound with
            the push's own moment about the CoM counted, ``f_max_impulse_moment_n``, rounded to 0.1 N: the largest
            push at the torso the CoP alone can absorb in the linear inverted pendulum; a robot whose DCM then
            leaves its soles shrunk by the trigger margin steps).
        push_duration: s, > 0.
        push_dir: horizontal push direction, deg (world: 0 = +x, 90 = +y).

    Returns:
        force (N).
    """
    a = math.radians(push_dir)
    cp = capture_point_bound(robot, push_duration, (math.cos(a), math.sin(a), 0.0))
    if scenario == "push-step":
        return 450.0 if robot.name == "talos" else round(cp["f_max_impulse_moment_n"], 1)
    return DEFAULT_PUSH_FORCE.get(robot.name, 0.5 * cp["f_max_impulse_n"])


def effort_saturation(model, tau: np.ndarray, dt: float, until: float | None = None, *, fraction: float = 0.99,
                      top: int = 3) -> dict[str, float]:
    """The joints longest at their effort limit: ``{joint name: seconds with |τ| ≥ fraction × effortLimit}`` for
    the ``top`` joints with any such tick, longest first, counted over the ticks before ``until`` (s; the fall time,
    or None for the whole run).

    Args:
        model: Pinocchio model (effort limits ``effortLimit[6:]``, N·m; 1-DoF actuated joints after the free flyer).
        tau: (N, nv − 6) commanded joint torques (N·m), one row per tick of ``dt`` (s).
    """
    effort = np.asarray(model.effortLimit[6:], dtype=float)
    n = len(tau) if until is None else min(len(tau), int(math.floor(until / dt + 1e-9)) + 1)
    lim = np.isfinite(effort) & (effort > 0)
    hits = np.zeros(len(effort))
    hits[lim] = np.sum(np.abs(tau[:n, lim]) >= fraction * effort[lim], axis=0) * dt
    names = {model.joints[j].idx_v - 6: model.names[j] for j in range(1, model.njoints) if model.joints[j].idx_v >= 6}
    order = [i for i in np.argsort(-hits, kind="stable")[:top] if hits[i] > 0]
    return {names[i]: round(float(hits[i]), 4) for i in order}


def unloaded_contacts(contact_active: np.ndarray, normal_force: np.ndarray, dt: float, weight: float,
                      until: float | None = None, *, fraction: float = 0.01) -> dict[str, float]:
    """Longest time each sole was a contact of the controller while the plant did not load it: ``{"left": s,
    "right": s}``, the longest run of consecutive ticks (before ``until``, s; None: all) with the sole's contact
    active and its plant normal force below ``fraction`` × ``weight`` — e.g. the far sole lifted while a pushed
    robot pivots on the other sole's edge, which the controller still treats as a flat contact.

    Args:
        contact_active: (N, 2) bool, (left, right) contact state of the controller per tick.
        normal_force: (N, 2) N, the plant's (MuJoCo's) normal force on each sole per tick.
        dt: tick (s). weight: robot weight (N, > 0). fraction: load threshold (fraction of the weight).
    """
    ca = np.asarray(contact_active, dtype=bool)
    fz = np.asarray(normal_force, dtype=float)
    n = len(ca) if until is None else min(len(ca), int(math.floor(until / dt + 1e-9)) + 1)
    out = {}
    for j, side in enumerate(("left", "right")):
        off = ca[:n, j] & (fz[:n, j] < fraction * weight)
        best = run = 0
        for x in off:
            run = run + 1 if x else 0
            best = max(best, run)
        out[side] = round(best * dt, 4)
    return out


def summarize(run, scenario, controller=None) -> dict:
    """Summary of a :class:`~wbc.sim.closed_loop.SimRun` (keys listed in the CLI help / module docstring)."""
    c = run.com
    c0 = c[0]
    err = np.linalg.norm(c - run.com_ref, axis=1)
    drift = float(np.linalg.norm(c[-1, :2] - c0[:2]))
    robot_effort = None
    if controller is not None:
        robot_effort = np.asarray(controller.robot.model.effortLimit[6:])
    tick_us = run.tick_time * 1e6
    sim_time = len(run.t) * run.dt
    out = {
        "scenario": run.scenario, "robot": run.robot, "controller": run.controller,
        "duration_s": round(sim_time, 6), "control_hz": round(1.0 / run.dt, 3),
        "fell": bool(run.fell), "fall_reason": run.fall_reason, "fall_time_s": run.fall_time,
        **{k: v for k, v in run.outcome.items() if k not in ("fell", "fall_reason", "fall_time_s")},
        "com_drift_m": drift,
        "max_com_deviation_m": float(np.linalg.norm(c[:, :2] - c0[:2], axis=1).max()),
        "max_com_error_m": float(err.max()),
    }
    # Contact forces: the controller's (QP) and MuJoCo's ground truth.
    if run.controller == "id" and controller is not None:
        qp = controller.qp
        fric, normal, cop = np.inf, np.inf, np.inf
        for k, cont in enumerate(qp.contacts):
            act = run.contact_active[:, k]
            if not act.any():
                continue
            f = run.qp_forces[act, 12 * k:12 * k + 12].reshape(-1, 4, 3)
            mu_in = cont.mu / math.sqrt(2)
            fric = min(fric, float((mu_in * f[:, :, 2:3] - np.abs(f[:, :, :2])).min()))
            normal = min(normal, float((f[:, :, 2] - cont.f_min).min()))
            fz = f[:, :, 2]
            tot = fz.sum(axis=1)
            loaded = tot > 10.0  # the CoP of a nearly unloaded foot (< 10 N) is not meaningful
            if loaded.any():
                cp = (fz[loaded] @ cont.corners[:, :2]) / tot[loaded, None]
                a, b = cont.corners[0, 0], cont.corners[0, 1]
                cop = min(cop, float(np.min(np.minimum(a - np.abs(cp[:, 0]), b - np.abs(cp[:, 1])))))
        ok = run.ok
        out.update({
            "min_friction_margin_n": fric, "min_normal_force_margin_n": normal, "min_cop_margin_m": cop,
            "max_dynamics_residual": float(np.nanmax(run.residual[ok])) if ok.any() else float("nan"),
            "solver_failures": int((~ok).sum()),
            "relaxed_qp_ticks": int(run.relaxed.sum()),
            **count_paths(run.path),
        })
        tick = getattr(controller, "controller", None)  # the InverseDynamicsController: budget, routes, fallbacks
        if tick is not None and hasattr(tick, "summary"):
            out["tick_budget"] = tick.summary()
    settle = min(len(run.t) - 1, int(round(0.01 / run.dt)))  # skip the first 10 ms (contact settling at t = 0)
    w = run.sim_wrench[settle:]
    fz = w[:, :, 2]
    ft = np.linalg.norm(w[:, :, :2], axis=2)
    loaded = fz > 10.0
    out["sim_max_tangential_ratio"] = float((ft[loaded] / fz[loaded]).max()) if loaded.any() else 0.0
    out["sim_min_normal_force_n"] = float(fz.sum(axis=1).min())
    if robot_effort is not None:
        lim = np.isfinite(robot_effort) & (robot_effort > 0)
        margin = robot_effort[lim] - np.abs(run.tau[:, lim])
        out["min_torque_margin_nm"] = float(margin.min())
        out["min_torque_margin_fraction"] = float((margin / robot_effort[lim]).min())
        out["effort_saturation_s"] = effort_saturation(controller.robot.model, run.tau, run.dt,
                                                       run.fall_time if run.fell else None)
    out["real_time_factor"] = sim_time / run.wall_time if run.wall_time > 0 else float("inf")
    out["tick_time_us"] = {"median": float(np.median(tick_us)), "p99": float(np.percentile(tick_us, 99)),
                           "max": float(tick_us.max())}
    out["mj_step_time_us"] = {"median": float(np.median(run.step_time * 1e6))}
    out.update(scenario.extra_summary(run))
    return out


def acceptance(summary: dict, scenario) -> tuple[bool, list[str]]:
    """(passed, failed criteria) of a scenario summary: :func:`wbc.scenarios.framework.evaluate` of
    :data:`OUTCOME` followed by ``scenario.criteria()`` (each criterion once)."""
    own = list(scenario.criteria())
    return evaluate(summary, [c for c in OUTCOME if c not in own] + own)


def make_controller(robot, kind: str = "id", *, dt: float = 0.002, solver: str = "fast", **options):
    """``"id"`` → :class:`~wbc.dynamics.balance.IDBalanceController` (``options`` passed on), ``"pd"`` →
    :class:`~wbc.sim.baseline.JointPDController`.

    Raises:
        InvalidInputError: unknown kind.
    """
    if kind == "id":
        return IDBalanceController(robot, dt=dt, solver=solver, **options)
    if kind == "pd":
        from wbc.sim.baseline import JointPDController

        return JointPDController(robot, dt)
    raise InvalidInputError(f"controller must be 'id' or 'pd', got {kind!r}")


def run_scenario(sim, controller, scenario, **kwargs):
    """Run and summarize: ``(run, summary)`` with ``summary['passed']`` and ``summary['failed_criteria']``.

    Raises:
        InvalidInputError: a scenario that needs the ID controller run with another controller.
    """
    from wbc.sim.closed_loop import run_closed_loop

    if scenario.needs_id and not isinstance(controller, IDBalanceController):
        raise InvalidInputError(f"scenario {scenario.name!r} needs the inverse-dynamics controller (--controller id)")
    run = run_closed_loop(sim, controller, scenario, **kwargs)
    summary = summarize(run, scenario, controller)
    passed, fails = acceptance(summary, scenario)
    summary["passed"], summary["failed_criteria"] = passed, fails
    return run, summary


def push_sweep(sim, make, *, push_duration: float = 0.1, f_hi: float, resolution: float = 10.0,
               max_force: float = 5000.0, log=None) -> dict:
    """Largest lateral push force survived (push acceptance: no fall, feet within 2 cm), by bisection.

    Args:
        sim: MuJoCo model. make: () → a fresh controller. push_duration: s.
        f_hi: first upper guess (N); doubled while it is survived (up to ``max_force``).
        resolution: bisection stops when the bracket is narrower (N).
        log: optional callable(str) for progress lines.

    Returns:
        ``{"max_survived_n", "min_failed_n", "trials": [{"force_n", "survived", "fell", "feet_moved_m"}...]}``.
        The bisection assumes survival is monotonic in the force; every trial is listed so a non-monotonic
        response is visible.
    """
    trials = []

    def survives(force: float) -> bool:
        sc = PushScenario(force, push_duration)
        _, s = run_scenario(sim, make(), sc)
        trials.append({"force_n": force, "survived": s["passed"], "fell": s["fell"],
                       "feet_moved_m": s["feet_moved_m"]})
        if log:
            log(f"    {force:7.1f} N: {'survived' if s['passed'] else 'FAILED'}"
                f" (fell {s['fell']}, feet moved {s['feet_moved_m']:.3f} m)")
        return s["passed"]

    lo, hi = largest_passing(survives, float(f_hi), limit=max_force, resolution=resolution, lo=0.0)
    return {"max_survived_n": lo, "min_failed_n": hi, "trials": trials}


def largest_passing(ok, start: float, *, limit: float, resolution: float, lo: float | None = None):
    """Bracket then bisect the largest value that passes ``ok`` (assumed monotonic: passes below a threshold).

    ``start`` is doubled while it passes (``None`` for the failing end once it exceeds ``limit``), then the bracket
    [lo, hi] is halved until narrower than ``resolution`` (units of the value).

    Returns:
        (largest passing value or ``lo`` when ``start`` already fails, smallest failing value or None).
    """
    hi = start
    while ok(hi):
        lo = hi
        hi *= 2.0
        if hi > limit:
            return lo, None
    if lo is None:
        return None, hi
    while hi - lo > resolution:
        mid = 0.5 * (lo + hi)
        if ok(mid):
            lo = mid
        else:
            hi = mid
    return lo, hi
