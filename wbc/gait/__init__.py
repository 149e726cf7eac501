"""Gait layer: footstep plans, support schedule, LIPM/DCM centre-of-mass plan, swing-foot trajectories.

Entry point: :func:`plan_walk` → :class:`WalkPlan` (arrays precomputed on the control-sample grid, plus
:meth:`WalkPlan.replan` from a measured CoM state). The support-polygon geometry lives in :mod:`wbc.geometry`
(re-exported here), the minimum-jerk profile in :mod:`wbc.profiles`.
"""

from wbc.gait.com_plan import LipmPlan, LipmSamples, lipm_omega, plan_lipm
from wbc.gait.footsteps import Footstep, feet_overlap, plan_footsteps, pose_to_xy_yaw
from wbc.gait.schedule import DOUBLE_SUPPORT, LEFT_SUPPORT, RIGHT_SUPPORT, Phase, Support, ZmpSegments
from wbc.geometry import convex_hull, polygons_overlap, signed_distance, sole_polygon
from wbc.gait.swing import sample_feet
from wbc.profiles import min_jerk
from wbc.gait.walk import WalkPlan, plan_walk

__all__ = [
    "Support",
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
