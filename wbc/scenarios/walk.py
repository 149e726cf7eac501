"""Walking at 500 Hz: the gait plan feeds the kinematic QP controller every tick.

Per tick k (period dt): the :class:`~wbc.gait.WalkPlan` gives the CoM reference (position, velocity), the swing
sole reference (pose, velocity) and the support phase; stance soles are hard contact constraints at their
touch-down placement; the QP gives v; q ← pin.integrate(q, v dt).

The log (``--log walk.npz``) holds, for N ticks: ``t`` (N,) s; ``q`` (N, nq); ``v`` (N, nv); ``com`` and
``com_ref`` (N, 3) m, world; ``zmp_ref`` (N, 2) m, world; ``left_sole``/``right_sole`` (N, 4, 4) world poses;
``support`` (N,) 0 = double, 1 = left stance, 2 = right stance; ``tick_time`` (N,) s; ``joint_names`` (nv−6,);
``robot`` (name); ``dt``; ``relaxed`` (N,) bool, tick solved without its relaxable constraints. Row k is the state at the start of tick k, t[k] = k dt, and v[k] the command
computed from it (applied for dt); ``com_ref[k]`` is the plan's CoM at t[k].
"""

from __future__ import annotations

from dataclasses import dataclass
from time import perf_counter

import numpy as np
import pinocchio as pin

from wbc.configuration import Configuration
from wbc.exceptions import InvalidInputError, InvalidTargetError
from wbc.solvers import DEFAULT_SOLVER
from wbc.gait import WalkPlan, plan_walk
from wbc.geometry import mean_heading
from wbc.robot import Robot
from wbc.tick import count_paths
from wbc.scenarios.metrics import executed_angular_momentum, executed_zmp, stance_ground_z, support_margin
from wbc.scenarios.stance import DOUBLE, LEFT_STANCE, RIGHT_STANCE, StanceController, StanceRecorder, StanceRun

__all__ = ["WalkController", "WalkRun", "plan_default_walk", "run_walk", "walk_summary"]



def plan_default_walk(robot: Robot, config: Configuration | None = None, dt: float = 0.002, **overrides) -> WalkPlan:
    """Plan a straight walk from the robot's current stance with its descriptor's gait defaults.

    Args:
        robot: the robot; ``robot.gait`` holds its defaults.
        config: current configuration (default: ``robot.q_ref``).
        dt: sampling period (s).
        **overrides: any keyword of :func:`wbc.gait.plan_walk` (``n_steps``, ``step_length``...); None values
            are ignored.

    Raises:
        GaitError: the requested walk cannot be planned.
    """
    config = config or Configuration(robot)
    kwargs = dict(robot.gait)
    kwargs.update({k: v for k, v in overrides.items() if v is not None})
    return plan_walk(
        config.data.oMf[robot.frame_id(robot.left_sole)].homogeneous,
        config.data.oMf[robot.frame_id(robot.right_sole)].homogeneous,
        config.com.copy(),
        dt=dt,
        sole_length=robot.sole_length,
        sole_width=robot.sole_width,
        **kwargs,
    )


