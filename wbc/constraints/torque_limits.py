"""Torque limits of the inverse-dynamics QP (eq. 6 of :mod:`wbc.formulations.acceleration`):
−τ_max − h_a ≤ M_a v̇ − (J_cᵀ)_a f ≤ τ_max − h_a (N·m), relaxable.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from wbc.compiled import FASTMATH
from wbc.constraints.base import IDConstraint
from wbc.exceptions import InvalidInputError
from wbc.robot import Robot

__all__ = ["TorqueLimits", "torque_limit_rows"]


class TorqueLimits(IDConstraint):
    """URDF effort limits on the torques of eq. 2 (eq. 6, N·m), joints with a finite positive limit only.

    Args:
        robot: the robot. scale: fraction of the URDF effort limit, in (0, 1].

    Attributes:
        tau_max: (nv − 6,) scaled effort limits (all joints). joints: indices (into τ) of the limited joints.
        limits: (dim,) the limits of those joints. velocity_indices: (dim,) int64 their indices in v.
    """

    name = "torque_limits"
    kind = "inequality"
    relaxable = True

    def __init__(self, robot: Robot, scale: float = 1.0):
        if not (0 < scale <= 1):
            raise InvalidInputError(f"torque_limit_scale must be in (0, 1], got {scale!r}")
        effort = np.asarray(robot.model.effortLimit[6:], dtype=float) * float(scale)
        self.tau_max = effort
        self.joints = np.flatnonzero(np.isfinite(effort) & (effort > 0))
        self.dim = int(self.joints.size)
        self.velocity_indices = (6 + self.joints).astype(np.int64)
        self.limits = effort[self.joints]

    def write(self, ctx, C, l, u):
        if not self.dim:
            return
        torque_limit_rows(ctx.state.M, ctx.state.h, ctx.JcT, self.velocity_indices, self.limits, C, l, u, 0)


@nb.njit(cache=True, nogil=True, fastmath=FASTMATH, inline="always")
def torque_limit_rows(M, h, JcT, vrows, limits, C, l, u, row):
    """Rows ``row ..`` of l ≤ C x ≤ u: eq. 6, −τ_max − h_a ≤ M_a v̇ − (J_cᵀ)_a f ≤ τ_max − h_a (N·m) for the
    joints with velocity indices ``vrows`` (k,) int64 and limits ``limits`` (k,)."""
    nv = M.shape[0]
    nf = C.shape[1] - nv
    for r in range(vrows.size):
        vr = vrows[r]
        for j in range(nv):
            C[row + r, j] = M[vr, j]
        for j in range(nf):
            C[row + r, nv + j] = -JcT[vr, j]
        l[row + r] = -limits[r] - h[vr]
        u[row + r] = limits[r] - h[vr]
