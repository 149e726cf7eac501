"""Contact constraint: a frame in rigid contact does not move.

Hard equality on its 6-D velocity, with drift correction towards the pose recorded at contact:
    J v = −K e,   e = frame pose error w.r.t. the contact placement (see :mod:`wbc.tasks.frame`).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from wbc.configuration import Configuration
from wbc.constraints.base import EqualityConstraint
from wbc.exceptions import InvalidInputError
from wbc.tasks.frame import as_se3, frame_error_and_jacobian

__all__ = ["ContactConstraint"]


class ContactConstraint(EqualityConstraint):
    """Keep a frame (e.g. a stance sole) fixed at its contact placement.

    Args:
        robot: the robot.
        frame: frame name (e.g. ``robot.left_sole``).
        gain: drift-correction gain K (1/s), 0 ≤ K ≤ 1/dt.
        name: label in reports (default ``contact:<frame>``).

    Raises:
        UnknownFrameError: no such frame.
    """

    dim = 6

    def __init__(self, robot, frame: str, *, gain: float = 100.0, name: str | None = None):
        if not (np.isfinite(gain) and gain >= 0):
            raise InvalidInputError(f"contact gain must be finite and ≥ 0 (1/s), got {gain!r}")
        self.frame = frame
        self.frame_id = robot.frame_id(frame)
        self.gain = float(gain)
        self.name = name or f"contact:{frame}"
        self.placement = pin.SE3.Identity()

    def set_placement(self, pose) -> None:
        """Contact placement (pin.SE3 or (4,4), world) the frame must hold."""
        self.placement = as_se3(pose, f"placement of {self.name}").copy()

    def set_placement_from_configuration(self, config: Configuration) -> None:
        """Contact placement = the frame's current placement."""
        self.placement = config.data.oMf[self.frame_id].copy()

    def compute_error(self, config: Configuration) -> np.ndarray:
        """(6,) pose error of the frame w.r.t. its contact placement (m, rad)."""
        return frame_error_and_jacobian(config, self.frame_id, self.placement)[0]

    def compute(self, config: Configuration, dt: float) -> tuple[np.ndarray, np.ndarray]:
        error, jac = frame_error_and_jacobian(config, self.frame_id, self.placement)
        return jac, -min(self.gain, 1.0 / dt) * error
