"""Walks on terrain as scenarios: the plan from a robot's stance and gait defaults, and what the robot did on it.

:func:`plan_default_terrain_walk` is :func:`wbc.scenarios.walk.plan_default_walk` on a terrain
(:func:`wbc.gait.terrain_walk.plan_terrain_walk`); on stairs the default step length is the tread (one foot per
tread). :func:`terrain_summary` measures, from the soles' executed world poses (logged q, not the plan):

* ``foothold_error_m``: per step, the distance (m, 3-D) between the sole origin at the end of the double support
  that follows its touch-down (the sole at rest on its foothold) and the planned foothold;
* ``max_sole_support_gap_m``: the largest, over the steps, gap between the ground and the plane of the ground under
  the landed sole (:meth:`wbc.terrain.Terrain.sole_support`, no margin): 0 when every sole lies wholly on one tread;
* ``min_swing_clearance_m``: the smallest height of a swinging sole's underside above the terrain away from where
  it lifted off and where it landed (the executed lift-off and landing positions, not the planned footholds: a sole
  landing beside its foothold still descends onto the tread, which is no edge crossing;
  :meth:`wbc.terrain.Terrain.swing_clearance`), i.e. over the step edges (``null`` when no swing is long enough
  to be counted);
* ``planned_min_swing_clearance_m`` and ``max_apex_m``: the same clearance of the plan, and its highest apex.
"""

from __future__ import annotations

import math

import numpy as np

from wbc.configuration import Configuration
from wbc.gait.terrain_walk import TerrainWalk, plan_terrain_walk, steps_to_cross
from wbc.robot import Robot
from wbc.scenarios.framework import Criterion, evaluate
from wbc.terrain import Terrain, parse_terrain

__all__ = ["plan_default_terrain_walk", "default_steps", "stair_defaults", "STAIR_CONTROLLER_KEYS", "terrain_summary",
           "TERRAIN_CRITERIA", "terrain_passes"]

#: Acceptance on terrain: thresholds on what the robot did.
TERRAIN_CRITERIA = [
    Criterion("every landed sole wholly on one tread (support gap ≤ 5 mm)", "max_sole_support_gap_m", "<=", 0.005),
    Criterion("swing soles clear the step edges (≥ 5 mm)", "min_swing_clearance_m", ">=", 0.005),
]


def terrain_passes(summary: dict) -> tuple[bool, list[str]]:
    """(all :data:`TERRAIN_CRITERIA` hold, descriptions of the failed ones); a clearance of None (no counted swing)
    holds."""
    s = dict(summary)
    if s.get("min_swing_clearance_m") is None:
        s["min_swing_clearance_m"] = math.inf
    return evaluate(s, TERRAIN_CRITERIA)


#: Keys of :func:`stair_defaults` that set the physics walk's controller (:class:`wbc.sim.walk.WalkScenario`), not
#: the plan.
STAIR_CONTROLLER_KEYS = ("base_weight",)


def stair_defaults(robot: Robot, terrain: Terrain) -> dict[str, float]:
    """The walk parameters that a terrain of stairs (more than two treads) sets in place of the robot's defaults:
    ``step_length`` (m), one tread, and the robot file's ``[stairs]`` table (``step_width``, m; ``base_weight``, the
    pelvis orientation task's weight; :attr:`Robot.stairs`). Empty for any other terrain. A value the user gives
    replaces these in turn.

    Args:
        robot: the robot. terrain: a parsed :class:`wbc.terrain.Terrain`.

    Returns:
        dict: keywords of :func:`wbc.gait.plan_walk` (m) and, those of :data:`STAIR_CONTROLLER_KEYS`, of
        :class:`wbc.sim.walk.WalkScenario`.
    """
    if len(terrain.treads) <= 2:
        return {}
    return {"step_length": terrain.treads[1][1] - terrain.treads[1][0], **robot.stairs}


def plan_default_terrain_walk(robot: Robot, terrain: Terrain | str, config: Configuration | None = None,
                              dt: float = 0.002, **overrides) -> TerrainWalk:
    """A straight walk on ``terrain`` from the robot's current stance with its descriptor's gait defaults.

    Args:
        robot: the robot (``robot.gait`` holds its defaults). terrain: a :class:`wbc.terrain.Terrain` or its
            description. config: current configuration (default ``robot.q_ref``). dt: sample period (s).
        **overrides: keywords of :func:`wbc.gait.plan_walk` and :func:`wbc.gait.terrain_walk.plan_terrain_walk`;
            None values are ignored. Without them, stairs use :func:`stair_defaults`.

    Raises:
        GaitError, TerrainError: see :func:`wbc.gait.terrain_walk.plan_terrain_walk`.
    """
    terrain = parse_terrain(terrain)
    config = config or Configuration(robot)
    return plan_terrain_walk(terrain, *_soles(robot, config), config.com.copy(), dt=dt, sole_length=robot.sole_length,
                             sole_width=robot.sole_width, **_walk_keywords(robot, terrain, overrides))


