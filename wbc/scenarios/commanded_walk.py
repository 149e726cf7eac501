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
  The re-plan of a velocity command is computed three ticks before its touch-down (its inputs, the plan's samples
  at the touch-down and the command, are known then) and its rows two ticks before, so that no tick does more than
  one of the three parts (plan, rows, the switch) and the touch-down tick only swaps it in; if the command, a goal
  or a stop came in between, the touch-down tick plans as above.
* **Pose goal** ``(x, y, yaw)`` of the base (world): the footsteps reaching it (:func:`wbc.gait.commands.goal_steps`:
  ``n`` walking steps and a closing step, within the speed limits) are planned at once (from the standing stance,
  or from the next touch-down when walking). Backward steps are planned (``max_backward = max_velocity``).
* **Stop** (:meth:`stop`): in a double support before a step (at least 0.1 s of it left) the closing step is
  planned at once, the remaining double support as its initial one; during a swing, at its touch-down. Standing
  once the closing step has settled: at most one step starts after a stop.

Frames and units: world frame (``odom``), z up, flat ground; m, s, rad.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from wbc.solvers import DEFAULT_SOLVER
from wbc.configuration import Configuration
from wbc.exceptions import GaitError, InvalidInputError
from wbc.gait import plan_walk
from wbc.gait.commands import CommandLimits, Stance, check_finite, check_velocity, feet_can_yaw, goal_steps
from wbc.gait.footsteps import pose_to_xy_yaw
from wbc.robot import Robot
from wbc.scenarios.walk import WalkController
from wbc.tasks.base import ValidatedAttribute

__all__ = ["CommandedWalk"]

_DOUBLE = 0


