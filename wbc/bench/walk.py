"""Walk tick benchmark: the main job (Talos walks the default plan at 500 Hz) under wbc and under placo.

Every library follows the same :class:`~wbc.gait.WalkPlan` (``plan_default_walk``: CoM, sole poses, torso yaw),
one tick every ``plan.dt``:

* ``wbc``: :func:`wbc.scenarios.walk.run_walk`'s tick — ``WalkController.set_references`` (support switch, CoM,
  swing sole, torso targets) + ``WalkController.solve`` + ``Configuration.step``; stance soles are hard
  contact constraints, the swing sole a soft frame task.
* ``placo-hard``: placo ``KinematicsSolver`` with both soles as HARD frame tasks on the plan's sole poses (the
  stance sole's pose is constant, the swing sole's follows the plan), CoM (weight 10), torso orientation (1) and
  posture (1e-2) soft, joint position and velocity limits; tick = set targets + ``solve(True)`` +
  ``update_kinematics``. The problem never changes structure (no support switch).
* ``placo-soft``: placo's own walk tasks (``placo.WalkTasks`` on a ``HumanoidRobot``: soft feet, CoM, trunk
  orientation), ``update_tasks`` with the plan's sole poses, CoM and torso orientation each tick + ``solve(True)``
  + ``update_kinematics``.

Per library and repeat: median, p99 and max of the wall time of one tick (ns), plus the motion's CoM tracking
error (max over ticks, m) and the largest sole position error against the plan (m), so a fast but wrong run shows.
"""

from __future__ import annotations

import gc
from dataclasses import asdict, dataclass
from time import perf_counter_ns

import numpy as np
import pinocchio as pin

from wbc.bench.stats import pooled_summary_us, summarize_us
from wbc.solvers import DEFAULT_SOLVER
from wbc.robot import Robot

__all__ = ["WalkBenchSpec", "run_walk_benchmark", "walk_ticks"]


@dataclass(frozen=True)
class WalkBenchSpec:
    """Attributes: n_steps (plan's steps), repeats (interleaved), solver (wbc backend)."""

    n_steps: int = 8
    repeats: int = 3
    solver: str = DEFAULT_SOLVER


def _torso_rotations(plan, rot0: np.ndarray) -> np.ndarray:
    """(N, 3, 3) torso target: yaw = mean heading of the plan's soles (as ``WalkController.set_references``)."""
    yl = np.arctan2(plan.left_sole[:, 1, 0], plan.left_sole[:, 0, 0])
    yr = np.arctan2(plan.right_sole[:, 1, 0], plan.right_sole[:, 0, 0])
    yaw = np.arctan2(np.sin(yl) + np.sin(yr), np.cos(yl) + np.cos(yr))
    return np.array([pin.rpy.rpyToMatrix(0.0, 0.0, float(y)) @ rot0 for y in yaw])


def _motion_errors(robot: Robot, plan, qs: np.ndarray) -> dict[str, float]:
    """CoM tracking error (max over ticks, m) and sole position error against the plan (max, m) of a run."""
    model, data = robot.model, robot.model.createData()
    lf, rf = robot.frame_id(robot.left_sole), robot.frame_id(robot.right_sole)
    com_err = sole_err = 0.0
    finite = bool(np.isfinite(qs).all())
    if not finite:
        return {"finite": False, "max_com_error": float("nan"), "max_sole_error": float("nan")}
    for k, q in enumerate(qs):
        c = pin.centerOfMass(model, data, q)
        pin.updateFramePlacements(model, data)
        com_err = max(com_err, float(np.linalg.norm(c - plan.com[k])))
        sole_err = max(sole_err, float(np.linalg.norm(data.oMf[lf].translation - plan.left_sole[k][:3, 3])),
                       float(np.linalg.norm(data.oMf[rf].translation - plan.right_sole[k][:3, 3])))
    return {"finite": True, "max_com_error": com_err, "max_sole_error": sole_err}


