"""Balance behaviours at 500 Hz: the behaviour interface, the common runner, the run record and the summary.

A behaviour (``shift``, ``one-leg``, ``wave``, ``squat``, ``reach``; one module ``balance_<name>.py`` each) is a
reference generator: time t (s) → CoM target, support phase, swing-sole target, joint targets, hand target.
:func:`run_balance` feeds it to :class:`BalanceController` every tick of period dt:

* stance soles are hard contacts (:class:`~wbc.constraints.ContactConstraint`) at their touch-down placement;
* the capture point (DCM) c + ċ/ω is kept inside the current support polygon shrunk by a margin, as a hard
  inequality (:class:`~wbc.constraints.zmp.DcmPolygonConstraint`, re-targeted at every support change): the CoM
  ground projection stays inside too and approaches an edge exponentially instead of stopping within one tick;
* the multi-body ZMP of the motion each command produces stays inside the stance soles
  (:class:`~wbc.constraints.zmp.ExecutedZmpConstraint`, relaxable; :mod:`wbc.scenarios.stance`);
* joint position and velocity limits are hard bounds (joint accelerations are not bounded by default:
  ``BalanceController(joint_acceleration=...)``);
* tasks: CoM (weight 10), torso orientation (1), posture on every DoF (weight 1e-2, gain 2/s: a regulariser —
  Talos's grippers sit on their limit and need a cost — whose low gain keeps it from biasing the tracked tasks:
  at gain 10/s it cost ~1.5 mm of squat depth), plus the behaviour's own tasks (swing sole, arms, hand);
* q ← pin.integrate(q, v dt).

The building blocks (references, support polygon, CoM constraint, controller wiring) are in
:mod:`wbc.scenarios.balance_control` and re-exported here. References are quintic minimum-jerk ramps
(Flash & Hogan, "The coordination of arm movements: an experimentally confirmed mathematical model",
J. Neurosci. 1985) or cosine-enveloped sines, always with their velocity as feed-forward, so tracking errors
stay around a millimetre or below.

The log (``--log balance.npz``) holds, for N ticks: ``t`` (N,) s; ``q`` (N, nq); ``v`` (N, nv); ``com`` (N, 3)
m, world; ``com_ref`` (N, 3) m, world (NaN rows while the behaviour has no CoM target, e.g. ``reach``);
``left_sole``/``right_sole`` (N, 4, 4) world poses; ``support`` (N,) 0 = double, 1 = left stance, 2 = right
stance; ``com_margin`` (N,) m, signed distance of the CoM ground projection to the current support polygon
(> 0 inside); ``tick_time`` (N,) s; ``solver_ok`` (N,) bool; ``task_names`` (T,), ``task_units`` (T,) and
``task_error`` (N, T), norm of each task's error at the start of the tick in ``task_units`` (``m`` or ``rad``; a
frame task with position and orientation rows has two columns, ``<name> position`` m and ``<name> orientation``
rad; NaN while the task is inactive);
``joint_names`` (nv−6,); ``robot``; ``behaviour``; ``dt``; ``relaxed`` (N,) bool, tick solved without its
relaxable constraints. Row k is the state at the start of tick k,
t[k] = k dt, v[k] the command computed from it (applied for dt), references are those of t[k].
"""

from __future__ import annotations

import importlib
import math
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from time import perf_counter

import numpy as np

from wbc.configuration import Configuration
from wbc.constraints.limits import bounded_joints
from wbc.exceptions import InvalidInputError
from wbc.geometry import signed_distance, support_polygon
from wbc.solvers import DEFAULT_SOLVER
from wbc.robot import Robot
from wbc.tick import count_paths
from wbc.scenarios.framework import Criterion, evaluate
from wbc.scenarios.stance import StanceRecorder, StanceRun
from wbc.scenarios.metrics import executed_angular_momentum, executed_zmp, stance_ground_z, support_margin
from wbc.tasks.com import ComTask
from wbc.tasks.frame import FrameTask
from wbc.tasks.posture import PostureTask
from wbc.scenarios.balance_control import (  # noqa: F401  (re-exported for the behaviour modules)
    DOUBLE, LEFT_STANCE, RIGHT_STANCE, BalanceController, JointTrackingTask, MinJerkPath, min_jerk_ramp,
)

