"""``wbc balance jump``: kinematic preview of the planned jump (no physics) — the motion that ``wbc sim jump``
asks MuJoCo for, with the numbers the plan implies.

The references are those of :class:`~wbc.gait.jump_plan.JumpPlan` on the **planned** states (take-off at the
planned velocity after the push, touch-down after the planned flight time T_f = 2 v_z / g with the planned
velocity (v_x, 0, −v_z); method and sources in :mod:`wbc.gait.jump_plan`: ballistic SLIP flight, Wensing & Orin
2013; capture-point landing, Pratt et al. 2006). A velocity-level kinematic QP
(:class:`~wbc.controllers.kinematic.KinematicController`, floating base free, no contact constraint) tracks them at period
dt: CoM (weight 1000), both sole poses (weight 100: held on the ground in stance, the flight profile in the air),
torso orientation (1), posture (1e-2, gain 2/s); q ← pin.integrate(q, v dt).

Summary (all from the executed kinematic motion, not from the plan):

* ``apex_foot_clearance_m``: max over time of the lower sole's height above the ground;
* ``flight_time_s``: longest interval with both soles > 1 mm up (``planned_flight_time_s``: T_f);
* ``peak_grf_n``: m (c̈_z + g) over the ground phases (Newton's law on the CoM, c̈ by central differences of the
  executed CoM; the total ground reaction of any dynamics realising this motion), and in body weights;
* ``max_torque_over_limit`` (and the joint): inverse dynamics (Pinocchio RNEA) of the executed motion, v̇ by
  forward differences of the commanded v, minus the least-norm pair of sole wrenches that balances the
  floating-base rows on the ground phases (no contact force in flight); |τ| / URDF effort limit;
* ``flight_base_wrench_residual_n``: max over flight of ‖RNEA base rows‖ (force part) — the force the motion
  would need from nowhere (0 for a perfectly ballistic CoM);
* ``landing_com_overshoot_m``: standing CoM height minus the lowest CoM height after the first touch-down;
* ticks within :data:`SWITCH_WINDOW` of a planned take-off / touch-down are left out of the three figures above
  (the velocity steps of the kinematic feet there are impulses, not forces);
* ``fell``: always False (no physics: the preview cannot fall — run ``wbc sim jump`` for that).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from time import perf_counter

import numpy as np
import pinocchio as pin

from wbc.configuration import Configuration
from wbc.constants import SIDES
from wbc.controllers.kinematic import KinematicController
from wbc.exceptions import InvalidInputError
from wbc.gait.jump_plan import JumpPlan
from wbc.solvers import DEFAULT_SOLVER
from wbc.robot import Robot
from wbc.scenarios.framework import MotionRun
from wbc.tasks import ComTask, FrameTask, OrientationTask, PostureTask

__all__ = ["JumpPreviewRun", "preview_jump", "preview_summary"]

#: Ticks within this time (s) of a planned take-off or touch-down are left out of the GRF / torque / residual
#: figures: the kinematic feet follow the reference's velocity step there (0 → the CoM's velocity at take-off,
#: back to 0 at touch-down), an infinite acceleration that physics (``wbc sim jump``) smooths.
SWITCH_WINDOW = 0.01


@dataclass
class JumpPreviewRun(MotionRun):
    """Time series of a preview (N ticks): t (N,) s; q (N, nq); v (N, nv) commanded; com, com_ref (N, 3) m,
    world; sole_pos (N, 2, 3) m, world (left, right); contact_active (N, 2) planned contact flags; tick_time (N,)
    s; plus the plan and the planned touch-down times (s)."""

    sole_pos: np.ndarray
    contact_active: np.ndarray
    tick_time: np.ndarray
    plan: JumpPlan
    touchdowns: list = field(default_factory=list)
    scenario: str = "jump preview"

    not_logged = ("touchdowns",)  # in the summary; the log (``save``) keeps the arrays, names, dt and scenario


def preview_jump(robot: Robot, *, height: float = 0.08, forward: float = 0.0, count: int = 1, dt: float = 0.002,
                 solver: str = DEFAULT_SOLVER, settle: float = 1.5, t_start: float = 0.2, viewer=None,
                 pacer=None) -> JumpPreviewRun:
    """Run the kinematic preview (module docstring) from ``robot.q_ref``.

    Args:
        robot: the robot.
        height: planned apex CoM rise (m).
        forward: planned foot displacement per jump (m, world x).
        count: number of jumps.
        dt: period (s).
        solver: QP backend.
        settle: stance after each planned touch-down (s).
        t_start: stand before the first crouch (s).
        viewer, pacer: see :func:`wbc.scenarios.balance.run_balance`.

    Returns:
        :class:`JumpPreviewRun`.

    Raises:
        InvalidInputError: bad numbers (see :class:`~wbc.gait.jump_plan.JumpPlan`), count < 1 or dt ≤ 0.
    """
    if not (isinstance(count, int) and count >= 1):
        raise InvalidInputError(f"jump preview: count must be an int >= 1, got {count!r}")
    if not (np.isfinite(dt) and dt > 0 and np.isfinite(settle) and settle > 0 and t_start >= 0):
        raise InvalidInputError("jump preview: dt and settle must be finite and > 0 s, t_start >= 0 s")
    config = Configuration(robot)
    model = robot.model
    com0 = config.com.copy()
    fids = [robot.frame_id(f) for f in (robot.left_sole, robot.right_sole)]
    soles0 = [config.data.oMf[f].copy() for f in fids]
    mid0 = 0.5 * (soles0[0].translation + soles0[1].translation)
    offset = com0 - mid0
    plan = JumpPlan(height=height, forward=forward, com_height=float(offset[2]))
    com_task = ComTask(weight=1000.0, gain=50.0)
    feet = [FrameTask(robot, f, position_weight=100.0, orientation_weight=100.0, gain=50.0, name=f"{s}_sole")
            for s, f in zip(SIDES, (robot.left_sole, robot.right_sole))]
    torso = OrientationTask(robot, robot.torso, weight=1.0, gain=20.0)
    torso.set_target(config.data.oMf[robot.frame_id(robot.torso)].copy())
    posture = PostureTask(robot, weight=1e-2, gain=2.0)
    posture.set_target(robot.q_ref)
    ctrl = KinematicController(robot, [com_task, *feet, torso, posture], solver=solver)
    t_to_rel = t_start + plan.t_push_start + plan.t_push
    period = t_to_rel + plan.t_flight + settle
    n = int(math.floor(count * period / dt + 1e-9))
    out = {"q": np.empty((n, model.nq)), "v": np.empty((n, model.nv)), "com": np.empty((n, 3)),
           "com_ref": np.empty((n, 3)), "sole_pos": np.empty((n, 2, 3)), "contact_active": np.ones((n, 2), bool),
           "tick_time": np.empty(n)}
    stance = [p.translation.copy() for p in soles0]
    c_start = com0.copy()
    touchdowns = []
    jump = -1
    for k in range(n):
        t = k * dt
        if int(t // period) != jump:  # a new jump: start from the current stance
            jump = int(t // period)
            if jump > 0:
                stance = [targets[i].copy() for i in range(2)]
                c_start = 0.5 * (stance[0] + stance[1]) + offset
            targets = [plan.foot_landing_target(p) for p in stance]
            c_to, _, _ = plan.push_reference(c_start, plan.t_push)
            v_to = plan.takeoff_velocity
            c_td, v_td, _ = plan.flight_reference(c_to, v_to, plan.t_flight)
            land_target = 0.5 * (targets[0] + targets[1]) + offset
            touchdowns.append(jump * period + t_to_rel + plan.t_flight)
        tau = t - jump * period - t_start
        foot_refs = [(p, np.zeros(3)) for p in stance]
        if tau < plan.t_push_start:
            c, dc, _ = plan.crouch_reference(c_start, max(tau, 0.0))
        elif tau < plan.t_push_start + plan.t_push:
            c, dc, _ = plan.push_reference(c_start, tau - plan.t_push_start)
        elif tau < plan.t_push_start + plan.t_push + plan.t_flight:
            tf = tau - plan.t_push_start - plan.t_push
            c, dc, ac = plan.flight_reference(c_to, v_to, tf)
            foot_refs = []
            for i in range(2):
                p, vel, _ = plan.foot_flight_offset(stance[i], targets[i], c[2] - c_to[2], dc[2], ac[2], tf,
                                                    plan.t_flight)
                foot_refs.append((p, vel))
            out["contact_active"][k] = False
        else:
            tl = tau - plan.t_push_start - plan.t_push - plan.t_flight
            c, dc, _ = plan.landing_reference(c_td, v_td, land_target, tl)
            foot_refs = [(p, np.zeros(3)) for p in targets]
        t0 = perf_counter()
        com_task.set_target(c, dc)
        for i, task in enumerate(feet):
            task.set_target(pin.SE3(soles0[i].rotation, foot_refs[i][0]), np.r_[foot_refs[i][1], 0.0, 0.0, 0.0])
        result = ctrl.solve(config, dt)
        out["tick_time"][k] = perf_counter() - t0
        out["q"][k] = config.q
        out["com"][k] = config.com
        out["com_ref"][k] = c
        out["sole_pos"][k] = [config.data.oMf[f].translation for f in fids]
        out["v"][k] = result.v
        config.step(result.v, dt)
        if viewer is not None:
            viewer.update(config.q, (k + 1) * dt, overlays={"com": config.com})
        if pacer is not None:
            pacer.wait((k + 1) * dt)
    return JumpPreviewRun(robot=robot.name, dt=dt, t=np.arange(n) * dt, plan=plan, touchdowns=touchdowns, **out)


def preview_summary(robot: Robot, run: JumpPreviewRun) -> dict:
    """Summary of a preview (module docstring)."""
    model = robot.model
    data = model.createData()
    dt = run.dt
    ground = run.sole_pos[0, :, 2]
    both = (run.sole_pos[:, :, 2] - ground).min(axis=1)
    best = cur = 0
    for up in both > 1e-3:
        cur = cur + 1 if up else 0
        best = max(best, cur)
    acc = np.zeros_like(run.com)
    acc[1:-1] = (run.com[2:] - 2 * run.com[1:-1] + run.com[:-2]) / dt**2
    on_ground = run.contact_active.all(axis=1)
    grf = robot.mass * (acc[:, 2] + robot.gravity)
    lim = np.asarray(model.effortLimit[6:], dtype=float)
    ok = np.isfinite(lim) & (lim > 0)
    worst, worst_j, base_res = 0.0, 0, 0.0
    plan = run.plan
    switches = [x for td in run.touchdowns for x in (td - plan.t_flight, td)]
    smooth = np.ones(len(run.t), dtype=bool)
    for x in switches:
        smooth &= np.abs(run.t - x) > SWITCH_WINDOW
    for k in range(len(run.t) - 1):
        if not smooth[k]:
            continue
        q, v = run.q[k], run.v[k]
        a = (run.v[k + 1] - v) / dt
        tau_full = pin.rnea(model, data, q, v, a)
        if on_ground[k]:
            pin.computeJointJacobians(model, data, q)
            pin.framesForwardKinematics(model, data, q)
            Jc = np.vstack([pin.getFrameJacobian(model, data, robot.frame_id(f), pin.LOCAL)
                            for f in (robot.left_sole, robot.right_sole)])
            W = np.linalg.lstsq(Jc[:, :6].T, tau_full[:6], rcond=None)[0]
            tau = tau_full[6:] - (Jc.T @ W)[6:]
        else:
            tau = tau_full[6:]
            base_res = max(base_res, float(np.linalg.norm(tau_full[:3])))
        ratio = np.where(ok, np.abs(tau) / np.where(ok, lim, 1.0), 0.0)
        j = int(np.argmax(ratio))
        if ratio[j] > worst:
            worst, worst_j = float(ratio[j]), j
    td = run.touchdowns[0] if run.touchdowns else run.t[-1]
    after = run.t >= td
    sel = on_ground & smooth
    return {
        "robot": robot.name, "preview": "kinematic (no physics)", "jumps": len(run.touchdowns),
        "planned_height_m": plan.height, "planned_forward_m": plan.forward,
        "takeoff_velocity_plan_mps": [float(x) for x in plan.takeoff_velocity],
        "planned_flight_time_s": plan.t_flight, "push_time_s": plan.t_push,
        "apex_foot_clearance_m": float(both.max()), "flight_time_s": best * dt,
        "peak_grf_n": float(grf[sel].max()), "peak_grf_body_weights": float(grf[sel].max() / (robot.mass * robot.gravity)),
        "max_torque_over_limit": worst, "max_torque_joint": robot.joint_names[worst_j],
        "flight_base_wrench_residual_n": base_res, "switch_window_excluded_s": SWITCH_WINDOW,
        "landing_com_overshoot_m": float(run.com[0, 2] - run.com[after, 2].min()) if after.any() else None,
        "hop_distance_m": float(np.mean(run.sole_pos[-1, :, 0] - run.sole_pos[0, :, 0])),
        "max_com_error_m": float(np.linalg.norm(run.com - run.com_ref, axis=1).max()),
        "tick_time_us": {"median": float(np.median(run.tick_time) * 1e6), "max": float(run.tick_time.max() * 1e6)},
        "fell": False,
    }

