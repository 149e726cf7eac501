"""Constraints: linear equalities, inequalities and bounds on the generalized velocity v."""

from wbc.constraints.acceleration import JointAccelerationLimit
from wbc.constraints.base import BoxConstraint, Constraint, EqualityConstraint, InequalityConstraint
from wbc.constraints.com_polygon import ComPolygonConstraint
from wbc.constraints.contact import ContactConstraint
from wbc.constraints.limits import JointPositionLimit, JointVelocityLimit
from wbc.constraints.self_collision import SelfCollisionConstraint
from wbc.constraints.task import TaskConstraint

__all__ = [
    "BoxConstraint", "Constraint", "EqualityConstraint", "InequalityConstraint",
    "ComPolygonConstraint", "ContactConstraint", "JointAccelerationLimit", "JointPositionLimit",
    "JointVelocityLimit", "SelfCollisionConstraint", "TaskConstraint",
]
