"""What to draw over a walk: moving markers, support polygons, footsteps and trajectories (world frame, m).

:func:`walk_overlays` turns a walk plan and its run into the three kinds of items :func:`wbc.viz.record_html`
draws, each under its own meshcat path (toggled in meshcat's "Open Controls" panel):

* ``points`` name -> (N, 3) moving spheres: ``com`` (measured CoM), ``com_ground`` (its ground projection),
  ``zmp_planned`` (plan's ZMP), ``zmp_executed`` (multi-body ZMP of the executed motion, the one the summaries
  judge: :func:`wbc.scenarios.metrics.executed_multibody_zmp`; c̈ by central finite differences, L̇ from
  Pinocchio's centroidal momentum),
  ``dcm_planned`` (plan's DCM), ``dcm_executed`` (ξ = c + ċ / ω, ω = sqrt(g / c_z), Englsberger et al. 2015,
  eq. 7; ċ by finite differences), at z = 0 except the CoM;
* ``polygons`` (t_start, t_end, (K, 3)): the support polygon of each support phase (realized sole poses);
* ``outlines`` name -> list of closed (K, 3) outlines, static: ``footsteps_planned`` (sole rectangles of the
  plan's footsteps), ``footprints`` (realized sole rectangles at the start and at each touchdown);
* ``paths`` name -> list of open (K, 3) polylines, static: ``swing_left`` / ``swing_right`` (sole-origin
  trajectories).

:func:`sim_overlays` does the same for a MuJoCo run from the plant's ground truth (support from the measured
foot forces, measured CoP, contact-force and push arrows) plus the walk plan's footsteps, ZMP and DCM.
"""

from __future__ import annotations

import math

import numpy as np

from wbc.constants import GRAVITY
from wbc.geometry import convex_hull, sole_polygon
from wbc.scenarios.metrics import executed_multibody_zmp

__all__ = ["walk_overlays", "balance_overlays", "sim_overlays", "contact_items", "cart_table_zmp", "dcm_of", "cop_track"]



def cart_table_zmp(t: np.ndarray, com: np.ndarray, g: float = GRAVITY) -> np.ndarray:
    """(N, 3) cart-table ZMP on z = 0 of a CoM path (N, 3) sampled at times t (N,) (Kajita 2003, eq. 3)."""
    acc = np.gradient(np.gradient(com[:, :2], t, axis=0), t, axis=0)
    p = com[:, :2] - (com[:, 2:3] / g) * acc
    return np.c_[p, np.zeros(len(t))]


def _zmp_executed(robot, run) -> np.ndarray:
    """(N, 3) multi-body ZMP of a kinematic run on z = 0 (module docstring)."""
    zmp = executed_multibody_zmp(robot.model, robot.mass, run.dt, run.com, run.q, run.v, run.left_sole,
                                 run.right_sole, run.support)
    return np.c_[zmp, np.zeros(len(zmp))]


def dcm_of(t: np.ndarray, com: np.ndarray, g: float = GRAVITY) -> np.ndarray:
    """(N, 3) DCM ξ = c + ċ/ω on z = 0, ω = sqrt(g / c_z) (Englsberger 2015, eq. 7)."""
    vel = np.gradient(com[:, :2], t, axis=0)
    omega = np.sqrt(g / np.maximum(com[:, 2:3], 1e-3))
    return np.c_[com[:, :2] + vel / omega, np.zeros(len(t))]


def _outline(pose: np.ndarray, length: float, width: float, z: float = 0.002) -> np.ndarray:
    xy = sole_polygon(pose[0, 3], pose[1, 3], math.atan2(pose[1, 0], pose[0, 0]), length, width)
    return np.c_[xy, np.full(len(xy), z)]


