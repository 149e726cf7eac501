"""Inverse-dynamics whole-body control: the balance controller and the stateful ID controller, re-exporting the
acceleration-level public API.

Layers (TSID's split): tasks (:mod:`wbc.tasks`: each states e(q), J and the drift J̇v once, for both levels) and
contacts (:mod:`~wbc.constraints.sole_contact`) → named constraints (:mod:`~wbc.constraints`) → the
formulation, the QP written once in :mod:`~wbc.formulations.acceleration`'s docstring, with each task's PD
reference a* (:class:`~wbc.formulations.reference.AccelerationReference`) → solvers (:mod:`wbc.solvers` backends; the
compiled tick :mod:`~wbc.formulations.idkernel`) → the controller (:mod:`~wbc.controllers.inverse_dynamics`: diagnosis,
relaxed solve, safe command) → :class:`IDBalanceController`.
"""

from wbc.dynamics.balance import DEFAULT_GAINS, IDBalanceController
from wbc.constraints.sole_contact import SoleContact
from wbc.controllers.inverse_dynamics import InverseDynamicsController
from wbc.formulations.acceleration import IDCommand, InverseDynamicsQP
from wbc.state import DynamicsState
from wbc.formulations.reference import AccelerationReference

__all__ = [
    "AccelerationReference", "DEFAULT_GAINS", "DynamicsState", "IDBalanceController", "IDCommand",
    "InverseDynamicsController", "InverseDynamicsQP", "SoleContact",
]