class WalkController(StanceController):
    """:class:`~wbc.scenarios.stance.StanceController` driven by a walk plan: CoM and swing-sole references, and
    a torso yaw that follows the mean heading of the soles.

    Args:
        robot: the robot.
        config: its current configuration (contacts start at the current sole placements).
        solver: QP backend name.
        com_gain, foot_gain, torso_gain, posture_gain: task gains K (1/s).
        joint_acceleration: a_max (rad/s²) of the joint acceleration and braking limits (relaxable; None: none).
            Without them a lift-off moved Alexander's swing hip by 1.9 rad/s in one tick (CoM acceleration
            53 m/s² vertically) and Romeo's ankle stopped at its limit within one tick (8.2 m/s²).
        **stance_options: other keywords of :class:`~wbc.scenarios.stance.StanceController` (e.g. ``zmp_margin``).
    """

    def __init__(self, robot: Robot, config: Configuration, *, solver: str = DEFAULT_SOLVER, com_gain: float = 100.0,
                 foot_gain: float = 100.0, torso_gain: float = 50.0, posture_gain: float = 10.0,
                 joint_acceleration: float | None = 50.0, **stance_options):
        super().__init__(robot, config, solver=solver, com_gain=com_gain, foot_gain=foot_gain,
                         torso_gain=torso_gain, posture_gain=posture_gain, joint_acceleration=joint_acceleration,
                         **stance_options)
        self._torso_ref_rot = config.data.oMf[self.torso.frame_id].rotation.copy()
        self._plan: WalkPlan | None = None
        self._rows: _PlanRows | None = None
        self._swing_rows: dict = {}
        self._prepared: tuple | None = None  # (plan, rows, swing rows) of prepare_plan, until set_plan takes it

    def set_plan(self, plan: WalkPlan) -> None:
        """Validate ``plan`` once and precompute the per-tick targets of all its samples (module docstring of
        :class:`_PlanRows`), so that :meth:`set_references` only hands rows to the tasks, and build the QP layouts of
        the plan's support phases (:meth:`prepare_supports`), so that no support switch builds one. Called by
        :meth:`set_references` for a plan it has not seen; call it before a real-time loop to keep that work
        (linear in the number of samples) out of the first tick.

        Raises:
            InvalidTargetError: the plan has non-finite samples or a sole rotation block that is not a rotation.
        """
        prepared = self._prepared
        if prepared is None or prepared[0] is not plan:
            self.prepare_plan(plan)
        self._plan, self._rows, self._swing_rows = self._prepared
        self._prepared = None

    def prepare_plan(self, plan: WalkPlan) -> None:
        """The work of :meth:`set_plan` (validation, target rows, support layouts) done ahead, without switching:
        the next :meth:`set_plan` of this same plan object only swaps it in. A caller that knows its next plan
        ticks early (:class:`~wbc.scenarios.commanded_walk.CommandedWalk` at a touch-down) keeps that work out of
        the tick that switches.

        Raises:
            InvalidTargetError: as :meth:`set_plan`.
        """
        if not isinstance(plan, WalkPlan):
            raise InvalidTargetError(f"expected a wbc.gait.WalkPlan, got {type(plan).__name__}")
        rows = _PlanRows(plan, self._torso_ref_rot)
        # the layouts of the plan's support phases, built now rather than in the first tick of each
        self.prepare_supports(set(rows.support), Configuration(self.robot), plan.dt)
        # the swing sole's task and target rows of each support code (None: double support, no swing)
        swing_rows = {int(DOUBLE): None,
                      int(LEFT_STANCE): (self.swing["right"].set_target_rows, rows.right_rot_t_rows,
                                         rows.right_pos_rows, rows.right_ff_rows),
                      int(RIGHT_STANCE): (self.swing["left"].set_target_rows, rows.left_rot_t_rows,
                                          rows.left_pos_rows, rows.left_ff_rows)}
        self._prepared = (plan, rows, swing_rows)

    def set_references(self, plan: WalkPlan, k: int, config: Configuration) -> None:
        """Targets of sample k of the plan, at the current configuration.

        The plan's samples are validated once per plan and turned into the tasks' target rows (:meth:`set_plan`);
        each tick then hands row k to the tasks without validation, copy or allocation.

        Raises:
            InvalidTargetError: the plan has non-finite samples or a sole rotation block that is not a rotation.
            InvalidInputError: ``k`` is not an integer sample index in [0, N − 1].
        """
        if self._plan is not plan:
            self.set_plan(plan)
        rows = self._rows
        if type(k) is not int or not 0 <= k < rows.n:
            if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not 0 <= k < rows.n:
                raise InvalidInputError(f"walk sample index k must be an integer in [0, {rows.n - 1}], got {k!r}")
        support = rows.support[k]
        if support != self.support:
            self.set_support(support, config)
        self.com.set_target_trusted(rows.com_rows[k], rows.com_vel_rows[k])
        swing = self._swing_rows[support]  # the plan's support is the controller's (set_support above)
        if swing is not None:
            set_rows, rot_t, pos, ff = swing
            set_rows(rot_t[k], pos[k], ff[k])
        self.torso.set_target_rows(rows.torso_row(k), rows.zero3)


