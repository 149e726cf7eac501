"""Gait layer: footstep plans, support schedule, LIPM/DCM centre-of-mass plan, swing-foot trajectories.

Entry point: :func:`plan_walk` → :class:`WalkPlan` (arrays precomputed on the control-sample grid, plus
:meth:`WalkPlan.replan` from a measured CoM state). Geometry helpers for support polygons live in
:mod:`wbc.gait.support`.
"""

from wbc.gait.com_plan import LipmPlan, LipmSamples, lipm_omega, plan_lipm
from wbc.gait.footsteps import Footstep, feet_overlap, plan_footsteps, pose_to_xy_yaw
from wbc.gait.schedule import DOUBLE_SUPPORT, LEFT_SUPPORT, RIGHT_SUPPORT, Phase, ZmpSegments
from wbc.geometry import convex_hull, polygons_overlap, signed_distance, sole_polygon
from wbc.gait.swing import min_jerk, sample_feet
from wbc.gait.walk import WalkPlan, plan_walk

__all__ = [
    "DOUBLE_SUPPORT",
    "LEFT_SUPPORT",
    "RIGHT_SUPPORT",
    "Footstep",
    "LipmPlan",
    "LipmSamples",
    "Phase",
    "WalkPlan",
    "ZmpSegments",
    "convex_hull",
    "feet_overlap",
    "lipm_omega",
    "min_jerk",
    "plan_footsteps",
    "plan_lipm",
    "plan_walk",
    "polygons_overlap",
    "pose_to_xy_yaw",
    "sample_feet",
    "signed_distance",
    "sole_polygon",
]