__all__ = [
    "BEHAVIOURS", "COMMON_CRITERIA", "DOUBLE", "LEFT_STANCE", "RIGHT_STANCE", "Behaviour", "BalanceController",
    "BalanceRun", "Criterion", "JointTrackingTask", "MinJerkPath", "balance_passes", "balance_summary",
    "make_behaviour", "min_jerk_ramp", "run_balance", "side_option",
]

#: behaviour name → "module:class" (imported on demand: the behaviour modules import this one).
BEHAVIOURS = {
    "shift": "wbc.scenarios.balance_shift:ShiftBehaviour",
    "one-leg": "wbc.scenarios.balance_one_leg:OneLegBehaviour",
    "wave": "wbc.scenarios.balance_wave:WaveBehaviour",
    "squat": "wbc.scenarios.balance_squat:SquatBehaviour",
    "reach": "wbc.scenarios.balance_reach:ReachBehaviour",
}


# -- behaviours -------------------------------------------------------------------------------------------------
class Behaviour(ABC):
    """A balance behaviour: reference generator + its own summary entries and acceptance criteria.

    Subclasses set ``name``, ``duration`` (s) and implement :meth:`update`; they may add tasks in :meth:`setup`
    and change ``polygon_margin`` (m, margin of the CoM polygon constraint).

    Args:
        robot: the robot.
        config: the starting configuration (the plan is built from it).
    """

    name: str = "behaviour"
    duration: float = 0.0
    polygon_margin: float = 0.01

    def __init__(self, robot: Robot, config: Configuration):
        self.robot = robot
        self.com0 = config.com.copy()
        self.left0 = config.data.oMf[robot.frame_id(robot.left_sole)].copy()
        self.right0 = config.data.oMf[robot.frame_id(robot.right_sole)].copy()

    def setup(self, ctrl: BalanceController) -> None:
        """Add the behaviour's tasks / adjust weights (called once before the first tick)."""

    @abstractmethod
    def update(self, ctrl: BalanceController, t: float, config: Configuration) -> None:
        """Set every reference (and the support phase via ``ctrl.set_support``) for time t (s)."""

    def summary(self, run: BalanceRun) -> dict:
        """Behaviour-specific summary entries."""
        return {}

    def criteria(self) -> list[Criterion]:
        """Behaviour-specific acceptance criteria."""
        return []

    def overlays(self, run: BalanceRun) -> dict[str, np.ndarray]:
        """Extra points to draw in recordings: name → (N, 3) world points (m)."""
        return {}


def side_option(value: str, what: str) -> str:
    """``value`` if it is ``"left"`` or ``"right"``.

    Raises:
        InvalidInputError: any other value, naming the option ``what``.
    """
    if value not in ("left", "right"):
        raise InvalidInputError(f"{what} must be 'left' or 'right', got {value!r}")
    return value


def make_behaviour(name: str, robot: Robot, config: Configuration, **options) -> Behaviour:
    """Instantiate a behaviour by name (see :data:`BEHAVIOURS`).

    Raises:
        InvalidInputError: unknown behaviour name.
    """
    if name not in BEHAVIOURS:
        raise InvalidInputError(f"unknown balance behaviour {name!r}; valid: {sorted(BEHAVIOURS)}")
    module, cls = BEHAVIOURS[name].split(":")
    return getattr(importlib.import_module(module), cls)(robot, config, **options)


