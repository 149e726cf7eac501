"""Physical and naming constants shared by the library (each defined here once).

Where a robot is at hand, gravity comes from its Pinocchio model (:attr:`wbc.robot.Robot.gravity`, the norm of
``model.gravity.linear``; Pinocchio's default is (0, 0, −9.81) m/s²). :data:`GRAVITY` is the same value for the
places that have no model: default arguments of closed-form planners (LIPM ω = √(g/z)), the IMU's noise figures, the
viewer's overlays.
"""

from __future__ import annotations

__all__ = ["GRAVITY", "SIDES"]

#: Standard gravity magnitude (m/s²), along −z of the world frame; equal to Pinocchio's default ``model.gravity``.
GRAVITY = 9.81
#: The two legs, in the order every per-foot list of the library uses.
SIDES = ("left", "right")
