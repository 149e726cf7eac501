"""Joint speed limits on the accelerations the inverse-dynamics QP commands, kept in every solve.

:class:`JointSpeedBounds`: for every 1-DoF joint with a URDF velocity limit q̇_max (scaled by ``1 − margin``),

    −s q̇_max ≤ v + v̇ dt ≤ s q̇_max,   s = 1 − margin,

i.e. v̇ ∈ [(−s q̇_max − v)/dt, (s q̇_max − v)/dt] (rad/s²): the velocity the commanded acceleration reaches at the
next tick is within the limit. It is the velocity term of the joint bounds (eq. 9 of
:mod:`wbc.formulations.acceleration`, del Prete 2018, IEEE RA-L 3(1):281–288, §III), which the relaxed solve drops
together with the position and viability terms; this constraint is **not relaxable**, so the relaxed solve
intersects its bounds back in (a joint above its limit is braked back under it, over the horizon below or at the
braking floor below when that asks for less).

**Speed horizon.** The one-tick bound is dead-beat: it lets a joint reach the bound in one tick. When the velocity
the controller reads lags the plant's (encoder differencing and low-pass filtering: ~1.5 ticks with
:class:`wbc.estimation.JointStateFilter`'s low-pass at 80 Hz and 2 ms; its optional g-h-k filter lags only
while the acceleration changes; a control delay of d ticks adds d), a dead-beat bound computed on the lagging
velocity overshoots the limit. With a horizon of h ticks the bound becomes

    −s q̇_max − v ≤ v̇ h dt ≤ s q̇_max − v,

i.e. the joint approaches the limit at most as a first-order system of time constant h dt, and a joint beyond the
bound is brought back under it at that rate too (asking a dead-beat return of a lagging measurement demands
braking torques beyond the drive's limits and makes the full QP infeasible). A first-order loop of
time constant τ with a pure delay θ does not overshoot for θ/τ ≤ 1/e, so h ≳ e × (lag in ticks) keeps the plant's
velocity under the bound (h = 4 for the 1.5-tick estimator lag, + 2 per tick of control delay:
:data:`wbc.sim.actuators.SPEED_HORIZON`). h = 1 is the dead-beat bound above.

**Braking floor.** A joint already past its bound (an impact, a foot rolling under a push) is asked to brake at
``braking`` a_brk (rad/s²) or more, not at (|v| − s q̇_max)/(h dt) however large that is: the bound is widened to
v̇ ≤ max((s q̇_max − v)/(h dt), −a_brk) and v̇ ≥ min((−s q̇_max − v)/(h dt), a_brk) — the full QP's own rule (eq. 9's
velocity term with its braking acceleration, :func:`~wbc.constraints.joint_acceleration_bounds.joint_bounds_kernel`).
With the full QP's a_brk and horizon these bounds contain the full QP's joint bounds, so the relaxed solve that keeps
them is a relaxation of the full QP (its hard set contains the full one's): the relaxed ID QP therefore applies its
full QP's current horizon and at most its current a_brk (``JointAccelerationLimits.speed_horizon`` and
``braking_acceleration``, assignable between ticks), not the values given here at construction. Without the floor
(a_brk = ∞), a joint at 2.8× its limit under a loaded sole asks more braking than the contact, friction and dynamics
rows allow: the relaxed set is empty while the full one is not (record 66).
"""

from __future__ import annotations

import numpy as np

from wbc.constraints.base import IDConstraint
from wbc.exceptions import InvalidInputError

__all__ = ["JointSpeedBounds", "speed_margins"]


def speed_margins(robot, margin) -> np.ndarray:
    """(nv − 6,) per-joint speed margins (fractions of the URDF limit kept free) from ``margin``: a number in
    [0, 1) for every actuated joint, or an (nv − 6,) array of them (a copy is returned).

    Raises:
        InvalidInputError: a margin outside [0, 1) or not finite, an array of the wrong size.
    """
    n = robot.model.nv - 6
    if isinstance(margin, bool):
        raise InvalidInputError(f"margin must be a number or an array of {n} numbers in [0, 1), got {margin!r}")
    try:
        m = np.array(margin, dtype=float)
    except (TypeError, ValueError):
        raise InvalidInputError(f"margin must be a number or an array of {n} numbers in [0, 1), got {margin!r}") \
            from None
    if m.ndim == 0:
        m = np.full(n, float(m))
    if m.shape != (n,):
        raise InvalidInputError(f"margin must be a number or an array of {n} numbers (one per actuated joint), got "
                                f"shape {m.shape}")
    if not (np.all(np.isfinite(m)) and np.all(m >= 0.0) and np.all(m < 1.0)):
        raise InvalidInputError(f"margin must be in [0, 1), got {margin!r}")
    return m


