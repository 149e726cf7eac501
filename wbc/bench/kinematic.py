"""Kinematic tick benchmark: one scenario, one runner per library (wbc, placo, Pink).

Scenario (:class:`KinematicSpec`): a humanoid with a free-flyer base starts at its reference posture (Talos:
``half_sitting``); both soles are fixed by hard equality constraints; the CoM target sways laterally,
``c*(t) = c0 + [0, A sin(2π f t), 0]`` (A = 3 cm, f = 0.5 Hz); the torso keeps its initial orientation; a
low-weight posture task pulls every actuated joint to the reference posture; joint position and velocity limits
hold. Control period dt = 2 ms.

The three libraries get the same problem, written in each one's own terms. All tasks are dead-beat (each tick asks
to cancel the whole error in one period: wbc gain K = 1/dt, Pink gain α = 1, placo's tasks always are), the task
weights are the same weights on squared residuals (Pink's ``cost`` is a square-root weight, so cost = √w), and the
Tikhonov regularisation of the step is the same (``damping``).

One tick = set the CoM target + solve the QP + integrate q + update the kinematics of the new q. That is, per
library: wbc ``ComTask.set_target`` + ``KinematicController.solve`` + ``Configuration.integrate`` +
``Configuration.update``; placo ``target_world = ...`` + ``KinematicsSolver.solve(True)`` (it integrates) +
``RobotWrapper.update_kinematics()``; Pink ``ComTask.set_target`` + ``solve_ik`` +
``Configuration.integrate_inplace`` (it updates the kinematics).
"""

from __future__ import annotations

import gc
import math
from abc import ABC, abstractmethod
from dataclasses import dataclass
from time import perf_counter_ns, thread_time_ns

import numpy as np
import pinocchio as pin

from wbc.solvers import DEFAULT_SOLVER
from wbc.constraints.limits import bounded_joints
from wbc.robot import Robot

__all__ = ["KinematicSpec", "KinematicRun", "KinematicRunner", "WbcRunner", "PlacoRunner", "PinkRunner",
           "pink_available", "evaluate_motion", "same_work_check", "SameWorkTolerance"]


@dataclass(frozen=True)
class KinematicSpec:
    """The scenario shared by every runner.

    Attributes:
        robot: catalog name.
        dt: control period (s).
        ticks: timed ticks per run.
        warmup: ticks run before the timed ones (same trajectory, not timed).
        sway_amplitude: lateral CoM sway amplitude A (m).
        sway_frequency: sway frequency f (Hz).
        com_weight, torso_weight, posture_weight: weights of the squared residuals of the CoM (m), torso
            orientation (rad) and posture (rad) tasks.
        damping: weight of ‖Δq‖² (Tikhonov regularisation of the step).
        solver: QP backend (wbc: a :func:`wbc.solvers.available_solvers` name; Pink: a qpsolvers name; placo: its
            built-in eiquadprog, this field is ignored).
    """

    robot: str = "talos"
    dt: float = 0.002
    ticks: int = 2000
    warmup: int = 100
    sway_amplitude: float = 0.03
    sway_frequency: float = 0.5
    com_weight: float = 10.0
    torso_weight: float = 1.0
    posture_weight: float = 1e-2
    damping: float = 1e-6
    solver: str = DEFAULT_SOLVER  # wbc's own default backend; Pink picks its fastest valid one separately

    @property
    def total_ticks(self) -> int:
        return self.warmup + self.ticks

    def com_targets(self, com0: np.ndarray) -> np.ndarray:
        """(total_ticks + 1, 3) CoM target (m, world) at t_k = k dt for k = 0 .. total_ticks."""
        t = np.arange(self.total_ticks + 1) * self.dt
        out = np.repeat(np.asarray(com0, dtype=float)[None, :], t.size, axis=0)
        out[:, 1] += self.sway_amplitude * np.sin(2 * math.pi * self.sway_frequency * t)
        return out


