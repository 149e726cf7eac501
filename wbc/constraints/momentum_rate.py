"""A bound on the centroidal angular momentum rate, a constraint of the inverse-dynamics QP only (x = [v̇; f]):

    −L̇_max − (Ȧ_G v)_ang ≤ A_G,ang v̇ ≤ L̇_max − (Ȧ_G v)_ang        (N·m, world axes, about the CoM)

L̇ = A_G,ang v̇ + (Ȧ_G v)_ang is the rate of the robot's angular momentum about its centre of mass, A_G the centroidal
momentum matrix (Orin, Goswami & Lee 2013, "Centroidal dynamics of a humanoid robot", Auton. Robots 35:161–176;
:attr:`wbc.state.DynamicsState.centroidal_momentum_matrix` and :attr:`~wbc.state.DynamicsState.centroidal_drift`).
Through the floating-base dynamics (eq. 4 of :mod:`wbc.formulations.acceleration`) it equals the moment of the contact
forces about the CoM, Σ_k (p_k − c) × f_k, so the bound limits how hard the tasks may spin the trunk and arms and how
far the contact wrenches may pull the centre of pressure from under the CoM. Herzog et al. 2016 ("Momentum control
with hierarchical inverse dynamics on a torque-controlled humanoid", Auton. Robots 40:473–491) regulate the same
quantity as a task; here it is a hard inequality. Add it with ``qp.add_constraint(AngularMomentumRateBound(...))``:
its rows are written by :meth:`~AngularMomentumRateBound.write` before the compiled tick, which solves with them.
"""

from __future__ import annotations

from wbc.constraints.base import AxisBound

__all__ = ["AngularMomentumRateBound"]


class AngularMomentumRateBound(AxisBound):
    """|L̇_i| ≤ L̇_max,i on the centroidal angular momentum rate, per world axis i = x, y, z (module docstring):
    three inequality rows A_G,ang v̇ (force columns zero), bounds ±L̇_max − (Ȧ_G v)_ang (N·m).

    Args:
        limit: L̇_max (N·m), > 0: one number for the three axes, or (3,) per world axis x, y, z (``math.inf``
            leaves an axis free).
        name: label in reports and diagnoses (default ``"angular_momentum_rate"``).
        relaxable: dropped by the relaxed solve when the full QP is infeasible with it (default True: a shaping
            bound rather than a hardware limit).

    Attributes:
        limit: (3,) L̇_max (N·m), a copy; assign it or call :meth:`~wbc.constraints.base.AxisBound.set_limit`.

    Raises:
        InvalidInputError: a limit that is not one number or three, or not > 0 (NaN included).
    """

    unit = "N·m"

    def __init__(self, limit, *, name: str = "angular_momentum_rate", relaxable: bool = True):
        super().__init__(limit, name=name, relaxable=relaxable)

    def axis_rows(self, state):
        return state.centroidal_momentum_matrix[3:6], state.centroidal_drift[3:6]
