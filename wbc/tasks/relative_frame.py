"""Relative frame pose task: drive the placement of a frame *in another frame* (e.g. a hand in the torso frame).

With oMf, oMr the world placements of the frame f and the reference frame r, the relative placement is
rMf = oMr⁻¹ oMf. Its body velocity (f axes) is

    ν_rel = ν_f − Ad(fMr) ν_r = (J_f − Ad(fMr) J_r) v          (J_f, J_r: Pinocchio LOCAL frame Jacobians)

since oMf = oMr rMf ⇒ ν_f = Ad(fMr) ν_r + ν_rel. The error and Jacobian are then those of
:mod:`wbc.tasks.frame` applied to rMf: position rMf.p − p* in the reference frame's axes (m), orientation
log₃(R*ᵀ R_rel) in the target's axes (rad); J = [R_rel J_rel,lin ; Jlog₃(R*ᵀR_rel) J_rel,ang] (6, nv).

Drift (acceleration level): with d/dt Ad(fMr) = −ad(ν_rel) Ad(fMr) (fMr = rMf⁻¹, rMḟ = rMf [ν_rel]), the body
acceleration of rMf at v̇ = 0 is

    α₀ = a_f − Ad(fMr) a_r + ν_rel × (Ad(fMr) ν_r)                (a_f, a_r: LOCAL frame accelerations at v̇ = 0)

and, with ν_rel = (v, ω), the position rows drift by R_rel (α₀,lin + ω × v) (the classical acceleration) and the
orientation rows by Jlog₃ α₀,ang + Hlog₃(R*ᵀR_rel, ω) ω (:func:`wbc.tasks.frame.frame_drift`).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from wbc.configuration import LOCAL, Configuration
from wbc.tasks.frame import FrameTask, frame_drift, pose_error_and_jacobian

__all__ = ["RelativeFrameTask"]


class RelativeFrameTask(FrameTask):
    """Track the placement of ``frame`` expressed in ``reference_frame``, with per-axis weights.

    Args:
        robot: the robot (frame names are resolved on ``robot.model``).
        frame: the driven frame f (e.g. ``robot.right_hand``).
        reference_frame: the frame r the target is expressed in (e.g. ``robot.torso``).
        position_weight: scalar or (3,) weights of the position rows (reference frame axes); 0 drops a row.
        orientation_weight: scalar or (3,) weights of the orientation rows (target axes); 0 drops a row.
        gain: K (1/s).
        name: label (default ``"<frame>@<reference_frame>"``).

    ``set_target(pose_in_reference, velocity=None)`` (inherited): pose rMf* as pin.SE3 or (4, 4); velocity (6,)
    = rate of the relative position (m/s) and relative angular velocity (rad/s), both in the reference frame's
    axes.

    Raises:
        UnknownFrameError: no such frame.
        InvalidTargetError: every weight is zero.
        InvalidInputError: bad weights or gain.
    """

    def __init__(self, robot, frame: str, reference_frame: str, *, position_weight=1.0, orientation_weight=1.0,
                 gain: float = 100.0, name: str | None = None):
        self.reference_frame = reference_frame
        self.reference_id = robot.frame_id(reference_frame)
        super().__init__(robot, frame, position_weight=position_weight, orientation_weight=orientation_weight,
                         gain=gain, name=name or f"{frame}@{reference_frame}")

    def relative_placement(self, config: Configuration) -> pin.SE3:
        """rMf = oMr⁻¹ oMf at ``config`` (translation in m)."""
        return config.data.oMf[self.reference_id].actInv(config.data.oMf[self.frame_id])

    def set_target_from_configuration(self, config: Configuration) -> None:
        """Target = the current relative placement, zero velocity."""
        self.set_target(self.relative_placement(config))

    def compute(self, config: Configuration):
        rMf = self.relative_placement(config)
        j_rel = config.frame_jacobian(self.frame_id, LOCAL) - rMf.inverse().toActionMatrix() @ config.frame_jacobian(
            self.reference_id, LOCAL)
        error, jac = pose_error_and_jacobian(rMf, j_rel, self.target)
        if self._all_rows:
            return error, jac
        return error[self.rows], jac[self.rows]

    def drift(self, state) -> np.ndarray:
        """(dim,) J̇ v (module docstring): m/s² (position rows, reference frame axes), rad/s² (orientation rows)."""
        model, data = state.model, state.data
        rMf = self.relative_placement(state)
        fMr = rMf.inverse()
        nu_r = pin.getFrameVelocity(model, data, self.reference_id, LOCAL)
        nu_rel = pin.getFrameVelocity(model, data, self.frame_id, LOCAL) - fMr.act(nu_r)
        acc = (pin.getFrameAcceleration(model, data, self.frame_id, LOCAL)
               - fMr.act(pin.getFrameAcceleration(model, data, self.reference_id, LOCAL))
               + nu_rel.cross(fMr.act(nu_r)))
        return frame_drift(rMf.rotation, self._target_rot_t, nu_rel, acc, self.rows)