@dataclass
class KinematicRun:
    """Result of one run.

    Attributes:
        library, robot, solver: what ran.
        wall_ns, cpu_ns: (ticks,) wall and thread-CPU time of each timed tick (ns).
        failures: ticks whose QP failed (the library's own failure signal).
        metrics: same-work quantities from :func:`evaluate_motion`.
        breakdown_ns: (ticks,) arrays per phase ('kinematics', 'assembly', 'solve'), wbc only, when requested.
        note: how the library was configured where it differs from the others.
        first_error: message of the first failed tick ('' if none).
    """

    library: str
    robot: str
    solver: str
    wall_ns: np.ndarray
    cpu_ns: np.ndarray
    failures: int
    metrics: dict[str, object]
    breakdown_ns: dict[str, np.ndarray] | None = None
    note: str = ""
    first_error: str = ""


class KinematicRunner(ABC):
    """Runs :class:`KinematicSpec` with one library. Subclasses build the problem in :meth:`reset` and do one
    tick (the timed scope, module docstring) in :meth:`tick`."""

    library: str = ""
    note: str = ""
    #: factor turning the raw value returned by :meth:`tick` into a velocity (rad/s): 1/dt when it is a step Δq.
    velocity_scale: float = 1.0
    #: whether :meth:`tick` fills per-phase timers when ``run(breakdown=True)``.
    supports_breakdown: bool = False

    def __init__(self, spec: KinematicSpec, robot: Robot):
        self.spec = spec
        self.robot = robot
        data = robot.model.createData()
        pin.framesForwardKinematics(robot.model, data, robot.q_ref)
        self.com0 = pin.centerOfMass(robot.model, data, robot.q_ref).copy()
        self.targets = spec.com_targets(self.com0)
        self.failures = 0
        self.first_error = ""
        self._breakdown: dict[str, np.ndarray] | None = None

    @abstractmethod
    def reset(self) -> None:
        """Build a fresh problem at ``robot.q_ref`` (not timed)."""

    @abstractmethod
    def tick(self, k: int) -> np.ndarray:
        """Tick k: target ``self.targets[k + 1]``, solve, integrate, update kinematics. Returns v or Δq."""

    @abstractmethod
    def configuration(self) -> np.ndarray:
        """(nq,) current configuration (a copy)."""

    @property
    def solver_name(self) -> str:
        return self.spec.solver

    def run(self, breakdown: bool = False) -> KinematicRun:
        """Reset, run warmup + timed ticks, evaluate the motion."""
        spec = self.spec
        n = spec.total_ticks
        self.reset()
        self.failures = 0
        self.first_error = ""
        self._breakdown = {k: np.zeros(n, dtype=np.int64) for k in ("kinematics", "assembly", "solve")} \
            if breakdown and self.supports_breakdown else None
        qs = np.empty((n + 1, self.robot.nq))
        vs = np.empty((n, self.robot.nv))
        qs[0] = self.configuration()
        wall = np.empty(n, dtype=np.int64)
        cpu = np.empty(n, dtype=np.int64)
        gc.collect()
        for k in range(n):
            c0 = thread_time_ns()
            w0 = perf_counter_ns()
            raw = self.tick(k)
            w1 = perf_counter_ns()
            c1 = thread_time_ns()
            wall[k] = w1 - w0
            cpu[k] = c1 - c0
            vs[k] = raw
            qs[k + 1] = self.configuration()
        vs *= self.velocity_scale
        metrics = evaluate_motion(self.robot, spec, qs, vs, self.targets)
        bd = None if self._breakdown is None else {k: v[spec.warmup:] for k, v in self._breakdown.items()}
        return KinematicRun(self.library, self.robot.name, self.solver_name, wall[spec.warmup:], cpu[spec.warmup:],
                            self.failures, metrics, bd, self.note, self.first_error)

    def _fail(self, message: str) -> None:
        self.failures += 1
        if not self.first_error:
            self.first_error = message


