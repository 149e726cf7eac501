"""A bound on the linear acceleration of a frame's origin, a constraint of the inverse-dynamics QP only
(x = [v̇; f]):

    −a_max − (J̇v)_lin ≤ J_lin v̇ ≤ a_max − (J̇v)_lin        (m/s², world axes at the frame origin)

p̈ = J_lin v̇ + (J̇v)_lin is the classical (not spatial) acceleration of the frame's origin in world axes: J_lin the
linear rows of the frame Jacobian in ``LOCAL_WORLD_ALIGNED`` (:meth:`wbc.configuration.Configuration.frame_jacobian`)
and (J̇v)_lin the linear part of the frame's classical acceleration at v̇ = 0
(:meth:`wbc.state.DynamicsState.frame_classical_drift`, ``pin.getFrameClassicalAcceleration``). The bound keeps a
hand carrying an open container, a tool or a camera from being jerked by the tasks' PD references, whatever the
task gains ask; with the contact forces left free it only shapes the motion. Add it with
``qp.add_constraint(FrameAccelerationBound(robot, frame, limit))``: its rows are written by
:meth:`~FrameAccelerationBound.write` before the compiled tick, which solves with them.
"""

from __future__ import annotations

import numpy as np

from wbc.constraints.base import IDConstraint
from wbc.exceptions import InvalidInputError

__all__ = ["FrameAccelerationBound"]


class FrameAccelerationBound(IDConstraint):
    """|p̈_i| ≤ a_max,i on the linear acceleration of a frame's origin, per world axis i = x, y, z (module
    docstring): three inequality rows J_lin v̇ (force columns zero), bounds ±a_max − (J̇v)_lin (m/s²).

    Args:
        robot: the robot (:class:`wbc.robot.Robot`).
        frame: name of the frame whose origin is bounded (e.g. ``robot.right_hand``).
        limit: a_max (m/s²), > 0: one number for the three axes, or (3,) per world axis x, y, z (``math.inf``
            leaves an axis free).
        name: label in reports and diagnoses (default ``"frame_acceleration:<frame>"``).
        relaxable: dropped by the relaxed solve when the full QP is infeasible with it (default True: a shaping
            bound rather than a hardware limit).

    Attributes:
        frame_id: Pinocchio frame index. limit: (3,) a_max (m/s²), a copy; change it with :meth:`set_limit`.

    Raises:
        UnknownFrameError: no such frame.
        InvalidInputError: a limit that is not one number or three, or not > 0 (NaN included).
    """

    kind = "inequality"
    dim = 3

    def __init__(self, robot, frame: str, limit, *, name: str | None = None, relaxable: bool = True):
        self.frame_id = robot.frame_id(frame)
        self.name = f"frame_acceleration:{frame}" if name is None else str(name)
        self.relaxable = bool(relaxable)
        self._limit = np.zeros(3)
        self.set_limit(limit)

    @property
    def limit(self) -> np.ndarray:
        """(3,) a_max per world axis (m/s²), a copy."""
        return self._limit.copy()

    def set_limit(self, limit) -> None:
        """Set a_max (m/s²): one number > 0 or (3,) of them (``math.inf``: free axis).

        Raises:
            InvalidInputError: another shape, or an entry not > 0 (NaN included).
        """
        try:
            value = np.broadcast_to(np.asarray(limit, dtype=float), (3,))
        except (TypeError, ValueError):
            raise InvalidInputError(f"{self.name}: limit must be one number or 3 (m/s², world x, y, z), "
                                    f"got {limit!r}") from None
        if not (value > 0).all():  # NaN fails too
            raise InvalidInputError(f"{self.name}: limit must be > 0 (m/s²; math.inf leaves an axis free), "
                                    f"got {value.tolist()}")
        self._limit[:] = value

    def write(self, ctx, C, l, u):
        state = ctx.state
        C[:, :ctx.nv] = state.frame_jacobian(self.frame_id)[0:3]
        C[:, ctx.nv:] = 0.0
        drift = state.frame_classical_drift(self.frame_id)[0:3]
        np.subtract(-self._limit, drift, out=l)
        np.subtract(self._limit, drift, out=u)
