"""Constraint interfaces: linear equalities, inequalities and bounds on the decision variable v (nv,).

* :class:`EqualityConstraint`: A v = b.
* :class:`InequalityConstraint`: l ≤ C v ≤ u.
* :class:`BoxConstraint`: lb ≤ v[idx] ≤ ub on some velocity coordinates.

Each computes its rows from a :class:`~wbc.configuration.Configuration` and the control period dt (s).

Bounds never conflict with each other: the controller intersects boxes in increasing ``priority`` (then insertion
order), each one clipped into the intersection of those before it, so a lower-priority box *yields* where it would
empty the box (joint velocity limits 0 > recoverable position limits 1 > acceleration limits 2). Inside the
joint range every box contains 0 and nothing is clipped.

A constraint that needs the command actually sent at the previous tick sets ``needs_previous_command = True`` and
implements ``set_previous(v)``; the controller calls it with ``TickResult.v`` after every tick (fallbacks included).
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np

from wbc.configuration import Configuration

__all__ = ["Constraint", "EqualityConstraint", "InequalityConstraint", "BoxConstraint"]


class Constraint(ABC):
    """Common base: a name (used in infeasibility reports) and a dimension (number of rows, fixed for the
    constraint's lifetime: the controller's row layout is built from it)."""

    name: str = "constraint"
    dim: int = 0
    #: True: the controller calls ``set_previous(v)`` with the command of every tick (module docstring).
    needs_previous_command: bool = False
    #: True: a preference rather than a safety limit — left out of a tick whose QP is infeasible with it
    #: (``TickResult.relaxed``), e.g. acceleration limits against a contact + joint-limit recovery.
    relaxable: bool = False


class EqualityConstraint(Constraint):
    """A :math:`A v = b` block (e.g. contacts, hard tasks)."""
    @abstractmethod
    def compute(self, config: Configuration, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """Return (A (m, nv), b (m,)) such that A v = b must hold."""


class InequalityConstraint(Constraint):
    """An :math:`l ≤ C v ≤ u` block (e.g. CoM polygon, self-collision).

    A constraint that keeps a function h(q) ≥ 0 (a distance, a margin) also gives :meth:`barrier`, the same
    quantity for the acceleration level: h, its Jacobian G = ∂h/∂q and its drift Ġv, so the inverse-dynamics
    formulation can hold it as the second-order barrier of :class:`wbc.constraints.dynamics.AccelerationBarrier`
    under the same name."""
    @abstractmethod
    def compute(self, config: Configuration, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return (C (m, nv), l (m,), u (m,)) such that l ≤ C v ≤ u must hold (±inf allowed)."""

    def barrier(self, state, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(h (m,), G (m, nv), Ġv (m,)) at a :class:`~wbc.state.DynamicsState`: the rows' functions h(q) ≥ 0 (units of
        the constraint, +inf on an unused row), their Jacobians ∂h/∂q and drifts (ḧ = G v̇ + Ġv).

        Raises:
            NotImplementedError: a constraint without an acceleration-level (barrier) form.
        """
        raise NotImplementedError(f"{type(self).__name__} has no acceleration-level (barrier) form")


class BoxConstraint(Constraint):
    """Bounds :math:`lb ≤ v[indices] ≤ ub`, intersected by the controller in ``priority`` order."""
    #: (k,) indices of v that are bounded.
    indices: np.ndarray
    #: intersection order; a box with a larger number yields to those before it (module docstring).
    priority: int = 0
    #: True: the bounds depend on neither the configuration nor dt (computed once by the controller).
    constant: bool = False

    @abstractmethod
    def compute(self, config: Configuration, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """Return (lb (k,), ub (k,)) with lb ≤ v[indices] ≤ ub."""

    def intersect_into(self, config: Configuration, dt: float, lb: np.ndarray, ub: np.ndarray) -> None:
        """Intersect this box with the running box lb ≤ v ≤ ub ((nv,) each, in place), clipped into it so that it
        yields where it would empty it (module docstring): on ``indices``, lb ← min(max(lo, lb), ub) and
        ub ← max(min(hi, ub), lb), both from the running values, (lo, hi) = :meth:`compute`. Boxes with a compiled
        form override it (the same numbers)."""
        lo, hi = self.compute(config, dt)
        idx = self.indices
        cur_lo, cur_hi = lb[idx], ub[idx]
        lb[idx] = np.minimum(np.maximum(lo, cur_lo), cur_hi)
        ub[idx] = np.maximum(np.minimum(hi, cur_hi), cur_lo)
