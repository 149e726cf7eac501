"""Baseline standing controller: joint-space PD plus a gravity compensation that shares the weight between the feet.

At the reference configuration q_ref (v = 0), the gravity torques g = RNEA(q_ref, 0, 0) are balanced by the two
sole wrenches of least norm, W = argmin ‖W‖ s.t. (J_cᵀ)_u W = g_u (J_c the stacked (12, nv) LOCAL_WORLD_ALIGNED
sole Jacobians), so the feed-forward torque is τ_ff = (g − J_cᵀ W)_a. The command is

    τ = τ_ff + K_p (q_ref − q)_a − K_d v_a,

with per-joint gains from the joint's effective inertia I_eff = 1 / (M⁻¹)_ii (base free) at q_ref and the
simulation step dt: K_p = min(10 τ_max, 0.1 I_eff / dt²), K_d = 0.5 I_eff / dt (the stability bounds of an
explicit PD on light links, see :mod:`wbc.sim.mujoco_model`). This is the baseline of the field notes; the pushes
it survives are found by ``wbc sim push --sweep`` (figures in ``benchmarks/README.md``).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from wbc.robot import Robot

__all__ = ["JointPDController"]


class JointPDController:
    """Joint PD + weight-sharing gravity compensation around ``robot.q_ref`` (module docstring).

    Args:
        robot: the robot.
        dt: simulation/control step (s) used in the gain rule.
        effort_limit: (nv − 6,) torque limits (N·m); default the URDF's.
    """

    name = "pd"

    def __init__(self, robot: Robot, dt: float = 0.002, effort_limit: np.ndarray | None = None):
        model, q0 = robot.model, robot.q_ref
        data = model.createData()
        zero = np.zeros(model.nv)
        g = pin.rnea(model, data, q0, zero, zero)
        J = np.vstack([pin.computeFrameJacobian(model, data, q0, robot.frame_id(f), pin.LOCAL_WORLD_ALIGNED)
                       for f in (robot.left_sole, robot.right_sole)])
        W = np.linalg.lstsq(J[:, :6].T, g[:6], rcond=None)[0]
        M = pin.crba(model, data, q0)
        M = np.triu(M) + np.triu(M, 1).T
        i_eff = 1.0 / np.diag(np.linalg.inv(M))[6:]
        effort = np.asarray(model.effortLimit[6:] if effort_limit is None else effort_limit, dtype=float)
        self.robot = robot
        self.q_ref = q0.copy()
        self.tau_ff = (g - J.T @ W)[6:]
        self.kp = np.minimum(10.0 * effort, 0.1 * i_eff / dt**2)
        self.kd = 0.5 * i_eff / dt
        self.effort = effort

    def reset(self, q: np.ndarray, v: np.ndarray | None = None) -> None:
        """Nothing to reset (the reference is ``robot.q_ref``)."""

    def solve(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """(nv − 6,) torques (N·m) for the state (q, v), clipped to the effort limits."""
        tau = self.tau_ff + self.kp * (self.q_ref[7:] - q[7:]) - self.kd * v[6:]
        return np.clip(tau, -self.effort, self.effort)