class _PlanRows:
    """A walk plan's samples as the tasks' target rows, validated and computed once per plan (N samples):

    ``com``, ``com_vel`` (N, 3) (views of the plan); per sole, ``*_rot_t`` (N, 3, 3) the transposed rotation R*ᵀ,
    ``*_pos`` (N, 3) the position (m, world) and ``*_ff`` (N, 6) the error rate [ṗ* (world); R*ᵀ ω*], each row
    C-contiguous (:meth:`wbc.tasks.FrameTask.set_target_rows`); :meth:`torso_row`: the torso target, yaw = mean
    heading of the soles (:func:`wbc.geometry.mean_heading`) applied to the torso's initial rotation, made on first
    use; ``support``: the support codes as a list of ints. ``*_rows``: what a tick indexes with the sample k.

    Raises:
        InvalidTargetError: non-finite samples or a sole rotation block that is not a rotation.
    """

    def __init__(self, plan: WalkPlan, torso_ref_rot: np.ndarray):
        for name in ("com", "com_vel", "left_sole_vel", "right_sole_vel"):
            if not np.isfinite(getattr(plan, name)).all():
                raise InvalidTargetError(f"walk plan {name} contains NaN/inf")
        for name in ("left_sole", "right_sole"):
            poses = getattr(plan, name)
            rot = poses[:, :3, :3]
            if not np.isfinite(poses).all() or not _rotations(rot):
                raise InvalidTargetError(f"walk plan {name} has non-finite entries or a non-rotation block")
        self.n = len(plan.t)
        self.support = [int(s) for s in plan.support.tolist()]
        self.com, self.com_vel = plan.com, plan.com_vel
        self.zero3 = np.zeros(3)
        for side, poses, vel in (("left", plan.left_sole, plan.left_sole_vel),
                                 ("right", plan.right_sole, plan.right_sole_vel)):
            rot_t = np.ascontiguousarray(poses[:, :3, :3].transpose(0, 2, 1))
            ff = np.empty((self.n, 6))
            ff[:, :3] = vel[:, :3]
            ff[:, 3:] = np.matmul(rot_t, vel[:, 3:, None])[:, :, 0]
            setattr(self, f"{side}_rot_t", rot_t)
            setattr(self, f"{side}_pos", np.ascontiguousarray(poses[:, :3, 3]))
            setattr(self, f"{side}_ff", ff)
        # torso: one rotation per run of equal consecutive sole headings, made when a tick first needs it (a turning
        # swing changes the headings every sample: all of them at once cost ~3 ms in the tick that switched plans)
        keys = np.stack([plan.left_sole[:, 1, 0], plan.left_sole[:, 0, 0],
                         plan.right_sole[:, 1, 0], plan.right_sole[:, 0, 0]], axis=1)
        self._torso_first = np.flatnonzero(np.r_[True, (keys[1:] != keys[:-1]).any(axis=1)]).tolist()
        self._torso_run = np.repeat(np.arange(len(self._torso_first)),
                                    np.diff(np.r_[self._torso_first, self.n])).tolist()
        self._torso_rows: list = [None] * len(self._torso_first)
        self._plan, self._torso_ref_rot = plan, torso_ref_rot
        for name in ("com", "com_vel", "left_rot_t", "left_pos", "left_ff", "right_rot_t", "right_pos", "right_ff"):
            setattr(self, f"{name}_rows", getattr(self, name))  # indexed per tick: a list of N views per array
            # cost more (~2 ms per plan, in the tick that re-plans) than a tick's 8 indexings (~1 µs)
        # (left writeable: a read-only array is another type for the compiled task kernels, i.e. a recompile)

    def torso_row(self, k: int) -> np.ndarray:
        """(3, 3) the torso target's transposed rotation at sample ``k`` (one array per run of equal targets)."""
        i = self._torso_run[k]
        row = self._torso_rows[i]
        if row is None:
            plan, first = self._plan, self._torso_first[i]
            yaw = mean_heading(plan.left_sole[first], plan.right_sole[first])
            rot = pin.rpy.rpyToMatrix(0.0, 0.0, yaw) @ self._torso_ref_rot
            row = self._torso_rows[i] = np.ascontiguousarray(rot.T)
        return row


