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

import numba as nb
import numpy as np

from wbc.compiled import once_per_process, specialise
from wbc.exceptions import InvalidInputError
from wbc.geometry import FLOAT64

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
        self._vj, self._x = np.empty_like(d), np.empty_like(d)
        _warm_up()
        v = np.zeros(d.shape[0] + 6)
        self._kernels = (specialise(_commanded_velocity, v, v, 0.002, 0.05, self._vj, self._x),
                         specialise(_add_clipped, *(self._x,) * 8))

    def torque(self, joint_velocity: np.ndarray) -> np.ndarray:
        """(n,) compensation torque (N·m) for the joint velocities q̇* (n,) rad/s (a reused array)."""
        np.tanh(joint_velocity / self.velocity_scale, out=self._out)
        self._out *= self.friction
        self._out += self.damping * joint_velocity
        return self._out

    def compensated(self, tau: np.ndarray, v: np.ndarray, dv: np.ndarray, dt: float, tau_min: np.ndarray,
                    tau_max: np.ndarray) -> np.ndarray:
        """``min(max(tau + torque(q̇*), tau_min), tau_max)`` with q̇* = v[6:] + dv[6:] dt (a new (n,) array, N·m):
        the commanded torques ``tau`` (n,) with the compensation added and clipped, for the measured velocity
        ``v`` (n + 6,) and the QP's acceleration ``dv`` (n + 6,) over the period ``dt`` (s); the same numbers as
        :meth:`torque` followed by numpy's ``maximum`` and ``minimum``.

        Raises:
            InvalidInputError: arrays of the wrong shape.
        """
        n = self.damping.shape[0]
        contiguous = True
        for a in (tau, v, dv, tau_min, tau_max):
            if type(a) is not np.ndarray or (a.dtype is not FLOAT64 and a.dtype != FLOAT64) or a.ndim != 1:
                contiguous = None
                break
            contiguous = contiguous and a.flags.c_contiguous
        if contiguous is None or tau.shape[0] != n or v.shape[0] != n + 6 or dv.shape[0] != n + 6 \
                or tau_min.shape[0] != n or tau_max.shape[0] != n:
            raise InvalidInputError(f"compensated needs float arrays tau ({n},), v and dv ({n + 6},), tau_min and "
                                    f"tau_max ({n},)")
        vj, x = self._vj, self._x
        # contiguous float vectors (the controller's): the kernels' versions for them without the dispatcher's type
        # resolution (wbc.compiled.specialise), else the dispatchers
        velocity, add = self._kernels if contiguous else (_commanded_velocity, _add_clipped)
        velocity(v, dv, float(dt), self.velocity_scale, vj, x)
        np.tanh(x, out=x)  # (numpy's tanh, as torque: its CPU-dispatched kernel may differ from libm in the last bit)
        out = np.empty(n)
        add(tau, x, self.friction, self.damping, vj, tau_min, tau_max, out)
        return out


@nb.njit(cache=True)
def _commanded_velocity(v, dv, dt, eps, vj, x):
    """vj = v[6:] + dv[6:] dt and x = vj / eps, elementwise (the operations of numpy's expressions)."""
    off = v.shape[0] - vj.shape[0]
    for i in range(vj.shape[0]):
        vj[i] = v[off + i] + dv[off + i] * dt
        x[i] = vj[i] / eps


@nb.njit(cache=True)
def _add_clipped(tau, th, friction, damping, vj, lo, hi, out):
    """out = minimum(maximum(tau + (th f + d vj), lo), hi) elementwise, NaN propagated as numpy's maximum/minimum."""
    for i in range(tau.shape[0]):
        t = tau[i] + (th[i] * friction[i] + damping[i] * vj[i])
        a = lo[i] if t < lo[i] else t
        out[i] = hi[i] if a > hi[i] else a


@once_per_process
def _warm_up() -> None:
    """Load the kernels of :meth:`JointFrictionCompensation.compensated` (on-disk cache) once per process."""
    z = np.zeros(1)
    _commanded_velocity(np.zeros(7), np.zeros(7), 0.002, 0.05, z, z.copy())
    _add_clipped(z, z, z, z, z, z, z, z.copy())
