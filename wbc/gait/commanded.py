"""The command logic of a commanded walk, written once: what is asked (stand, velocity, pose goal, stop), what is
due to be planned and when, and the steps that answer it.

:class:`WalkCommands` is the base class of both commanded walks: the kinematic one
(:class:`wbc.scenarios.commanded_walk.CommandedWalk`: :func:`wbc.gait.plan_walk` plans tracked by the kinematic
controller) and the physics one (:class:`wbc.sim.commanded.SimCommandedWalk`: :class:`wbc.sim.walk.WalkScenario`
segments in MuJoCo under the inverse-dynamics controller). It holds the command, the goal and the limits, validates
what it is asked, says what is due and turns that into steps (:mod:`wbc.gait.commands`); a walk keeps only how it
plans those steps and how it advances its plant.

Commands (frames and units: world ``odom``, z up, flat ground; m, s, rad):

* **Velocity** ``(vx, vy, wz)`` (m/s, m/s, rad/s, walking frame: x forward along the mean heading of the soles, y
  left; :meth:`WalkCommands.set_velocity`) within :attr:`WalkCommands.limits`; clears any goal.
* **Pose goal** ``(x, y, yaw)`` of the base (:meth:`WalkCommands.set_goal`): waits in
  :attr:`WalkCommands.pending_goal` until planned, then is :attr:`WalkCommands.goal` until the walk ends; zeroes the
  command.
* **Stop** (:meth:`WalkCommands.stop`, or a zero velocity): clears the command and the goal; the walk ends with a
  closing step.

What is due (a ``due``): ``"goal"`` (:data:`GOAL`, plan the pending goal), ``"close"`` (:data:`CLOSE`, one closing
step: the swinging foot set beside the other) or the command tuple ``(vx, vy, wz)`` (floats).

* **Standing** (:meth:`WalkCommands.start_due`): the pending goal, else a nonzero command (nothing before the retry
  time of a failed start).
* **In the double support after a touch-down** (:meth:`WalkCommands.touchdown_due`, ``steps_left`` walking steps of
  the plan still to start): walking to a goal, nothing; a stop (zero command, or a new goal of a segment walk), the
  closing step unless the plan is closing already (one step or less left, or it was planned as one); a velocity
  command, a re-plan of it: at every touch-down with a receding horizon (``receding``), else (segments) only when
  the command changed or the next step is the plan's closing one. A goal set while walking is planned from the next
  touch-down with a receding horizon, walked once standing with segments.

The steps of a due (:meth:`WalkCommands.steps`): a goal, ``n`` walking steps and a closing one within the limits
(:func:`wbc.gait.commands.goal_steps`); a close, one step of length 0; a command, ``steps_per_plan`` steps (the last
closing) of length ``vx T``, lateral step ``vy T`` and turn ``wz T`` (``T`` the step duration), the right foot
first when ``vy < 0`` (or ``vy = 0`` and ``wz < 0``), else the left.

Where the two walks differ, a constructor argument (the kinematic walk's value first, then the physics walk's):
``backward`` (True, False: :class:`~wbc.sim.walk.WalkScenario` plans forward steps only), ``receding`` (True,
False), ``retry`` (0.5 s, None: the command is dropped), ``top_speed`` (2, 1 m/s), ``steps_per_plan`` (``horizon``
3, ``segment_steps`` 4).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import pinocchio as pin

from wbc.exceptions import InvalidInputError
from wbc.gait.commands import CommandLimits, Stance, check_finite, check_velocity, goal_steps
from wbc.gait.footsteps import pose_to_xy_yaw
from wbc.tasks.base import ValidatedAttribute

__all__ = ["CLOSE", "GOAL", "Steps", "WalkCommands"]

GOAL = "goal"  #: the due of a pending goal
CLOSE = "close"  #: the due of a closing step


class Steps(NamedTuple):
    """The steps that answer a due (module docstring).

    Attributes:
        n_steps: steps, the last one closing (>= 1).
        step_length: m, along the heading. step_lateral: m, to the left. turn: rad per step (counter-clockwise).
        first_side: ``"left"`` or ``"right"``, the foot swinging first (None: the planner's choice; a close with no
            side given).
        due: what they walk: :data:`GOAL`, :data:`CLOSE` or the command ``(vx, vy, wz)``.
        goal: the goal ``(x, y, yaw)`` (m, m, rad, world) they reach, None unless ``due`` is :data:`GOAL`.
    """

    n_steps: int
    step_length: float
    step_lateral: float
    turn: float
    first_side: str | None
    due: object
    goal: tuple[float, float, float] | None = None


class WalkCommands:
    """The command logic of a commanded walk (module docstring): the base class of both commanded walks.

    A walk sets :attr:`stance` (its reference stance) and defines :attr:`walking`, :attr:`q` and :meth:`soles`;
    it asks :meth:`start_due` / :meth:`touchdown_due`, plans :meth:`steps`, then reports :meth:`taken` (or
    :meth:`failed`) and :meth:`walk_ended`.

    Args:
        robot: the :class:`wbc.robot.Robot` (its name is in the messages).
        max_velocity: forward speed limit, m/s, in [0.001, ``top_speed``].
        max_lateral: lateral speed limit, m/s, in [0.001, 2].
        max_turn: yaw rate limit, rad/s, in [0.001, 3]; 0 (not checked) when ``can_turn`` is False.
        can_turn: the legs can yaw one sole relative to the other (:func:`wbc.gait.commands.feet_can_yaw`); False:
            turning commands are refused and goals must keep the heading.
        steps_per_plan: steps of a velocity command's plan (an integer >= 2: at least one walking step and the
            closing one). plan_name: its name in the messages (``"horizon"``, ``"segment_steps"``).
        backward: backward steps are planned (:attr:`max_backward` = ``max_velocity``); False: none
            (:attr:`max_backward` 0, goals behind the robot refused).
        receding: a receding horizon (velocity re-planned at every touch-down, a goal set while walking planned from
            the next touch-down); False: segments (module docstring).
        retry: s after which a start whose plan failed is tried again (command kept); None: the command is dropped.
        top_speed: the highest ``max_velocity`` accepted, m/s.

    Attributes:
        command: (3,) the velocity command (vx m/s, vy m/s, wz rad/s), zeros when none.
        goal: the goal ``(x, y, yaw)`` being walked to (None: none, or the walk ended).
        pending_goal: the goal set and not planned yet (None: none).
        planned: what the plan being walked walks: a due (None after :meth:`clear_commands`).
        replans, replan_failures: plans taken and failed since the start; last_error: the last failure's message.

    Raises:
        InvalidInputError: a limit out of range or a bad ``steps_per_plan`` (named, with the valid range).
    """

    max_velocity = ValidatedAttribute(lambda walk, v: check_finite(v, "max_velocity (m/s)", 1e-3, walk.top_speed),
                                      "Forward speed limit, m/s (in [0.001, top_speed]; raises InvalidInputError).")

    def __init__(self, robot, *, max_velocity: float, max_lateral: float, max_turn: float, can_turn: bool,
                 steps_per_plan: int, plan_name: str, backward: bool, receding: bool, retry: float | None,
                 top_speed: float):
        if isinstance(steps_per_plan, bool) or not isinstance(steps_per_plan, (int, np.integer)) \
                or steps_per_plan < 2:
            raise InvalidInputError(f"{plan_name} must be an integer >= 2 (steps); got {steps_per_plan!r}")
        self.robot = robot
        self.steps_per_plan = int(steps_per_plan)
        self.backward, self.receding, self.retry, self.top_speed = bool(backward), bool(receding), retry, top_speed
        self.max_velocity = max_velocity
        self.max_lateral = check_finite(max_lateral, "max_lateral (m/s)", 1e-3, 2.0)
        self.can_turn = bool(can_turn)
        self.max_turn = check_finite(max_turn, "max_turn (rad/s)", 1e-3, 3.0) if self.can_turn else 0.0
        self.command = np.zeros(3)
        self.goal: tuple[float, float, float] | None = None
        self.pending_goal: tuple[float, float, float] | None = None
        self.planned = None
        self.replans = 0
        self.replan_failures = 0
        self.last_error = ""
        self.stance: Stance | None = None
        self._retry_at = 0.0

    # -- limits ------------------------------------------------------------------------------------------------
    @property
    def max_backward(self) -> float:
        """Backward speed limit, m/s: ``max_velocity`` when backward steps are planned, else 0."""
        return self.max_velocity if self.backward else 0.0

    @property
    def limits(self) -> CommandLimits:
        """The command limits now."""
        return CommandLimits(self.max_velocity, self.max_backward, self.max_lateral, self.max_turn, self.can_turn,
                             self.robot.name)

    # -- the walk's side -----------------------------------------------------------------------------------------
    @property
    def walking(self) -> bool:
        """A plan is being walked (False: standing). Defined by the walk."""
        raise NotImplementedError

    @property
    def q(self) -> np.ndarray:
        """(nq,) the configuration of the walk (free flyer first). Defined by the walk."""
        raise NotImplementedError

    def soles(self) -> tuple[np.ndarray, np.ndarray]:
        """((4, 4), (4, 4)) the left and right sole poses (world) at :attr:`q`. Defined by the walk."""
        raise NotImplementedError

    # -- state -------------------------------------------------------------------------------------------------
    @property
    def idle(self) -> bool:
        """Standing still with no command and no goal waiting."""
        return not self.walking and self.pending_goal is None and not np.any(self.command)

    def base_pose(self) -> tuple[float, float, float]:
        """(x, y, yaw) of the free flyer in :attr:`q` (m, m, rad), world."""
        q = self.q
        yaw = pose_to_xy_yaw(pin.XYZQUATToSE3(q[:7]).homogeneous)[2]
        return float(q[0]), float(q[1]), yaw

    def footprint_pose(self) -> tuple[float, float, float]:
        """(x, y, yaw) where the base would stand at rest over the soles of :attr:`q` (m, m, rad, world): the feet
        mid-point and mean heading plus the base's offset from them in :attr:`stance`. It moves only while a foot
        swings, so its distance to a goal does not sway with the CoM."""
        return self.stance.footprint_pose(*self.soles())

    # -- commands ----------------------------------------------------------------------------------------------
    def set_velocity(self, vx: float, vy: float = 0.0, wz: float = 0.0) -> None:
        """Velocity command (m/s, m/s, rad/s, walking frame), taking effect at the next touch-down (or at once when
        standing); zeros: stop (module docstring). Clears the goal.

        Raises:
            InvalidInputError: non-finite, beyond ``[-max_backward, max_velocity]`` / ``max_lateral`` /
                ``max_turn``, or a turn for legs that cannot turn (nothing is applied).
        """
        self.command[:] = check_velocity(vx, vy, wz, self.limits)
        self.goal = self.pending_goal = None

    def set_goal(self, x: float, y: float, yaw: float) -> None:
        """Walk the base to ``(x, y, yaw)`` (m, m, rad, world); replaces any command or goal (module docstring:
        when it is planned).

        Raises:
            InvalidInputError: non-finite values (nothing is applied).
        """
        self.pending_goal = (check_finite(x, "goal x (m)"), check_finite(y, "goal y (m)"),
                             check_finite(yaw, "goal yaw (rad)"))
        self.command[:] = 0.0

    def stop(self) -> None:
        """Stop walking: the walk ends with a closing step (module docstring); clears the command and the goal."""
        self.command[:] = 0.0
        self.goal = self.pending_goal = None

    def clear_commands(self) -> None:
        """No command, no goal, nothing planned (a walk's reset)."""
        self.command[:] = 0.0
        self.goal = self.pending_goal = None
        self.planned = None

    # -- what is due -------------------------------------------------------------------------------------------
    def wanted(self):
        """What the commands ask for, whatever the plan: :data:`GOAL` when a goal waits, the command tuple when it
        is nonzero, else :data:`CLOSE`."""
        if self.pending_goal is not None:
            return GOAL
        if np.any(self.command):
            return tuple(float(c) for c in self.command)
        return CLOSE

    def start_due(self, t: float):
        """What to plan when standing at time ``t`` (s): :data:`GOAL`, the command tuple, or None (nothing asked,
        or before the retry time of a failed start)."""
        if t < self._retry_at:
            return None
        due = self.wanted()
        return None if due == CLOSE else due

    def touchdown_due(self, steps_left: int):
        """What to plan in the double support after a touch-down with ``steps_left`` walking steps of the plan
        still to start (module docstring): a due, or None (keep the plan)."""
        if self.pending_goal is not None and self.receding:
            return GOAL
        if self.pending_goal is not None or not np.any(self.command):
            if self.goal is not None and self.planned == GOAL:
                return None  # walking to the goal
            return CLOSE if steps_left > 1 and self.planned != CLOSE else None
        command = tuple(float(c) for c in self.command)
        if self.receding or command != self.planned or steps_left == 1:
            return command
        return None

    def steps(self, due, step_duration: float, first: str | None = None, soles=None) -> Steps:
        """The :class:`Steps` of ``due`` (module docstring) with steps of ``step_duration`` (s). ``first``: the
        side that must swing first (None: the command's or the goal's side). ``soles``: the (4, 4) left and right
        sole poses (world) the walk starts from, needed for a goal. A goal's steps take it out of
        :attr:`pending_goal`.

        Raises:
            GaitError, numpy.linalg.LinAlgError: a goal that cannot be walked (:func:`wbc.gait.commands.goal_steps`).
        """
        if due == GOAL:
            goal, self.pending_goal = self.pending_goal, None
            n, length, lateral, turn, side = goal_steps(*soles, goal, step_duration, self.limits, self.stance, first)
            return Steps(n, length, lateral, turn, side, GOAL, goal)
        if due == CLOSE:
            return Steps(1, 0.0, 0.0, 0.0, first, CLOSE)
        vx, vy, wz = due
        side = first or ("right" if vy < 0 or (vy == 0 and wz < 0) else "left")
        return Steps(self.steps_per_plan, vx * step_duration, vy * step_duration, wz * step_duration, side, due)

    # -- bookkeeping -------------------------------------------------------------------------------------------
    def taken(self, steps: Steps) -> None:
        """The walk now walks ``steps``: counted in :attr:`replans`; a goal's becomes :attr:`goal`."""
        self.planned = steps.due
        if steps.goal is not None:
            self.goal = steps.goal
        self.replans += 1

    def failed(self, error: Exception, t: float | None = None) -> None:
        """A plan failed with ``error``: counted in :attr:`replan_failures`, its message in :attr:`last_error`.
        ``t``: a start that failed at time ``t`` (s): tried again ``retry`` s later, or its command dropped."""
        self.replan_failures += 1
        self.last_error = str(error)
        if t is not None:
            if self.retry is None:
                self.command[:] = 0.0
            else:
                self._retry_at = t + self.retry

    def walk_ended(self) -> None:
        """The walk stands again: no goal being walked to."""
        self.goal = None
