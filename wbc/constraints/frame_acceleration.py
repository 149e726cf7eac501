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

from wbc.constraints.base import AxisBound

__all__ = ["FrameAccelerationBound"]


class FrameAccelerationBound(AxisBound):
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
        frame_id: Pinocchio frame index. limit: (3,) a_max (m/s²), a copy; assign it or call
            :meth:`~wbc.constraints.base.AxisBound.set_limit`.

    Raises:
        UnknownFrameError: no such frame.
        InvalidInputError: a limit that is not one number or three, or not > 0 (NaN included).
    """

    unit = "m/s²"

    def __init__(self, robot, frame: str, limit, *, name: str | None = None, relaxable: bool = True):
        self.frame_id = robot.frame_id(frame)
        super().__init__(limit, name=f"frame_acceleration:{frame}" if name is None else name, relaxable=relaxable)

    def axis_rows(self, state):
        return state.frame_jacobian(self.frame_id)[0:3], state.frame_classical_drift(self.frame_id)[0:3]