class _WbcWalk:
    library = "wbc"

    def __init__(self, robot: Robot, plan, solver: str):
        self.robot, self.plan, self.solver = robot, plan, solver

    def run(self) -> tuple[np.ndarray, np.ndarray, int]:
        from wbc.configuration import Configuration
        from wbc.scenarios.walk import WalkController

        robot, plan = self.robot, self.plan
        config = Configuration(robot)
        walker = WalkController(robot, config, solver=self.solver)
        walker.set_plan(plan)  # as run_walk: validated and precomputed before the first tick
        n, dt = len(plan.t), plan.dt
        wall = np.empty(n, np.int64)
        qs = np.empty((n + 1, robot.nq))
        qs[0] = config.q
        failures = 0
        gc.collect()
        for k in range(n):
            t0 = perf_counter_ns()
            walker.set_references(plan, k, config)
            res = walker.solve(config, dt)
            config.step(res.v, dt)
            wall[k] = perf_counter_ns() - t0
            failures += not res.ok
            qs[k + 1] = config.q
        return wall, qs, failures

    def ticks(self):
        """Generator: one untimed walk tick (the timed scope of :meth:`run`) per ``next``."""
        from wbc.configuration import Configuration
        from wbc.scenarios.walk import WalkController

        robot, plan = self.robot, self.plan
        config = Configuration(robot)
        walker = WalkController(robot, config, solver=self.solver)
        walker.set_plan(plan)
        for k in range(len(plan.t)):
            walker.set_references(plan, k, config)
            res = walker.solve(config, plan.dt)
            config.step(res.v, plan.dt)
            yield res.ok


class _PlacoWalk:
    """A placo ``KinematicsSolver`` tracking the plan (the same loop for the hard-feet and the soft-feet set-ups:
    subclasses load the placo model and add their tasks, returning the per-tick target update)."""

    library = "placo"

    def __init__(self, robot: Robot, plan):
        self.robot, self.plan = robot, plan
        self.model = self._load(robot)
        data = robot.model.createData()
        pin.framesForwardKinematics(robot.model, data, robot.q_ref)
        self.rot = _torso_rotations(plan, data.oMf[robot.frame_id(robot.torso)].rotation.copy())

    def _load(self, robot: Robot):
        raise NotImplementedError

    def ticks(self):
        """Generator: one untimed walk tick (the timed scope of :meth:`run`) per ``next``."""
        from wbc.bench.placo_models import kinematics_solver, reset_at_reference

        robot, plan, w = self.robot, self.plan, self.model
        reset_at_reference(w, robot)
        solver = kinematics_solver(w, plan.dt, 1e-6)
        update = self._tasks(solver, w)
        for k in range(len(plan.t)):
            update(k)
            ok = True
            try:
                solver.solve(True)
            except RuntimeError:
                ok = False
            w.update_kinematics()
            yield ok

    def _tasks(self, solver, model):
        """Add the tasks to ``solver``; return ``update(k)`` setting the targets of tick k."""
        raise NotImplementedError

    def run(self) -> tuple[np.ndarray, np.ndarray, int]:
        from wbc.bench.placo_models import kinematics_solver, reset_at_reference

        robot, plan, w = self.robot, self.plan, self.model
        reset_at_reference(w, robot)
        solver = kinematics_solver(w, plan.dt, 1e-6)
        update = self._tasks(solver, w)
        n = len(plan.t)
        wall = np.empty(n, np.int64)
        qs = np.empty((n + 1, robot.nq))
        qs[0] = w.state.q
        failures = 0
        gc.collect()
        for k in range(n):
            t0 = perf_counter_ns()
            update(k)
            try:
                solver.solve(True)
            except RuntimeError:
                failures += 1
            w.update_kinematics()
            wall[k] = perf_counter_ns() - t0
            qs[k + 1] = w.state.q
        return wall, qs, failures


class _PlacoHardWalk(_PlacoWalk):
    library = "placo-hard"

    def _load(self, robot: Robot):
        from wbc.bench.placo_models import placo_robot_wrapper

        return placo_robot_wrapper(robot)

    def _tasks(self, solver, w):
        robot, plan = self.robot, self.plan
        feet = []
        for frame in (robot.left_sole, robot.right_sole):
            t = solver.add_frame_task(frame, w.get_T_world_frame(frame))
            t.configure(frame, "hard", 1.0, 1.0)
            feet.append(t)
        com = solver.add_com_task(plan.com[0].copy())
        com.configure("com", "soft", 10.0)
        torso = solver.add_orientation_task(robot.torso, self.rot[0].copy())
        torso.configure("torso", "soft", 1.0)
        posture = solver.add_joints_task()
        posture.set_joints({name: float(robot.q_ref[robot.model.joints[robot.joint_id(name)].idx_q])
                            for name in robot.joint_names})
        posture.configure("posture", "soft", 1e-2)
        left, right, rot, com_ref = plan.left_sole, plan.right_sole, self.rot, plan.com

        def update(k: int) -> None:
            feet[0].T_world_frame = left[k]
            feet[1].T_world_frame = right[k]
            com.target_world = com_ref[k]
            torso.R_world_frame = rot[k]

        return update


