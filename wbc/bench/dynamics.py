"""Inverse-dynamics tick benchmark: wbc's ID controller vs placo's ``DynamicsSolver``.

Scenario (:class:`DynamicsSpec`): the robot stands at its reference posture on both soles — planar contacts with
friction (μ) and unilateral normal forces —, torque limits (URDF efforts) and joint position/velocity limits are
on; the CoM tracks the same lateral sway as the kinematic benchmark (3 cm, 0.5 Hz, position + velocity +
acceleration feed-forward) with a PD (kp, kd); the torso holds its orientation; a low-weight posture task
regularises every joint. There is no simulator: each library integrates its own QP acceleration,
``v ← v + v̇ dt, q ← q ⊕ v dt``, so the motion is the controller's own model of itself.

One tick = set the CoM references + solve + integrate (+ kinematics update for placo):
wbc ``IDBalanceController.set_com_reference`` + ``solve(q, v)`` + integration; placo target setters +
``DynamicsSolver.solve(True)`` (integrates) + ``RobotWrapper.update_kinematics()``.

wbc's controller is :mod:`wbc.dynamics` (when it exists): otherwise the wbc row reports "not available".
Differences that remain: wbc models each sole by 4 corner forces in an inscribed friction pyramid and adds a
low-weight centroidal angular-momentum task (its ``IDBalanceController`` default); placo uses its planar-contact
wrench model.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from wbc.bench.kinematic import KinematicRunner, KinematicSpec
from wbc.robot import Robot

__all__ = ["DynamicsSpec", "WbcDynamicsRunner", "PlacoDynamicsRunner", "wbc_dynamics_available",
           "dynamics_instructions_per_tick"]


@dataclass(frozen=True)
class DynamicsSpec(KinematicSpec):
    """Kinematic spec fields (robot, dt, ticks, warmup, sway) plus the ID gains and weights (wbc's
    ``IDBalanceController`` defaults, given to placo too).

    Attributes:
        mu: friction coefficient.
        com_kp, com_kd, torso_kp, torso_kd, posture_kp, posture_kd: PD gains (1/s², 1/s).
        com_weight, torso_weight, posture_weight: task weights.
    """

    mu: float = 0.3
    com_kp: float = 100.0
    com_kd: float = 20.0
    torso_kp: float = 100.0
    torso_kd: float = 20.0
    posture_kp: float = 50.0
    posture_kd: float = 14.0
    com_weight: float = 1000.0
    torso_weight: float = 10.0
    posture_weight: float = 1.0

    def com_references(self, com0: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(T+1, 3) CoM position (m), velocity (m/s), acceleration (m/s²) references at t_k = k dt."""
        pos = self.com_targets(com0)
        t = np.arange(self.total_ticks + 1) * self.dt
        w = 2 * math.pi * self.sway_frequency
        vel = np.zeros_like(pos)
        acc = np.zeros_like(pos)
        vel[:, 1] = self.sway_amplitude * w * np.cos(w * t)
        acc[:, 1] = -self.sway_amplitude * w * w * np.sin(w * t)
        return pos, vel, acc


def wbc_dynamics_available() -> tuple[bool, str]:
    """(available, reason): whether ``wbc.dynamics`` provides the ``IDBalanceController`` used here."""
    try:
        from wbc.dynamics.balance import IDBalanceController
    except Exception as exc:  # not written yet, or broken mid-edit
        return False, f"wbc.dynamics not available ({type(exc).__name__}: {exc})"
    return callable(IDBalanceController), ""


class _DynamicsRunner(KinematicRunner):
    spec: DynamicsSpec

    def __init__(self, spec: DynamicsSpec, robot: Robot):
        super().__init__(spec, robot)
        self.pos, self.vel, self.acc = spec.com_references(self.com0)


class WbcDynamicsRunner(_DynamicsRunner):
    """wbc :class:`~wbc.dynamics.balance.IDBalanceController` at ``spec``'s gains, μ and solver."""

    library = "wbc"
    supports_breakdown = True
    note = "4 corner forces per sole, inscribed friction pyramid; + angular-momentum task (weight 0.1)"

    def reset(self) -> None:
        from wbc.dynamics.balance import IDBalanceController

        s, robot = self.spec, self.robot
        gains = {"com_kp": s.com_kp, "com_kd": s.com_kd, "com_weight": s.com_weight, "torso_kp": s.torso_kp,
                 "torso_kd": s.torso_kd, "torso_weight": s.torso_weight, "posture_kp": s.posture_kp,
                 "posture_kd": s.posture_kd, "posture_weight": s.posture_weight}
        self.ctrl = IDBalanceController(robot, dt=s.dt, solver=s.solver, mu=s.mu, gains=gains)
        self.q = robot.q_ref.copy()
        self.v = np.zeros(robot.nv)
        self.ctrl.reset(self.q, self.v)
        self.model = robot.model

    def tick(self, k: int) -> np.ndarray:
        dt = self.spec.dt
        self.ctrl.set_com_reference(self.pos[k], self.vel[k], self.acc[k])
        cmd = self.ctrl.solve(self.q, self.v)
        if self._breakdown is not None:
            tm = cmd.timings
            self._breakdown["kinematics"][k] = int(tm.get("pinocchio", 0.0) * 1e9)
            self._breakdown["assembly"][k] = int(tm.get("assembly", 0.0) * 1e9)
            self._breakdown["solve"][k] = int(tm.get("solve", 0.0) * 1e9)
        if not cmd.ok:
            self._fail(cmd.message)
        self.v = self.v + cmd.dv * dt
        self.q = pin.integrate(self.model, self.q, self.v * dt)
        return self.v

    def configuration(self) -> np.ndarray:
        return self.q.copy()


