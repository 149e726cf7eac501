"""Feed-forward compensation of joint friction and damping on the commanded torques.

Joint friction model (per actuated joint i, the plant model of :mod:`wbc.sim.actuators`): viscous damping d_i q̇ plus
dry (Coulomb) friction f_i sign(q̇). The compensation adds to the inverse-dynamics torque

    τ_ff,i = d_i q̇*_i + f_i tanh(q̇*_i / ε),    q̇* = v + v̇ dt  (the joint velocity the QP commands for the next
                                                  tick, from the measured v and the QP's v̇),

the sign function smoothed by tanh with the velocity scale ε (rad/s): a smooth deadband, so a joint at rest gets
no friction torque and the command does not chatter with the sign of a velocity near zero (continuously
differentiable friction model of Makkar, Dixon, Sawyer and Hu, "A new continuously differentiable friction model
for control systems design", IEEE/ASME AIM 2005, eq. 1, its Coulomb term). Static friction is not compensated
(a joint held at rest stays held by friction, which helps a stance). The total is clipped to the torque limits.
"""

from __future__ import annotations

import numpy as np

from wbc.exceptions import InvalidInputError

__all__ = ["JointFrictionCompensation"]


class JointFrictionCompensation:
    """τ_ff = d q̇* + f tanh(q̇*/ε) (module docstring).

    Args:
        damping: (n,) viscous damping (N·m·s/rad, ≥ 0), Pinocchio's actuated order.
        friction: (n,) dry friction (N·m, ≥ 0).
        velocity_scale: ε (rad/s, > 0).

    Raises:
        InvalidInputError: shapes differ, negative or non-finite values.
    """

    def __init__(self, damping, friction, velocity_scale: float = 0.05):
        d = np.asarray(damping, dtype=float).reshape(-1)
        f = np.asarray(friction, dtype=float).reshape(-1)
        if d.shape != f.shape:
            raise InvalidInputError(f"damping {d.shape} and friction {f.shape} must have the same shape")
        if not (np.all(np.isfinite(d)) and np.all(d >= 0) and np.all(np.isfinite(f)) and np.all(f >= 0)):
            raise InvalidInputError("damping and friction must be finite and ≥ 0")
        if not (np.isfinite(velocity_scale) and velocity_scale > 0):
            raise InvalidInputError(f"velocity_scale must be finite and > 0 rad/s, got {velocity_scale!r}")
        self.damping, self.friction, self.velocity_scale = d, f, float(velocity_scale)
        self._out = np.empty_like(d)

    def torque(self, joint_velocity: np.ndarray) -> np.ndarray:
        """(n,) compensation torque (N·m) for the joint velocities q̇* (n,) rad/s (a reused array)."""
        np.tanh(joint_velocity / self.velocity_scale, out=self._out)
        self._out *= self.friction
        self._out += self.damping * joint_velocity
        return self._out