def _rotations(rot: np.ndarray) -> bool:
    """True if every block of ``rot`` (N, 3, 3) is a rotation: columns orthonormal within 1e-6, determinant > 0
    (column products and a triple product: a third of the batched matmul and ``det``'s cost)."""
    c = [rot[:, :, i] for i in range(3)]
    for i in range(3):
        for j in range(i, 3):
            if np.abs(np.einsum("ni,ni->n", c[i], c[j]) - (i == j)).max() > 1e-6:
                return False
    return bool((np.einsum("ni,ni->n", c[0], np.cross(c[1], c[2])) > 0).all())


@dataclass
class WalkRun(StanceRun):
    """Arrays recorded during a walk (see the module docstring for the log format; written by ``save``):
    those of :class:`~wbc.scenarios.stance.StanceRun` and the plan's ZMP reference ``zmp_ref`` (N, 2) m."""

    zmp_ref: np.ndarray


def run_walk(robot: Robot, plan: WalkPlan, *, solver: str = DEFAULT_SOLVER, config: Configuration | None = None,
             viewer=None, pacer=None, clock_guard: bool = False) -> WalkRun:
    """Walk ``plan`` at its sampling period under the kinematic QP.

    Args:
        robot: the robot.
        plan: the walk (from :func:`plan_default_walk` or :func:`wbc.gait.plan_walk`).
        solver: QP backend name.
        config: starting configuration (default ``robot.q_ref``; must match the plan's initial stance).
        viewer: optional object with ``update(q, t)`` (non-blocking, e.g. :class:`wbc.viz.LiveViewer`).
        pacer: optional :class:`wbc.viz.RealTimePacer` (``wait(t_sim)`` once per tick) for real-time pacing.
        clock_guard: the controller's clock guard (``KinematicController.clock_guard``): True where time is real
            (``--live``, ``--ros2``); False (default) keeps a run a function of its inputs (logs reproducible).

    Returns:
        :class:`WalkRun` with one row per tick.
    """
    config = config or Configuration(robot)
    walker = WalkController(robot, config, solver=solver, clock_guard=clock_guard)
    walker.set_plan(plan)  # validated and precomputed once, before the first tick
    n, dt = len(plan.t), plan.dt
    rec = StanceRecorder(robot, n)
    for k in range(n):
        rec.record_state(k, config)
        t0 = perf_counter()
        walker.set_references(plan, k, config)
        result = walker.solve(config, dt)
        config.step(result.v, dt)
        rec.record_command(k, result, perf_counter() - t0)
        if viewer is not None:
            viewer.update(config.q, (k + 1) * dt)
        if pacer is not None:
            pacer.wait((k + 1) * dt)
    return WalkRun(
        robot=robot.name, dt=dt, t=np.arange(n) * dt, com_ref=plan.com.copy(), zmp_ref=plan.zmp.copy(),
        support=plan.support.copy(), joint_names=robot.joint_names, **rec.arrays(),
    )


def _support_margin(points: np.ndarray, left: np.ndarray, right: np.ndarray, support: np.ndarray,
                    length: float, width: float) -> np.ndarray:
    """Signed distance (m, > 0 inside) of each point (N, 2) to the support polygon given by the sole poses."""
    return support_margin(points, left, right, support, length, width, DOUBLE, LEFT_STANCE, RIGHT_STANCE)


