"""Constraints: linear equalities, inequalities and bounds on the generalized velocity v."""

from wbc.constraints.base import BoxConstraint, Constraint, EqualityConstraint, InequalityConstraint
from wbc.constraints.contact import ContactConstraint
from wbc.constraints.limits import JointPositionLimit, JointVelocityLimit

__all__ = [
    "BoxConstraint", "Constraint", "EqualityConstraint", "InequalityConstraint",
    "ContactConstraint", "JointPositionLimit", "JointVelocityLimit",
]
