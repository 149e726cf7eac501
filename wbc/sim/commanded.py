"""Walking on command in MuJoCo, tick by tick: the closed loop of ``wbc sim walk`` as a long-running loop.

:class:`SimCommandedWalk` owns one MuJoCo plant, one inverse-dynamics controller and (by default) the state
estimator, built exactly as ``wbc sim walk`` builds them (:func:`build_walk_loop`: realistic drives, the
controller compensating the nominal drives, the controller reading the state estimated from the plant's sensors,
ZMP feedback 0.5). :meth:`SimCommandedWalk.tick` advances one control period (2 ms, one ``mj_step``) as one
iteration of :func:`wbc.sim.closed_loop.run_closed_loop`, without recording the run: memory stays constant
however long it runs.

Gait (walking **segments**, each a :class:`wbc.sim.walk.WalkScenario`; re-planned in the double support after a
touch-down, so that a command takes effect at the next touch-down):

* **Standing**: the stance is held by the ID controller (CoM over the feet, both soles in contact).
* **Velocity command** ``(vx, vy, wz)`` (m/s, m/s, rad/s, walking frame): when standing, a segment of
  ``segment_steps`` steps is planned from the measured stance — ``segment_steps − 1`` walking steps of length
  ``vx T``, lateral step ``vy T`` and turn ``wz T`` (``T`` the step duration) and a closing step — and tracked with
  step adjustment, the DCM stabilizer and state-based touch-down as in ``wbc sim walk``. In the double support
  after each touch-down (both soles fully loaded, :meth:`~wbc.sim.walk.WalkScenario.between_steps`) the walk is
  **re-planned from the measured CoM state** (``WalkScenario(from_motion=True)``: the footsteps from the current
  soles, the DCM plan from the measured CoM position and velocity) when the command changed, or when the next step
  would be the closing one and the command is still set: the robot walks on without stopping, and a new command
  takes effect at the next touch-down. Backward walking (``vx < 0``) is not planned by
  :class:`~wbc.sim.walk.WalkScenario`: ``max_backward`` is 0.
* **Stop** (zero command, :meth:`stop`, a cancelled or new goal): at the next touch-down the rest of the walk is
  replaced by one closing step (the trailing foot set beside the other, the CoM planned from its measured state):
  the robot is in double support at that touch-down (at most one step duration after the stop) and at most one
  step starts after it. A stop in the double support before a segment's first step takes effect after that step.
  A new goal is walked once the robot stands.
* **Pose goal** ``(x, y, yaw)`` of the base (world): one segment of ``n`` walking steps and a closing step, ``n``
  the smallest count keeping each step within the limits, the turn split equally and the step length and lateral
  step those whose planned final feet mid-point puts the base at the goal
  (:func:`wbc.gait.commands.goal_steps`, no backward steps); where the robot ends is what the plant did.

The command logic (what is asked, what is due when, the steps of it) is :class:`wbc.gait.commanded.WalkCommands`'s
with segments (not ``receding``), no backward steps, a failed start dropping its command; this module plans its
steps as :class:`~wbc.sim.walk.WalkScenario` segments and advances the MuJoCo closed loop.

State: :attr:`q`, :attr:`v` are what the controller reads (the estimate by default); :attr:`q_true`,
:attr:`v_true` MuJoCo's ground truth (Pinocchio conventions); :attr:`tau` the torques applied in the last tick
(N·m, (nv − 6,), joint order of ``robot.model``: the command written to the actuators, which MuJoCo clamps to
the URDF effort limits).
Frames and units: world (``odom``), z up; m, s, rad.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pinocchio as pin

from wbc.exceptions import GaitError, InvalidInputError, SimulationError
from wbc.gait.commanded import CLOSE, WalkCommands
from wbc.gait.commands import Stance, check_finite, feet_can_yaw
from wbc.geometry import ReadOnly
from wbc.sim.outcome import OutcomeMonitor
from wbc.sim.scenarios import StandScenario, make_controller
from wbc.sim.walk import WalkScenario
from wbc.tasks.base import ValidatedAttribute

__all__ = ["SimCommandedWalk", "build_walk_loop"]


def build_walk_loop(robot, *, plant: str = "realistic", state: str = "estimated", solver: str = "fast",
                    seed: int = 0):
    """``(sim, controller, state_estimator or None, zmp_feedback)`` of ``wbc sim walk``'s defaults.

    Args:
        robot: a :class:`wbc.robot.Robot`.
        plant: ``"realistic"`` (URDF damping and friction, armature, torque-speed envelope;
            :mod:`wbc.sim.actuators`) or ``"ideal"``.
        state: ``"estimated"`` (sensors + :class:`wbc.estimation.FloatingBaseEstimator`) or ``"ground-truth"``.
        solver: QP backend of the controller.
        seed: sensor noise seed.

    Raises:
        InvalidInputError: an unknown plant or state.
    """
    from wbc.sim.actuators import NO_LOAD_SPEED_FACTOR, SPEED_MARGIN, actuator_model, apply_actuators
    from wbc.sim.actuators import compensation_options
    from wbc.sim.mujoco_model import build_mujoco_model
    from wbc.sim.physics_scenarios import walk_options_for

    if plant not in ("realistic", "ideal"):
        raise InvalidInputError(f"plant {plant!r} is invalid: valid are 'realistic', 'ideal'")
    if state not in ("estimated", "ground-truth"):
        raise InvalidInputError(f"state {state!r} is invalid: valid are 'estimated', 'ground-truth'")
    drives = actuator_model(robot, plant, no_load_factor=NO_LOAD_SPEED_FACTOR)
    foot = robot.spec.mujoco.foot if robot.spec is not None else "box"
    sim = build_mujoco_model(robot, foot_contact=foot)
    apply_actuators(sim, drives)
    options = walk_options_for(robot, solver)
    if plant == "realistic":
        options.update(compensation_options(robot, drives, SPEED_MARGIN))
    controller = make_controller(robot, "id", dt=sim.timestep, **options)
    est = None
    if state == "estimated":
        from wbc.sim.estimated_state import EstimatedState

        est = EstimatedState(sim, seed=seed)
    return sim, controller, est, (0.5 if est is not None else 0.0)


class SimCommandedWalk(WalkCommands):
    """The commanded physics walk of the module docstring.

    Args:
        robot: a :class:`wbc.robot.Robot` with soles (free flyer first).
        plant, state, solver, seed: :func:`build_walk_loop`.
        step_duration: single + double support of a step, s, in [0.4, 3] (default 0.8, ``wbc sim walk``'s).
        max_velocity: forward speed limit, m/s, in [0.001, 1]. max_lateral: m/s, in [0.001, 2]. max_turn: rad/s, in
            [0.001, 3]; 0 when the legs cannot yaw the soles relative to each other
            (:func:`wbc.gait.commands.feet_can_yaw` at ``q_ref`` False: :attr:`can_turn`).
        segment_steps: steps per walking segment (>= 2: at least one walking step and the closing one).

    Attributes:
        segments, touchdown_replans: segments started from standing and re-plans in a double support between steps,
            since the start; last_replan: what the last of these planned (for the node's log). The command state and
            the other counts: :class:`~wbc.gait.commanded.WalkCommands`.

    Raises:
        InvalidInputError: a bad argument (named, with the valid range).
    """

    @property
    def clock_guard(self) -> bool:
        """The ID controller's clock guard (:class:`wbc.controllers.inverse_dynamics.InverseDynamicsController`;
        False by default, True in a real-time loop such as ``wbc ros2 node --sim``)."""
        return self.controller.controller.clock_guard

    @clock_guard.setter
    def clock_guard(self, value: bool) -> None:
        self.controller.controller.clock_guard = bool(value)

    def __init__(self, robot, *, plant: str = "realistic", state: str = "estimated", solver: str = "fast",
                 seed: int = 0, step_duration: float = 0.8, max_velocity: float = 0.3, max_lateral: float = 0.1,
                 max_turn: float = 0.5, segment_steps: int = 4):
        self.step_duration = step_duration
        super().__init__(robot, max_velocity=max_velocity, max_lateral=max_lateral, max_turn=max_turn,
                         can_turn=feet_can_yaw(robot, robot.q_ref), steps_per_plan=segment_steps,
                         plan_name="segment_steps", backward=False, receding=False, retry=None, top_speed=1.0)
        self.sim, self.controller, self.state, self.zmp_feedback = build_walk_loop(
            robot, plant=plant, state=state, solver=solver, seed=seed)
        self.dt = self.sim.timestep
        self._pdata = robot.model.createData()
        self._fid = (robot.frame_id(robot.left_sole), robot.frame_id(robot.right_sole))
        self.t = 0.0
        self.segments = 0
        self.touchdown_replans = 0  # re-plans in a double support between steps (``_replan``)
        self.last_replan = ""  # what the last re-plan at a touch-down planned (for the node's log)
        self._no_replan = None  # a segment whose re-plan failed (walked to its end)
        self.tau = np.zeros(robot.model.nv - 6)
        self.reset()

    # -- parameters (validated on assignment) ------------------------------------------------------------------
    step_duration = ValidatedAttribute(lambda walk, T: check_finite(T, "step_duration (s)", 0.4, 3.0),
                                       "Single + double support of a step, s (in [0.4, 3]; takes effect at the next "
                                       "segment).")

    # -- state -------------------------------------------------------------------------------------------------
    q = ReadOnly("""(nq,) the configuration the controller reads (estimate, or ground truth with
        ``state="ground-truth"``).""")
    v = ReadOnly("(nv,) the velocity the controller reads.")

    @property
    def q_true(self) -> np.ndarray:
        """(nq,) MuJoCo's ground-truth configuration (Pinocchio conventions), after the last tick."""
        return self.sim.get_state()[0]

    @property
    def v_true(self) -> np.ndarray:
        """(nv,) MuJoCo's ground-truth velocity, after the last tick."""
        return self.sim.get_state()[1]

    @property
    def fell(self) -> bool:
        """A fall was detected (base drop > 0.2 m, tilt > 30°, or a non-sole body on the floor)."""
        return self.monitor.fell

    @property
    def walking(self) -> bool:
        """A segment is being walked (False: standing)."""
        return self._segment is not None and not self._segment_done()

    def time_remaining(self) -> float:
        """Time (s) until the current segment's plan ends (0 when standing)."""
        if not self.walking:
            return 0.0
        return max(0.0, self._segment.ends_at - (self.t - self._t0))

    # -- commands (set_velocity, set_goal, stop: WalkCommands) ----------------------------------------------------
    def reset(self) -> None:
        """The plant back to ``q_ref`` at rest (teleported), the controller and estimator restarted, standing.
        The node time :attr:`t` goes on."""
        sim, robot = self.sim, self.robot
        mujoco.mj_resetData(sim.model, sim.data)
        sim.set_state(robot.q_ref)
        q, v = sim.get_state()
        self.controller.reset(q, v)
        if self.state is not None:
            self.state.reset(q, v)
        self._q, self._v = q.copy(), v.copy()
        self._segment = StandScenario(1.0)
        self._segment.setup(self.controller, sim, q, v)
        self._stand = self._segment
        self._t0 = self.t
        self.monitor = OutcomeMonitor(sim)
        self.clear_commands()
        self.stance = Stance.of(q[:2], *self.soles(q))

    # -- one tick ----------------------------------------------------------------------------------------------
    def tick(self) -> None:
        """One control period: start a segment if due, then one iteration of the closed loop
        (:func:`wbc.sim.closed_loop.run_closed_loop`'s steps 1–4 and 6, no log).

        Raises:
            SimulationError: the MuJoCo state became non-finite.
        """
        sim, model, data = self.sim, self.sim.model, self.sim.data
        walking = self.walking
        if not walking:
            self.walk_ended()
            due = None if self.monitor.fell else self.start_due(self.t)
            if due is not None:
                self._start_segment(due)
        elif not self.monitor.fell:
            seg = self._segment
            due = self.touchdown_due(seg.steps_left) if seg.steps_done >= 1 and seg.steps_left >= 1 \
                and seg is not self._no_replan else None
            seg.hold_next_swing = due is not None  # (a late touch-down: the next swing waits for the re-plan)
            if due is not None and seg.between_steps():
                self._replan(due, seg.next_side)
        if self.state is not None:
            mujoco.mj_step1(model, data)
        q, v = sim.get_state()
        if self.state is not None:
            q, v = self.state.measure(sim, self.t)
            if self._segment is not self._stand:
                self._segment.measured_zmp = self.state.measured_zmp()
                self._segment.measured_normal_force = self.state.measured_normal_force()
        self._segment.update(self.t - self._t0, self.controller, sim, q, v)
        cmd = self.controller.solve(q, v)
        sim.set_torques(cmd.tau)
        if self.state is None:
            mujoco.mj_step(model, data)
        else:
            mujoco.mj_step2(model, data)
        if not np.all(np.isfinite(data.qpos)):
            raise SimulationError(f"MuJoCo state became non-finite at t = {self.t:.3f} s")
        self._q[:], self._v[:] = q, v
        self.tau[:] = cmd.tau
        self.t += self.dt
        self.monitor.update(self.t)

    def _segment_done(self) -> bool:
        seg = self._segment
        if seg is self._stand:
            return True
        return self.t - self._t0 >= seg.ends_at - 1e-9  # (after a capture step, when one was started)

    def _replan(self, due, side: str) -> None:
        """Replace the current segment, in its double support between steps, by a walk planned from the measured
        CoM state with ``side`` swinging first: one closing step (``due == "close"``) or ``segment_steps`` steps of
        the command ``due``. The step width is the reference stance's (:meth:`reset`), not the current feet's:
        between steps of a side-step the feet are ``2 vy T`` wider, and re-plans chained on the measured width
        would widen the stance at each one."""
        q, v = self.sim.get_state() if self.state is None else (self._q, self._v)
        T = self.step_duration
        s = self.steps(due, T, side)
        n, length, lateral, turn = s.n_steps, s.step_length + 0.0, s.step_lateral + 0.0, s.turn + 0.0  # (no -0.0)
        try:
            seg = WalkScenario(n, length, T, turn=turn, step_lateral=lateral, settle=0.0,
                               zmp_feedback=self.zmp_feedback, first_side=side, from_motion=True,
                               t_init=max(0.08, 0.2 * T), step_width=self.stance.width)
            seg.setup(self.controller, self.sim, q, v)
        except (GaitError, InvalidInputError, np.linalg.LinAlgError) as exc:
            self.failed(exc)
            self._no_replan = self._segment  # (not retried: this plan goes on to its closing step)
            self._segment.hold_next_swing = False
            return
        self._segment, self._t0 = seg, self.t
        self.taken(s)
        self.touchdown_replans += 1
        self.last_replan = "closing step" if due == CLOSE else \
            f"{n} steps of {length:.3f} m, lateral {lateral:.3f} m, turn {math.degrees(turn):.1f} deg"

    def _start_segment(self, due) -> None:
        """Start walking ``due`` (a goal or a command, :meth:`start_due`) from standing; a failure drops the
        command."""
        q, v = self.sim.get_state() if self.state is None else (self._q, self._v)
        T = self.step_duration
        try:
            s = self.steps(due, T, soles=self.soles(q))
            seg = WalkScenario(s.n_steps, float(s.step_length), T, turn=float(s.turn),
                               step_lateral=float(s.step_lateral), settle=0.0, zmp_feedback=self.zmp_feedback,
                               first_side=s.first_side)
            seg.setup(self.controller, self.sim, q, v)
        except (GaitError, InvalidInputError, np.linalg.LinAlgError) as exc:
            self.failed(exc, self.t)
            return
        self._segment, self._t0 = seg, self.t
        self.taken(s)
        self.segments += 1

    # -- geometry ----------------------------------------------------------------------------------------------
    def soles(self, q: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """((4, 4), (4, 4)) the left and right sole poses (world) at ``q`` ((nq,); None: :attr:`q`)."""
        if q is None:
            q = self._q
        d = self._pdata
        pin.framesForwardKinematics(self.robot.model, d, q)
        return d.oMf[self._fid[0]].homogeneous.copy(), d.oMf[self._fid[1]].homogeneous.copy()
