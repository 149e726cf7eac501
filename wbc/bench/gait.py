"""Gait planning benchmark: wbc ``plan_walk`` / ``WalkPlan.replan`` vs placo's ``WalkPatternGenerator``.

Both plan the same 6-step straight walk of a catalog robot (Talos by default) from its reference stance: the same
footsteps (wbc's :func:`~wbc.gait.plan_footsteps` convention: left foot first, 5 steps of ``step_length`` and a
closing step, handed to placo as its ``Footsteps``), the same phase timing (placo rounds durations to its
knots, so the timing is chosen on placo's grid: single support 0.8 s = 10 knots of 80 ms, double support 0.32 s,
start/end double support 1.04 s) and the same sole rectangle.

Each plan's ZMP is recomputed from its CoM trajectory every 2 ms, ``p = c_xy − c̈_xy z / g`` (each planner's own
g: wbc 9.81, placo 9.80665 m/s²), and its margin is the signed distance (m, positive inside) to the support
polygon of the phase that starts at that sample: the stance sole rectangle in single support, the convex hull of
both sole rectangles in double support (:mod:`wbc.geometry`), with each planner's own phases.

Replanning: from the CoM state of the plan in the middle of the third single support; wbc ``WalkPlan.replan(k,
c, ċ)``; placo ``WalkPatternGenerator.replan(supports, trajectory, t)`` with the remaining supports (the current
one with its elapsed ratio, as placo's ``replan_supports`` builds them).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from time import perf_counter_ns
from typing import Callable

import numpy as np

from wbc.bench.stats import pooled_summary_us
from wbc.configuration import Configuration
from wbc.constants import GRAVITY
from wbc.gait import DOUBLE_SUPPORT, plan_walk
from wbc.geometry import convex_hull, signed_distance, sole_polygon
from wbc.robot import Robot

__all__ = ["GaitSpec", "run_gait_benchmark", "wbc_plan_margins", "placo_plan_margins"]

PLACO_G = 9.80665  # placo's LIPM gravity (placo.LIPM.compute_omega)


@dataclass(frozen=True)
class GaitSpec:
    """The walk both planners plan.

    Attributes:
        n_steps: swing phases (the last one closes the stance).
        step_length: m.
        t_ss, t_ds, t_startend: single, double, start/end double support durations (s); multiples of placo's knot.
        placo_ss_knots: placo knots per single support (knot = t_ss / placo_ss_knots).
        sample_dt: ZMP sampling period (s).
        repeats: timed plans per planner (wbc); placo_repeats for placo (slower); both split over ``rounds``
            interleaved rounds.
        gravity: wbc's g (m/s²).
    """

    n_steps: int = 6
    step_length: float = 0.15
    t_ss: float = 0.8
    t_ds: float = 0.32
    t_startend: float = 1.04
    placo_ss_knots: int = 10
    sample_dt: float = 0.002
    repeats: int = 200
    placo_repeats: int = 20
    rounds: int = 5
    gravity: float = GRAVITY


def _initial_state(robot: Robot) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    config = Configuration(robot)
    left = config.data.oMf[robot.frame_id(robot.left_sole)].homogeneous.copy()
    right = config.data.oMf[robot.frame_id(robot.right_sole)].homogeneous.copy()
    return left, right, config.com.copy()


def _wbc_plan_fn(robot: Robot, spec: GaitSpec):
    left, right, com = _initial_state(robot)
    kwargs = dict(n_steps=spec.n_steps, step_length=spec.step_length, t_ss=spec.t_ss, t_ds=spec.t_ds,
                  t_init=spec.t_startend, t_final=spec.t_startend, dt=spec.sample_dt,
                  sole_length=robot.sole_length, sole_width=robot.sole_width, gravity=spec.gravity,
                  step_height=robot.gait.get("step_height", 0.05))
    return lambda: plan_walk(left, right, com, **kwargs)


def wbc_plan_margins(plan, gravity: float) -> np.ndarray:
    """(N,) ZMP margin (m) of a :class:`~wbc.gait.WalkPlan` at each of its samples (module docstring)."""
    zmp = plan.com[:, :2] - plan.com_acc[:, :2] * plan.com_height / gravity
    out = np.empty(plan.n_samples)
    bounds = [(ph.first, ph.end) for ph in plan.phases]
    bounds[-1] = (bounds[-1][0], plan.n_samples)
    for k0, k1 in bounds:
        out[k0:k1] = signed_distance(zmp[k0:k1], plan.support_polygon_at(k0))
    return out


def _mid_single_support_sample(plan, which: int = 3) -> int:
    singles = [ph for ph in plan.phases if ph.support != DOUBLE_SUPPORT]
    ph = singles[min(which, len(singles)) - 1]
    return ph.first + ph.count // 2


# -- placo ----------------------------------------------------------------------------------------------------
def _placo_setup(robot: Robot, spec: GaitSpec):
    import placo

    from wbc.bench.placo_models import placo_humanoid
    from wbc.gait import plan_footsteps
    from wbc.gait.footsteps import pose_to_xy_yaw

    humanoid = placo_humanoid(robot)
    left, right, com = _initial_state(robot)
    p = placo.HumanoidParameters()
    p.single_support_duration = spec.t_ss
    p.single_support_timesteps = spec.placo_ss_knots
    p.double_support_ratio = spec.t_ds / spec.t_ss
    p.startend_double_support_ratio = spec.t_startend / spec.t_ss
    p.walk_com_height = float(com[2])
    p.foot_length = robot.sole_length
    p.foot_width = robot.sole_width
    p.feet_spacing = float(np.linalg.norm(left[:2, 3] - right[:2, 3]))
    horizon = spec.t_ss * spec.n_steps + spec.t_ds * (spec.n_steps - 1) + 2 * spec.t_startend
    p.planned_timesteps = int(math.ceil(horizon / p.dt())) + 2
    lft, rgt = pose_to_xy_yaw(left), pose_to_xy_yaw(right)
    steps = plan_footsteps(lft, rgt, spec.n_steps, spec.step_length, p.feet_spacing, 0.0, "left")
    footsteps = placo.Footsteps()
    sides = {"left": placo.HumanoidRobot_Side.left, "right": placo.HumanoidRobot_Side.right}
    for side, pose in (("left", left), ("right", right), *((s.side, s.pose()) for s in steps)):
        fs = placo.Footstep(robot.sole_width, robot.sole_length)
        fs.side = sides[side]
        fs.frame = pose
        footsteps.append(fs)
    wpg = placo.WalkPatternGenerator(humanoid, p)

    def supports():
        return placo.FootstepsPlanner.make_supports(footsteps, 0.0, True, p.has_double_support(), True)

    return wpg, supports, com, p, humanoid


def placo_plan_margins(trajectory, robot: Robot, sample_dt: float, t0: float | None = None) -> np.ndarray:
    """(N,) ZMP margin (m) of a placo walk trajectory every ``sample_dt`` from ``t0`` (default its start) to its
    end, against placo's own supports (module docstring)."""
    z = float(trajectory.com_target_z)
    t_start = float(trajectory.t_start if t0 is None else t0)
    n = int(math.floor((float(trajectory.t_end) - t_start) / sample_dt + 1e-9)) + 1
    out = np.empty(n)
    cache: dict[float, np.ndarray] = {}
    for i in range(n):
        t = t_start + i * sample_dt
        c = trajectory.get_p_world_CoM(t)
        a = trajectory.get_a_world_CoM(t)
        zmp = np.array([c[0] - a[0] * z / PLACO_G, c[1] - a[1] * z / PLACO_G])
        support = trajectory.get_support(min(t + 1e-7, float(trajectory.t_end)))
        key = float(trajectory.get_part_t_start(min(t + 1e-7, float(trajectory.t_end))))
        poly = cache.get(key)
        if poly is None:
            corners = []
            for fs in support.footsteps:
                frame = np.asarray(fs.frame)
                yaw = math.atan2(frame[1, 0], frame[0, 0])
                corners.append(sole_polygon(frame[0, 3], frame[1, 3], yaw, robot.sole_length, robot.sole_width))
            poly = convex_hull(np.vstack(corners)) if len(corners) > 1 else corners[0]
            cache[key] = poly
        out[i] = signed_distance(zmp, poly)
    return out