class JointSpeedBounds(IDConstraint):
    """Bounds on the joint accelerations that keep the next-tick joint speeds within the limits (module docstring).

    Args:
        robot: the robot (URDF velocity limits of its Pinocchio model; joints without a positive finite limit
            are unbounded).
        margin: fraction of the limit kept free, in [0, 1) (e.g. 0.05: bound at 95 % of the URDF limit): one
            number for every joint, or an (nv − 6,) array, one per actuated joint in Pinocchio's velocity order.
        horizon: h, ticks (≥ 1) over which the commanded acceleration may take a joint to the bound (module
            docstring); 1: the next tick's velocity is bounded.
        braking: a_brk (rad/s², > 0; ∞: none), the braking floor of a joint past its bound (module docstring): the
            full QP's ``braking_acceleration``.

    Raises:
        InvalidInputError: a margin outside [0, 1) or an array of the wrong size, horizon not a finite number ≥ 1,
            braking not a number > 0.
    """

    name = "joint_speed_limits"
    kind = "bounds"
    relaxable = False

    def __init__(self, robot, margin=0.0, horizon: float = 1.0, braking: float = np.inf):
        margins = speed_margins(robot, margin)
        if not (np.isfinite(horizon) and horizon >= 1.0):
            raise InvalidInputError(f"horizon must be a finite number of ticks ≥ 1, got {horizon!r}")
        self.horizon = float(horizon)
        self.braking = braking
        model = robot.model
        iv = [model.joints[j].idx_v for j in range(2, model.njoints)
              if model.joints[j].nv == 1 and 0 < model.velocityLimit[model.joints[j].idx_v] < np.inf]
        self.indices = np.array(iv, dtype=np.int64)
        self.dim = int(self.indices.size)
        self.vmax = (1.0 - margins[self.indices - 6]) * np.asarray(model.velocityLimit, dtype=float)[self.indices]
        self._lo = np.empty(self.dim)
        self._hi = np.empty(self.dim)

    @property
    def braking(self) -> float:
        """a_brk (rad/s², > 0; ∞: none): the braking floor of a joint past its bound (module docstring)."""
        return self._braking

    @braking.setter
    def braking(self, value) -> None:
        if isinstance(value, bool) or not isinstance(value, (int, float, np.floating)) or not value > 0:
            raise InvalidInputError(f"braking must be a number > 0 rad/s² (inf: no floor), got {value!r}")
        self._braking = float(value)

    def bounds(self, v: np.ndarray, dt: float, *, horizon: float | None = None,
               braking: float | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(lo, hi) (dim,) bounds on v̇[indices] (rad/s²) at the velocity ``v`` (nv,) for the period ``dt`` (s), with
        the braking floor (module docstring); ``horizon`` (ticks) and ``braking`` (rad/s²), when given, in place of
        :attr:`horizon` and :attr:`braking` (the relaxed ID QP passes its full QP's: module docstring). The
        arrays are reused across calls."""
        vj = v[self.indices]
        dth = dt * (self.horizon if horizon is None else horizon)
        floor = self.braking if braking is None else braking
        np.divide(-self.vmax - vj, dth, out=self._lo)
        np.divide(self.vmax - vj, dth, out=self._hi)
        np.minimum(self._lo, floor, out=self._lo)
        np.maximum(self._hi, -floor, out=self._hi)
        return self._lo, self._hi

    def intersect(self, v: np.ndarray, dt: float, lb: np.ndarray, ub: np.ndarray, *, horizon: float | None = None,
                  braking: float | None = None) -> None:
        """Tighten the QP's variable bounds ``lb``/``ub`` (n,) in place with these bounds (``horizon``, ``braking``:
        as in :meth:`bounds`)."""
        lo, hi = self.bounds(v, dt, horizon=horizon, braking=braking)
        idx = self.indices
        lb[idx] = np.maximum(lb[idx], lo)
        ub[idx] = np.minimum(ub[idx], hi)

    def write(self, ctx, _, lb, ub):
        lo, hi = self.bounds(ctx.state.v, ctx.dt)
        lb[:] = lo
        ub[:] = hi
