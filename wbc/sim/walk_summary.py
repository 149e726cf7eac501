"""The summary of a physics walk (:class:`wbc.sim.walk.WalkScenario`): walked distance and heading, landing errors,
stance slip, the measured CoP and its margin in the loaded soles' hull, touch-down times, support cuts
(:class:`WalkSummary`, the scenario's ``extra_summary`` and ``criteria``), and the pass criteria of a walk
(:func:`walk_criteria`, :func:`walk_acceptance`)."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from wbc.estimation import zmp_from_wrenches
from wbc.geometry import convex_hull, polygon_margin, projected_sole_corners
from wbc.scenarios.framework import Criterion, evaluate
from wbc.sim.scenarios import NO_FALL

__all__ = ["WalkSummary", "measured_cop", "walk_acceptance", "walk_criteria"]


def measured_cop(wrench: np.ndarray, sole_pos: np.ndarray, min_fz: float = 10.0,
                 height: float = 0.0) -> np.ndarray | None:
    """CoP (2,) on the plane z = ``height`` (m, world) of the plant's foot wrenches.

    Args:
        wrench: (2, 6) ground reaction per foot: force (N), moment (N·m) about the sole origin, world axes.
        sole_pos: (2, 3) sole origins (m, world).
        min_fz: total normal force (N) below which there is no CoP (None).
        height: height (m, world) of the plane: 0 on flat ground, the loaded treads' height on terrain (on the plane
            z = 0 a tread at height h moves the point by h F_xy / F_z).

    With the total force F and the moment about (0, 0, h) M = Σ (τ_i + o_i × f_i) − (0, 0, h) × F, a force F at
    p = (p_x, p_y, h) has moment (p − (0, 0, h)) × F, so p_x = −M_y / F_z, p_y = M_x / F_z (Sardain & Bessonnet 2004,
    ZMP = CoP on a plane contact); computed by :func:`wbc.estimation.zmp_from_wrenches` with world-aligned sole
    frames.
    """
    eye = np.eye(3)
    return zmp_from_wrenches(wrench, [pin.SE3(eye, np.asarray(o, dtype=float)) for o in sole_pos], min_fz, height)


def _sole_tracks(model, q: np.ndarray, fid: dict) -> tuple[np.ndarray, np.ndarray]:
    """(N, 2, 2) sole xy (m, world) and (N, 2) sole yaw (rad) of (left, right) along the configurations q (N, nq)."""
    data = model.createData()
    xy, yaw = np.zeros((len(q), 2, 2)), np.zeros((len(q), 2))
    for k in range(len(q)):
        pin.forwardKinematics(model, data, q[k])
        for j, s in enumerate(("left", "right")):
            M = pin.updateFramePlacement(model, data, fid[s])
            xy[k, j] = M.translation[:2]
            yaw[k, j] = math.atan2(M.rotation[1, 0], M.rotation[0, 0])
    return xy, yaw



class WalkSummary:
    """The summary and criteria of :class:`wbc.sim.walk.WalkScenario` (its state: the plan, the switcher, the
    logs of :meth:`~wbc.sim.walk.WalkScenario.update`)."""

    def criteria(self) -> list[Criterion]:
        """:func:`walk_criteria` with the default tolerances (on terrain, and
        :data:`wbc.scenarios.terrain_walk.TERRAIN_CRITERIA`)."""
        if self.terrain is not None:
            from wbc.scenarios.terrain_walk import TERRAIN_CRITERIA

            return walk_criteria() + TERRAIN_CRITERIA
        return walk_criteria()

    def extra_summary(self, run) -> dict:
        n = len(run.t)
        lg = {k: (v[:n] if isinstance(v, np.ndarray) else v[:n]) for k, v in self.log.items()}
        if "q_est" in run.extra:  # the controller read an estimate: the metrics use the plant's (logged) state
            lg["sole_xy"], lg["sole_yaw"] = _sole_tracks(self._model, run.q, self._fid)
        plan, dt = self.plan, self.dt
        # Measured CoP and its margin in the loaded soles' hull (plant's contact forces).
        cop = np.full((n, 2), np.nan)
        margin = np.full(n, np.nan)
        settle = min(n - 1, 5)
        r = self.robot
        for i in range(settle, n):
            wr = run.sim_wrench[i]
            h = 0.0
            if self.terrain_walk is not None:  # on the plane of the loaded soles (normal-force-weighted height)
                fz = np.maximum(wr[:, 2], 0.0)
                h = float(fz @ run.sole_pos[i, :, 2] / fz.sum()) if fz.sum() > 0 else 0.0
            p = measured_cop(wr, run.sole_pos[i], height=h)
            if p is None:
                continue
            cop[i] = p
            pts = []
            for j in range(2):
                if wr[j, 2] > 10.0:
                    yaw = lg["sole_yaw"][i, j]
                    pose = pin.SE3(pin.rpy.rpyToMatrix(0, 0, yaw), np.r_[run.sole_pos[i, j, :2], 0.0])
                    pts.append(projected_sole_corners(pose, r.sole_length, r.sole_width))
            if pts:
                margin[i] = polygon_margin(p, convex_hull(np.vstack(pts)))
        # Touch-downs vs footsteps; stance slip per loaded-stance interval.
        ev = self.switcher.events
        landing, td_delay, slips = [], [], []
        swings = list(self.swings)
        tds = [(t, s) for t, s, e in ev if e == "touchdown"]
        unloads = {sd: [t for t, s in self.swing_starts if s == sd] for sd in ("left", "right")}
        count = {"left": 0, "right": 0}
        for (side, k_lift, k_td, fs) in swings:
            # the swings of a side start in order: the i-th start of a side (its ramp-out) is its i-th swing
            if count[side] >= len(unloads[side]):
                continue
            t_unload = unloads[side][count[side]]
            count[side] += 1
            match = [t for t, s in tds if s == side and t > t_unload]
            if not match:
                continue
            ttd = match[0]
            i = min(int(round(ttd / dt)), n - 1)
            j = 0 if side == "left" else 1
            landing.append(float(np.linalg.norm(lg["sole_xy"][i, j] - [fs.x, fs.y])))
            earlier = sum(m for tt, sd, m in self.timing_changes if tt <= ttd)  # planned landing moved earlier
            td_delay.append(ttd - (k_td * dt - earlier))
        for j, s in enumerate(("left", "right")):
            stance = lg["phase"][:, j] == 0  # fully loaded stance
            k = 0
            while k < n:
                if stance[k]:
                    k1 = k
                    while k1 < n and stance[k1]:
                        k1 += 1
                    xy = lg["sole_xy"][k:k1, j]
                    slips.append(float(np.linalg.norm(xy - xy[0], axis=1).max()))
                    k = k1
                else:
                    k += 1
        mid0 = run.sole_pos[0, :, :2].mean(axis=0)
        mid1 = run.sole_pos[-1, :, :2].mean(axis=0)
        yaw_end = math.atan2(np.sin(lg["sole_yaw"][-1]).sum(), np.cos(lg["sole_yaw"][-1]).sum())
        yaw0 = math.atan2(np.sin(lg["sole_yaw"][0]).sum(), np.cos(lg["sole_yaw"][0]).sum())
        last = {}
        for fs in plan.footsteps:
            last[fs.side] = fs.yaw
        yaw_cmd = yaw0 + (self.n_steps - 1) * self.turn if self.n_steps > 1 else yaw0
        dxi = np.linalg.norm(lg["dcm"] - lg["dcm_ref"], axis=1)
        # the commanded motion was done: the run reached its end without a fall and every planned step landed
        complete = bool(run.t[-1] >= self.duration - 2 * dt) and not run.fell and len(landing) == len(swings)
        out = {
            "steps": self.n_steps, "step_length_m": self.step_length, "step_duration_s": self.step_duration,
            "commanded_speed_mps": self.step_length / self.step_duration,
            "commanded_distance_m": float(plan.planned_distance),
            "walked_distance_m": float(np.linalg.norm(mid1 - mid0)),
            "commanded_heading_rad": float(yaw_cmd - yaw0),
            "walked_heading_rad": float(math.remainder(yaw_end - yaw0, 2 * math.pi)),
            "touchdowns": len(landing),
            "landing_error_m": landing,
            "max_landing_error_m": max(landing) if landing else float("nan"),
            "touchdown_delay_s": td_delay,
            "stance_slip_m": slips,
            "max_stance_slip_m": max(slips) if slips else 0.0,
            "min_measured_cop_margin_m": float(np.nanmin(margin)) if np.isfinite(margin).any() else float("nan"),
            "max_dcm_error_m": float(np.nanmax(dxi)) if np.isfinite(dxi).any() else float("nan"),
            "stabilizer": self.stabilizer_on,
            "touchdown_detection": "state: sole height <= 3 mm and vertical sole velocity <= 0.05 m/s"
                                   + ("" if self.measured_normal_force is None or self.switcher.contact_force is None
                                      else f" and a measured normal force >= {self.switcher.contact_force:.1f} N")
                                   + ("" if self.measured_normal_force is None else
                                      f"; or F/T: normal force >= {100 * self.touchdown_load:g} % of the weight with "
                                      f"the sole below {self.switcher.touchdown_force_height * 1e3:g} mm"),
            "push_n": self.push, "push_time_s": self.push_time,
            "step_adjustments": len(self.adjustments),
            "support_cuts": self.support_cuts,
            "step_timing_changes_s": [m for _, _, m in self.timing_changes],
            "max_step_adjustment_m": max((math.hypot(a[2], a[3]) for a in self.adjustments), default=0.0),
            "adjusted_distance_m": float(np.linalg.norm(
                0.5 * (self.poses["left"][-1, :2, 3] + self.poses["right"][-1, :2, 3])
                - 0.5 * (self.poses["left"][0, :2, 3] + self.poses["right"][0, :2, 3]))),
            "replan_failures": self.replan_failures,
            "recovery_step_time_s": self._t_recovery,
            "recovery_plan_failures": self.recovery_failures,
            "recovery_step_by_far_foot": self.recovery_swapped,
            "trailing_releases": [{"t": t, "sole": side, "speed_ratio": ratio} for t, side, ratio in (
                *self.trailing_releases, *(() if self._recovery is None else (
                    (t + self._t_recovery, side, ratio) for t, side, ratio in self._recovery.trailing_releases)))],
            "completed": complete,
        }
        out["target_distance_m"] = out["adjusted_distance_m"] if self.adjustments else out["commanded_distance_m"]
        if self.terrain_walk is not None:  # from the plant's state (logged q), wbc.scenarios.terrain_walk
            from wbc.scenarios.terrain_walk import terrain_summary

            soles = {s: np.empty((n, 4, 4)) for s in ("left", "right")}
            data = self._model.createData()
            for i in range(n):
                pin.framesForwardKinematics(self._model, data, run.q[i])
                for s in soles:
                    soles[s][i] = data.oMf[self._fid[s]].homogeneous
            ts = terrain_summary(self.terrain_walk, soles["left"], soles["right"], r.sole_length, r.sole_width)
            if ts["min_swing_clearance_m"] is None:
                ts["min_swing_clearance_m"] = float("inf")
            out.update(ts)
        events = self.contact_events_summary()  # (empty unless contact_events)
        if events and self._recovery is not None:  # the capture walk's, on the walk's clock
            for key, rows in self._recovery.contact_events_summary().items():
                if key != "contact_event_latency_s":
                    events[key] += [{**row, "t": row["t"] + self._t_recovery} for row in rows]
        out.update(events)
        run.extra.update({"support_phase": lg["phase"], "measured_cop": cop, "measured_cop_margin": margin,
                          "dcm": lg["dcm"], "dcm_ref": lg["dcm_ref"], "cop_cmd": lg["cop_cmd"]})
        return out


def walk_criteria(*, distance_tol: float = 0.05, slip_max: float = 0.005,
                  heading_tol: float = math.radians(5.0)) -> list[Criterion]:
    """Criteria of a physics walk: no fall, walked distance within ``distance_tol`` (relative, at least 1 cm) of
    the target distance (commanded, or the adjusted plan's distance when steps were adjusted), final heading within ``heading_tol`` (rad) of commanded, stance slip ≤ ``slip_max`` (m) per step,
    0 solver failures, walk completed."""
    return [
        NO_FALL,
        Criterion(f"walked distance within {distance_tol:.0%} (≥ 1 cm) of the target", "walked_distance_m", "<=",
                  distance_tol, minus="target_distance_m", scale_by="target_distance_m", floor=0.01),
        Criterion(f"final heading within {math.degrees(heading_tol):.0f} deg of commanded", "walked_heading_rad",
                  "<=", heading_tol, minus="commanded_heading_rad", period=2 * math.pi),
        Criterion(f"stance slip ≤ {slip_max * 1e3:.0f} mm", "max_stance_slip_m", "<=", slip_max),
        Criterion("no solver failure", "solver_failures", "==", 0),
        Criterion("walk completed (ran to its end without a fall, every planned step landed)", "completed", "==",
                  True),
    ]


def walk_acceptance(summary: dict, **tolerances) -> list[str]:
    """Failed criteria of a walk summary (:func:`walk_criteria`, keyword arguments passed on)."""
    return evaluate(summary, walk_criteria(**tolerances))[1]