# -- wbc ------------------------------------------------------------------------------------------------------
class WbcRunner(KinematicRunner):
    """wbc :class:`~wbc.controllers.kinematic.KinematicController`: soles as :class:`~wbc.constraints.ContactConstraint`."""

    library = "wbc"
    supports_breakdown = True

    def reset(self) -> None:
        from wbc.configuration import Configuration
        from wbc.constraints import ContactConstraint, JointPositionLimit, JointVelocityLimit
        from wbc.controllers.kinematic import KinematicController
        from wbc.tasks import ComTask, OrientationTask, PostureTask

        s, robot = self.spec, self.robot
        k = 1.0 / s.dt
        self.config = Configuration(robot)
        self.com = ComTask(weight=s.com_weight, gain=k)
        self.com.set_target(self.targets[0])
        torso = OrientationTask(robot, robot.torso, weight=s.torso_weight, gain=k, name="torso")
        torso.set_target_from_configuration(self.config)
        posture = PostureTask(robot, weight=s.posture_weight, gain=k)
        contacts = [ContactConstraint(robot, f, gain=k) for f in (robot.left_sole, robot.right_sole)]
        for c in contacts:
            c.set_placement_from_configuration(self.config)
        self.controller = KinematicController(
            robot, [self.com, torso, posture],
            [*contacts, JointPositionLimit(robot), JointVelocityLimit(robot)],
            solver=s.solver, damping=s.damping,
        )

    def tick(self, k: int) -> np.ndarray:
        dt = self.spec.dt
        self.com.set_target(self.targets[k + 1])
        res = self.controller.solve(self.config, dt)
        if self._breakdown is None:
            self.config.step(res.v, dt)
        else:
            t0 = perf_counter_ns()
            self.config.step(res.v, dt)
            self._breakdown["kinematics"][k] = perf_counter_ns() - t0
            self._breakdown["assembly"][k] = int(res.timings["assembly"] * 1e9)
            self._breakdown["solve"][k] = int(res.timings["solve"] * 1e9)
        if not res.ok:
            self._fail(res.message)
        return res.v

    def configuration(self) -> np.ndarray:
        return self.config.q.copy()


# -- placo ----------------------------------------------------------------------------------------------------
class PlacoRunner(KinematicRunner):
    """placo ``KinematicsSolver``: soles as hard frame tasks, the rest soft tasks, ``enable_joint_limits`` and
    ``enable_velocity_limits``; regularisation set to ``damping``."""

    library = "placo"
    note = "soles: hard frame tasks; QP: placo's eiquadprog"

    def __init__(self, spec: KinematicSpec, robot: Robot):
        super().__init__(spec, robot)
        from wbc.bench.placo_models import placo_robot_wrapper

        self.wrapper = placo_robot_wrapper(robot)
        self.velocity_scale = 1.0 / spec.dt

    solver_name = "eiquadprog"

    def reset(self) -> None:
        from wbc.bench.placo_models import kinematics_solver, reset_at_reference

        s, robot, w = self.spec, self.robot, self.wrapper
        reset_at_reference(w, robot)
        solver = kinematics_solver(w, s.dt, s.damping)
        for frame in (robot.left_sole, robot.right_sole):
            solver.add_frame_task(frame, w.get_T_world_frame(frame)).configure(frame, "hard", 1.0, 1.0)
        self.com = solver.add_com_task(self.targets[0].copy())
        self.com.configure("com", "soft", s.com_weight)
        torso = solver.add_orientation_task(robot.torso, w.get_T_world_frame(robot.torso)[:3, :3].copy())
        torso.configure("torso", "soft", s.torso_weight)
        posture = solver.add_joints_task()
        posture.set_joints({name: float(robot.q_ref[robot.model.joints[robot.joint_id(name)].idx_q])
                            for name in robot.joint_names})
        posture.configure("posture", "soft", s.posture_weight)
        self.solver = solver

    def tick(self, k: int) -> np.ndarray:
        self.com.target_world = self.targets[k + 1]
        try:
            dq = self.solver.solve(True)
        except RuntimeError as exc:
            self._fail(str(exc))
            dq = np.zeros(self.robot.nv)
        self.wrapper.update_kinematics()
        return dq

    def configuration(self) -> np.ndarray:
        return np.array(self.wrapper.state.q)