# -- run --------------------------------------------------------------------------------------------------------
@dataclass
class BalanceRun(StanceRun):
    """Arrays recorded during a behaviour (see the module docstring for the log format; written by ``save``):
    those of :class:`~wbc.scenarios.stance.StanceRun`, the behaviour's name, ``com_margin`` (N,) m, and the
    tasks' names and errors."""

    behaviour: str
    com_margin: np.ndarray
    task_names: list[str]
    task_error: np.ndarray
    task_units: list[str] = field(default_factory=list)
    extra: dict = field(default_factory=dict)

    def polygons(self, robot: Robot) -> list[tuple[float, float, np.ndarray]]:
        """Support polygons for :func:`wbc.viz.record_html`: one ``(t_start, t_end, (k, 3))`` per support phase."""
        out = []
        change = np.flatnonzero(np.diff(self.support)) + 1
        starts, ends = np.r_[0, change], np.r_[change, len(self.t)]
        for a, b in zip(starts, ends):
            soles = [p[a] for s, p in ((LEFT_STANCE, self.left_sole), (RIGHT_STANCE, self.right_sole))
                     if self.support[a] in (DOUBLE, s)]
            poly = support_polygon(soles, robot.sole_length, robot.sole_width)
            t_end = self.t[b] if b < len(self.t) else self.t[-1] + self.dt
            out.append((float(self.t[a]), float(t_end), np.c_[poly, np.zeros(len(poly))]))
        return out


def _com_margin(robot: Robot, com_xy: np.ndarray, left: np.ndarray, right: np.ndarray,
                support: int) -> float:
    soles = [p for s, p in ((LEFT_STANCE, left), (RIGHT_STANCE, right)) if support in (DOUBLE, s)]
    return float(signed_distance(com_xy, support_polygon(soles, robot.sole_length, robot.sole_width)))


def run_balance(robot: Robot, behaviour: str | Behaviour, *, dt: float = 0.002, solver: str = DEFAULT_SOLVER,
                config: Configuration | None = None, viewer=None, pacer=None, **options) -> BalanceRun:
    """Run one balance behaviour under the kinematic QP at period dt.

    Args:
        robot: the robot.
        behaviour: a name of :data:`BEHAVIOURS` or a :class:`Behaviour` built on ``config``.
        dt: control period (s), > 0.
        solver: QP backend name.
        config: starting configuration (default ``robot.q_ref``, both soles on the ground).
        viewer: optional object with ``update(q, t, overlays={"com": c})`` (non-blocking, e.g.
            :class:`wbc.viz.LiveViewer`).
        pacer: optional :class:`wbc.viz.RealTimePacer` (``wait(t_sim)`` once per tick).
        **options: keyword arguments of the behaviour's constructor (when given by name).

    Returns:
        :class:`BalanceRun` with one row per tick.

    Raises:
        InvalidInputError: unknown behaviour, bad option or dt.
    """
    if not (np.isfinite(dt) and dt > 0):
        raise InvalidInputError(f"dt must be finite and > 0 (s), got {dt!r}")
    config = config or Configuration(robot)
    beh = make_behaviour(behaviour, robot, config, **options) if isinstance(behaviour, str) else behaviour
    ctrl = BalanceController(robot, config, solver=solver, polygon_margin=beh.polygon_margin)
    beh.setup(ctrl)
    tasks = list(ctrl.controller.tasks) + [t for t in ctrl.swing.values() if not ctrl.has_task(t)]
    extra_tasks = getattr(beh, "tasks", [])
    tasks += [t for t in extra_tasks if all(t is not u for u in tasks)]
    n = int(math.floor(beh.duration / dt + 1e-9)) + 1
    rec = StanceRecorder(robot, n)
    out_ref = np.full((n, 3), np.nan)
    support = np.empty(n, dtype=np.int8)
    margin = np.empty(n)
    parts = [(i, *part) for i, task in enumerate(tasks) for part in task_error_parts(task)]
    errors = np.full((n, len(parts)), np.nan)
    for k in range(n):
        t = k * dt
        rec.record_state(k, config)
        t0 = perf_counter()
        beh.update(ctrl, t, config)
        result = ctrl.solve(config, dt)
        tick = perf_counter() - t0
        support[k] = ctrl.support
        if ctrl.has_task(ctrl.com):
            out_ref[k] = ctrl.com.target
        last, e = -1, None
        for c, (i, _, _, rows) in enumerate(parts):
            if ctrl.has_task(tasks[i]):
                if i != last:
                    last, e = i, tasks[i].compute_error(config)
                errors[k, c] = float(np.linalg.norm(e if rows is None else e[rows]))
        margin[k] = _com_margin(robot, rec.com[k, :2], rec.left_sole[k], rec.right_sole[k], ctrl.support)
        config.step(result.v, dt)
        rec.record_command(k, result, tick)
        if viewer is not None:
            viewer.update(config.q, (k + 1) * dt, overlays={"com": config.com})
        if pacer is not None:
            pacer.wait((k + 1) * dt)
    return BalanceRun(
        robot=robot.name, behaviour=beh.name, dt=dt, t=np.arange(n) * dt, com_ref=out_ref, support=support,
        com_margin=margin, task_names=[p[1] for p in parts], task_error=errors, joint_names=robot.joint_names,
        task_units=[p[2] for p in parts], extra={"behaviour": beh}, **rec.arrays(),
    )


