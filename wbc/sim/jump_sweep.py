"""Highest jump within the URDF torque limits (``wbc sim jump --sweep``): a sweep of the planned height in MuJoCo
and a quasi-static push-off bound that names the limiting joint.

**Sweep** (:func:`jump_height_sweep`): planned apex heights h = ``start``, 2·start, 4·start, … (doubling while
the jump succeeds, up to ``max_height``), then bisection between the highest success and the lowest failure
down to ``resolution``. A trial succeeds when the robot does not fall, lands (:class:`~wbc.sim.jump.JumpScenario`
``landed``), both soles leave the ground by ≥ ``min_clearance`` (MuJoCo state) and no torque had to be clipped
(``torque_clipped_ticks`` = 0: every applied torque came from a QP solved with the URDF torque limits). Success
is assumed monotonic in h; every trial is listed, so a non-monotonic response is visible.

**Push-off bound** (:func:`pushoff_bound`), quasi-static: if the whole robot accelerates upward uniformly at a
(legs' relative accelerations and velocity-product terms neglected), every joint torque scales with the apparent
gravity, τ(a) = (1 + a/g) τ_s, τ_s the static torques of double support (gravity torques minus the least-norm
pair of sole wrenches that balances the floating base: the contact-consistent gravity compensation of
:mod:`wbc.controllers.inverse_dynamics`). The largest admissible push-off acceleration at a posture is then

    a_max = g (min_j L_j / |τ_s,j| − 1),

L_j the URDF effort limit, the arg-min the limiting joint; over a push stroke s from rest at constant a the
take-off velocity is √(2 a s) and the apex CoM rise h = a s / g (ballistic flight, v² = 2 g h). Evaluated on the
postures of the push phase of a run (the smallest a_max over them).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from wbc.exceptions import InvalidInputError
from wbc.sim.scenarios import largest_passing

__all__ = ["static_torques", "pushoff_bound", "jump_height_sweep", "sweep_report"]



def static_torques(robot, q: np.ndarray) -> np.ndarray:
    """(nv − 6,) joint torques (N·m) holding configuration q (nq,) at rest on both soles (module docstring)."""
    model = robot.model
    data = model.createData()
    pin.computeJointJacobians(model, data, q)
    pin.framesForwardKinematics(model, data, q)
    g = pin.computeGeneralizedGravity(model, data, q)
    Jc = np.vstack([pin.getFrameJacobian(model, data, robot.frame_id(f), pin.LOCAL)
                    for f in (robot.left_sole, robot.right_sole)])
    W = np.linalg.lstsq(Jc[:, :6].T, g[:6], rcond=None)[0]
    return g[6:] - (Jc.T @ W)[6:]


def pushoff_bound(robot, qs: np.ndarray, stroke: float) -> dict:
    """Quasi-static push-off bound over the postures ``qs`` (k, nq) of a push of vertical stroke ``stroke`` (m).

    Returns:
        ``{"max_acceleration_mps2", "limiting_joint", "torque_ratio_static", "takeoff_velocity_mps",
        "apex_rise_m"}`` (module docstring; the ratio is max_j |τ_s,j| / L_j at the limiting posture).

    Raises:
        InvalidInputError: empty ``qs`` or non-positive stroke.
    """
    qs = np.atleast_2d(np.asarray(qs, dtype=float))
    if qs.shape[0] == 0 or not (np.isfinite(stroke) and stroke > 0):
        raise InvalidInputError("pushoff_bound needs at least one posture and a stroke > 0 m")
    lim = np.asarray(robot.model.effortLimit[6:], dtype=float)
    ok = np.isfinite(lim) & (lim > 0)
    best = None
    for q in qs:
        ratio = np.where(ok, np.abs(static_torques(robot, q)) / np.where(ok, lim, 1.0), 0.0)
        j = int(np.argmax(ratio))
        if best is None or ratio[j] > best[0]:
            best = (float(ratio[j]), j)
    r, j = best
    g = robot.gravity
    a = g * (1.0 / r - 1.0) if r > 0 else float("inf")
    a_pos = max(a, 0.0)
    return {"max_acceleration_mps2": a, "limiting_joint": robot.joint_names[j], "torque_ratio_static": r,
            "takeoff_velocity_mps": float(np.sqrt(2 * a_pos * stroke)), "apex_rise_m": a_pos * stroke / g}


def jump_height_sweep(run_trial, *, start: float = 0.02, max_height: float = 0.32, resolution: float = 0.005,
                      min_clearance: float = 0.01, log=None) -> dict:
    """Highest succeeding planned height (module docstring).

    Args:
        run_trial: height (m) → summary dict of a one-jump run (``fell``, ``landed``, ``apex_foot_clearance_m``,
            ``torque_clipped_ticks``, ``max_torque_over_limit``, ``max_torque_joint``...).
        start, max_height, resolution: m. min_clearance: both soles' lift-off needed for a success (m).
        log: optional callable(str).

    Returns:
        ``{"max_height_m", "min_failed_m", "trials": [{"height_m", "success", ...}]}`` (max_height_m None when
        even ``start`` failed).
    """
    if not (0 < start <= max_height and resolution > 0):
        raise InvalidInputError("jump sweep needs 0 < start <= max_height and resolution > 0 (m)")
    trials = []

    def ok(h: float) -> bool:
        s = run_trial(h)
        success = (not s["fell"] and bool(s.get("landed")) and s.get("apex_foot_clearance_m", 0.0) >= min_clearance
                   and s.get("torque_clipped_ticks", 0) == 0)
        row = {"height_m": h, "success": success, "fell": s["fell"], "landed": s.get("landed"),
               "apex_foot_clearance_m": s.get("apex_foot_clearance_m"),
               "takeoff_velocity_mps": (s.get("takeoff_velocity_measured_mps") or [[None] * 3])[0][2],
               "torque_clipped_ticks": s.get("torque_clipped_ticks"),
               "max_torque_over_limit": s.get("max_torque_over_limit"), "max_torque_joint": s.get("max_torque_joint"),
               "push_max_torque_over_limit": s.get("push_max_torque_over_limit"),
               "push_max_torque_joint": s.get("push_max_torque_joint"),
               "torque_limited_ticks": s.get("torque_limited_ticks")}
        trials.append(row)
        if log:
            log(f"    h {h:.4f} m: {'ok    ' if success else 'FAILED'} fell {s['fell']}, clearance "
                f"{row['apex_foot_clearance_m']} m, take-off {row['takeoff_velocity_mps']} m/s, clipped "
                f"{row['torque_clipped_ticks']}, push max |τ|/limit {row['push_max_torque_over_limit']} "
                f"({row['push_max_torque_joint']}); torque-limited ticks {row['torque_limited_ticks']}")
        return success

    lo, hi = largest_passing(ok, start, limit=max_height, resolution=resolution)
    return {"max_height_m": lo, "min_failed_m": hi, "trials": trials}


def sweep_report(robot, sim, make, *, log=None, **sweep_options) -> tuple[dict, list]:
    """Run :func:`jump_height_sweep` with one-jump :class:`~wbc.sim.jump.JumpScenario` trials on ``sim`` (each
    with a fresh controller from ``make()``) and the push-off bound on the push postures of the highest success
    (or, if none, of the lowest failure).

    Returns:
        (report dict: ``max_planned_height_m``, ``min_failed_height_m``, ``apex_foot_clearance_at_max_m``,
        ``push_limiting_joint_measured``, ``push_max_torque_over_limit_measured``, ``quasi_static_bound``;
        the list of trials).
    """
    from wbc.sim.jump import JumpScenario
    from wbc.sim.scenarios import run_scenario

    scenarios = {}

    def trial(h):
        sc = JumpScenario(height=h)
        _, s = run_scenario(sim, make(), sc)
        scenarios[h] = sc
        return s

    if log:
        log("  sweep of the planned height (one jump per trial):")
    res = jump_height_sweep(trial, log=log, **sweep_options)
    best = res["max_height_m"]
    probe = scenarios.get(best) or scenarios[res["min_failed_m"]]
    bound = pushoff_bound(robot, probe.push_postures, probe.jump_plan.stroke) if len(probe.push_postures) else None
    row = next((r for r in res["trials"] if r["height_m"] == best), None)
    report = {"max_planned_height_m": best, "min_failed_height_m": res["min_failed_m"],
              "apex_foot_clearance_at_max_m": row and row["apex_foot_clearance_m"],
              "push_limiting_joint_measured": row and row["push_max_torque_joint"],
              "push_max_torque_over_limit_measured": row and row["push_max_torque_over_limit"],
              "quasi_static_bound": bound}
    return report, res["trials"]
