"""Inverse-dynamics whole-body control: acceleration tasks, sole contacts, named constraints, the ID QP and its
controller.

Layers (TSID's split): tasks (:mod:`~wbc.dynamics.tasks`: a kinematic task's e(q), J stated once in
:mod:`wbc.tasks`, plus its drift J̇v) and contacts (:mod:`~wbc.dynamics.contacts`) → named constraints
(:mod:`~wbc.dynamics.constraints`) → the formulation, the QP written once in :mod:`~wbc.dynamics.formulation`'s
docstring → solvers (:mod:`wbc.qp` backends; the compiled tick :mod:`~wbc.dynamics.idkernel`) → the controller
(:mod:`~wbc.dynamics.controller`: diagnosis, relaxed solve, safe command) → :class:`IDBalanceController`.
``BalanceController`` and ``AngularMomentumTask`` are the former names of :class:`IDBalanceController` and
:class:`AngularMomentumRateTask` (aliases).
"""

from wbc.dynamics.balance import DEFAULT_GAINS, BalanceController, IDBalanceController
from wbc.dynamics.contacts import SoleContact
from wbc.dynamics.controller import IDCommand, InverseDynamicsController
from wbc.dynamics.formulation import IDSolution, InverseDynamicsQP
from wbc.dynamics.state import DynamicsState
from wbc.dynamics.tasks import (
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
