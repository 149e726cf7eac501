"""Flat sole contacts modelled by 4 corner point forces.

A :class:`SoleContact` owns 12 QP variables: the forces f_i = (f_x, f_y, f_z) (N) at the 4 corners c_i of the
sole rectangle, **expressed in the sole frame** (z normal to the sole, pointing out of the ground into the foot).
Per corner:

* unilaterality and bounds: ``min(f_min, f_max) ≤ f_z ≤ f_max`` (box bounds of the QP: a maximum lowered below
  the nominal minimum, as when a foot is unloaded, lowers the minimum with it, so the bounds never cross);
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
from wbc.geometry import check_scalar
from wbc.robot import Robot
from wbc.tasks.base import ValidatedAttribute

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

    The parameters ``mu``, ``f_min``, ``f_max``, ``kp``, ``kd`` may be assigned later (validated on assignment,
    used from the next tick on); the sole size (``corners``) is read-only.
        kp, kd: stabilising gains of the contact acceleration constraint (1/s², 1/s).
        name: label (default: the frame name).

    Raises:
        UnknownFrameError: no such frame. InvalidInputError: bad numbers (at construction or assignment).
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
        self._half = (a, b)
        corners = np.array([[a, b, 0.0], [-a, b, 0.0], [-a, -b, 0.0], [a, -b, 0.0]])
        corners.setflags(write=False)
        self._corners = corners
        self._support = (-a, a, -b, b)
        #: (16, 12) friction rows: ``friction_matrix @ f ≤ 0`` (rewritten in place when :attr:`mu` is assigned).
        self.friction_matrix = np.zeros((16, 12))
        self._mu = math.nan
        self.mu = mu
        self._f_min, self._f_max = float(f_min), float(f_max)
        self.kp, self.kd = kp, kd
        self.active = True
        self.reference: pin.SE3 | None = None
        self._G = np.zeros((6, 12))
        for i, c in enumerate(self.corners):
            self._G[0:3, 3 * i:3 * i + 3] = np.eye(3)
            self._G[3:6, 3 * i:3 * i + 3] = pin.skew(c)
        self._G.setflags(write=False)

    # -- parameters (validated on assignment; the QP reads them every tick) ------------------------------------
    @property
    def corners(self) -> np.ndarray:
        """(4, 3) corners of the contact rectangle in the sole frame (m), read-only: the sole rectangle, or the
        part of it set by :meth:`set_support`."""
        return self._corners

    @property
    def half_size(self) -> tuple[float, float]:
        """(a, b): half length and half width (m) of the whole sole rectangle."""
        return self._half

    @property
    def support(self) -> tuple[float, float, float, float]:
        """(x_lo, x_hi, y_lo, y_hi) (m, sole frame) of the contact rectangle: the whole sole unless cut by
        :meth:`set_support`."""
        return self._support

    def set_support(self, x_lo: float, x_hi: float, y_lo: float, y_hi: float) -> None:
        """Confine the corner forces (and so the CoP) to the rectangle [x_lo, x_hi] × [y_lo, y_hi] (m, sole frame),
        clipped to the sole: a partial foothold, the sole supported by only a part of its area (Wiedebach et al.,
        "Walking on partial footholds including line contacts with the humanoid robot Atlas", Humanoids 2016,
        Sec. III: the contact points of the QP are the vertices of the supported polygon). The 4 corner forces
        act at that rectangle's corners: :attr:`corners` and :meth:`force_map` change in place (read by the QP on
        its next tick). :meth:`reset_support` restores the whole sole.

        Raises:
            InvalidInputError: a bound not finite, or an empty rectangle (x_lo ≥ x_hi or y_lo ≥ y_hi after
                clipping).
        """
        a, b = self._half
        vals = [float(x_lo), float(x_hi), float(y_lo), float(y_hi)]
        if not all(math.isfinite(x) for x in vals):
            raise InvalidInputError(f"support bounds must be finite (m), got {vals!r}")
        x0, x1 = max(vals[0], -a), min(vals[1], a)
        y0, y1 = max(vals[2], -b), min(vals[3], b)
        if not (x0 < x1 and y0 < y1):
            raise InvalidInputError(f"empty support rectangle [{x0}, {x1}] x [{y0}, {y1}] m")
        self._set_rectangle(x0, x1, y0, y1)

    def reset_support(self) -> None:
        """The contact rectangle is the whole sole again (undoes :meth:`set_support`)."""
        a, b = self._half
        if self._support != (-a, a, -b, b):
            self._set_rectangle(-a, a, -b, b)

    def _set_rectangle(self, x0: float, x1: float, y0: float, y1: float) -> None:
        c = self._corners
        c.setflags(write=True)
        c[:, :2] = [[x1, y1], [x0, y1], [x0, y0], [x1, y0]]
        c.setflags(write=False)
        G = self._G
        G.setflags(write=True)
        for i in range(4):
            G[3:6, 3 * i:3 * i + 3] = pin.skew(c[i])
        G.setflags(write=False)
        self._support = (x0, x1, y0, y1)

    @corners.setter
    def corners(self, value) -> None:
        raise InvalidInputError("SoleContact.corners is read-only (the sole size is fixed at construction): "
                                "create a new SoleContact with the length and width wanted")

    @property
    def mu(self) -> float:
        """Friction coefficient (> 0, finite) of the cone the pyramids are inscribed in. Assigning it rewrites
        :attr:`friction_matrix` in place; the QP rewrites its friction rows on the next tick.

        Raises:
            InvalidInputError: on assignment of a value that is not finite and > 0.
        """
        return self._mu

    @mu.setter
    def mu(self, value) -> None:
        mu = check_scalar(value, "friction coefficient mu", "dimensionless", strict=True)
        mu_in = mu / math.sqrt(2.0)
        F = self.friction_matrix
        F.fill(0.0)
        r = 0
        for i in range(4):
            for axis in (0, 1):
                for sign in (1.0, -1.0):
                    F[r, 3 * i + axis] = sign
                    F[r, 3 * i + 2] = -mu_in
                    r += 1
        self._mu = mu

    @staticmethod
    def _force(value, what: str, *, allow_inf: bool) -> float:
        try:
            f = float(value)
        except (TypeError, ValueError):
            raise InvalidInputError(f"{what} must be a number of newtons ≥ 0, got {value!r}") from None
        if math.isnan(f) or f < 0 or (math.isinf(f) and not allow_inf):
            raise InvalidInputError(f"{what} must be {'≥ 0 (inf allowed)' if allow_inf else 'finite and ≥ 0'} (N), "
                                    f"got {value!r}")
        return f

    @property
    def f_min(self) -> float:
        """Nominal minimum normal force per corner (N, finite, ≥ 0). The bound used is
        :attr:`normal_force_bounds`.

        Raises:
            InvalidInputError: on assignment of a NaN, negative or infinite value.
        """
        return self._f_min

    @f_min.setter
    def f_min(self, value) -> None:
        self._f_min = self._force(value, "f_min", allow_inf=False)

    @property
    def f_max(self) -> float:
        """Maximum normal force per corner (N, ≥ 0, inf for none). Lowering it below :attr:`f_min` (a foot being
        unloaded) lowers the lower bound with it (:attr:`normal_force_bounds`).

        Raises:
            InvalidInputError: on assignment of a NaN or negative value.
        """
        return self._f_max

    @f_max.setter
    def f_max(self, value) -> None:
        self._f_max = self._force(value, "f_max", allow_inf=True)

    @property
    def normal_force_bounds(self) -> tuple[float, float]:
        """(lo, hi) per-corner normal-force bounds of an active contact (N): (min(f_min, f_max), f_max) — lo ≤ hi
        always, so ramping f_max down to 0 (unloading) never makes the bounds cross."""
        return min(self._f_min, self._f_max), self._f_max

    kp = ValidatedAttribute(lambda contact, kp: check_scalar(kp, "contact kp", "1/s²"),
                            "Stabilising stiffness of the contact acceleration constraint (1/s², finite, ≥ 0; "
                            "raises InvalidInputError on assignment of anything else).")
    kd = ValidatedAttribute(lambda contact, kd: check_scalar(kd, "contact kd", "1/s"),
                            "Stabilising damping of the contact acceleration constraint (1/s, finite, ≥ 0; "
                            "raises InvalidInputError on assignment of anything else).")

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
            lb[2::3], ub[2::3] = self.normal_force_bounds
        else:
            lb[:], ub[:] = 0.0, 0.0
        return lb, ub

    def force_map(self, state: DynamicsState | None = None) -> np.ndarray:
        """(6, 12) G: corner forces (sole frame, N) → wrench at the sole origin (sole frame, N and N·m), read-only;
        constant unless :meth:`set_support` or :meth:`reset_support` moves the corners (rewritten in place)."""
        return self._G

    def jacobian(self, state: DynamicsState) -> np.ndarray:
        """(6, nv) sole frame Jacobian, LOCAL (sole axes)."""
        return state.frame_jacobian(self.frame_id, pin.LOCAL)

    def acceleration_offset(self, state: DynamicsState) -> np.ndarray:
        """(6,) the velocity-free part −J̇v − K_p e of the right-hand side b = −J̇v − K_d J v − K_p e of ``J v̇ = b``
        (module docstring; LOCAL; m/s², rad/s²), a new array; the ID QP adds −K_d J v
        (:func:`wbc.constraints.contact_acceleration.contact_acceleration_rows`)."""
        model, data = state.model, state.kinematics_data  # (LOCAL: from the joint's motion, no frame placement)
        b = -pin.getFrameClassicalAcceleration(model, data, self.frame_id, pin.LOCAL).vector
        if self.kp > 0 and self.reference is not None:
            b -= self.kp * pin.log6(self.reference.actInv(pin.updateFramePlacement(model, data, self.frame_id))).vector
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
