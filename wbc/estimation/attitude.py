"""Base orientation from a gyroscope and an accelerometer: the explicit complementary filter on SO(3) with gyro
bias estimation (Mahony, Hamel, Pflimlin 2008, "Nonlinear complementary filters on the special orthogonal group",
IEEE Trans. Automatic Control 53(5), Sec. V-C, eq. 32).

With the IMU frame B, the estimate R̂ = ᴬR̂_B (world ← IMU), gyro reading Ωʸ (rad/s, B axes), inertial reference
directions v₀ᵢ (world) measured in B as vᵢ (unit vectors) with weights kᵢ:

    v̂ᵢ     = R̂ᵀ v₀ᵢ                                (the prediction of the measured direction)
    ω_mes  = Σᵢ kᵢ vᵢ × v̂ᵢ                          (eq. 32c)
    dR̂/dt  = R̂ (Ωʸ − b̂ + k_P ω_mes)×               (eq. 32a)
    db̂/dt  = −k_I ω_mes                             (eq. 32b)

integrated once per sample with the exponential map, R̂ ← R̂ exp((Ωʸ − b̂ + k_P ω_mes + k_H ω_yaw) Δt) (Pinocchio
``exp3``; R̂ stays a rotation).

The accelerometer gives the "up" direction: its specific force a − g is ``+g e_z`` at rest, so
v = a/‖a‖ with v₀ = e_z. While the robot accelerates, a/‖a‖ is not the vertical; the filter trusts it with a
small k_P (a low corner frequency) and with the weight k = 0 when ‖a‖ differs from g by more than ``accel_gate``.
Only the directions given are corrected: with gravity alone, yaw follows the gyro (its bias about the vertical is
not observable from gravity).

**Heading directions** (optional, e.g. the forward axis of a sole standing on the ground, from the leg kinematics)
correct yaw only: their error ω_h = Σⱼ kⱼ vⱼ × v̂ⱼ is projected on the estimated vertical u = R̂ᵀ e_z,
ω_yaw = (ω_h · u) u, with its own gains k_H (rate) and k_IH (bias, db̂/dt = −k_I ω_mes − k_IH ω_yaw). A heading
reference that is much better than the gyro's integral (a loaded sole does not turn) can then be trusted with a
high gain without pulling the tilt away from gravity (this projection is wbc's addition to eq. 32).
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from wbc.constants import GRAVITY
from wbc.exceptions import InvalidInputError
from wbc.geometry import check_scalar

__all__ = ["ComplementaryAttitudeFilter", "GAIN_NAMES"]

#: the filter's numbers in the order of :attr:`ComplementaryAttitudeFilter.gains`
GAIN_NAMES = ("dt", "k_p", "k_i", "k_heading", "k_heading_bias", "accel_gate", "bias_gate", "bias_max")



def _cross(a, b) -> tuple[float, float, float]:
    """a × b of two (3,) arrays, as Python floats."""
    a0, a1, a2 = a.tolist()
    b0, b1, b2 = b.tolist()
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


def _nonneg(value, what: str, positive: bool = False) -> float:
    """``value`` as a float, finite and ≥ 0 (> 0 with ``positive``) (:func:`wbc.geometry.check_scalar`)."""
    return check_scalar(value, what, "SI units, see the docstring", strict=positive)


class ComplementaryAttitudeFilter:
    """Mahony et al. 2008's explicit complementary filter (module docstring).

    Args:
        dt: sample period (s, > 0).
        k_p: proportional gain (rad/s, ≥ 0; the corner frequency of the tilt correction).
        k_i: integral (bias) gain (1/s², ≥ 0).
        accel_gate: |‖a‖ − g| (m/s²) above which the accelerometer is ignored for that sample (> 0).
        bias_max: bound on each component of the estimated gyro bias (rad/s, > 0).
        bias_gate: the bias is integrated (eq. 32b) only on samples where the accelerometer was used and
            ‖ω_mes‖ ≤ ``bias_gate`` (rad/s, > 0): impacts (a landing) give large, short, wrong corrections that
            would otherwise be integrated into the bias and then turn into a drift. The heading's bias term
            likewise needs ‖ω_yaw‖ ≤ ``bias_gate``.
        k_heading: k_H, the yaw gain of the heading directions (rad/s, ≥ 0).
        k_heading_bias: k_IH, their yaw-bias gain (1/s², ≥ 0).

    Attributes:
        rotation: (3, 3) R̂, world ← IMU. bias: (3,) b̂ (rad/s, IMU axes). omega: (3,) Ωʸ − b̂ of the last sample.
        gains: (9,) the numbers named in :data:`GAIN_NAMES`, in that order, kept equal to the attributes, then
            the gravity g (m/s²) that ``accel_gate`` compares ‖a‖ with.

    Raises:
        InvalidInputError: bad gains or period, at construction and on assignment.
    """

    def __init__(self, dt: float, *, k_p: float = 0.2, k_i: float = 0.01, accel_gate: float = 2.0,
                 bias_max: float = 0.05, bias_gate: float = 0.02, k_heading: float = 1.0,
                 k_heading_bias: float = 0.1):
        object.__setattr__(self, "gains", np.zeros(len(GAIN_NAMES) + 1))
        self.gains[-1] = GRAVITY
        self.dt = dt
        self.k_p, self.k_i, self.accel_gate, self.bias_max, self.bias_gate = k_p, k_i, accel_gate, bias_max, bias_gate
        self.k_heading, self.k_heading_bias = k_heading, k_heading_bias
        self.accel_used = False
        self.rotation = np.eye(3)
        self.bias = np.zeros(3)
        self.omega = np.zeros(3)
        self._wm = np.zeros(3)
        self._wh = np.zeros(3)
        self._w = np.zeros(3)

    def __setattr__(self, name, value):
        if name in ("dt", "accel_gate", "bias_max", "bias_gate"):
            value = _nonneg(value, name, positive=True)
        elif name in ("k_p", "k_i", "k_heading", "k_heading_bias"):
            value = _nonneg(value, name)
        object.__setattr__(self, name, value)
        if name in GAIN_NAMES:
            self.gains[GAIN_NAMES.index(name)] = value

    def reset(self, rotation, bias=None) -> None:
        """Start from ``rotation`` (3, 3, world ← IMU) and ``bias`` (3,) rad/s (default zeros).

        Raises:
            InvalidInputError: not a rotation matrix (‖RᵀR − I‖ > 1e-6) or a non-finite bias.
        """
        R = np.asarray(rotation, dtype=float)
        if R.shape != (3, 3) or not np.all(np.isfinite(R)) or np.abs(R.T @ R - np.eye(3)).max() > 1e-6 \
                or np.linalg.det(R) < 0:
            raise InvalidInputError(f"rotation must be a (3, 3) rotation matrix, got {R!r}")
        self.rotation = R.copy()
        b = np.zeros(3) if bias is None else np.asarray(bias, dtype=float)
        if b.shape != (3,) or not np.all(np.isfinite(b)):
            raise InvalidInputError(f"bias must be a finite (3,) vector (rad/s), got {bias!r}")
        self.bias = b.copy()

    def update(self, gyro: np.ndarray, accel: np.ndarray, directions=(), heading=()) -> np.ndarray:
        """One sample: gyro (3,) rad/s and accelerometer (3,) m/s² in IMU axes, plus optional extra
        ``directions`` (corrected with k_P, all axes) and ``heading`` directions (corrected with k_H about the
        vertical only): iterables of (v₀ (3,) world unit vector, v (3,) measured IMU-frame unit vector, weight k).

        Returns:
            R̂ (3, 3), world ← IMU (the :attr:`rotation` array, updated).
        """
        R = self.rotation
        a0, a1, a2 = accel.tolist()
        n = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
        self.accel_used = used = n > 0 and abs(n - GRAVITY) <= self.accel_gate
        m0 = m1 = m2 = 0.0  # ω_mes
        if used:  # v × v̂ with v = a/‖a‖, v̂ = R̂ᵀ e_z (the third row of R̂)
            a0, a1, a2 = a0 / n, a1 / n, a2 / n
            u0, u1, u2 = R[2].tolist()
            m0, m1, m2 = a1 * u2 - a2 * u1, a2 * u0 - a0 * u2, a0 * u1 - a1 * u0
        crosses = [(k, _cross(v, R.T @ v0)) for v0, v, k in directions]  # kᵢ, vᵢ × v̂ᵢ
        for k, (c0, c1, c2) in crosses:
            m0, m1, m2 = m0 + k * c0, m1 + k * c1, m2 + k * c2
        if heading is not directions:
            crosses = [(k, _cross(v, R.T @ v0)) for v0, v, k in heading]
        h0 = h1 = h2 = 0.0
        for k, (c0, c1, c2) in crosses:
            h0, h1, h2 = h0 + k * c0, h1 + k * c1, h2 + k * c2
        wm, wh = self._wm, self._wh
        wm[:] = (m0, m1, m2)
        wh[:] = (h0, h1, h2)
        up = R[2]  # u = R̂ᵀ e_z, the vertical in IMU axes
        wh[:] = (wh @ up) * up
        omega = self.omega
        np.subtract(gyro, self.bias, out=omega)
        w = self._w
        np.multiply(wm, self.k_p, out=w)
        w += omega  # (ω + k_P ω_mes + k_H ω_yaw) Δt, summed in that order
        w += self.k_heading * wh
        w *= self.dt
        object.__setattr__(self, "rotation", R @ pin.exp3(w))
        gate = self.bias_gate * self.bias_gate
        bias = self.bias
        if self.k_i and used and wm @ wm <= gate:
            bias -= self.k_i * self.dt * wm
        if self.k_heading_bias and wh @ wh <= gate:
            bias -= self.k_heading_bias * self.dt * wh
        np.maximum(bias, -self.bias_max, out=bias)  # clip to ±bias_max
        np.minimum(bias, self.bias_max, out=bias)
        return self.rotation