class PlacoDynamicsRunner(_DynamicsRunner):
    """placo ``DynamicsSolver``: soles as hard frame tasks made planar contacts (μ, sole size), torque, joint
    and velocity limits enabled, CoM / torso / posture soft tasks with the spec's gains and weights."""

    library = "placo"
    note = "planar contacts (placo wrench model)"

    def __init__(self, spec: DynamicsSpec, robot: Robot):
        super().__init__(spec, robot)
        from wbc.bench.placo_models import placo_robot_wrapper

        self.wrapper = placo_robot_wrapper(robot)

    solver_name = "eiquadprog"

    def reset(self) -> None:
        import placo

        from wbc.bench.placo_models import reset_at_reference

        s, robot, w = self.spec, self.robot, self.wrapper
        reset_at_reference(w, robot)
        solver = placo.DynamicsSolver(w)
        solver.dt = s.dt
        solver.mask_fbase(False)
        solver.enable_torque_limits(True)
        solver.enable_joint_limits(True)
        solver.enable_velocity_limits(True)
        self.contacts = []
        for frame in (robot.left_sole, robot.right_sole):
            task = solver.add_frame_task(frame, w.get_T_world_frame(frame))
            task.configure(frame, "hard", 1.0, 1.0)
            contact = solver.add_planar_contact(task)
            contact.mu = s.mu
            contact.length = robot.sole_length
            contact.width = robot.sole_width
            self.contacts.append(contact)
        self.com = solver.add_com_task(self.pos[0].copy())
        self.com.configure("com", "soft", s.com_weight)
        self.com.kp, self.com.kd = s.com_kp, s.com_kd
        torso = solver.add_orientation_task(robot.torso, w.get_T_world_frame(robot.torso)[:3, :3].copy())
        torso.configure("torso", "soft", s.torso_weight)
        torso.kp, torso.kd = s.torso_kp, s.torso_kd
        posture = solver.add_joints_task()
        posture.set_joints({name: float(robot.q_ref[robot.model.joints[robot.joint_id(name)].idx_q])
                            for name in robot.joint_names})
        posture.configure("posture", "soft", s.posture_weight)
        posture.kp, posture.kd = s.posture_kp, s.posture_kd
        self.solver = solver

    def tick(self, k: int) -> np.ndarray:
        self.com.target_world = self.pos[k]
        self.com.dtarget_world = self.vel[k]
        self.com.ddtarget_world = self.acc[k]
        result = self.solver.solve(True)
        if not result.success:
            self._fail("DynamicsSolver result.success is False")
        self.wrapper.update_kinematics()
        return self.wrapper.state.qd

    def configuration(self) -> np.ndarray:
        return np.array(self.wrapper.state.q)


def _instructions_child(library: str, n: int, robot_name: str = "talos") -> None:
    """Child of :func:`dynamics_instructions_per_tick`: READY after 30 uninstrumented ticks, HALF after N, DONE
    after 2N, each followed by a line read from stdin."""
    from wbc.bench.instructions import run_marked
    from wbc.bench.stats import limit_blas_threads
    from wbc.robot import load_robot

    limit_blas_threads(1)
    robot = load_robot(robot_name)
    spec = DynamicsSpec(robot=robot_name, ticks=2 * n + 30, warmup=30)
    runner = {"wbc": WbcDynamicsRunner, "placo": PlacoDynamicsRunner}[library](spec, robot)
    run_marked(runner, library, 30, n)


def dynamics_instructions_per_tick(n: int = 100, robot_name: str = "talos", log=print) -> dict[str, object]:
    """Instructions per inverse-dynamics tick of wbc and placo (this module's scenario), counted by valgrind's
    callgrind as :func:`wbc.bench.instructions.instructions_per_tick` does for the kinematic tick: each library in
    a child process, instrumentation on after 30 ticks, (Ir(2N) − Ir(N)) / N — a measure that does not move with
    machine load.

    Returns:
        {"n", "robot", "instructions": {lib: per tick}, "ratio_wbc_placo"}.

    Raises:
        RuntimeError: valgrind missing or a child run failed.
    """
    from wbc.bench.instructions import callgrind_available, callgrind_half_and_done

    if not callgrind_available():
        raise RuntimeError("valgrind is not installed (apt-get install valgrind)")
    per = {}
    for lib in ("wbc", "placo"):
        irs = callgrind_half_and_done("wbc.bench.dynamics", [lib, str(n), robot_name], f"dynamics {lib}")
        per[lib] = (irs[1] - irs[0]) / n
        log(f"callgrind dynamics {lib}: {per[lib]:,.0f} instructions per tick ({n} vs {2 * n} ticks differenced)")
    return {"n": n, "robot": robot_name, "instructions": per, "ratio_wbc_placo": per["wbc"] / per["placo"]}


if __name__ == "__main__":
    import sys

    if len(sys.argv) == 1:
        out = dynamics_instructions_per_tick()
        print(f"instruction ratio wbc / placo: {out['ratio_wbc_placo']:.3f}")
    else:
        _instructions_child(sys.argv[1], int(sys.argv[2]), sys.argv[3] if len(sys.argv) > 3 else "talos")
