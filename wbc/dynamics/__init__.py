"""Inverse-dynamics whole-body control: acceleration tasks, sole contacts, named constraints, the ID QP and its
controller.

Layers (TSID's split): tasks (:mod:`~wbc.tasks.acceleration`: a kinematic task's e(q), J stated once in
:mod:`wbc.tasks`, plus its drift J̇v) and contacts (:mod:`~wbc.constraints.sole_contact`) → named constraints
(:mod:`~wbc.constraints.dynamics`) → the formulation, the QP written once in :mod:`~wbc.formulations.acceleration`'s
docstring → solvers (:mod:`wbc.qp` backends; the compiled tick :mod:`~wbc.formulations.idkernel`) → the controller
(:mod:`~wbc.dynamics.controller`: diagnosis, relaxed solve, safe command) → :class:`IDBalanceController`.
``BalanceController`` and ``AngularMomentumTask`` are the former names of :class:`IDBalanceController` and
:class:`AngularMomentumRateTask` (aliases).
"""

from wbc.dynamics.balance import DEFAULT_GAINS, BalanceController, IDBalanceController
from wbc.constraints.sole_contact import SoleContact
from wbc.dynamics.controller import IDCommand, InverseDynamicsController
from wbc.formulations.acceleration import IDSolution, InverseDynamicsQP
from wbc.state import DynamicsState
from wbc.tasks.acceleration import (
    AccelerationTask,
    AngularMomentumRateTask,
    AngularMomentumTask,
    ComAccelerationTask,
    FrameAccelerationTask,
    PostureAccelerationTask,
    acceleration_task,
)

__all__ = [
    "AccelerationTask", "AngularMomentumRateTask", "AngularMomentumTask", "BalanceController", "ComAccelerationTask",
    "DEFAULT_GAINS", "IDBalanceController", "DynamicsState", "FrameAccelerationTask", "IDCommand", "IDSolution", "InverseDynamicsController",
    "InverseDynamicsQP", "PostureAccelerationTask", "SoleContact", "acceleration_task",
]