def task_error_parts(task) -> list[tuple[str, str, np.ndarray | None]]:
    """How a task's error splits by unit: ``(label, unit, rows of compute_error() or None for all)``.

    CoM and frame position rows are in m, posture and frame orientation rows in rad (revolute joints); a frame
    task with both gives ``<name> position`` and ``<name> orientation``; any other task is one part whose
    unit is ``"task"`` (its own units).
    """
    if isinstance(task, FrameTask):
        rows = np.asarray(task.rows)
        pos, rot = np.flatnonzero(rows < 3), np.flatnonzero(rows >= 3)
        if pos.size and rot.size:
            return [(f"{task.name} position", "m", pos), (f"{task.name} orientation", "rad", rot)]
        return [(task.name, "m" if pos.size else "rad", None)]
    if isinstance(task, ComTask):
        return [(task.name, "m", None)]
    if isinstance(task, PostureTask):
        return [(task.name, "rad", None)]
    return [(task.name, "task", None)]


# -- summary and acceptance ---------------------------------------------------------------------------------
def _stance_slip(run: BalanceRun) -> float:
    """Largest displacement (m) of a stance sole from where its stance began."""
    slip = 0.0
    for stance_ids, poses in (((DOUBLE, LEFT_STANCE), run.left_sole), ((DOUBLE, RIGHT_STANCE), run.right_sole)):
        in_stance = np.isin(run.support, stance_ids)
        starts = np.flatnonzero(in_stance & ~np.r_[False, in_stance[:-1]])
        ends = np.flatnonzero(in_stance & ~np.r_[in_stance[1:], False])
        for a, b in zip(starts, ends):
            slip = max(slip, float(np.max(np.linalg.norm(poses[a:b + 1, :3, 3] - poses[a, :3, 3], axis=1))))
    return slip


#: Criteria of every behaviour (from the issue).
COMMON_CRITERIA: list[Criterion] = [
    Criterion("CoM projection inside the support polygon at every tick", "min_com_margin_m", ">=", 0.0),
    Criterion("ZMP of the executed motion inside the support polygon at every tick", "min_zmp_margin_m", ">=", 0.0),
    Criterion("stance soles do not slip (≤ 1 mm)", "max_stance_slip_m", "<=", 1e-3),
    Criterion("no joint position limit violation", "joint_position_violations", "==", 0),
    Criterion("no joint velocity limit violation", "joint_velocity_violations", "==", 0),
    Criterion("no solver failure", "solver_failures", "==", 0),
    Criterion("no NaN", "nan", "==", False),
]


def _executed_zmp_margin(robot: Robot, run: BalanceRun, multibody: bool = True) -> float:
    """Min over ticks of the signed distance (m) of the executed-motion ZMP (multi-body, or CoM-only with L̇ = 0)
    to the realized support polygon."""
    ground = stance_ground_z(run.left_sole, run.right_sole, run.support, DOUBLE, LEFT_STANCE)
    if multibody:
        zmp = executed_zmp(run.com, run.dt, ground, mass=robot.mass,
                           angular_momentum=executed_angular_momentum(robot.model, run.q, run.v))
    else:
        zmp = executed_zmp(run.com, run.dt, ground)
    return float(support_margin(zmp, run.left_sole, run.right_sole, run.support, robot.sole_length,
                                robot.sole_width, DOUBLE, LEFT_STANCE, RIGHT_STANCE).min())


