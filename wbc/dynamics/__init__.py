"""Inverse-dynamics whole-body control: acceleration tasks, sole contacts, the ID QP and its controller."""

from wbc.dynamics.balance import DEFAULT_GAINS, BalanceController
from wbc.dynamics.contacts import SoleContact
from wbc.dynamics.controller import IDCommand, InverseDynamicsController
from wbc.dynamics.formulation import IDSolution, InverseDynamicsQP
from wbc.dynamics.state import DynamicsState
from wbc.dynamics.tasks import (
    AccelerationTask,
    AngularMomentumTask,
    ComAccelerationTask,
    FrameAccelerationTask,
    PostureAccelerationTask,
    acceleration_task,
)

__all__ = [
    "AccelerationTask", "AngularMomentumTask", "BalanceController", "ComAccelerationTask", "DEFAULT_GAINS",
    "DynamicsState", "FrameAccelerationTask", "IDCommand", "IDSolution", "InverseDynamicsController",
    "InverseDynamicsQP", "PostureAccelerationTask", "SoleContact", "acceleration_task",
]
