"""Support-polygon geometry of the gait layer: re-exported from :mod:`wbc.geometry`, where it lives (below
tasks, constraints and gait)."""

from wbc.geometry import convex_hull, polygons_overlap, signed_distance, sole_polygon, support_polygon

__all__ = ["sole_polygon", "convex_hull", "signed_distance", "polygons_overlap", "support_polygon"]
