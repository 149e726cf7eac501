"""Base orientation from a gyroscope and an accelerometer: the explicit complementary filter on SO(3) with gyro
bias estimation (Mahony, Hamel, Pflimlin 2008, "Nonlinear complementary filters on the special orthogonal group",
IEEE Trans. Automatic Control 53(5), Sec. V-C, eq. 32).

With the IMU frame B, the estimate R̂ = ᴬR̂_B (world ← IMU), gyro reading Ωʸ (rad/s, B axes), inertial reference
directions v₀ᵢ (world) measured in B as vᵢ (unit vectors) with weights kᵢ:

    v̂ᵢ     = R̂ᵀ v₀ᵢ                                (the prediction of the measured direction)
    ω_mes  = Σᵢ kᵢ vᵢ × v̂ᵢ                          (eq. 32c)
    dR̂/dt  = R̂ (Ωʸ − b̂ + k_P ω_mes)×               (eq. 32a)
    db̂/dt  = −k_I ω_mes                             (eq. 32b)

integrated once per sample with the exponential map, R̂ ← R̂ exp((Ωʸ − b̂ + k_P ω_mes + k_H ω_yaw) Δt) (Pinocchio's
``exp3`` formula, :func:`wbc.estimation.kernels.exp3`; R̂ stays a rotation).

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

from wbc.constants import GRAVITY
from wbc.estimation.kernels import attitude_step, check_storage, warm_up
from wbc.exceptions import InvalidInputError
from wbc.geometry import check_scalar

__all__ = ["ComplementaryAttitudeFilter"]


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
        rotation: (3, 3) R̂, world ← IMU. bias: (3,) b̂ (rad/s, IMU axes). omega: (3,) Ωʸ − b̂ of the last sample
            (arrays updated in place).

    Raises:
        InvalidInputError: bad gains or period, at construction and on assignment.
    """

    _PARAMS = ("dt", "k_p", "k_i", "accel_gate", "bias_max", "bias_gate", "k_heading", "k_heading_bias")

    def __init__(self, dt: float, *, k_p: float = 0.2, k_i: float = 0.01, accel_gate: float = 2.0,
                 bias_max: float = 0.05, bias_gate: float = 0.02, k_heading: float = 1.0,
                 k_heading_bias: float = 0.1):
        # the compiled filter's state and parameters (wbc.estimation.kernels layouts)
        object.__setattr__(self, "_params", np.zeros(len(self._PARAMS)))
        object.__setattr__(self, "_state", np.zeros(24))
        self.dt = dt
        self.k_p, self.k_i, self.accel_gate, self.bias_max, self.bias_gate = k_p, k_i, accel_gate, bias_max, bias_gate
        self.k_heading, self.k_heading_bias = k_heading, k_heading_bias
        self.accel_used = False
        st = self._state
        self.rotation, self.bias, self.omega = st[0:9].reshape(3, 3), st[9:12], st[12:15]
        self.rotation[:] = np.eye(3)
        self._no_dirs = np.zeros((0, 7))
        warm_up()

    def __setattr__(self, name, value):
        if name in ("dt", "accel_gate", "bias_max", "bias_gate"):
            value = _nonneg(value, name, positive=True)
        elif name in ("k_p", "k_i", "k_heading", "k_heading_bias"):
            value = _nonneg(value, name)
        if name in self._PARAMS:
            self._params[self._PARAMS.index(name)] = value
        object.__setattr__(self, name, value)

    @property
    def storage(self) -> tuple[np.ndarray, np.ndarray]:
        """(state (24,), parameters (8,)): the arrays the compiled update (``wbc.estimation.kernels.attitude_step``)
        reads and writes; :attr:`rotation`, :attr:`bias` and :attr:`omega` are views of the state."""
        return self._state, self._params

    def use_storage(self, state: np.ndarray, params: np.ndarray) -> None:
        """Move the filter's state and parameters into ``state`` (24,) and ``params`` (8,) float arrays (e.g. views
        of a caller's buffer that one compiled update reads in place): their values are copied there and
        :attr:`rotation`, :attr:`bias`, :attr:`omega` become views of ``state``.

        Raises:
            InvalidInputError: not float64 arrays of those shapes.
        """
        check_storage(state, params, self._state, self._params)
        state[:], params[:] = self._state, self._params
        object.__setattr__(self, "_state", state)
        object.__setattr__(self, "_params", params)
        self.rotation, self.bias, self.omega = state[0:9].reshape(3, 3), state[9:12], state[12:15]

    def reset(self, rotation, bias=None) -> None:
        """Start from ``rotation`` (3, 3, world ← IMU) and ``bias`` (3,) rad/s (default zeros).

        Raises:
            InvalidInputError: not a rotation matrix (‖RᵀR − I‖ > 1e-6) or a non-finite bias.
        """
        R = np.asarray(rotation, dtype=float)
        if R.shape != (3, 3) or not np.all(np.isfinite(R)) or np.abs(R.T @ R - np.eye(3)).max() > 1e-6 \
                or np.linalg.det(R) < 0:
            raise InvalidInputError(f"rotation must be a (3, 3) rotation matrix, got {R!r}")
        b = np.zeros(3) if bias is None else np.asarray(bias, dtype=float)
        if b.shape != (3,) or not np.all(np.isfinite(b)):
            raise InvalidInputError(f"bias must be a finite (3,) vector (rad/s), got {bias!r}")
        self.rotation[:] = R
        self.bias[:] = b

    def update(self, gyro: np.ndarray, accel: np.ndarray, directions=(), heading=()) -> np.ndarray:
        """One sample: gyro (3,) rad/s and accelerometer (3,) m/s² in IMU axes, plus optional extra
        ``directions`` (corrected with k_P, all axes) and ``heading`` directions (corrected with k_H about the
        vertical only): iterables of (v₀ (3,) world unit vector, v (3,) measured IMU-frame unit vector, weight k).

        Returns:
            R̂ (3, 3), world ← IMU (the :attr:`rotation` array, updated).
        """
        dirs = self._rows(directions)
        heads = dirs if heading is directions else self._rows(heading)
        self.accel_used = attitude_step(self._state, self._params, np.asarray(gyro, dtype=float),
                                        np.asarray(accel, dtype=float), dirs, heads)
        return self.rotation

    def _rows(self, directions) -> np.ndarray:
        """(k, 7) rows (v₀, v, weight) of an iterable of (v₀, v, k)."""
        rows = [np.r_[v0, v, k] for v0, v, k in directions]
        return np.array(rows, dtype=float) if rows else self._no_dirs