def balance_summary(robot: Robot, run: BalanceRun) -> dict:
    """Acceptance metrics of a balance run.

    Returns a dict with: robot, behaviour, dt_s, ticks, duration_s, tick_time_us {median, p99, max} (reference
    update + QP assembly + solve), min_com_margin_m (signed distance of the CoM ground projection to the support
    polygon of the realized stance soles, min over ticks, negative = outside), min_zmp_margin_m (the same for the ZMP
    of the EXECUTED motion: multi-body ZMP from the CoM of the integrated q, c̈ by central second finite
    differences of that CoM and L̇ by backward differences of the centroidal angular momentum A_G(q_k) v_k, see
    :mod:`wbc.scenarios.metrics`), min_zmp_margin_com_only_m (the same with L̇ = 0; reported, not judged),
    max_task_error_m {task: max over active ticks of ‖e‖ in m: CoM, frame
    positions}, max_task_error_rad {the same in rad: orientations, posture} (see :func:`task_error_parts`; a
    task in other units goes under max_task_error_task), max_stance_slip_m,
    joint_position_violations / joint_velocity_violations ((tick, joint) pairs outside the URDF limits),
    solver_failures (ticks whose command fell back to a safe command), relaxed_ticks (ticks solved without the
    relaxable constraints — executed-ZMP constraint — reported, not judged), ticks_per_route and ticks_per_path
    (ticks per route and per path of ``TickResult.path``, :func:`wbc.tick.count_paths`), nan; then the behaviour's own entries; then ``passed`` and ``failed_criteria``.
    """
    model = robot.model
    idx_q, _ = bounded_joints(model)
    qj = run.q[:, idx_q]
    pos_viol = int(np.sum((qj < model.lowerPositionLimit[idx_q]) | (qj > model.upperPositionLimit[idx_q])))
    vel_viol = int(np.sum(np.abs(run.v[:, 6:]) > model.velocityLimit[6:]))
    tt = run.tick_time * 1e6
    task_err: dict[str, dict[str, float]] = {"m": {}, "rad": {}}
    units = run.task_units or ["task"] * len(run.task_names)
    for i, (name, unit) in enumerate(zip(run.task_names, units)):
        col = run.task_error[:, i]
        if np.isfinite(col).any():
            task_err.setdefault(unit, {})[name] = float(np.nanmax(col))
    summary = {
        "robot": robot.name,
        "behaviour": run.behaviour,
        "dt_s": run.dt,
        "ticks": int(len(run.t)),
        "duration_s": float(run.t[-1]),
        "tick_time_us": {"median": float(np.median(tt)), "p99": float(np.percentile(tt, 99)), "max": float(tt.max())},
        "min_com_margin_m": float(run.com_margin.min()),
        "min_zmp_margin_m": _executed_zmp_margin(robot, run),
        "min_zmp_margin_com_only_m": _executed_zmp_margin(robot, run, multibody=False),
        **{f"max_task_error_{unit}": errs for unit, errs in task_err.items()},
        "max_stance_slip_m": _stance_slip(run),
        "joint_position_violations": pos_viol,
        "joint_velocity_violations": vel_viol,
        "solver_failures": int(np.sum(~run.solver_ok)),
        "relaxed_ticks": int(np.sum(run.relaxed)) if run.relaxed is not None else 0,
        **count_paths(run.path),
        "nan": bool(not (np.isfinite(run.q).all() and np.isfinite(run.v).all())),
    }
    beh = run.extra.get("behaviour")
    criteria = list(COMMON_CRITERIA)
    if beh is not None:
        summary.update(beh.summary(run))
        criteria += beh.criteria()
    passed, failed = balance_passes(summary, criteria)
    summary["passed"] = passed
    summary["failed_criteria"] = failed
    return summary


def balance_passes(summary: dict, criteria: list[Criterion]) -> tuple[bool, list[str]]:
    """(all criteria hold, descriptions of the failed ones); a criterion whose key is missing fails."""
    return evaluate(summary, criteria)
