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

The command logic (what is asked, what is due when, the steps of it) is :class:`wbc.gait.commanded.WalkCommands`'s
with a receding horizon (``receding``), backward steps, a failed start retried after 0.5 s; this module plans its
steps with :func:`wbc.gait.plan_walk` and integrates the kinematic controller's velocity.

Frames and units: world frame (``odom``), z up, flat ground; m, s, rad.
"""

from __future__ import annotations

import numpy as np

from wbc.solvers import DEFAULT_SOLVER
from wbc.configuration import Configuration
from wbc.exceptions import GaitError, InvalidInputError
from wbc.gait import plan_walk
from wbc.gait.commanded import CLOSE, GOAL, WalkCommands
from wbc.gait.commands import Stance, check_finite, feet_can_yaw
from wbc.robot import Robot
from wbc.scenarios.walk import WalkController
from wbc.tasks.base import ValidatedAttribute

__all__ = ["CommandedWalk"]

_DOUBLE = 0


def _check_bool(value, name: str) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        raise InvalidInputError(f"{name} must be True or False; got {value!r}")
    return bool(value)


class CommandedWalk(WalkCommands):
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
        early_replans, touchdowns: counts since the start (``early_replans``: re-plans made ahead and taken at
            their touch-down); the command state and the other counts: :class:`~wbc.gait.commanded.WalkCommands`.

    Raises:
        InvalidInputError: a non-finite or out-of-range argument (the message names it and the valid range).
    """

    def __init__(self, robot: Robot, *, dt: float = 0.002, solver: str = DEFAULT_SOLVER, horizon: int = 3,
                 step_duration: float | None = None, max_velocity: float = 0.3, max_lateral: float = 0.1,
                 max_turn: float = 0.5):
        self.dt = check_finite(dt, "dt", 1e-4, 0.1)
        gait = dict(robot.gait)
        self._t_ss0 = float(gait.get("t_ss", 0.8))
        self._t_ds0 = float(gait.get("t_ds", 0.3))
        self.step_height = float(gait.get("step_height", 0.05))
        self.step_duration = self._t_ss0 + self._t_ds0 if step_duration is None else step_duration
        self.config = Configuration(robot)
        super().__init__(robot, max_velocity=max_velocity, max_lateral=max_lateral, max_turn=max_turn,
                         can_turn=feet_can_yaw(robot, self.config.q), steps_per_plan=horizon, plan_name="horizon",
                         backward=True, receding=True, retry=0.5, top_speed=2.0)
        self._solver = solver
        self.walker = WalkController(robot, self.config, solver=solver)
        self._clock_guard = False
        self.v = np.zeros(robot.model.nv)
        self.t = 0.0
        self.plan = None
        self.k = 0
        self._stop_now = False
        self.early_replans = 0  # touch-down re-plans made ahead (module docstring) and taken at the touch-down
        self.plan_ahead = True  # False: every touch-down re-plan is made in the touch-down tick
        self.touchdowns = 0
        # the base's offset from the feet mid-point and the nominal step width, at q_ref (side steps widen the
        # stance only transiently)
        self.stance = Stance.of(self.config.q[:2], *self.soles())

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

    plan_ahead = ValidatedAttribute(lambda walk, v: _check_bool(v, "plan_ahead"),
                                    "Touch-down re-plans made ahead (module docstring): a bool (raises "
                                    "InvalidInputError otherwise).")

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

    def time_remaining(self) -> float:
        """Time (s) until the current plan ends (0 when standing)."""
        return 0.0 if self.plan is None else (self.plan.n_samples - self.k) * self.dt

    # -- commands ----------------------------------------------------------------------------------------------
    def stop(self) -> None:
        """Stop (:meth:`WalkCommands.stop <wbc.gait.commanded.WalkCommands.stop>`): the closing step is planned in
        the next tick when that tick is in a double support before a step with at least 0.1 s of it left, else at
        the next touch-down; standing, there is nothing to close (a later command or goal walks as usual)."""
        super().stop()
        self._stop_now = self.plan is not None

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
        self._stop_now = False
        self.clear_commands()

    # -- one tick ----------------------------------------------------------------------------------------------
    def tick(self) -> None:
        """Advance one control period ``dt``: (re)plan if due, then one QP tick (or hold when standing)."""
        plan = self.plan
        if plan is None:
            due = self.start_due(self.t)
            if due is not None:
                self._take(self._plan_from_state(due, None))  # (failed: retried 0.5 s later)
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
                self.walker.prepare_plan(self._early[2][0])
            self.walker.set_references(self.plan, self.k, self.config)
            result = self.walker.solve(self.config, self.dt)
            self.config.step(result.v, self.dt)
            self.v[:] = result.v
            self.k += 1
            if self.k >= self.plan.n_samples:
                self.plan, self.k = None, 0
                self.walk_ended()
        self.t += self.dt

    def _take(self, new) -> None:
        """Walk ``new`` = (plan, steps) from now (None: keep the plan)."""
        if new is not None:
            self.plan, self.k = new[0], 0
            self.taken(new[1])

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
        """What a touch-down re-plan depends on besides the plan: the command and goal state, the timing."""
        return (tuple(self.command), self.goal, self.pending_goal, self._t_ss, self._t_ds, self.steps_per_plan,
                self.step_height)

    def _prepare_touchdown(self) -> None:
        """Three ticks before the next touch-down of a velocity-command walk: its re-plan (:meth:`_at_touchdown`)."""
        k = self._next_touchdown
        due = self.wanted()
        if due == GOAL or due == CLOSE:
            return  # goals and stops: planned in the touch-down tick
        landed = int(self.plan.support[k - 1])
        failures, error = self.replan_failures, self.last_error
        new = self._plan_from_state(due, (k, "left" if landed == 1 else "right"))
        self.replan_failures, self.last_error = failures, error  # counted when the touch-down tick plans
        if new is not None:
            self._early = (k, self._early_inputs(), new)

    def _at_touchdown(self) -> None:
        plan, k = self.plan, self.k
        early, self._early = self._early, None
        steps_left = sum(1 for ph in plan.phases if ph.support != _DOUBLE and ph.first >= k)
        due = self.touchdown_due(steps_left)
        if due is None:
            return  # walking to a goal (its plan already ends there), or already closing (or closed)
        landed = int(plan.support[k - 1])  # 1: left stance, right swung; 2: right stance, left swung
        first = "left" if landed == 1 else "right"
        if early is not None and early[0] == k and early[1] == self._early_inputs():
            new = early[2]  # planned three ticks ago from these same inputs
            self.early_replans += 1
        else:
            new = self._plan_from_state(due, (k, first))
        self._take(new)

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
        self._take(self._plan_from_state(self.wanted(), (k, first), t_init=left))

    def _plan_from_state(self, due, at, t_init: float | None = None):
        """(plan, steps) of ``due`` (:mod:`wbc.gait.commanded`) from the current double support, or None when it
        cannot be planned (counted): ``at`` None (standing) or (k, first swinging side)."""
        if at is None:
            lf, rf = self.soles()
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
        try:
            s = self.steps(due, self.step_duration, first, (lf, rf))
            plan = plan_walk(lf, rf, com, n_steps=s.n_steps, step_length=s.step_length, step_lateral=s.step_lateral,
                             turn=s.turn, first_side=s.first_side, step_width=self.stance.width, **kwargs)
        except (GaitError, np.linalg.LinAlgError) as exc:
            self.failed(exc, self.t if at is None else None)
            return None
        return plan, s

    # -- geometry ----------------------------------------------------------------------------------------------
    def soles(self) -> tuple[np.ndarray, np.ndarray]:
        """((4, 4), (4, 4)) the left and right sole poses (world) of the current configuration."""
        d = self.config.data
        return (d.oMf[self.robot.frame_id(self.robot.left_sole)].homogeneous.copy(),
                d.oMf[self.robot.frame_id(self.robot.right_sole)].homogeneous.copy())
