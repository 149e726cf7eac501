"""Closed loop: a controller drives the MuJoCo model built from the robot's URDF.

Every control tick k (period dt = the MuJoCo timestep, 2 ms → 500 Hz, one ``mj_step`` per tick, no substeps):

1. read (q, v): MuJoCo's **ground truth** converted to Pinocchio conventions by
   :class:`~wbc.sim.conventions.StateMap` (``state=None``), or the **estimate** of ``state`` from the plant's
   sensors (:class:`~wbc.sim.estimated_state.EstimatedState`: encoders, IMU and ankle F/T with noise and bias,
   sampled after ``mj_step1`` — positions and velocities of the state at t — and fused by
   :class:`wbc.estimation.FloatingBaseEstimator`; ``mj_step2`` then completes the step, together bitwise
   ``mj_step``); the log keeps the ground truth, the estimate goes beside it;
2. the scenario updates the references and external forces for time t = k dt;
3. the controller computes τ (timed: this is the "tick time");
4. τ is written to the actuators (MuJoCo clamps it to the URDF effort limits) and ``mj_step`` advances dt;
5. the log records t, q, v, τ, the CoM and its reference, the controller's contact forces and the ground-truth foot
   wrenches (contact forces summed per foot, valid for the state at t); on an estimated state (and a viewer that
   does not read q) the ground truth is copied as MuJoCo's qpos/qvel rows and converted, with the CoM, after the
   loop;
6. :class:`~wbc.sim.outcome.OutcomeMonitor` checks the new state (t + dt) from MuJoCo's data: a fall (base drop
   > 0.2 m, pelvis or torso tilt > 30° from nominal, or a non-foot body touching the floor), joint speeds above
   the URDF limits, and the landing slide of the soles' contact points.

The real-time factor is simulated time / wall time of the whole loop (controller + ``mj_step`` + logging).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from time import perf_counter
from typing import NamedTuple

import mujoco
import numba as nb
import numpy as np
import pinocchio as pin

from wbc.compiled import CHECK_TYPES, once_per_process, specialise
from wbc.dynamics.balance import IDBalanceController
from wbc.exceptions import InvalidInputError, SimulationError
from wbc.formulations.velocity_kernel import all_finite
from wbc.scenarios.framework import RunRecord
from wbc.sim.mujoco_runtime import MujocoModel
from wbc.sim.outcome import FALL_HEIGHT_DROP, OutcomeMonitor
from wbc.tick import PATH_DTYPE

__all__ = ["SimRun", "run_closed_loop", "FALL_HEIGHT_DROP"]


@dataclass
class SimRun(RunRecord):
    """Time series of a closed-loop run (one row per control tick; arrays truncated at the last tick run).

    Attributes:
        robot, controller, scenario: names.
        dt: control period = simulation step (s).
        t: (N,) time (s). q: (N, nq), v: (N, nv) MuJoCo ground-truth state in Pinocchio conventions.
        tau: (N, nv − 6) commanded torques (N·m).
        com, com_ref: (N, 3) CoM (Pinocchio on the MuJoCo state) and its reference (m, world).
        qp_forces: (N, 12 n_c) controller corner forces (N, sole frames) (zeros for the PD baseline).
        contact_active: (N, 2) controller contact flags (left, right).
        sim_wrench: (N, 2, 6) ground-truth ground reaction on (left, right) foot: force (N), moment (N·m) about
            the sole origin, world axes.
        sole_pos: (N, 2, 3) sole frame positions (m, world).
        ext_force: (N, 3) external force applied during the step (N, world).
        residual: (N,) dynamics residual of the QP (nan for the baseline / fallback).
        ok: (N,) a QP was solved (True for the baseline); relaxed: (N,) the relaxed QP was used.
        path: (N,) text, the route each tick took (string form of :class:`wbc.tick.TickPath`; '' for the baseline).
        tick_time: (N,) controller time per tick (s). step_time: (N,) ``mj_step`` time (s).
        wall_time: wall time of the whole loop (s).
        fell, fall_reason, fall_time: fall detection (:mod:`wbc.sim.outcome`).
        outcome: :meth:`wbc.sim.outcome.OutcomeMonitor.summary` of the run (fall, tilt, joint speed, landing
            slide).
    """

    robot: str
    controller: str
    scenario: str
    dt: float
    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    tau: np.ndarray
    com: np.ndarray
    com_ref: np.ndarray
    qp_forces: np.ndarray
    contact_active: np.ndarray
    sim_wrench: np.ndarray
    sole_pos: np.ndarray
    ext_force: np.ndarray
    residual: np.ndarray
    ok: np.ndarray
    relaxed: np.ndarray
    path: np.ndarray
    tick_time: np.ndarray
    step_time: np.ndarray
    wall_time: float = 0.0
    fell: bool = False
    fall_reason: str = ""
    fall_time: float | None = None
    outcome: dict = field(default_factory=dict)
    extra: dict = field(default_factory=dict)

    not_logged = ("wall_time", "fall_time", "outcome")  # wall time is measured, not computed; fall_time is in the summary


class _FootWrenches:
    """Ground-truth ground reaction on each foot and the sole positions of ``sim``, for the log.

    Calling it writes ``out_wrench`` (2, 6: force N, moment N·m about the sole origin, world axes; left, right)
    and ``out_pos`` (2, 3: sole origins, m, world). Uses ``mj_rnePostConstraint``'s ``cfrc_ext`` (the
    constraint/contact wrench on each body, about the subtree CoM, world axes) summed over the bodies rigidly
    attached to each sole; without self-collision and external forces on the feet this is exactly the sum of the
    foot–floor contact forces that ``MujocoModel.foot_contact_wrenches`` computes contact by contact (checked
    equal to 1e-12 in the tests), with one MuJoCo call instead of a loop over the contacts. Valid after
    ``mj_step`` for the state at the start of that step. When that step already computed ``cfrc_ext`` (MuJoCo's
    ``flg_rnepost``: a force/torque or accelerometer sensor's acceleration stage) and the integrator evaluates the
    dynamics once per step (not RK4), those numbers are used as they are: ``mj_rnePostConstraint`` on the same
    inputs gives them again.
    """

    def __init__(self, sim: MujocoModel):
        sides = ("left", "right")
        self.sim = sim
        self.rows = np.concatenate([np.asarray(sim.foot_bodies[s], dtype=int) for s in sides])  # both feet's bodies
        self.starts = np.array([0, len(sim.foot_bodies["left"])])  # where each foot's bodies start in ``rows``
        self.sole_body = [int(sim.sole_placements[s][0]) for s in sides]
        self.sole_offset = [sim.sole_placements[s][1].translation.tolist() for s in sides]  # in the body's frame
        self.root = [int(sim.model.body_rootid[b]) for b in self.sole_body]  # subtree whose CoM cfrc_ext is about
        # the same as arrays for the kernel
        self.rows = self.rows.astype(np.int64)
        self.feet = _FeetBodies(self.rows, np.array([len(sim.foot_bodies["left"]), len(self.rows)], dtype=np.int64),
                               np.array(self.sole_body, dtype=np.int64), np.array(self.sole_offset, dtype=float),
                               np.array(self.root, dtype=np.int64))
        self.single_stage = int(sim.model.opt.integrator) != int(mujoco.mjtIntegrator.mjINT_RK4)
        _warm_up()
        # the compiled call's arguments are MuJoCo's arrays, this object's and the log's rows, of fixed types
        # (wbc.compiled.specialise; with kernel type checks on, the dispatcher)
        d = sim.data
        self._kernel = _foot_wrench_kernel if CHECK_TYPES else specialise(
            _foot_wrench_kernel, d.cfrc_ext, d.xmat, d.xpos, d.subtree_com, self.feet, np.zeros((2, 6)),
            np.zeros((2, 3)))
        self._views_of = None  # the MjData whose cfrc_ext, xmat, xpos, subtree_com views are kept in _views

    def __call__(self, out_wrench: np.ndarray, out_pos: np.ndarray) -> None:
        model, d = self.sim.model, self.sim.data
        if not (self.single_stage and d.flg_rnepost):
            mujoco.mj_rnePostConstraint(model, d)
        if d is not self._views_of:  # (views of fixed buffers of that MjData: one binding call each, not per tick)
            self._views_of, self._views = d, (d.cfrc_ext, d.xmat, d.xpos, d.subtree_com)
        self._kernel(*self._views, self.feet, out_wrench, out_pos)


class _FeetBodies(NamedTuple):
    """The feet of :func:`_foot_wrench_kernel` (left, right) in MuJoCo's model."""

    rows: np.ndarray         #: int64 the bodies rigidly attached to each foot, the left's then the right's
    ends: np.ndarray         #: (2,) int64 where each foot's bodies end in ``rows``
    sole_body: np.ndarray    #: (2,) int64 the body of each sole
    sole_offset: np.ndarray  #: (2, 3) the sole origin in its body's frame (m)
    root: np.ndarray         #: (2,) int64 the root body of the subtree whose CoM ``cfrc_ext`` is about


@nb.njit(cache=True)
def _foot_wrench_kernel(cfrc_ext, xmat, xpos, subtree_com, feet, out_wrench, out_pos):
    """:class:`_FootWrenches`' arithmetic after ``mj_rnePostConstraint``: per side i (``feet``: :class:`_FeetBodies`;
    bodies ``rows[ends[i-1]:ends[i]]``, sole on body ``sole_body[i]`` at ``sole_offset[i]`` in its frame,
    ``cfrc_ext`` about the CoM of the subtree of ``root[i]``), the summed (torque, force) moved to the sole origin →
    ``out_wrench[i]`` (force, moment), the sole origin → ``out_pos[i]``."""
    rows, ends, sole_body, sole_offset, root = feet
    start = 0
    for i in range(2):
        t0 = t1 = t2 = f0 = f1 = f2 = 0.0
        for r in range(start, ends[i]):  # numpy.add.reduceat: the rows summed in order
            row = cfrc_ext[rows[r]]
            if r == start:
                t0, t1, t2, f0, f1, f2 = row[0], row[1], row[2], row[3], row[4], row[5]
            else:
                t0, t1, t2, f0, f1, f2 = t0 + row[0], t1 + row[1], t2 + row[2], f0 + row[3], f1 + row[4], f2 + row[5]
        start = ends[i]
        b = sole_body[i]
        o0, o1, o2 = sole_offset[i, 0], sole_offset[i, 1], sole_offset[i, 2]
        m = xmat[b]
        p0 = xpos[b, 0] + (m[0] * o0 + m[1] * o1 + m[2] * o2)  # sole origin p = x_body + R_body o
        p1 = xpos[b, 1] + (m[3] * o0 + m[4] * o1 + m[5] * o2)
        p2 = xpos[b, 2] + (m[6] * o0 + m[7] * o1 + m[8] * o2)
        c = subtree_com[root[i]]
        d0, d1, d2 = c[0] - p0, c[1] - p1, c[2] - p2
        out_pos[i, 0], out_pos[i, 1], out_pos[i, 2] = p0, p1, p2
        # τ_p = τ_com + (com − p) × f
        out_wrench[i, 0], out_wrench[i, 1], out_wrench[i, 2] = f0, f1, f2
        out_wrench[i, 3] = t0 + d1 * f2 - d2 * f1
        out_wrench[i, 4] = t1 + d2 * f0 - d0 * f2
        out_wrench[i, 5] = t2 + d0 * f1 - d1 * f0


@once_per_process
def _warm_up() -> None:
    """Load :func:`_foot_wrench_kernel` and the finiteness test of the state (on-disk cache) once per process."""
    all_finite(np.zeros(2))
    i2 = np.zeros(2, dtype=np.int64)
    _foot_wrench_kernel(np.zeros((2, 6)), np.zeros((2, 9)), np.zeros((2, 3)), np.zeros((2, 3)),
                        _FeetBodies(i2, np.ones(2, np.int64), i2, np.zeros((2, 3)), i2), np.zeros((2, 6)),
                        np.zeros((2, 3)))


def run_closed_loop(sim: MujocoModel, controller, scenario, *, after_fall: float = 0.0, viewer=None,
                    pacer=None, state=None) -> SimRun:
    """Run ``scenario`` with ``controller`` on ``sim`` from ``robot.q_ref`` at rest (module docstring).

    Args:
        sim: MuJoCo model (its timestep is the control period).
        controller: a :class:`~wbc.dynamics.balance.IDBalanceController` or an object with
            ``reset(q, v)`` and ``solve(q, v) -> tau`` (e.g. :class:`~wbc.sim.baseline.JointPDController`).
        scenario: an object with ``duration`` (s), ``name``, ``setup(controller, sim, q, v)``,
            ``update(t, controller, sim, q, v) -> external force (3,) or None`` and ``com_reference(t)`` —
            see :mod:`wbc.sim.scenarios`.
        after_fall: keep simulating this long (s) after a fall is detected (0: stop at once).
        viewer, pacer: optional live viewer (``update(q, t)``) and real-time pacer (``wait(t)``). A viewer whose
            ``reads_configuration`` is False gets ``q = None`` when ``state`` is given.
        state: what the controller and the scenario read: None for MuJoCo's ground truth, or an estimator of the
            state from the plant's sensors (:class:`~wbc.sim.estimated_state.EstimatedState`: ``reset(q, v)``,
            ``measure(sim, t) -> (q, v)``, called after ``mj_step1`` so the sensors see the state at t). The log's
            ``q``, ``v`` stay the ground truth; the estimate goes to ``extra["q_est"]``, ``extra["v_est"]``. A
            scenario with the attributes ``measured_zmp``, ``measured_normal_force`` or ``measured_wrench`` gets
            them from the sensors every tick (``measured_zmp`` not when its ``reads_measured_zmp`` is False).

    Returns:
        :class:`SimRun`.

    Raises:
        SimulationError: the MuJoCo state became non-finite.
        InvalidInputError: a scenario duration ≤ 0.
    """
    robot = sim.robot
    model, data = sim.model, sim.data
    dt = sim.timestep
    if not scenario.duration > 0:
        raise InvalidInputError(f"scenario duration must be > 0 s, got {scenario.duration!r}")
    mujoco.mj_resetData(model, data)
    sim.set_state(robot.q_ref)
    q, v = sim.get_state()
    controller.reset(q, v)
    scenario.setup(controller, sim, q, v)
    n = int(round(scenario.duration / dt))  # (after setup: a walk's plan may set its length, e.g. step timing)
    if state is not None:
        state.reset(q, v)
    is_id = isinstance(controller, IDBalanceController)
    pm = robot.model
    pdata = pm.createData()
    nc = 12 * len(controller.qp.contacts) if is_id else 24
    log = {
        "t": np.empty(n), "q": np.empty((n, pm.nq)), "v": np.empty((n, pm.nv)), "tau": np.empty((n, pm.nv - 6)),
        "com": np.empty((n, 3)), "com_ref": np.empty((n, 3)), "qp_forces": np.zeros((n, nc)),
        "contact_active": np.ones((n, 2), dtype=bool), "sim_wrench": np.empty((n, 2, 6)),
        "sole_pos": np.empty((n, 2, 3)), "ext_force": np.zeros((n, 3)), "residual": np.full(n, np.nan),
        "ok": np.ones(n, dtype=bool), "relaxed": np.zeros(n, dtype=bool),
        "path": np.full(n, "", dtype=PATH_DTYPE), "tick_time": np.empty(n), "step_time": np.empty(n),
    }
    est = {"q_est": np.empty((n, pm.nq)), "v_est": np.empty((n, pm.nv))} if state is not None else {}
    monitor = OutcomeMonitor(sim)
    foot_wrenches = _FootWrenches(sim)
    fell, stop_at = False, n
    k_end = n
    # (per run, not per tick: what the scenario reads from the sensors, and the log's arrays)
    give_zmp = state is not None and hasattr(scenario, "measured_zmp") and getattr(scenario, "reads_measured_zmp", True)
    give_normal_force = state is not None and hasattr(scenario, "measured_normal_force")
    give_wrench = state is not None and hasattr(scenario, "measured_wrench")
    log_t, log_q, log_v, log_tau, log_com, log_com_ref = (log[key] for key in ("t", "q", "v", "tau", "com", "com_ref"))
    log_forces, log_residual, log_ok, log_relaxed, log_path, log_active = (
        log[key] for key in ("qp_forces", "residual", "ok", "relaxed", "path", "contact_active"))
    log_wrench, log_sole, log_ext, log_tick, log_step = (
        log[key] for key in ("sim_wrench", "sole_pos", "ext_force", "tick_time", "step_time"))
    q_est, v_est = (est["q_est"], est["v_est"]) if state is not None else (None, None)
    # With an estimated state and a viewer that does not read the configuration, the ground truth only feeds the
    # log: MuJoCo's qpos/qvel rows are copied in the loop and converted (with the log's CoM) after it.
    deferred = state is not None and (viewer is None or not getattr(viewer, "reads_configuration", True))
    sm = sim.state_map
    raw_qpos = np.empty((n, sm.nq_mj)) if deferred else None
    raw_qvel = np.empty((n, sm.nv)) if deferred else None
    qpos = data.qpos  # (views of the fixed buffers of ``data``: one binding call each, not one per tick)
    qpos_mj, qvel_mj = qpos[: sm.nq_mj], data.qvel[: sm.nv]
    last_path, last_text = None, ""
    # the finiteness test of MuJoCo's qpos (a fixed buffer: wbc.compiled.specialise; with kernel type checks on, the
    # dispatcher)
    qpos_finite = all_finite if CHECK_TYPES else specialise(all_finite, qpos)
    wall0 = perf_counter()
    for k in range(n):
        t = k * dt
        if state is not None:
            mujoco.mj_step1(model, data)  # positions, velocities and their sensors at t
        if deferred:
            raw_qpos[k] = qpos_mj
            raw_qvel[k] = qvel_mj
        else:
            q, v = sim.get_state()
        qc, vc = (q, v) if state is None else state.measure(sim, t)
        if give_zmp:
            scenario.measured_zmp = state.measured_zmp()  # ZMP from the ankle F/T sensors
        if give_normal_force:
            scenario.measured_normal_force = state.measured_normal_force()  # touch-down from the F/T sensors
        if give_wrench:
            scenario.measured_wrench = state.estimator.wrench  # (2, 6) F/T wrenches at the soles, sole axes
        f_ext = scenario.update(t, controller, sim, qc, vc)
        t0 = perf_counter()
        if is_id:
            cmd = controller.solve(qc, vc)
            tau = cmd.tau
        else:
            tau = controller.solve(qc, vc)
        t1 = perf_counter()
        sim.set_torques(tau)
        if state is None:
            mujoco.mj_step(model, data)
        else:
            mujoco.mj_step2(model, data)  # mj_step1 + mj_step2 = mj_step
        t2 = perf_counter()
        if not qpos_finite(qpos):
            raise SimulationError(f"MuJoCo state became non-finite at t = {t:.3f} s")
        # -- log (state at t, forces applied during [t, t + dt]) -------------------------------------------
        log_t[k] = t
        if not deferred:
            log_q[k] = q
            log_v[k] = v
            log_com[k] = pin.centerOfMass(pm, pdata, q, False)
        if state is not None:
            q_est[k] = qc
            v_est[k] = vc
        log_tau[k] = tau
        log_com_ref[k] = scenario.com_reference(t)
        if is_id:
            log_forces[k] = cmd.forces
            log_residual[k] = cmd.dynamics_residual
            log_ok[k] = cmd.ok
            log_relaxed[k] = cmd.relaxed
            if cmd.path is not last_path:  # (the compiled ticks share one frozen path object: its text once)
                last_path, last_text = cmd.path, str(cmd.path)
            log_path[k] = last_text
            contacts = controller.contacts
            log_active[k, 0] = contacts["left"].active
            log_active[k, 1] = contacts["right"].active
        foot_wrenches(log_wrench[k], log_sole[k])
        if f_ext is not None:
            log_ext[k] = f_ext
        log_tick[k] = t1 - t0
        log_step[k] = t2 - t1
        # -- outcome (fall, joint speed, landing slide) of the new state ------------------------------------
        if monitor.update(t + dt) and not fell:
            fell = True
            stop_at = min(n, k + 1 + int(round(after_fall / dt)))
        if viewer is not None:
            viewer.update(None if deferred else q, t)
        if pacer is not None:
            pacer.wait(t + dt)
        if k + 1 >= stop_at:
            k_end = k + 1
            break
    wall = perf_counter() - wall0
    sim.clear_external_forces()
    if deferred:
        sm.states_from_mj(raw_qpos[:k_end], raw_qvel[:k_end], log_q[:k_end], log_v[:k_end])
        for k in range(k_end):
            log_com[k] = pin.centerOfMass(pm, pdata, log_q[k], False)
    cut = {key: val[:k_end] for key, val in log.items()}
    return SimRun(robot=robot.name, controller="id" if is_id else getattr(controller, "name", "custom"),
                  scenario=scenario.name, dt=dt, wall_time=wall, fell=monitor.fell,
                  fall_reason=monitor.fall_reason, fall_time=monitor.fall_time, outcome=monitor.summary(),
                  extra={key: val[:k_end] for key, val in est.items()}, **cut)