# -- Pink -----------------------------------------------------------------------------------------------------
def pink_available() -> bool:
    """Whether ``pin-pink`` (the ``[bench]`` extra) is importable."""
    import importlib.util

    return importlib.util.find_spec("pink") is not None


class PinkRunner(KinematicRunner):
    """Pink ``solve_ik``: soles as hard equality constraints (``constraints=`` of ``solve_ik`` in pin-pink 4.4),
    ``ConfigurationLimit`` with gain 1 (same as the others: a joint may reach its limit in one tick) and
    ``VelocityLimit``."""

    library = "pink"
    note = "soles: hard equality constraints (solve_ik constraints=); ConfigurationLimit gain 1"

    def reset(self) -> None:
        import pink
        from pink.limits import ConfigurationLimit, VelocityLimit
        from pink.tasks import ComTask, FrameTask, PostureTask

        s, robot = self.spec, self.robot
        model = robot.model
        self.conf = pink.Configuration(model, model.createData(), robot.q_ref.copy())
        self.com = ComTask(cost=math.sqrt(s.com_weight), gain=1.0)
        self.com.set_target(self.targets[0].copy())
        torso = FrameTask(robot.torso, position_cost=0.0, orientation_cost=math.sqrt(s.torso_weight), gain=1.0)
        torso.set_target_from_configuration(self.conf)
        posture = PostureTask(cost=math.sqrt(s.posture_weight), gain=1.0)
        posture.set_target(robot.q_ref.copy())
        self.soles = []
        for frame in (robot.left_sole, robot.right_sole):
            t = FrameTask(frame, position_cost=1.0, orientation_cost=1.0, gain=1.0)
            t.set_target_from_configuration(self.conf)
            self.soles.append(t)
        self.tasks = [self.com, torso, posture]
        self.limits = [ConfigurationLimit(model, config_limit_gain=1.0), VelocityLimit(model)]

    def tick(self, k: int) -> np.ndarray:
        from pink import solve_ik
        from pink.exceptions import NoSolutionFound

        dt = self.spec.dt
        self.com.set_target(self.targets[k + 1])
        try:
            v = solve_ik(self.conf, self.tasks, dt, solver=self.spec.solver, damping=self.spec.damping,
                         limits=self.limits, constraints=self.soles, safety_break=False)
        except NoSolutionFound as exc:
            self._fail(str(exc))
            v = np.zeros(self.robot.nv)
        self.conf.integrate_inplace(v, dt)
        return v

    def configuration(self) -> np.ndarray:
        return np.array(self.conf.q)


# -- same-work check ------------------------------------------------------------------------------------------
def evaluate_motion(robot: Robot, spec: KinematicSpec, qs: np.ndarray, vs: np.ndarray,
                    targets: np.ndarray) -> dict[str, object]:
    """Same-work quantities of a run, computed with one Pinocchio model for every library.

    Args:
        qs: (T+1, nq) configurations q_0 .. q_T (T = total ticks).
        vs: (T, nv) commanded velocities (rad/s, m/s).
        targets: (T+1, 3) CoM targets.

    Returns:
        ``final_com_error`` |c(q_T) − c*_T| (m), ``max_com_error`` over k ≥ 1 (m), ``final_com`` (3,) (m),
        ``feet_drift`` max sole displacement from its initial placement (m), ``feet_rotation`` (rad),
        ``position_limit_violation`` max over ticks and joints of (q − q_max, q_min − q) (rad, ≤ 0 inside),
        ``velocity_limit_violation`` max of |v_j| − v_max,j (rad/s), ``finite``.
    """
    model = robot.model
    data = model.createData()
    fids = [robot.frame_id(robot.left_sole), robot.frame_id(robot.right_sole)]
    finite = bool(np.isfinite(qs).all() and np.isfinite(vs).all())
    if not finite:
        nan = float("nan")
        return {"finite": False, "final_com_error": nan, "max_com_error": nan, "final_com": [nan] * 3,
                "feet_drift": nan, "feet_rotation": nan, "position_limit_violation": nan,
                "velocity_limit_violation": nan}
    com = np.empty((qs.shape[0], 3))
    drift = rot = 0.0
    pin.framesForwardKinematics(model, data, qs[0])
    feet0 = [data.oMf[f].copy() for f in fids]
    for k, q in enumerate(qs):
        com[k] = pin.centerOfMass(model, data, q)  # also runs forward kinematics
        pin.updateFramePlacements(model, data)
        for f, f0 in zip(fids, feet0):
            m = data.oMf[f]
            drift = max(drift, float(np.linalg.norm(m.translation - f0.translation)))
            rot = max(rot, float(np.linalg.norm(pin.log3(f0.rotation.T @ m.rotation))))
    err = np.linalg.norm(com - targets, axis=1)
    idx_q, idx_v = bounded_joints(model)
    lo, hi = model.lowerPositionLimit[idx_q], model.upperPositionLimit[idx_q]
    pos_viol = float(np.max(np.maximum(qs[:, idx_q] - hi, lo - qs[:, idx_q])))
    vmax = model.velocityLimit[6:]
    act = np.isfinite(vmax) & (vmax < 1e30)
    vel_viol = float(np.max(np.abs(vs[:, 6:][:, act]) - vmax[act]))
    return {"finite": True, "final_com_error": float(err[-1]), "max_com_error": float(err[1:].max()),
            "final_com": com[-1].tolist(), "feet_drift": drift, "feet_rotation": rot,
            "position_limit_violation": pos_viol, "velocity_limit_violation": vel_viol}