def walk_overlays(robot, plan, run) -> dict:
    """Overlays of a kinematic walk (``plan``: :class:`wbc.gait.WalkPlan`, ``run``: ``WalkRun``).

    Returns ``{"points": {...}, "polygons": [...], "outlines": {...}, "paths": {...}}`` (see the module docstring).
    """
    t = run.t
    n = len(t)
    zeros = np.zeros((n, 1))
    points = {
        "com": run.com,
        "com_ground": np.c_[run.com[:, :2], zeros],
        "zmp_planned": np.c_[run.zmp_ref[:, :2], zeros],
        "zmp_executed": _zmp_executed(robot, run),
        "dcm_planned": np.c_[plan.dcm[:n, :2], zeros],
        "dcm_executed": dcm_of(t, run.com),
    }
    polygons, prints, paths = contact_items(t, run.support, run.left_sole, run.right_sole, robot.sole_length,
                                            robot.sole_width)
    planned = [_outline(f.pose(), robot.sole_length, robot.sole_width) for f in plan.footsteps]
    outlines = {"footsteps_planned": planned, "footprints": prints}
    return {"points": points, "polygons": polygons, "outlines": outlines, "paths": paths}


def balance_overlays(robot, run) -> dict:
    """Overlays of a balance run (``run``: :class:`wbc.scenarios.balance.BalanceRun`), same items as a walk's:
    points com, com_ground, com_reference (ground projection of the CoM target, when the behaviour has one all
    along), zmp_executed (multi-body ZMP of the executed motion, as for a walk), dcm_executed; support polygons of each phase;
    footprints; swing_left / swing_right sole paths."""
    t, com = run.t, run.com
    zeros = np.zeros((len(t), 1))
    points = {"com": com, "com_ground": np.c_[com[:, :2], zeros]}
    if np.isfinite(run.com_ref).all():
        points["com_reference"] = np.c_[run.com_ref[:, :2], zeros]
    points["zmp_executed"] = _zmp_executed(robot, run)
    points["dcm_executed"] = dcm_of(t, com)
    polygons, prints, paths = contact_items(t, run.support, run.left_sole, run.right_sole, robot.sole_length,
                                            robot.sole_width)
    return {"points": points, "polygons": polygons, "outlines": {"footprints": prints}, "paths": paths}


def contact_items(t: np.ndarray, support: np.ndarray, left_sole: np.ndarray, right_sole: np.ndarray,
                  length: float, width: float) -> tuple[list, list, dict]:
    """Support polygons, footprints and swing paths from a support sequence and the realized sole poses.

    Args:
        t: (N,) s. support: (N,) codes 0 double support, 1 left stance, 2 right stance, 3 no contact (flight).
        left_sole, right_sole: (N, 4, 4) world poses (m). length, width: sole rectangle (m).

    Returns:
        ``(polygons, footprints, paths)``: one ``(t_start, t_end, (K, 3))`` support polygon per phase with a
        contact (3 mm above the ground); closed sole outlines at the start and at each touchdown (end of a
        phase in which that foot was not in contact); ``{"swing_left": [(N, 3)], "swing_right": [(N, 3)]}``
        sole-origin paths.
    """
    n = len(t)
    support = np.asarray(support)
    polygons = []
    starts = np.r_[0, np.flatnonzero(np.diff(support)) + 1]
    ends = np.r_[starts[1:], n]
    for a, b in zip(starts, ends):
        polys = []
        if support[a] in (0, 1):
            polys.append(_outline(left_sole[a], length, width)[:, :2])
        if support[a] in (0, 2):
            polys.append(_outline(right_sole[a], length, width)[:, :2])
        if not polys:
            continue
        hull = polys[0] if len(polys) == 1 else convex_hull(np.vstack(polys))
        t_end = t[b] if b < n else t[-1] + (t[-1] - t[-2] if n > 1 else 1.0)
        polygons.append((float(t[a]), float(t_end), np.c_[hull, np.full(len(hull), 0.003)]))
    prints = []
    for soles, stance in ((left_sole, (0, 1)), (right_sole, (0, 2))):
        prints.append(_outline(soles[0], length, width))
        down = np.isin(support, stance)
        for k in np.flatnonzero(~down[:-1] & down[1:]) + 1:  # touchdown: the foot is in contact again
            prints.append(_outline(soles[k], length, width))
    paths = {"swing_left": [left_sole[:, :3, 3]], "swing_right": [right_sole[:, :3, 3]]}
    return polygons, prints, paths


