"""Constraint interfaces: linear equalities, inequalities and bounds on the decision variable v (nv,).

* :class:`EqualityConstraint`: A v = b.
* :class:`InequalityConstraint`: l ≤ C v ≤ u.
* :class:`BoxConstraint`: lb ≤ v[idx] ≤ ub on some velocity coordinates.

Each computes its rows from a :class:`~wbc.configuration.Configuration` and the control period dt (s).
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np

from wbc.configuration import Configuration

__all__ = ["Constraint", "EqualityConstraint", "InequalityConstraint", "BoxConstraint"]


class Constraint(ABC):
    """Common base: a name (used in infeasibility reports) and a dimension."""

    name: str = "constraint"
    dim: int = 0


class EqualityConstraint(Constraint):
    @abstractmethod
    def compute(self, config: Configuration, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """Return (A (m, nv), b (m,)) such that A v = b must hold."""


class InequalityConstraint(Constraint):
    @abstractmethod
    def compute(self, config: Configuration, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return (C (m, nv), l (m,), u (m,)) such that l ≤ C v ≤ u must hold (±inf allowed)."""


class BoxConstraint(Constraint):
    #: (k,) indices of v that are bounded.
    indices: np.ndarray

    @abstractmethod
    def compute(self, config: Configuration, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """Return (lb (k,), ub (k,)) with lb ≤ v[indices] ≤ ub."""