@dataclass(frozen=True)
class SameWorkTolerance:
    """Tolerances of the same-work check.

    Attributes:
        com: final CoM error, and distance between final CoMs of two libraries (m).
        feet: sole drift (m); feet_rotation: sole rotation (rad).
        limit: position (rad) and velocity (rad/s) limit violation: solver precision, not a physical tolerance.
    """

    com: float = 1e-3
    feet: float = 1e-3
    feet_rotation: float = 1e-3
    limit: float = 1e-6


def same_work_check(metrics: dict[str, dict], reference: str = "placo",
                    tol: SameWorkTolerance = SameWorkTolerance(), failures: dict[str, int] | None = None
                    ) -> dict[str, dict[str, object]]:
    """Check that every library did the same work as ``reference``.

    Args:
        metrics: library -> :func:`evaluate_motion` output.
        reference: library whose final CoM the others' must match.
        failures: library -> number of failed ticks (must be 0).

    Returns:
        library -> {"passed": bool, "failed": [reasons], "verdict": "ok" | "comparison VOID", "compared_with":
        the library whose final CoM was the reference (``reference`` unless it failed its own checks)}.
    """
    checks = [("final_com_error", tol.com), ("feet_drift", tol.feet), ("feet_rotation", tol.feet_rotation),
              ("position_limit_violation", tol.limit), ("velocity_limit_violation", tol.limit)]
    own: dict[str, list[str]] = {}
    for lib, m in metrics.items():
        reasons = []
        if not m.get("finite", False):
            reasons.append("non-finite motion")
        else:
            reasons += [f"{key} {float(m[key]):.3g} > {limit:g}" for key, limit in checks if not float(m[key]) <= limit]
        if failures and failures.get(lib, 0):
            reasons.append(f"{failures[lib]} failed ticks")
        own[lib] = reasons
    # The final CoMs are compared with the reference library's, or, if that one failed its own checks, with the
    # first library that passed them.
    ref_lib = reference if not own.get(reference, ["missing"]) else next((k for k, r in own.items() if not r), None)
    out: dict[str, dict[str, object]] = {}
    for lib, m in metrics.items():
        reasons = list(own[lib])
        if not reasons and ref_lib is not None and lib != ref_lib:
            gap = float(np.linalg.norm(np.subtract(m["final_com"], metrics[ref_lib]["final_com"])))
            if not gap <= tol.com:
                reasons.append(f"final CoM {gap:.3g} m away from {ref_lib}'s > {tol.com:g}")
        out[lib] = {"passed": not reasons, "failed": reasons, "verdict": "ok" if not reasons else "comparison VOID",
                    "compared_with": ref_lib}
    return out