def cop_track(sim_wrench: np.ndarray, sole_pos: np.ndarray, min_fz: float = 1.0) -> np.ndarray:
    """(N, 3) net CoP of ground reactions (N, 2, 6: force N, moment N·m about the sole origin, world axes) at sole
    origins (N, 2, 3): per sample :func:`wbc.sim.walk.measured_cop` on the plane at the f_z-weighted mean height of
    the soles loaded above ``min_fz`` N (0 on flat ground; on a terrain, between the treads), that height as z.
    nan where the total f_z is below ``min_fz`` N (flight)."""
    from wbc.sim.walk_summary import measured_cop  # (the simulation layer, loaded for simulation logs only)

    w, p = np.asarray(sim_wrench, float), np.asarray(sole_pos, float)
    fz = w[:, :, 2]
    weight = np.where(fz > min_fz, fz, 0.0)
    out = np.full((len(w), 3), np.nan)
    for k in np.flatnonzero(weight.sum(axis=1) > min_fz):
        h = float(weight[k] @ p[k, :, 2] / weight[k].sum())
        cop = measured_cop(w[k], p[k], min_fz, height=h)
        if cop is not None:
            out[k] = cop[0], cop[1], h
    return out


def sim_overlays(run, robot=None, plan=None, min_fz: float = 10.0) -> dict:
    """Overlays of a MuJoCo run (:class:`wbc.sim.closed_loop.SimRun`).

    Args:
        run: the run. robot: its :class:`~wbc.robot.Robot` (sole frames and rectangle), to draw the support
            polygons, footprints and swing-foot paths; None skips them. plan: the walk's
            :class:`~wbc.gait.WalkPlan` (same clock as ``run.t``), to draw its footsteps, ZMP and DCM; or None.
        min_fz: a foot is in contact while the plant's ground reaction on it exceeds this (N).

    Returns:
        ``{"points", "arrows", "polygons", "outlines", "paths"}``: points com, com_ground, cop (measured,
        ground truth; at the CoM projection in flight), dcm_executed (+ zmp_planned, dcm_planned with a plan);
        arrows: contact forces on each sole (ground truth) and the push on the torso (drawn from the CoM),
        1 mm per N; support polygons of the feet in contact, footprints at the start and at each touchdown,
        swing_left / swing_right sole paths (with a robot), footsteps_planned (with a plan).
    """
    import pinocchio as pin

    t, com = run.t, run.com
    n = len(t)
    ground = np.c_[com[:, :2], np.zeros(n)]
    cop = cop_track(run.sim_wrench, run.sole_pos)
    cop = np.where(np.isnan(cop), ground, cop)
    points = {"com": com, "com_ground": ground, "cop": cop, "dcm_executed": dcm_of(t, com)}
    arrows = {
        "contact_force_left": (run.sole_pos[:, 0], run.sim_wrench[:, 0, :3]),
        "contact_force_right": (run.sole_pos[:, 1], run.sim_wrench[:, 1, :3]),
    }
    if np.any(run.ext_force):
        arrows["push"] = (com, run.ext_force)
    out = {"points": points, "arrows": arrows, "polygons": [], "outlines": {}, "paths": {}}
    if plan is not None:
        k = np.clip(np.rint(t / plan.dt).astype(int), 0, plan.n_samples - 1)
        points["zmp_planned"] = np.c_[plan.zmp[k], np.zeros(n)]
        points["dcm_planned"] = np.c_[plan.dcm[k], np.zeros(n)]
        if robot is not None:
            out["outlines"]["footsteps_planned"] = [_outline(f.pose(), robot.sole_length, robot.sole_width)
                                                    for f in plan.footsteps]
    if robot is not None:
        model = robot.model
        data = model.createData()
        frames = (robot.frame_id(robot.left_sole), robot.frame_id(robot.right_sole))
        soles = np.empty((2, n, 4, 4))
        for i, q in enumerate(run.q):
            pin.framesForwardKinematics(model, data, q)
            for j, f in enumerate(frames):
                soles[j, i] = data.oMf[f].homogeneous
        down = run.sim_wrench[:, :, 2] > min_fz
        support = np.where(down[:, 0] & down[:, 1], 0, np.where(down[:, 0], 1, np.where(down[:, 1], 2, 3)))
        polygons, prints, paths = contact_items(t, support, soles[0], soles[1], robot.sole_length,
                                                robot.sole_width)
        out["polygons"] = polygons
        out["outlines"]["footprints"] = prints
        out["paths"] = paths
    return out