def _placo_replan_supports(trajectory, wpg, t_replan: float):
    """Remaining supports from the one active at ``t_replan`` (its elapsed ratio set), as placo's
    ``replan_supports`` builds them."""
    import placo

    all_supports = trajectory.get_supports()
    out = placo.Supports()
    for s in all_supports:
        if s.t_start + wpg.support_default_duration(s) * s.time_ratio <= t_replan + 1e-9:
            continue
        out.append(s)
    first = out[0]
    first.elapsed_ratio = (t_replan - first.t_start) / (wpg.support_default_duration(first) * first.time_ratio)
    first.start = False
    out[0] = first
    return out


# -- benchmark ------------------------------------------------------------------------------------------------
def _margin_summary(m: np.ndarray) -> dict[str, object]:
    return {"min_margin_m": float(m.min()), "samples": int(m.size), "samples_below_0": int((m < 0).sum()),
            "samples_below_20mm": int((m < 0.02).sum())}


def _interleaved(fns: dict[str, tuple[Callable[[], object], int]], rounds: int) -> dict[str, tuple[dict, object]]:
    """Time each ``name -> (fn, calls per round)`` in turn, round after round; per name: (summary µs with
    ``median`` = median of the round medians and pooled p90/p99/max, last result)."""
    durations: dict[str, list[np.ndarray]] = {name: [] for name in fns}
    last: dict[str, object] = {}
    for name, (fn, _) in fns.items():  # warm-up
        last[name] = fn()
    for _ in range(rounds):
        for name, (fn, calls) in fns.items():
            d = np.empty(calls, dtype=np.int64)
            for i in range(calls):
                t0 = perf_counter_ns()
                last[name] = fn()
                d[i] = perf_counter_ns() - t0
            durations[name].append(d)
    return {name: (pooled_summary_us(durations[name]), last[name]) for name in fns}


