"""Walking on command, tick by tick: velocity commands and pose goals drive the kinematic walk controller online.

:class:`CommandedWalk` owns one :class:`~wbc.configuration.Configuration` and one
:class:`~wbc.scenarios.walk.WalkController` and advances them one control tick (``dt``) per :meth:`tick`. It
never records the run: memory stays constant however long it runs (a caller that wants a log streams
:attr:`CommandedWalk.q` itself).

Gait (a receding horizon of :func:`wbc.gait.plan_walk` plans):

* **Standing** (no plan): the configuration is held, ``v = 0``.
* **Velocity command** ``(vx, vy, wz)`` (m/s, m/s, rad/s, in the walking frame: x forward along the mean heading
  of the soles, y left): a walk of ``horizon`` steps is planned from the current stance with step length
  ``vx T``, lateral step ``vy T`` and turn ``wz T`` per step (``T`` = single + double support duration, the step
  duration). At every touch-down the rest of the plan is replaced by a new one planned from that double support
  (feet where they landed, the plan's CoM position and velocity, the next foot swinging first, initial double
  support the plan's ``t_ds``): a new command takes effect at the next touch-down, and a zero command replans a
  single closing step (the swing foot lands beside the stance foot; the CoM comes to rest over the feet).
* **Pose goal** ``(x, y, yaw)`` of the base (world): the footsteps reaching it are planned at once (from the
  standing stance, or from the next touch-down when walking): ``n`` walking steps with equal turn ``dyaw / n``
  and the step length and lateral step that put the feet mid-point at the goal exactly (solved from
  :func:`wbc.gait.plan_footsteps`, which is affine in both for a fixed turn), then a closing step. ``n`` is the
  smallest count keeping the step within ``max_velocity T`` forward, ``max_lateral T`` sideways and
  ``max_turn T`` in yaw. The base pose is the free flyer's (x, y, yaw); its offset from the feet mid-point at
  rest (``q_ref``, heading frame) is kept.
* **Stop** (:meth:`stop`): in a double support before a step (at least 0.1 s of it left) the closing step is
  planned at once, the remaining double support as its initial one; during a swing, at its touch-down. Standing
  once the closing step has settled: at most one step starts after a stop.

Frames and units: world frame (``odom``), z up, flat ground; m, s, rad.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from wbc.solvers import DEFAULT_SOLVER
from wbc.configuration import Configuration
from wbc.exceptions import GaitError, InvalidInputError
from wbc.gait import plan_walk
from wbc.gait.footsteps import plan_footsteps, pose_to_xy_yaw
from wbc.geometry import mean_heading
from wbc.robot import Robot
from wbc.scenarios.walk import WalkController
from wbc.tasks.base import ValidatedAttribute

__all__ = ["CommandedWalk", "wrap_angle", "steps_to_midpoint", "check_finite"]

_DOUBLE = 0


def wrap_angle(a: float) -> float:
    """``a`` (rad) wrapped to [−π, π)."""
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def check_finite(value, name: str, lo: float = -math.inf, hi: float = math.inf) -> float:
    """``value`` as a float if it is a finite number (int or float, Python or numpy; not a bool) in [lo, hi].

    Raises:
        InvalidInputError: not such a number ("<name> must be a finite number"), or out of [lo, hi].
    """
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)) \
            or not math.isfinite(float(value)):
        raise InvalidInputError(f"{name} must be a finite number; got {value!r}")
    v = float(value)
    if not lo <= v <= hi:
        raise InvalidInputError(f"{name} = {v} is out of range: valid is [{lo:g}, {hi:g}]")
    return v


class CommandedWalk:
    """The online walk of the module docstring.

    Args:
        robot: the robot (``robot.gait`` gives the step timing and height).
        dt: control period, s (> 0).
        solver: QP backend name.
        horizon: steps planned ahead for a velocity command (>= 2: at least one walking step and the closing one).
        step_duration: single + double support, s, in [0.4, 3]; default the robot's ``t_ss + t_ds``. The
            single/double support split of the robot's gait is kept.
        max_velocity: forward speed limit, m/s (> 0); commands beyond it are refused, goals walk at most at it.
        max_lateral: lateral speed limit, m/s (> 0).
        max_turn: yaw rate limit, rad/s (> 0); 0 when the legs cannot yaw the soles relative to each other (no
            hip yaw joint, :attr:`can_turn` False): turning commands are then refused and goals must keep the heading.

    Raises:
        InvalidInputError: a non-finite or out-of-range argument (the message names it and the valid range).
    """

    def __init__(self, robot: Robot, *, dt: float = 0.002, solver: str = DEFAULT_SOLVER, horizon: int = 3,
                 step_duration: float | None = None, max_velocity: float = 0.3, max_lateral: float = 0.1,
                 max_turn: float = 0.5):
        self.robot = robot
        self.dt = check_finite(dt, "dt", 1e-4, 0.1)
        if isinstance(horizon, bool) or not isinstance(horizon, (int, np.integer)) or horizon < 2:
            raise InvalidInputError(f"horizon must be an integer >= 2 (steps); got {horizon!r}")
        self.horizon = int(horizon)
        gait = dict(robot.gait)
        self._t_ss0 = float(gait.get("t_ss", 0.8))
        self._t_ds0 = float(gait.get("t_ds", 0.3))
        self.step_height = float(gait.get("step_height", 0.05))
        self.step_duration = self._t_ss0 + self._t_ds0 if step_duration is None else step_duration
        self.max_velocity = max_velocity
        self.max_lateral = check_finite(max_lateral, "max_lateral", 1e-3, 2.0)
        self.config = Configuration(robot)
        self.can_turn = self._feet_can_yaw()
        self.max_turn = check_finite(max_turn, "max_turn", 1e-3, 3.0) if self.can_turn else 0.0
        self._solver = solver
        self.walker = WalkController(robot, self.config, solver=solver)
        self.v = np.zeros(robot.model.nv)
        self.t = 0.0
        self.plan = None
        self.k = 0
        self.command = np.zeros(3)
        self.goal: tuple[float, float, float] | None = None
        self._pending_goal: tuple[float, float, float] | None = None
        self._stop = False
        self._stop_now = False
        self._retry_at = 0.0
        self.replans = 0
        self.replan_failures = 0
        self.touchdowns = 0
        self.last_error = ""
        lf, rf = self._soles()
        mx, my, yaw = self._midpoint(lf, rf)
        c, s = math.cos(yaw), math.sin(yaw)
        dx, dy = self.config.q[0] - mx, self.config.q[1] - my
        self._base_offset = (c * dx + s * dy, -s * dx + c * dy)  # base - feet mid-point, heading frame
        self._step_width = self._width(lf, rf)  # nominal, at q_ref (side steps widen the stance only transiently)

    # -- parameters --------------------------------------------------------------------------------------------
    @property
    def step_duration(self) -> float:
        """Single + double support duration T, s."""
        return self._t_ss + self._t_ds

    @step_duration.setter
    def step_duration(self, value) -> None:
        T = check_finite(value, "step_duration (s)", 0.4, 3.0)
        scale = T / (self._t_ss0 + self._t_ds0)
        self._t_ss, self._t_ds = self._t_ss0 * scale, self._t_ds0 * scale

    max_velocity = ValidatedAttribute(lambda walk, v: check_finite(v, "max_velocity (m/s)", 1e-3, 2.0),
                                      "Forward speed limit, m/s (in [0.001, 2]; raises InvalidInputError).")

    # -- state -------------------------------------------------------------------------------------------------
    @property
    def q(self) -> np.ndarray:
        """(nq,) current configuration (Pinocchio order, free flyer first)."""
        return self.config.q

    @property
    def walking(self) -> bool:
        """True while a plan is being tracked (False: standing still)."""
        return self.plan is not None

    @property
    def support(self) -> int:
        """Support code now: 0 double, 1 left stance, 2 right stance (standing is 0)."""
        return _DOUBLE if self.plan is None else int(self.plan.support[min(self.k, self.plan.n_samples - 1)])

    @property
    def idle(self) -> bool:
        """Standing still with no command and no goal waiting."""
        return self.plan is None and self._pending_goal is None and not np.any(self.command)

    def base_pose(self) -> tuple[float, float, float]:
        """(x, y, yaw) of the free flyer (m, m, rad), world."""
        q = self.config.q
        yaw = pose_to_xy_yaw(pin.XYZQUATToSE3(q[:7]).homogeneous)[2]
        return float(q[0]), float(q[1]), yaw

    def footprint_pose(self) -> tuple[float, float, float]:
        """(x, y, yaw) where the base would stand at rest over the current soles (m, m, rad, world): the feet
        mid-point and mean heading plus the base's offset from them at ``q_ref``. It moves only while a foot
        swings, so its distance to a goal does not sway with the CoM."""
        lf, rf = self._soles()
        mx, my, yaw = self._midpoint(lf, rf)
        ox, oy = self._base_offset
        c, s = math.cos(yaw), math.sin(yaw)
        return mx + c * ox - s * oy, my + s * ox + c * oy, yaw

    def time_remaining(self) -> float:
        """Time (s) until the current plan ends (0 when standing)."""
        return 0.0 if self.plan is None else (self.plan.n_samples - self.k) * self.dt

    # -- commands ----------------------------------------------------------------------------------------------
    def set_velocity(self, vx: float, vy: float = 0.0, wz: float = 0.0) -> None:
        """Velocity command (m/s, m/s, rad/s, walking frame); zeros stop at the next touch-down.

        Raises:
            InvalidInputError: non-finite or beyond ``max_velocity`` / ``max_lateral`` / ``max_turn``.
        """
        if wz and not self.can_turn:
            raise InvalidInputError(f"wz = {wz} rad/s: {self.robot.name}'s legs cannot yaw one sole relative to the "
                                    "other (no hip yaw joint); valid: wz = 0")
        self.command[:] = (check_finite(vx, "vx (m/s)", -self.max_velocity, self.max_velocity),
                           check_finite(vy, "vy (m/s)", -self.max_lateral, self.max_lateral),
                           check_finite(wz, "wz (rad/s)", -self.max_turn, self.max_turn))
        self.goal = self._pending_goal = None
        if np.any(self.command):
            self._stop = False

    def set_goal(self, x: float, y: float, yaw: float) -> None:
        """Walk the base to ``(x, y, yaw)`` (m, m, rad, world); replaces any command or goal.

        Raises:
            InvalidInputError: non-finite values.
        """
        self._pending_goal = (check_finite(x, "goal x (m)"), check_finite(y, "goal y (m)"),
                              check_finite(yaw, "goal yaw (rad)"))
        self.command[:] = 0.0
        self._stop = False

    def stop(self) -> None:
        """Stop at the next touch-down (a closing step); clears the command and goal."""
        self.command[:] = 0.0
        self.goal = self._pending_goal = None
        self._stop = True
        self._stop_now = True

    def reset(self) -> None:
        """Back to the reference standing configuration, standing, no command."""
        self.config.update(self.robot.q_ref.copy())
        self.walker = WalkController(self.robot, self.config, solver=self._solver)
        self.plan, self.k = None, 0
        self.v[:] = 0.0
        self.command[:] = 0.0
        self.goal = self._pending_goal = None
        self._stop = False

    # -- one tick ----------------------------------------------------------------------------------------------
    def tick(self) -> None:
        """Advance one control period ``dt``: (re)plan if due, then one QP tick (or hold when standing)."""
        plan = self.plan
        if plan is None:
            if (self._pending_goal is not None or np.any(self.command)) and self.t >= self._retry_at:
                self._start(self._plan_from_state(None))
                if self.plan is None:
                    self._retry_at = self.t + 0.5  # a walk that cannot be planned is retried every 0.5 s
        elif self.k > 0 and plan.support[self.k] == _DOUBLE and plan.support[self.k - 1] != _DOUBLE:
            self.touchdowns += 1
            self._stop_now = False
            self._at_touchdown()
        elif self._stop_now:
            self._stop_now = False
            self._close_in_double_support()
        if self.plan is None:
            self.v[:] = 0.0
        else:
            self.walker.set_references(self.plan, self.k, self.config)
            result = self.walker.solve(self.config, self.dt)
            self.config.step(result.v, self.dt)
            self.v[:] = result.v
            self.k += 1
            if self.k >= self.plan.n_samples:
                self.plan, self.k = None, 0
                self.goal = None
                self._stop = False
        self.t += self.dt

    def _start(self, plan) -> None:
        if plan is not None:
            self.plan, self.k = plan, 0
            self.replans += 1

    def _at_touchdown(self) -> None:
        plan, k = self.plan, self.k
        steps_left = sum(1 for ph in plan.phases if ph.support != _DOUBLE and ph.first >= k)
        if self._pending_goal is None and self.goal is not None and not self._stop:
            return  # walking to a goal: its plan already ends there
        if self._pending_goal is None and not np.any(self.command) and steps_left <= 1:
            return  # already closing (or closed)
        landed = int(plan.support[k - 1])  # 1: left stance, right swung; 2: right stance, left swung
        first = "left" if landed == 1 else "right"
        new = self._plan_from_state((k, first))
        if new is not None:
            self.plan, self.k = new, 0
            self.replans += 1

    def _close_in_double_support(self) -> None:
        """On :meth:`stop` in a double support before a step (≥ 0.1 s of it left): replace the rest of the plan by
        the closing step now, instead of at the next touch-down (the step about to start is not taken)."""
        plan, k = self.plan, self.k
        phases = plan.phases
        i = next(i for i, ph in enumerate(phases) if ph.first <= k < ph.first + ph.count)
        ph = phases[i]
        if ph.support != _DOUBLE or i + 1 >= len(phases):
            return  # swinging (the closing step is planned at touch-down) or already in the final double support
        left = (ph.first + ph.count - k) * self.dt
        if left < 0.1:
            return
        first = "right" if int(phases[i + 1].support) == 1 else "left"  # left stance next: the right foot swings
        new = self._plan_from_state((k, first), t_init=left)
        if new is not None:
            self.plan, self.k = new, 0
            self.replans += 1

    def _plan_from_state(self, at, t_init: float | None = None):
        """A plan from the current double support: ``at`` None (standing) or (k, first swinging side)."""
        if at is None:
            lf, rf = self._soles()
            com, com_vel, first, t_init = self.config.com.copy(), None, None, None
        else:
            k, first = at
            p = self.plan
            lf, rf = p.left_sole[k], p.right_sole[k]
            com, com_vel = p.com[k].copy(), p.com_vel[k].copy()
            t_init = self._t_ds if t_init is None else t_init
        kwargs = dict(step_height=self.step_height, t_ss=self._t_ss, t_ds=self._t_ds, dt=self.dt,
                      sole_length=self.robot.sole_length, sole_width=self.robot.sole_width)
        if t_init is not None:
            kwargs["t_init"] = t_init
        if com_vel is not None:
            kwargs["com_velocity"] = com_vel
        width = self._step_width
        try:
            if self._pending_goal is not None:
                goal, self._pending_goal = self._pending_goal, None
                n, L, d, turn, side = self._goal_steps(lf, rf, goal, first, width)
                plan = plan_walk(lf, rf, com, n_steps=n, step_length=L, step_lateral=d, turn=turn,
                                 first_side=side, step_width=width, **kwargs)
                self.goal = goal
                return plan
            T = self.step_duration
            vx, vy, wz = self.command
            if not np.any(self.command):
                if at is None:
                    return None
                return plan_walk(lf, rf, com, n_steps=1, step_length=0.0, first_side=first, step_width=width,
                                 **kwargs)
            side = first or ("right" if vy < 0 or (vy == 0 and wz < 0) else "left")
            return plan_walk(lf, rf, com, n_steps=self.horizon, step_length=vx * T, step_lateral=vy * T,
                             turn=wz * T, first_side=side, step_width=width, **kwargs)
        except (GaitError, np.linalg.LinAlgError) as exc:
            self.replan_failures += 1
            self.last_error = str(exc)
            return None

    # -- geometry ----------------------------------------------------------------------------------------------
    def _feet_can_yaw(self) -> bool:
        """Whether the joints can change the relative yaw of the soles at the current q: the z row of the Jacobian
        of ω_left − ω_right (world axes; the floating base cancels) is non-zero. False for legs without a hip yaw
        joint, whose feet cannot turn relative to each other."""
        model, data, q = self.robot.model, self.robot.model.createData(), self.config.q
        pin.computeJointJacobians(model, data, q)
        pin.framesForwardKinematics(model, data, q)
        jl, jr = (pin.getFrameJacobian(model, data, self.robot.frame_id(f), pin.LOCAL_WORLD_ALIGNED)
                  for f in (self.robot.left_sole, self.robot.right_sole))
        return bool(np.abs(jl[5] - jr[5]).max() > 1e-6)

    def _soles(self):
        d = self.config.data
        return (d.oMf[self.robot.frame_id(self.robot.left_sole)].homogeneous.copy(),
                d.oMf[self.robot.frame_id(self.robot.right_sole)].homogeneous.copy())

    @staticmethod
    def _midpoint(lf, rf) -> tuple[float, float, float]:
        return 0.5 * (lf[0, 3] + rf[0, 3]), 0.5 * (lf[1, 3] + rf[1, 3]), mean_heading(lf, rf)

    def _width(self, lf, rf) -> float:
        """Lateral distance (m) between the soles across their mean heading."""
        yaw = mean_heading(lf, rf)
        dx, dy = lf[0, 3] - rf[0, 3], lf[1, 3] - rf[1, 3]
        return abs(-math.sin(yaw) * dx + math.cos(yaw) * dy)

    def _goal_steps(self, lf, rf, goal, first, width):
        """(n_steps, step_length, step_lateral, turn, first side) whose final feet mid-point and heading put the
        base at ``goal`` (module docstring)."""
        gx, gy, gyaw = goal
        ox, oy = self._base_offset
        c, s = math.cos(gyaw), math.sin(gyaw)
        tx, ty = gx - (c * ox - s * oy), gy - (s * ox + c * oy)  # feet mid-point target
        mx, my, yaw0 = self._midpoint(lf, rf)
        dyaw = wrap_angle(gyaw - yaw0)
        c0, s0 = math.cos(yaw0), math.sin(yaw0)
        fwd, lat = c0 * (tx - mx) + s0 * (ty - my), -s0 * (tx - mx) + c0 * (ty - my)
        T = self.step_duration
        if not self.can_turn and abs(dyaw) > math.radians(0.5):
            raise GaitError(f"{self.robot.name}'s legs cannot yaw one sole relative to the other (no hip yaw joint): "
                            f"a goal heading change of {math.degrees(dyaw):.1f} deg cannot be walked; valid: the "
                            "current heading")
        n_walk = max(1, math.ceil(max(abs(fwd) / (self.max_velocity * T), abs(lat) / (self.max_lateral * T),
                                      abs(dyaw) / (self.max_turn * T) if self.can_turn else 0.0) - 1e-9))
        if not self.can_turn:
            dyaw = 0.0
        turn = dyaw / n_walk
        side = first or ("right" if lat < 0 else "left")
        L, d = steps_to_midpoint(pose_to_xy_yaw(lf), pose_to_xy_yaw(rf), (tx, ty), n_walk, width, turn, side,
                                 lat >= 0)
        return n_walk + 1, L, d, float(turn), side


def steps_to_midpoint(left, right, target, n_walk: int, width: float, turn: float, side: str,
                      to_the_left: bool) -> tuple[float, float]:
    """(step_length, step_lateral) (m) of a walk of ``n_walk`` walking steps and a closing step
    (:func:`wbc.gait.footsteps.plan_footsteps` with ``turn`` rad per step, ``width`` m, ``side`` swinging first)
    whose final feet mid-point is ``target`` (x, y) (m, world) exactly, from the soles ``left``, ``right``
    ``(x, y, yaw)``: the mid-point is affine in both for a fixed turn, solved from three evaluations.
    ``to_the_left``: whether the target lies left of the current heading (the side of the leading foot tried first;
    the other is tried when the solve gives a negative lateral step).

    Raises:
        numpy.linalg.LinAlgError: a singular solve (no such steps).
    """
    def end(L, d):
        steps = plan_footsteps(left, right, n_walk + 1, L, width, turn, side, d)
        a, b = steps[-1], steps[-2]
        return np.array([0.5 * (a.x + b.x), 0.5 * (a.y + b.y)])

    goal = np.asarray(target, dtype=float)
    e0 = end(0.0, 0.0)
    sign = 1.0 if to_the_left else -1.0
    J = np.column_stack([end(1.0, 0.0) - e0, end(0.0, sign) - e0])
    L, dd = np.linalg.solve(J, goal - e0)
    if dd < 0:  # the lateral step's sign flipped: solve with the other leading foot
        sign = -sign
        J[:, 1] = end(0.0, sign) - e0
        L, dd = np.linalg.solve(J, goal - e0)
    return float(L), float(sign * dd)
