"""Flat sole contacts modelled by 4 corner point forces.

A :class:`SoleContact` owns 12 QP variables: the forces f_i = (f_x, f_y, f_z) (N) at the 4 corners c_i of the
sole rectangle, **expressed in the sole frame** (z normal to the sole, pointing out of the ground into the foot).
Per corner:

* unilaterality and bounds: ``f_min ≤ f_z ≤ f_max`` (box bounds of the QP);
* linearised friction cone, the pyramid inscribed in the cone of coefficient μ:
  ``|f_x| ≤ μ/√2 f_z`` and ``|f_y| ≤ μ/√2 f_z`` (4 linear rows; inscribed, so every force it admits lies in the
  true cone).

The centre of pressure (CoP) of the foot is ``Σ f_z,i c_i / Σ f_z,i``, a convex combination of the corners
since every f_z,i ≥ 0: **the CoP is inside the sole rectangle by construction**, and no explicit CoP row is
needed. The yaw torque is likewise bounded by the corner friction pyramids.

The wrench that the corner forces exert on the foot at the sole origin, **in the sole frame** (LOCAL), is
``w = G f`` with the constant (6, 12) map, for corner i at c_i (sole frame),

    G[:, 3i:3i+3] = [ I₃ ; [c_i]× ]

so their generalized force is ``J_cᵀ f = J_soleᵀ G f`` with J_sole the (6, nv) LOCAL frame Jacobian (equal to
Σ_i J_iᵀ f_i, J_i the LOCAL corner point Jacobians). In world axes the wrench is ``blockdiag(R, R) G f``.

While the contact is **active** the sole does not accelerate:
``J_sole v̇ + J̇_sole v = −K_d J_sole v − K_p e`` (classical acceleration, LOCAL), with e the (6,) drift of the
sole from its placement when the contact was activated, ``log₆(oMf_ref⁻¹ oMf)`` (sole frame) — a stabilising term against the numerical drift of a rigid contact (K_p = 0 by default: MuJoCo's
soft contact itself keeps the foot on the floor). While **inactive** its forces are bounded to 0.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from wbc.state import DynamicsState
from wbc.exceptions import InvalidInputError
from wbc.robot import Robot

__all__ = ["SoleContact"]


class SoleContact:
    """A rectangular sole in flat contact through 4 corner forces (module docstring).

    Args:
        robot: the robot.
        frame: sole frame name (z up out of the ground, rectangle centred on it).
        length, width: sole rectangle (m); default the robot's ``sole_length``/``sole_width``.
        mu: friction coefficient (> 0) of the cone the pyramid is inscribed in.
        f_min: minimum normal force per corner (N, ≥ 0).
        f_max: maximum normal force per corner (N, > f_min; default inf).
        kp, kd: stabilising gains of the contact acceleration constraint (1/s², 1/s).
        name: label (default: the frame name).

    Raises:
        UnknownFrameError: no such frame. InvalidInputError: bad numbers.
    """

    n_forces = 12

    def __init__(self, robot: Robot, frame: str, *, length: float | None = None, width: float | None = None,
                 mu: float = 0.7, f_min: float = 0.0, f_max: float = math.inf, kp: float = 0.0,
                 kd: float = 20.0, name: str | None = None):
        self.frame = frame
        self.frame_id = robot.frame_id(frame)
        self.name = name or frame
        length = robot.sole_length if length is None else float(length)
        width = robot.sole_width if width is None else float(width)
        if not (length > 0 and width > 0):
            raise InvalidInputError(f"sole size must be positive, got {length} x {width} m")
        if not (np.isfinite(mu) and mu > 0):
            raise InvalidInputError(f"friction coefficient mu must be finite and > 0, got {mu!r}")
        if not (np.isfinite(f_min) and f_min >= 0 and f_max > f_min):
            raise InvalidInputError(f"need 0 ≤ f_min < f_max (N), got f_min={f_min!r}, f_max={f_max!r}")
        for g, what in ((kp, "kp"), (kd, "kd")):
            if not (np.isfinite(g) and g >= 0):
                raise InvalidInputError(f"contact {what} must be finite and ≥ 0, got {g!r}")
        a, b = 0.5 * length, 0.5 * width
        self.corners = np.array([[a, b, 0.0], [-a, b, 0.0], [-a, -b, 0.0], [a, -b, 0.0]])
        self.mu = float(mu)
        self.f_min = float(f_min)
        self.f_max = float(f_max)
        self.kp, self.kd = float(kp), float(kd)
        self.active = True
        self.reference: pin.SE3 | None = None
        mu_in = self.mu / math.sqrt(2.0)
        rows = []
        for i in range(4):
            for axis in (0, 1):
                for sign in (1.0, -1.0):
                    r = np.zeros(12)
                    r[3 * i + axis] = sign
                    r[3 * i + 2] = -mu_in
                    rows.append(r)
        #: (16, 12) friction rows: ``friction_matrix @ f ≤ 0``.
        self.friction_matrix = np.array(rows)
        self._G = np.zeros((6, 12))
        for i, c in enumerate(self.corners):
            self._G[0:3, 3 * i:3 * i + 3] = np.eye(3)
            self._G[3:6, 3 * i:3 * i + 3] = pin.skew(c)

    # -- switching -------------------------------------------------------------------------------------------
    def activate(self, state: DynamicsState | None = None) -> None:
        """Make the contact active; its reference placement is the sole's current placement in ``state``."""
        self.active = True
        self.reference = None if state is None else state.data.oMf[self.frame_id].copy()

    def deactivate(self) -> None:
        """Release the contact: its forces are bounded to zero and its acceleration is free."""
        self.active = False
        self.reference = None

    # -- per tick --------------------------------------------------------------------------------------------
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """(lb (12,), ub (12,)) of the corner forces (N): tangential free, normal in [f_min, f_max]; zero when
        inactive."""
        lb = np.full(12, -np.inf)
        ub = np.full(12, np.inf)
        if self.active:
            lb[2::3], ub[2::3] = self.f_min, self.f_max
        else:
            lb[:], ub[:] = 0.0, 0.0
        return lb, ub

    def force_map(self, state: DynamicsState | None = None) -> np.ndarray:
        """(6, 12) constant G: corner forces (sole frame) → wrench at the sole origin, sole frame."""
        return self._G

    def jacobian(self, state: DynamicsState) -> np.ndarray:
        """(6, nv) sole frame Jacobian, LOCAL (sole axes)."""
        return state.frame_jacobian(self.frame_id, pin.LOCAL)

    def acceleration_target(self, state: DynamicsState, J: np.ndarray) -> np.ndarray:
        """(6,) right-hand side b of ``J v̇ = b`` (LOCAL): −J̇v − K_d J v − K_p e (module docstring)."""
        b = self.acceleration_offset(state)
        b -= self.kd * (J @ state.v)
        return b

    def acceleration_offset(self, state: DynamicsState) -> np.ndarray:
        """(6,) the velocity-free part −J̇v − K_p e of :meth:`acceleration_target` (LOCAL; m/s², rad/s²), a new
        array."""
        b = -pin.getFrameClassicalAcceleration(state.model, state.data, self.frame_id, pin.LOCAL).vector
        if self.kp > 0 and self.reference is not None:
            b -= self.kp * pin.log6(self.reference.actInv(state.data.oMf[self.frame_id])).vector
        return b

    def world_wrench(self, state: DynamicsState, forces: np.ndarray) -> np.ndarray:
        """(6,) wrench (N, N·m) at the sole origin in world axes of corner forces (12,) (sole frame)."""
        w = self._G @ forces
        R = state.data.oMf[self.frame_id].rotation
        return np.concatenate([R @ w[:3], R @ w[3:]])

    def cop(self, forces: np.ndarray) -> np.ndarray | None:
        """(2,) centre of pressure in the sole frame (m) of corner forces (12,), None when unloaded."""
        fz = forces[2::3]
        total = float(fz.sum())
        if total <= 1e-9:
            return None
        return (fz @ self.corners[:, :2]) / total