def run_gait_benchmark(robot: Robot, spec: GaitSpec = GaitSpec(), with_placo: bool = True) -> dict[str, object]:
    """Time plan and replan of both planners, interleaved over ``spec.rounds`` rounds (wbc plan, wbc replan,
    placo plan, placo replan, …), and the ZMP margin of every plan.

    Returns:
        {"spec": ..., "wbc": {"plan_us": summary, "replan_us": summary, "plan": margins, "replan": margins,
        "replan_t": s}, "placo": {... same, or "error"}}.
    """
    out: dict[str, object] = {"spec": asdict(spec), "robot": robot.name}
    rounds = max(1, spec.rounds)
    per_round = max(1, spec.repeats // rounds)
    placo_per_round = max(1, spec.placo_repeats // rounds)
    plan_fn = _wbc_plan_fn(robot, spec)
    plan = plan_fn()
    k = _mid_single_support_sample(plan)
    t_replan = k * spec.sample_dt
    fns: dict[str, tuple[Callable[[], object], int]] = {
        "wbc_plan": (plan_fn, per_round),
        "wbc_replan": (lambda: plan.replan(k, plan.com[k], plan.com_vel[k]), per_round),
    }
    placo_error = None
    if with_placo:
        try:
            wpg, supports, com, params, humanoid = _placo_setup(robot, spec)
            traj = wpg.plan(supports(), com, 0.0)
            fns["placo_plan"] = (lambda: wpg.plan(supports(), com, 0.0), placo_per_round)
            fns["placo_replan"] = (lambda: wpg.replan(_placo_replan_supports(traj, wpg, t_replan), traj, t_replan),
                                   placo_per_round)
        except Exception as exc:  # placo missing or failing: report, do not abort the suite
            placo_error = f"{type(exc).__name__}: {exc}"
    timed = _interleaved(fns, rounds)
    (plan_us, plan), (replan_us, replanned) = timed["wbc_plan"], timed["wbc_replan"]
    out["wbc"] = {"plan_us": plan_us, "replan_us": replan_us, "duration_s": plan.duration,
                  "plan": _margin_summary(wbc_plan_margins(plan, spec.gravity)),
                  "replan": _margin_summary(wbc_plan_margins(replanned, spec.gravity)),
                  "builtin_min_margin_m": float(plan.zmp_margin().min()), "replan_t": t_replan}
    if placo_error is not None:
        out["placo"] = {"error": placo_error}
    elif "placo_plan" in timed:
        (p_us, traj), (r_us, rtraj) = timed["placo_plan"], timed["placo_replan"]
        out["placo"] = {"plan_us": p_us, "replan_us": r_us, "duration_s": float(traj.t_end - traj.t_start),
                        "plan": _margin_summary(placo_plan_margins(traj, robot, spec.sample_dt)),
                        "replan": _margin_summary(placo_plan_margins(rtraj, robot, spec.sample_dt, t_replan)),
                        "replan_success": bool(rtraj.replan_success), "knot_s": float(params.dt()),
                        "zmp_margin_param_m": float(params.zmp_margin), "replan_t": t_replan,
                        "note": "timed: make_supports + plan (placo builds and solves one QP over the walk)"}
    return out