def walk_summary(robot: Robot, plan: WalkPlan, run: WalkRun) -> dict:
    """Acceptance metrics of a walk.

    Returns a dict with: robot, solver-independent plan info, dt_s, ticks, planned_distance and
    walked_distance (m, feet mid-point displacement in the ground plane), tick_time_us {median, p99, max},
    max_com_error (m, ‖c − c_ref‖), max_stance_slip (m, largest displacement of a stance sole from where it was when
    its stance began), min_zmp_margin_m (m, signed distance of the ZMP of the EXECUTED motion to the support
    polygon of the realized soles at that tick, negative = outside; multi-body ZMP: the CoM is the one of the
    integrated q, its acceleration the central second finite difference of that executed CoM, the rate of
    centroidal angular momentum the backward difference of A_G(q_k) v_k, see :mod:`wbc.scenarios.metrics`),
    min_zmp_margin_com_only_m (the same with L̇ = 0, reported, not judged), min_zmp_margin_plan_m (the same
    distance for the plan's ZMP, reported beside it, not judged),
    joint_position_violations / joint_velocity_violations (number of (tick, joint) pairs outside the URDF limits),
    solver_failures, relaxed_ticks (ticks solved without the relaxable constraints, e.g. the executed-ZMP
    constraint; reported, not judged: the ZMP margin judges the motion), ticks_per_route and ticks_per_path (ticks per
    route and per path of ``TickResult.path``, :func:`wbc.tick.count_paths`), nan (any non-finite q or v), passed and failed_criteria
    (:data:`wbc.scenarios.acceptance.WALK_CRITERIA`).
    """
    from wbc.constraints.limits import bounded_joints
    from wbc.scenarios.acceptance import walk_passes

    model = robot.model

    idx_q, idx_v = bounded_joints(model)
    qj = run.q[:, idx_q]
    pos_viol = int(np.sum((qj < model.lowerPositionLimit[idx_q]) | (qj > model.upperPositionLimit[idx_q])))
    vmax = model.velocityLimit[6:]
    vel_viol = int(np.sum(np.abs(run.v[:, 6:]) > vmax))
    mid0 = 0.5 * (plan.left_sole[0, :2, 3] + plan.right_sole[0, :2, 3])
    mid1 = 0.5 * (run.left_sole[-1, :2, 3] + run.right_sole[-1, :2, 3])
    slip = 0.0
    for side, stance_ids, poses in (("left", (DOUBLE, LEFT_STANCE), run.left_sole),
                                    ("right", (DOUBLE, RIGHT_STANCE), run.right_sole)):
        in_stance = np.isin(run.support, stance_ids)
        # contiguous stance intervals (rows are states at the start of each tick)
        starts = np.flatnonzero(in_stance & ~np.r_[False, in_stance[:-1]])
        ends = np.flatnonzero(in_stance & ~np.r_[in_stance[1:], False])
        for a, b in zip(starts, ends):
            anchor = poses[a, :3, 3]  # where the sole was when its stance began
            slip = max(slip, float(np.max(np.linalg.norm(poses[a:b + 1, :3, 3] - anchor, axis=1))))
    zmp_plan = plan.com[:, :2] - plan.com_acc[:, :2] / plan.omega**2
    zmp_margin_plan = _support_margin(zmp_plan, run.left_sole, run.right_sole, run.support, robot.sole_length,
                                      robot.sole_width)
    ground = stance_ground_z(run.left_sole, run.right_sole, run.support, DOUBLE, LEFT_STANCE)
    zmp_exec = executed_zmp(run.com, run.dt, ground, angular_momentum=executed_angular_momentum(model, run.q, run.v),
                            mass=robot.mass)
    zmp_margin = _support_margin(zmp_exec, run.left_sole, run.right_sole, run.support, robot.sole_length,
                                 robot.sole_width)
    zmp_margin_com = _support_margin(executed_zmp(run.com, run.dt, ground), run.left_sole, run.right_sole,
                                     run.support, robot.sole_length, robot.sole_width)
    tt = run.tick_time * 1e6
    summary = {
        "robot": robot.name,
        "dt_s": run.dt,
        "ticks": int(len(run.t)),
        "duration_s": float(run.t[-1]),
        "steps": int(len(plan.footsteps)),
        "planned_distance_m": float(plan.planned_distance),
        "walked_distance_m": float(np.linalg.norm(mid1 - mid0)),
        "tick_time_us": {"median": float(np.median(tt)), "p99": float(np.percentile(tt, 99)), "max": float(tt.max())},
        "max_com_error_m": float(np.max(np.linalg.norm(run.com - run.com_ref, axis=1))),
        "max_stance_slip_m": slip,
        "min_zmp_margin_m": float(zmp_margin.min()),
        "min_zmp_margin_com_only_m": float(zmp_margin_com.min()),
        "min_zmp_margin_plan_m": float(zmp_margin_plan.min()),
        "joint_position_violations": pos_viol,
        "joint_velocity_violations": vel_viol,
        "solver_failures": int(np.sum(~run.solver_ok)),
        "relaxed_ticks": int(np.sum(run.relaxed)) if run.relaxed is not None else 0,
        **count_paths(run.path),
        "nan": bool(not (np.isfinite(run.q).all() and np.isfinite(run.v).all())),
    }
    summary["passed"], summary["failed_criteria"] = walk_passes(summary)
    return summary
