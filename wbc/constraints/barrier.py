"""A kinematic inequality constraint held at the acceleration level as a second-order barrier.

The barrier rows make the kinematic constraint objects of :mod:`wbc.constraints` (the same object, the same name)
constraints of the acceleration level: with h(q) ≥ 0 the constrained function, ḣ = G v and ḧ = G v̇ + Ġv (from the
constraint's :meth:`~wbc.constraints.base.InequalityConstraint.barrier`), asking ḧ + 2γ ḣ + γ² h ≥ 0 makes
h(t) ≥ (h₀ + (ḣ₀ + γ h₀) t) e^{−γt} ≥ 0 whenever h₀ ≥ 0 and ḣ₀ ≥ −γ h₀ (comparison with the critically damped
solution; exponential control barrier function of relative degree 2, Nguyen & Sreenath, "Exponential control
barrier functions for enforcing high relative-degree safety-critical constraints", ACC 2016). A row with h = +inf
(unused) is −inf ≤ C x.
"""

from __future__ import annotations

import numpy as np

from wbc.constraints.base import IDConstraint, InequalityConstraint
from wbc.exceptions import InvalidInputError

__all__ = ["AccelerationBarrier"]


class AccelerationBarrier(IDConstraint):
    """A kinematic inequality constraint with a :meth:`~wbc.constraints.base.InequalityConstraint.barrier` held at
    the acceleration level by the second-order barrier of the module docstring, under the same name.

    Args:
        constraint: e.g. :class:`~wbc.constraints.ComPolygonConstraint`, :class:`~wbc.constraints.SelfCollisionConstraint`.
        gain: γ (1/s, > 0) of ḧ + 2γ ḣ + γ² h ≥ 0.

    Raises:
        InvalidInputError: a constraint without a barrier form, or a bad gain.
    """

    kind = "inequality"

    def __init__(self, constraint, *, gain: float = 10.0):
        if type(constraint).barrier is InequalityConstraint.barrier or not isinstance(constraint,
                                                                                       InequalityConstraint):
            raise InvalidInputError(f"{type(constraint).__name__} has no acceleration-level (barrier) form")
        if not (np.isfinite(gain) and gain > 0):
            raise InvalidInputError(f"barrier gain must be finite and > 0 (1/s), got {gain!r}")
        self.constraint = constraint
        self.name = constraint.name
        self.dim = constraint.dim
        self.relaxable = constraint.relaxable
        self.gain = float(gain)

    def write(self, ctx, C, l, u):
        h, G, drift = self.constraint.barrier(ctx.state, ctx.dt)
        nv, g = ctx.nv, self.gain
        C[:, :nv] = G
        C[:, nv:] = 0.0
        with np.errstate(invalid="ignore"):
            l[:] = -drift - 2.0 * g * (G @ ctx.state.v) - g * g * h
        l[~np.isfinite(h)] = -np.inf
        u[:] = np.inf
