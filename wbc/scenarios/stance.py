"""Stance controller: the kinematic QP wired for a humanoid standing or stepping on flat ground.

Tasks: CoM (weight 10), torso orientation (1), posture on every DoF (1e-2), and a frame task on each swinging
sole (10 on position and orientation). Constraints: each stance sole is a hard contact; joint position and
velocity limits; the ZMP of the executed motion inside the stance soles' polygon
(:class:`~wbc.constraints.zmp.ExecutedZmpConstraint`, relaxable); optional extra constraints (e.g. CoM in the
support polygon). Contact switching
(:meth:`StanceController.set_support`): a sole that touches down is held where it is; one that lifts off gets
a swing task starting at its current placement. Walking (:mod:`wbc.scenarios.walk`) and the balance behaviours
(:mod:`wbc.scenarios.balance_control`) are both this controller with their own references.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from wbc.configuration import Configuration
from wbc.constants import SIDES
from wbc.constraints import ContactConstraint, JointAccelerationLimit, JointPositionLimit, JointVelocityLimit
from wbc.constraints.base import Constraint
from wbc.constraints.braking import JointBrakingLimit
from wbc.constraints.zmp import ExecutedZmpConstraint
from wbc.exceptions import InvalidInputError
from wbc.controllers.kinematic import KinematicController
from wbc.tick import TickResult
from wbc.gait.schedule import Support
from wbc.solvers import DEFAULT_SOLVER
from wbc.robot import Robot
from wbc.scenarios.framework import MotionRun
from wbc.tasks import ComTask, FrameTask, OrientationTask, PostureTask
from wbc.tick import PATH_DTYPE

__all__ = ["Support", "DOUBLE", "LEFT_STANCE", "RIGHT_STANCE", "StanceController", "StanceRecorder", "StanceRun"]

#: Support codes (as in :class:`wbc.gait.WalkPlan`): double support, left stance (right swinging), right stance.
# The support codes of :class:`wbc.gait.schedule.Support` under the scenarios' names.
DOUBLE, LEFT_STANCE, RIGHT_STANCE = Support.DOUBLE, Support.LEFT, Support.RIGHT


class StanceController:
    """The stance wiring of the module docstring around a :class:`~wbc.controllers.kinematic.KinematicController`.

    Args:
        robot: the robot.
        config: current configuration: both soles start in contact where they are; CoM, torso and posture targets
            start at their current values.
        solver: QP backend name.
        com_gain, foot_gain, torso_gain, posture_gain: task gains K (1/s); ``foot_gain`` also drives the
            contacts' drift correction.
        extra_constraints: added after the contacts (before the joint limits).
        zmp_margin: margin (m) of the :class:`~wbc.constraints.zmp.ExecutedZmpConstraint` that keeps the ZMP of
            the executed motion inside the support polygon of the stance soles (None: no such constraint).
        joint_acceleration: a_max (rad/s²) of a :class:`~wbc.constraints.JointAccelerationLimit` on every actuated
            joint and of a :class:`~wbc.constraints.braking.JointBrakingLimit` (joints approach their position
            limits no faster than they can stop at a_max); both relaxable; None: neither.
        **controller_options: passed to :class:`~wbc.controllers.kinematic.KinematicController` (e.g. ``rank_rtol``).
    """

    def __init__(self, robot: Robot, config: Configuration, *, solver: str = DEFAULT_SOLVER,
                 com_gain: float = 100.0, foot_gain: float = 100.0, torso_gain: float = 50.0,
                 posture_gain: float = 10.0, extra_constraints: tuple[Constraint, ...] = (),
                 zmp_margin: float | None = 0.002, joint_acceleration: float | None = None, **controller_options):
        self.robot = robot
        self.com = ComTask(weight=10.0, gain=com_gain)
        self.com.set_target(config.com.copy())
        self.torso = OrientationTask(robot, robot.torso, weight=1.0, gain=torso_gain, name="torso")
        self.torso.set_target_from_configuration(config)
        self.posture = PostureTask(robot, weight=1e-2, gain=posture_gain)
        self.posture.set_target(config.q)
        frames = {"left": robot.left_sole, "right": robot.right_sole}
        self.swing = {side: FrameTask(robot, frames[side], position_weight=10.0, orientation_weight=10.0,
                                      gain=foot_gain, name=f"swing:{side}") for side in SIDES}
        self.contact = {side: ContactConstraint(robot, frames[side], gain=foot_gain) for side in SIDES}
        for c in self.contact.values():
            c.set_placement_from_configuration(config)
        self.zmp = None if zmp_margin is None else ExecutedZmpConstraint(robot, margin=zmp_margin)
        if self.zmp is not None:
            self.zmp.set_support([self.contact[s].placement for s in SIDES])
            extra_constraints = (*extra_constraints, self.zmp)
            config.keep_centroidal_map()  # the ZMP rows read Ag every tick: computed in the kinematics update
        smooth = () if joint_acceleration is None else (
            JointAccelerationLimit(robot, a_max=joint_acceleration), JointBrakingLimit(robot, a_max=joint_acceleration))
        self.smoothness = smooth
        self.controller = KinematicController(
            robot, [self.com, self.torso, self.posture],
            [self.contact["left"], self.contact["right"], *extra_constraints, JointPositionLimit(robot),
             JointVelocityLimit(robot), *smooth],
            solver=solver, **controller_options,
        )
        self.stance = {"left": True, "right": True}
        self.support = DOUBLE

    def set_support(self, support: int, config: Configuration) -> None:
        """Switch to a support phase (0 double, 1 left stance, 2 right stance) at the current configuration."""
        if support == self.support:
            return
        wanted = {"left": support in (DOUBLE, LEFT_STANCE), "right": support in (DOUBLE, RIGHT_STANCE)}
        for side in SIDES:
            if wanted[side] == self.stance[side]:
                continue
            if wanted[side]:  # touch-down: held where it landed, at its place among the contacts (first, in SIDES
                # order): one constraint order per support, so each support's QP layout is built once and reused
                self.controller.remove_task(self.swing[side])
                self.contact[side].set_placement_from_configuration(config)
                before = sum(self.stance[s] for s in SIDES[:SIDES.index(side)])
                self.controller.add_constraint(self.contact[side], index=before)
            else:  # lift-off
                self.controller.remove_constraint(self.contact[side])
                self.swing[side].set_target_from_configuration(config)
                self.controller.add_task(self.swing[side])
            self.stance[side] = wanted[side]
        self.support = support
        if self.zmp is not None:  # the contacts' placements, validated when set
            self.zmp.set_support_trusted([self.contact[s].placement for s in SIDES if self.stance[s]])
        self.support_changed()

    def prepare_supports(self, supports, config: Configuration, dt: float) -> None:
        """Build ahead what the first switch to each of ``supports`` (codes 0, 1, 2) would build in its tick: the
        controller's layout of that phase's contacts and swing tasks
        (:meth:`~wbc.controllers.kinematic.KinematicController.prepare_layouts`). Nothing else changes: the current
        support, placements and targets stay, and the ticks' answers are the same.

        Args:
            supports: iterable of support codes.
            config: a configuration of the robot (argument types and constant bounds are taken at it).
            dt: the control period (s).

        Raises:
            InvalidInputError: a support code other than 0 (double), 1 (left) or 2 (right); ``dt`` not finite
                and > 0.
        """
        ctrl = self.controller
        arrangements = []
        codes = list(supports)
        valid = {int(DOUBLE), int(LEFT_STANCE), int(RIGHT_STANCE)}
        bad = [c for c in codes if not isinstance(c, (int, np.integer)) or int(c) not in valid]
        if bad:
            raise InvalidInputError(f"support codes must be {sorted(valid)} (double, left, right), got {bad[:5]!r}")
        for support in sorted({int(s) for s in codes}):
            wanted = {"left": support in (DOUBLE, LEFT_STANCE), "right": support in (DOUBLE, RIGHT_STANCE)}
            tasks, constraints, stance = list(ctrl.tasks), list(ctrl.constraints), dict(self.stance)
            for side in SIDES:  # the list operations of set_support
                if wanted[side] == stance[side]:
                    continue
                if wanted[side]:
                    tasks.remove(self.swing[side])
                    constraints.insert(sum(stance[s] for s in SIDES[:SIDES.index(side)]), self.contact[side])
                else:
                    constraints.remove(self.contact[side])
                    tasks.append(self.swing[side])
                stance[side] = wanted[side]
            arrangements.append((tasks, constraints))
        ctrl.prepare_layouts(arrangements, config, dt)

    def support_changed(self) -> None:
        """Hook called after every support switch (default: nothing)."""

    def solve(self, config: Configuration, dt: float) -> TickResult:
        """One QP tick (``KinematicController.solve``).

        The controller leaves every relaxable constraint out of a tick that is infeasible with them. When the
        acceleration limits are what conflicts (e.g. a change of rank of the contact rows asks for a velocity step),
        dropping the executed-ZMP constraint too would let the ZMP leave the feet: such a tick is solved again
        without the acceleration and braking limits only, keeping the ZMP constraint; ``relaxed`` then names the
        limits left out.
        """
        result = self.controller.solve(config, dt)
        if not result.relaxed or self.zmp is None or not self.smoothness:
            return result
        self.zmp.undo_previous()  # the tick is solved again: its ZMP memory back to before this tick
        for c in self.smoothness:
            self.controller.remove_constraint(c)
        try:
            retry = self.controller.solve(config, dt)
        finally:
            for c in self.smoothness:
                self.controller.add_constraint(c)
        if not retry.ok or retry.relaxed:  # the ZMP constraint itself conflicts: keep the controller's answer
            self.zmp.undo_previous()
            self.zmp.set_previous(result.v)
            return result
        retry.relaxed = [c.name for c in self.smoothness]
        for c in self.smoothness:
            if c.needs_previous_command:
                c.set_previous(retry.v)
        return retry


@dataclass
class StanceRun(MotionRun):
    """What every run of the stance controller records (walk, balance behaviours), one row per tick k at
    t[k] = k dt: ``t`` (N,) s; ``q`` (N, nq); ``v`` (N, nv) the command computed at row k; ``com``, ``com_ref``
    (N, 3) m, world; ``left_sole``, ``right_sole`` (N, 4, 4) world poses; ``support`` (N,) int8
    (:class:`Support`); ``tick_time`` (N,) s; ``solver_ok`` (N,) bool; ``relaxed`` (N,) bool, the tick was solved
    without its relaxable constraints; ``path`` (N,) text, the route each tick took (string form of
    :class:`wbc.tick.TickPath`); ``joint_names`` (nv − 6,); ``robot``; ``dt`` s."""

    left_sole: np.ndarray
    right_sole: np.ndarray
    support: np.ndarray
    tick_time: np.ndarray
    solver_ok: np.ndarray
    relaxed: np.ndarray
    path: np.ndarray
    joint_names: list[str]


class StanceRecorder:
    """Preallocated per-tick arrays of a stance-controller run of ``n`` ticks (the common part of
    :class:`StanceRun`): state at the start of tick k (:meth:`record_state`), then the command (:meth:`record_command`).
    """

    def __init__(self, robot: Robot, n: int):
        model = robot.model
        self._lf, self._rf = robot.frame_id(robot.left_sole), robot.frame_id(robot.right_sole)
        self.q = np.empty((n, model.nq))
        self.v = np.empty((n, model.nv))
        self.com = np.empty((n, 3))
        self.left_sole = np.empty((n, 4, 4))
        self.right_sole = np.empty((n, 4, 4))
        self.tick_time = np.empty(n)
        self.solver_ok = np.empty(n, dtype=bool)
        self.relaxed = np.zeros(n, dtype=bool)
        self.path = np.full(n, "", dtype=PATH_DTYPE)

    def record_state(self, k: int, config: Configuration) -> None:
        """Row k: q, CoM and sole poses of ``config``."""
        self.q[k] = config.q
        self.com[k] = config.com
        self.left_sole[k] = config.data.oMf[self._lf].homogeneous
        self.right_sole[k] = config.data.oMf[self._rf].homogeneous

    def record_command(self, k: int, result: TickResult, tick_time: float) -> None:
        """Row k: the command, whether the QP solved (and without its relaxable constraints), its route, the tick
        time (s)."""
        self.tick_time[k] = tick_time
        self.solver_ok[k] = result.ok
        self.relaxed[k] = bool(result.relaxed)
        self.path[k] = str(result.path)
        self.v[k] = result.v

    def arrays(self) -> dict:
        """The recorded arrays under their :class:`StanceRun` field names."""
        return {"q": self.q, "v": self.v, "com": self.com, "left_sole": self.left_sole, "right_sole": self.right_sole,
                "tick_time": self.tick_time, "solver_ok": self.solver_ok, "relaxed": self.relaxed, "path": self.path}