def _check_bool(value, name: str) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        raise InvalidInputError(f"{name} must be True or False; got {value!r}")
    return bool(value)


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

    Attributes:
        plan_ahead: True (default): a velocity command's touch-down re-plan is made ahead (module docstring);
            False: in the touch-down tick. The walk is the same either way; only the ticks that pay for it differ.
        replans, early_replans, replan_failures, touchdowns: counts since the start (``early_replans``: re-plans
            made ahead and taken at their touch-down).

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
        self.can_turn = feet_can_yaw(robot, self.config.q)
        self.max_turn = check_finite(max_turn, "max_turn", 1e-3, 3.0) if self.can_turn else 0.0
        self._solver = solver
        self.walker = WalkController(robot, self.config, solver=solver)
        self._clock_guard = False
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
        self.early_replans = 0  # touch-down re-plans made ahead (module docstring) and taken at the touch-down
        self.plan_ahead = True  # False: every touch-down re-plan is made in the touch-down tick
        self.replan_failures = 0
        self.touchdowns = 0
        self.last_error = ""
        # the base's offset from the feet mid-point and the nominal step width, at q_ref (side steps widen the
        # stance only transiently)
        self._stance = Stance.of(self.config.q[:2], *self._soles())

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
    plan_ahead = ValidatedAttribute(lambda walk, v: _check_bool(v, "plan_ahead"),
                                    "Touch-down re-plans made ahead (module docstring): a bool (raises "
                                    "InvalidInputError otherwise).")

    @property
    def limits(self) -> CommandLimits:
        """The command limits now (backward as fast as forward)."""
        return CommandLimits(self.max_velocity, self.max_velocity, self.max_lateral, self.max_turn, self.can_turn,
                             self.robot.name)

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
        return self._stance.footprint_pose(*self._soles())

    def time_remaining(self) -> float:
        """Time (s) until the current plan ends (0 when standing)."""
        return 0.0 if self.plan is None else (self.plan.n_samples - self.k) * self.dt

    # -- commands ----------------------------------------------------------------------------------------------
    def set_velocity(self, vx: float, vy: float = 0.0, wz: float = 0.0) -> None:
        """Velocity command (m/s, m/s, rad/s, walking frame); zeros stop at the next touch-down.

        Raises:
            InvalidInputError: non-finite or beyond ``max_velocity`` / ``max_lateral`` / ``max_turn``.
        """
        self.command[:] = check_velocity(vx, vy, wz, self.limits)
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

    @property
    def clock_guard(self) -> bool:
        """The kinematic controller's clock guard (:class:`wbc.controllers.kinematic.KinematicController`; False
        by default, True in a real-time loop such as ``wbc ros2 node``); kept over :meth:`reset`."""
        return self._clock_guard

    @clock_guard.setter
    def clock_guard(self, value: bool) -> None:
        self._clock_guard = bool(value)
        self.walker.controller.clock_guard = self._clock_guard

    def reset(self) -> None:
        """Back to the reference standing configuration, standing, no command."""
        self.config.update(self.robot.q_ref.copy())
        self.walker = WalkController(self.robot, self.config, solver=self._solver, clock_guard=self._clock_guard)
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
            self._next_touchdown = self._touchdowns.pop(0) if self._touchdowns else -10
            self.touchdowns += 1
            self._stop_now = False
            self._at_touchdown()
        elif self._stop_now:
            self._stop_now = False
            self._close_in_double_support()
        if self.plan is None:
            self.v[:] = 0.0
        else:
            if self.k == self._next_touchdown - 3 and self.plan_ahead:
                self._prepare_touchdown()
            elif self.k == self._next_touchdown - 2 and self._early is not None:
                self.walker.prepare_plan(self._early[2])
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

    @property
    def plan(self):
        """The plan being tracked (a :class:`~wbc.gait.WalkPlan`), or None when standing."""
        return self._plan

    @plan.setter
    def plan(self, plan) -> None:
        self._plan, self._early = plan, None
        self._touchdowns = [] if plan is None else (np.flatnonzero(
            (plan.support[1:] == _DOUBLE) & (plan.support[:-1] != _DOUBLE)) + 1).tolist()
        self._next_touchdown = self._touchdowns.pop(0) if self._touchdowns else -10

    def _early_inputs(self) -> tuple:
        """What a touch-down re-plan depends on besides the plan: the command, goal and stop state, the timing."""
        return (tuple(self.command), self.goal, self._pending_goal, self._stop, self._t_ss, self._t_ds, self.horizon,
                self.step_height)

    def _prepare_touchdown(self) -> None:
        """Three ticks before the next touch-down of a velocity-command walk: its re-plan (:meth:`_at_touchdown`)."""
        k = self._next_touchdown
        if self.goal is not None or self._pending_goal is not None or not np.any(self.command):
            return  # goals and stops: planned in the touch-down tick
        landed = int(self.plan.support[k - 1])
        failures, error = self.replan_failures, self.last_error
        new = self._plan_from_state((k, "left" if landed == 1 else "right"))
        self.replan_failures, self.last_error = failures, error  # counted when the touch-down tick plans
        if new is not None:
            self._early = (k, self._early_inputs(), new)

    def _at_touchdown(self) -> None:
        plan, k = self.plan, self.k
        early, self._early = self._early, None
        steps_left = sum(1 for ph in plan.phases if ph.support != _DOUBLE and ph.first >= k)
        if self._pending_goal is None and self.goal is not None and not self._stop:
            return  # walking to a goal: its plan already ends there
        if self._pending_goal is None and not np.any(self.command) and steps_left <= 1:
            return  # already closing (or closed)
        landed = int(plan.support[k - 1])  # 1: left stance, right swung; 2: right stance, left swung
        first = "left" if landed == 1 else "right"
        if early is not None and early[0] == k and early[1] == self._early_inputs():
            new = early[2]  # planned three ticks ago from these same inputs
            self.early_replans += 1
        else:
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
        width = self._stance.width
        try:
            if self._pending_goal is not None:
                goal, self._pending_goal = self._pending_goal, None
                n, L, d, turn, side = goal_steps(lf, rf, goal, self.step_duration, self.limits, self._stance, first)
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
    def _soles(self):
        d = self.config.data
        return (d.oMf[self.robot.frame_id(self.robot.left_sole)].homogeneous.copy(),
                d.oMf[self.robot.frame_id(self.robot.right_sole)].homogeneous.copy())