class _PlacoSoftWalk(_PlacoWalk):
    library = "placo-soft"

    def _load(self, robot: Robot):
        from wbc.bench.placo_models import placo_humanoid

        return placo_humanoid(robot)

    def _tasks(self, solver, h):
        import placo

        tasks = placo.WalkTasks()
        tasks.initialize_tasks(solver, h)
        left, right, rot, com_ref = self.plan.left_sole, self.plan.right_sole, self.rot, self.plan.com

        def update(k: int) -> None:
            tasks.update_tasks(left[k], right[k], com_ref[k], rot[k])

        return update


def walk_ticks(library: str, robot: Robot, plan, solver: str = DEFAULT_SOLVER):
    """Generator of the walk ticks of ``library`` (``"wbc"`` or ``"placo-hard"``, module docstring) on ``plan``,
    one per ``next`` (yielding whether the tick solved), for instruction counting.

    Raises:
        ValueError: unknown library.
    """
    if library == "wbc":
        return _WbcWalk(robot, plan, solver).ticks()
    if library == "placo-hard":
        return _PlacoHardWalk(robot, plan).ticks()
    raise ValueError(f"unknown walk library {library!r} (wbc, placo-hard)")


def run_walk_benchmark(robot: Robot, spec: WalkBenchSpec = WalkBenchSpec(), with_placo: bool = True,
                       log=print) -> dict[str, object]:
    """Run the walk with every library, interleaved A B C A B C … ``spec.repeats`` times (module docstring).

    Returns:
        {"spec", "ticks", "libraries": {lib: {"wall_us": pooled summary, "repeat_medians_us",
        "repeat_p99_us", "failures", "max_com_error", "max_sole_error", "finite"}},
        "ratios_to_placo-hard": {lib: median over repeats of median(lib) / median(placo-hard)}}.
    """
    from wbc.scenarios.walk import plan_default_walk

    plan = plan_default_walk(robot, n_steps=spec.n_steps)
    runners: list = [_WbcWalk(robot, plan, spec.solver)]
    if with_placo:
        runners += [_PlacoHardWalk(robot, plan), _PlacoSoftWalk(robot, plan)]
    walls: dict[str, list[np.ndarray]] = {r.library: [] for r in runners}
    out: dict[str, dict] = {r.library: {"failures": 0, "max_com_error": 0.0, "max_sole_error": 0.0,
                                        "finite": True} for r in runners}
    for rep in range(spec.repeats):
        for r in runners:
            wall, qs, failures = r.run()
            walls[r.library].append(wall)
            err = _motion_errors(robot, plan, qs[:-1])
            o = out[r.library]
            o["failures"] += failures
            o["finite"] = o["finite"] and err["finite"]
            o["max_com_error"] = max(o["max_com_error"], err["max_com_error"])
            o["max_sole_error"] = max(o["max_sole_error"], err["max_sole_error"])
            log(f"walk repeat {rep + 1}/{spec.repeats} {r.library}: median {np.median(wall) / 1e3:.1f} µs, "
                f"p99 {np.percentile(wall, 99) / 1e3:.1f} µs")
    for lib, ws in walls.items():
        out[lib]["wall_us"] = pooled_summary_us(ws)
        out[lib]["repeat_medians_us"] = [summarize_us(w)["median"] for w in ws]
        out[lib]["repeat_p99_us"] = [float(np.percentile(w, 99)) / 1e3 for w in ws]
        out[lib]["p99_us"] = float(np.median(out[lib]["repeat_p99_us"]))
    ratios = {}
    if "placo-hard" in walls:
        for lib, ws in walls.items():
            ratios[lib] = float(np.median([np.median(a) / np.median(b) for a, b in zip(ws, walls["placo-hard"])]))
    return {"spec": asdict(spec), "ticks": len(plan.t), "dt": plan.dt, "libraries": out,
            "ratios_to_placo-hard": ratios, "_raw": {lib: np.concatenate(ws) for lib, ws in walls.items()}}
