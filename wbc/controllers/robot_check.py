"""Inputs of a kinematic controller checked against its robot: a task or constraint built for another robot is
refused with a typed error when added (:class:`RobotCheck`), and joints whose range has zero width are found at
build (:func:`zero_range_joints`)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from wbc.constraints.limits import JointPositionLimit, JointVelocityLimit, bounded_joints
from wbc.constraints.task import TaskConstraint
from wbc.exceptions import InvalidInputError

__all__ = ["RobotCheck", "zero_range_joints"]


class RobotCheck:
    """Refuses a task or constraint built for another robot than ``model``'s: another model (other nq, nv or joint
    names), a frame id whose name differs in this model, a Jacobian or an index set sized for another nv.

    Args:
        model: the controller's Pinocchio model.
        remember: most objects remembered as checked (by identity): an object added again (a sole's contact or
            swing task at a support switch) is not checked again.
    """

    def __init__(self, model: pin.Model, remember: int = 64):
        self.model = model
        self.remember = remember
        self._checked: dict[int, object] = {}

    def check(self, obj, what: str) -> None:
        """Check ``obj`` (a task or constraint; ``what`` names its kind in the message) unless it was checked
        already.

        Raises:
            InvalidInputError: ``obj`` was built for another robot (the message names why and this robot).
        """
        if self._checked.get(id(obj)) is not obj:
            self._check_model(obj, what)
            if len(self._checked) >= self.remember:
                self._checked.clear()
            self._checked[id(obj)] = obj

    def _check_model(self, obj, what: str) -> None:
        model = self.model
        name = getattr(obj, "name", type(obj).__name__)
        here = f"this controller's robot is {model.name!r} (nq {model.nq}, nv {model.nv})"

        def foreign(why: str) -> InvalidInputError:
            return InvalidInputError(f"{what} {name!r} was built for another robot ({why}); {here}: build it "
                                     f"with the controller's robot")

        if isinstance(obj, TaskConstraint):
            self._check_model(obj.task, what)
        other = getattr(obj, "model", None)
        if other is None and getattr(obj, "robot", None) is not None:
            other = getattr(obj.robot, "model", None)
        if isinstance(other, pin.Model) and other is not model and (
                other.nq != model.nq or other.nv != model.nv or list(other.names) != list(model.names)):
            raise foreign(f"model {other.name!r}, nq {other.nq}, nv {other.nv}")
        for id_attr, name_attr in (("frame_id", "frame"), ("reference_id", "reference_frame")):
            fid, fname = getattr(obj, id_attr, None), getattr(obj, name_attr, None)
            if isinstance(fid, (int, np.integer)) and isinstance(fname, str) and (
                    not 0 <= fid < model.nframes or model.frames[fid].name != fname):
                raise foreign(f"its frame {fname!r} has id {fid}, which is "
                              + (f"{model.frames[fid].name!r} here" if 0 <= fid < model.nframes else
                                 f"beyond this model's {model.nframes} frames"))
        if isinstance(getattr(obj, "nv", None), (int, np.integer)) and obj.nv != model.nv:
            raise foreign(f"nv {obj.nv}")
        indices = getattr(obj, "indices", None)
        if indices is not None and np.size(indices) and int(np.max(indices)) >= model.nv:
            raise foreign(f"velocity index {int(np.max(indices))} ≥ nv")
        if isinstance(obj, (JointPositionLimit, JointVelocityLimit)):
            expected = bounded_joints(model)[1] if isinstance(obj, JointPositionLimit) else np.arange(6, model.nv)
            if not np.array_equal(np.asarray(obj.indices), expected):
                raise foreign(f"limits on {np.size(obj.indices)} velocity indices, this robot has {expected.size}")


def zero_range_joints(model: pin.Model) -> list[str]:
    """Names of the joints (free-flyer excluded) whose position range has zero width or whose velocity limit is
    ≤ 0: their bounds pin v to 0."""
    locked = []
    for j in range(1, model.njoints):
        joint = model.joints[j]
        if joint.nv == 0 or joint.shortname() == "JointModelFreeFlyer":
            continue
        iq, iv = joint.idx_q, joint.idx_v
        lo, hi = model.lowerPositionLimit[iq:iq + joint.nq], model.upperPositionLimit[iq:iq + joint.nq]
        vmax = model.velocityLimit[iv:iv + joint.nv]
        if np.any(np.isfinite(lo) & (hi - lo <= 0)) or np.any(vmax <= 0):
            locked.append(model.names[j])
    return locked