def _walk_keywords(robot: Robot, terrain: Terrain, overrides: dict) -> dict:
    """The :func:`plan_terrain_walk` keywords of :func:`plan_default_terrain_walk`: the robot's gait, the stair
    defaults, then the non-None ``overrides``."""
    kwargs = dict(robot.gait)
    if terrain.treads:
        kwargs.setdefault("step_length", 0.15)
    kwargs.update({k: v for k, v in stair_defaults(robot, terrain).items() if k not in STAIR_CONTROLLER_KEYS})
    kwargs.update({k: v for k, v in overrides.items() if v is not None})
    return kwargs


def _soles(robot: Robot, config: Configuration) -> tuple[np.ndarray, np.ndarray]:
    """(4, 4) world poses of the left and right sole frames at ``config``."""
    return (config.data.oMf[robot.frame_id(robot.left_sole)].homogeneous,
            config.data.oMf[robot.frame_id(robot.right_sole)].homogeneous)


def default_steps(robot: Robot, terrain: Terrain | str, config: Configuration | None = None, *,
                  blind: bool = False, **overrides) -> int | None:
    """The number of steps that crosses ``terrain`` (the default of ``wbc walk`` and ``wbc sim walk`` on a terrain
    with an end, :attr:`wbc.terrain.Terrain.end_x`): the smallest count whose footholds put both heels past the
    end (:func:`wbc.gait.terrain_walk.steps_to_cross`), the walk planned as :func:`plan_default_terrain_walk` plans
    it from ``config``'s stance (default ``robot.q_ref``).

    Args:
        robot: the robot. terrain: a :class:`wbc.terrain.Terrain` or its description. blind: the walk is planned
            on flat ground (its footsteps are not moved onto the treads). **overrides: ``step_length``,
            ``step_width`` (m), ``first_side``; None values are ignored.

    Returns:
        The count (>= 2), or None: a terrain without an end, or no count up to 200 crosses it.

    Raises:
        GaitError: a step without a foothold on the way (as the plan would).
    """
    terrain = parse_terrain(terrain)
    if terrain.end_x is None:
        return None
    kwargs = _walk_keywords(robot, terrain, overrides)
    keys = ("step_length", "step_width", "first_side", "edge_margin", "max_shift")
    return steps_to_cross(terrain, *_soles(robot, config or Configuration(robot)), sole_length=robot.sole_length,
                          sole_width=robot.sole_width, on_terrain=not blind,
                          **{k: kwargs[k] for k in keys if k in kwargs})


def terrain_summary(walk: TerrainWalk, left: np.ndarray, right: np.ndarray, length: float, width: float) -> dict:
    """Terrain metrics of an executed walk (module docstring).

    Args:
        walk: the plan. left, right: (N, 4, 4) executed world poses of the sole frames, row k at the plan's sample
            k (shorter logs are read up to their end). length, width: sole rectangle (m).

    Returns:
        dict: ``terrain``, ``foothold_error_m`` (list, m), ``max_foothold_error_m``, ``max_sole_support_gap_m``,
        ``min_swing_clearance_m`` (m or None), ``planned_min_swing_clearance_m`` (m or None), ``max_apex_m``.
    """
    plan, terrain = walk.plan, walk.terrain
    n = min(len(left), len(right))
    feet = {"left": np.asarray(left), "right": np.asarray(right)}
    phases = list(plan.phases)
    errors, gaps, clear = [], [], []
    for i, ph in enumerate(phases):
        if ph.step < 0:
            continue
        side = plan.footsteps[ph.step].side
        P = feet[side]
        rest = phases[i + 1].end - 1 if i + 1 < len(phases) else ph.end
        k = min(rest, n - 1)
        hold = walk.footholds[ph.step]
        errors.append(float(np.linalg.norm(P[k, :3, 3] - hold[:3, 3])))
        yaw = math.atan2(P[k, 1, 0], P[k, 0, 0])
        gaps.append(terrain.sole_support(float(P[k, 0, 3]), float(P[k, 1, 3]), yaw, length, width, 0.0))
        a, b = ph.first, min(ph.end, n)
        if b > a:
            clear.append(terrain.swing_clearance(P[a:b], P[a, :3, 3], P[k, :3, 3], length, width, walk.approach))
    finite = [c for c in clear if math.isfinite(c)]
    planned = [c for c in walk.planned_clearance.tolist() if math.isfinite(c)]
    return {
        "terrain": terrain.name,
        "foothold_error_m": errors,
        "max_foothold_error_m": max(errors) if errors else 0.0,
        "max_sole_support_gap_m": max(gaps) if gaps else 0.0,
        "min_swing_clearance_m": min(finite) if finite else None,
        "planned_min_swing_clearance_m": min(planned) if planned else None,
        "max_apex_m": float(walk.apex.max()) if len(walk.apex) else 0.0,
    }
