"""Centroidal angular momentum task: regulate k_G = A_g,ang(q) v to a target (default zero).

A_g(q) (6, nv) is Pinocchio's centroidal momentum matrix (``pin.computeCentroidalMap``; Orin, Goswami, Lee,
"Centroidal dynamics of a humanoid robot", Autonomous Robots 35, 2013: h_G = A_g(q) q̇). Rows 0:3 are the
linear momentum (kg·m/s), rows 3:6 the angular momentum about the CoM (kg·m²/s), both in world axes.

This is a velocity-level task: the decision variable v enters linearly and exactly, so there is no configuration
error e(q). It is written in the :class:`~wbc.tasks.base.Task` form with e ≡ 0, J = A_g,ang and the target as
feed-forward: v* = k* and the cost is Σ_r w_r (A_g,ang v − k*)_r². The gain K therefore has no effect (accepted
for a uniform signature). Its drift is J̇ v = (dAg v)[3:6] (``pin.computeCentroidalMapTimeVariation``, via
``DynamicsState.centroidal_drift``), so at the acceleration level the same object asks
L̇ = A_g,ang v̇ + (dAg v)[3:6] = L̇* with L̇* = L̇_ff − Kd (L − k*) (Kp plays no role, e ≡ 0; Lee & Goswami 2012,
"A momentum-based balance controller for humanoid robots on non-level and non-stationary ground", Auton. Robots
33:399–414). Its check is not a finite difference of e: ``tests/tasks/test_momentum.py`` checks that
J v equals ``pin.computeCentroidalMomentum(model, data, q, v).angular`` and an independent sum over bodies
Σ_i (c_i − c) × m_i ċ_i + I_i ω_i built from Pinocchio's body velocities.
"""

from __future__ import annotations

import numpy as np

from wbc.configuration import Configuration, check_vector
from wbc.exceptions import InvalidTargetError
from wbc.state import DynamicsState
from wbc.tasks.base import Task

__all__ = ["AngularMomentumTask"]


class AngularMomentumTask(Task):
    """Drive the centroidal angular momentum (3,) (kg·m²/s, world axes, about the CoM) to a target.

    Args:
        robot: the robot (optional: the task needs no model of its own).
        weight: scalar or (3,) weights of the x, y, z rows (per (kg·m²/s)²).
        gain: accepted for a uniform signature; no effect (module docstring).
        name: label (default ``"angular_momentum"``).

    Raises:
        InvalidInputError: bad weight or gain.
    """

    dim = 3
    name = "angular_momentum"

    def __init__(self, robot=None, *, weight=1e-2, gain: float = 0.0, name: str | None = None):
        super().__init__(gain=gain, weight=weight, name=name)
        self.target = np.zeros(3)
        self._zero = np.zeros(3)

    def set_target(self, momentum) -> None:
        """Target angular momentum k* (3,) (kg·m²/s, world axes, about the CoM).

        Raises:
            InvalidTargetError: wrong shape or NaN.
        """
        self.target = check_vector(momentum, 3, "angular momentum target", InvalidTargetError).copy()

    def compute(self, config: Configuration) -> tuple[np.ndarray, np.ndarray]:
        """(zeros (3,), A_g,ang (3, nv)) from ``config.centroidal_momentum_matrix``: a view of the rows of a
        :class:`~wbc.state.DynamicsState`'s per-tick Ag, a copy of the fresh ``pin.computeCentroidalMap`` of a
        :class:`~wbc.configuration.Configuration` (whose storage the next call rewrites)."""
        ag = config.centroidal_momentum_matrix[3:6]
        return self._zero, (ag if isinstance(config, DynamicsState) else ag.copy())

    def feedforward(self) -> np.ndarray:
        return self.target

    def drift(self, state) -> np.ndarray:
        """(3,) (dAg v)[3:6]: L̇ at v̇ = 0 (N·m, world axes about the CoM)."""
        return state.centroidal_drift[3:6]
