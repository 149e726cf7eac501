"""Inverse-dynamics whole-body control: the balance controller and the stateful ID controller, re-exporting the
acceleration-level public API.

Layers (TSID's split): tasks (:mod:`wbc.tasks`: each states e(q), J and the drift J̇v once, for both levels) and
contacts (:mod:`~wbc.constraints.sole_contact`) → named constraints (:mod:`~wbc.constraints.dynamics`) → the
formulation, the QP written once in :mod:`~wbc.formulations.acceleration`'s docstring, with each task's PD
reference a* (:class:`~wbc.formulations.reference.AccelerationReference`) → solvers (:mod:`wbc.qp` backends; the
compiled tick :mod:`~wbc.formulations.idkernel`) → the controller (:mod:`~wbc.dynamics.controller`: diagnosis,
relaxed solve, safe command) → :class:`IDBalanceController`.

Deprecated names kept for callers: ``BalanceController`` (= :class:`IDBalanceController`), ``AccelerationTask``
(= :class:`~wbc.formulations.reference.AccelerationReference`), the constructors ``ComAccelerationTask``,
``FrameAccelerationTask``, ``PostureAccelerationTask``, ``AngularMomentumRateTask`` (also under its former name
``AngularMomentumTask``, not to be confused with the shared :class:`wbc.tasks.AngularMomentumTask`) and
``acceleration_task``, each returning an ``AccelerationReference`` on a shared task.
"""

from wbc.dynamics.balance import DEFAULT_GAINS, IDBalanceController
from wbc.constraints.sole_contact import SoleContact
from wbc.dynamics.controller import IDCommand, InverseDynamicsController
from wbc.formulations.acceleration import IDSolution, InverseDynamicsQP
from wbc.state import DynamicsState
from wbc.formulations.reference import (
    AccelerationReference,
    AngularMomentumRateTask,
    ComAccelerationTask,
    FrameAccelerationTask,
    PostureAccelerationTask,
    acceleration_task,
    deprecated,
)

_RENAMED = {"BalanceController": ("IDBalanceController", IDBalanceController),
            "AccelerationTask": ("AccelerationReference", AccelerationReference),
            # not to be confused with the shared task wbc.tasks.AngularMomentumTask
            "AngularMomentumTask": ("AngularMomentumRateTask (itself deprecated: AccelerationReference("
                                    "wbc.tasks.AngularMomentumTask(), kp=0, kd=gain))", AngularMomentumRateTask)}


def __getattr__(name: str):
    if name in _RENAMED:  # former names (deprecated)
        new, value = _RENAMED[name]
        deprecated(f"wbc.dynamics.{name}", new)
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

__all__ = [
    "AccelerationReference", "AccelerationTask", "AngularMomentumRateTask", "AngularMomentumTask", "BalanceController", "ComAccelerationTask",
    "DEFAULT_GAINS", "IDBalanceController", "DynamicsState", "FrameAccelerationTask", "IDCommand", "IDSolution", "InverseDynamicsController",
    "InverseDynamicsQP", "PostureAccelerationTask", "SoleContact", "acceleration_task",
]
