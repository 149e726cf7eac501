"""The one constraint protocol of both QP levels.

Every constraint, at the kinematic level (decision variable v (nv,), :class:`~wbc.controllers.kinematic.
KinematicController`) and at the inverse-dynamics level (x = [v̇; f] (nv + 12 n_c,), :class:`~wbc.formulations.
acceleration.InverseDynamicsQP`), is a :class:`Constraint`: a ``name`` (used in infeasibility reports,
:mod:`wbc.solvers.diagnosis`), a ``kind`` (one of :data:`CONSTRAINT_KINDS`), a number of rows ``dim`` (fixed while the constraint
is in a QP: the row layout is built from it), ``relaxable`` and one verb, :meth:`Constraint.write`, which writes the
constraint's numbers of this tick **in place** into views of the QP's preallocated arrays:

* ``equality``: ``write(ctx, A_rows, b_rows, None)`` — rows of A x = b;
* ``inequality``: ``write(ctx, C_rows, l_rows, u_rows)`` — rows of l ≤ C x ≤ u (±inf allowed);
* ``bounds``: ``write(ctx, None, lb_view, ub_view)`` — lb ≤ x[indices] ≤ ub, the views of length ``dim``.

``ctx`` carries what the constraints of a level share at one tick: a :class:`KinematicContext` (the configuration
and the control period) or an :class:`IDContext` (the dynamic state, M, h, the contact Jacobians). The level's
formulation places each constraint once (``rows``, ``indices``); relaxation and diagnosis iterate the one list of
constraints by ``kind`` and ``relaxable``.

Kinematic level (this module, rows in v):

* :class:`EqualityConstraint`: A v = b (contacts, hard tasks);
* :class:`InequalityConstraint`: l ≤ C v ≤ u (CoM polygon, self-collision, executed ZMP);
* :class:`BoxConstraint`: lb ≤ v[idx] ≤ ub on some velocity coordinates (joint position, velocity, acceleration
  limits), intersected by the controller in increasing ``priority`` (then insertion order), each one clipped into
  the intersection of those before it, so a lower-priority box *yields* where it would empty the box (joint velocity
  limits 0 > recoverable position limits 1 > acceleration limits 2). Inside the joint range every box contains 0 and
  nothing is clipped.

Each computes its rows from a :class:`~wbc.configuration.Configuration` and the control period dt (s) by
``compute(config, dt)``; its :meth:`~Constraint.write` writes them. A constraint that needs the command actually sent
at the previous tick sets ``needs_previous_command = True`` and implements ``set_previous(v)``; the controller calls
it with ``TickResult.v`` after every tick (fallbacks included).

Inverse-dynamics level (rows in [v̇; f]): :class:`IDConstraint`, with one module per concept in
:mod:`wbc.constraints` (the table of :mod:`wbc.constraints`).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, field

import numpy as np

from wbc.configuration import Configuration
from wbc.exceptions import InvalidInputError
from wbc.state import DynamicsState

__all__ = ["CONSTRAINT_KINDS", "Constraint", "KinematicContext", "EqualityConstraint", "InequalityConstraint", "BoxConstraint",
           "IDContext", "IDConstraint", "AxisBound"]

#: The kinds of constraint rows (``Constraint.kind``): A x = b, l ≤ C x ≤ u, lb ≤ x[indices] ≤ ub.
CONSTRAINT_KINDS = ("equality", "inequality", "bounds")


class Constraint(ABC):
    """The protocol of a constraint of either QP level (module docstring).

    Attributes:
        name: label in reports. kind: one of :data:`CONSTRAINT_KINDS`. dim: rows (or bounded entries), fixed for the
            constraint's lifetime in a QP. relaxable: a preference rather than a safety limit — left out of a tick
            whose QP is infeasible with it (e.g. joint acceleration limits, torque limits).
        level: ``"velocity"`` (kinematic, x = v) or ``"acceleration"`` (inverse dynamics, x = [v̇; f]): the QP
            whose context :meth:`write` reads.
        needs_previous_command: kinematic level: True when the controller must call ``set_previous(v)`` with the
            command of every tick (module docstring).
    """

    name: str = "constraint"
    kind: str = "equality"
    level: str = "velocity"
    dim: int = 0
    relaxable: bool = False
    needs_previous_command: bool = False

    @property
    def enabled(self) -> bool:
        """False while the constraint has no rows in the QP (e.g. an inactive contact's acceleration rows)."""
        return True

    @abstractmethod
    def write(self, ctx, M_rows: np.ndarray | None, lo: np.ndarray, hi: np.ndarray | None) -> None:
        """Write this tick's numbers in place (module docstring): ``equality`` M_rows = A[rows], lo = b[rows]
        (hi None); ``inequality`` C[rows], l[rows], u[rows]; ``bounds`` (M_rows None) the views lb[indices],
        ub[indices] of length ``dim``. ``ctx``: the level's :class:`KinematicContext` or :class:`IDContext`."""


@dataclass
class KinematicContext:
    """Per-tick quantities of the kinematic level, read by :meth:`Constraint.write`.

    Attributes:
        config: the :class:`~wbc.configuration.Configuration` (kinematics updated). dt: control period (s).
    """

    config: Configuration | None = None
    dt: float = 0.0


class EqualityConstraint(Constraint):
    """A :math:`A v = b` block (e.g. contacts, hard tasks).
    """

    kind = "equality"

    def write(self, ctx: KinematicContext, M_rows: np.ndarray, lo: np.ndarray, hi=None) -> None:
        """A[rows] (dim, nv) and b[rows] (dim,) from :meth:`compute` at ``ctx.config``, ``ctx.dt``."""
        M_rows[:], lo[:] = self.compute(ctx.config, ctx.dt)
    @abstractmethod
    def compute(self, config: Configuration, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """Return (A (m, nv), b (m,)) such that A v = b must hold."""


class InequalityConstraint(Constraint):
    """An :math:`l ≤ C v ≤ u` block (e.g. CoM polygon, self-collision).

    A constraint that keeps a function h(q) ≥ 0 (a distance, a margin) also gives :meth:`barrier`, the same
    quantity for the acceleration level: h, its Jacobian G = ∂h/∂q and its drift Ġv, so the inverse-dynamics
    formulation can hold it as the second-order barrier of :class:`wbc.constraints.barrier.AccelerationBarrier`
    under the same name."""

    kind = "inequality"

    def write(self, ctx: KinematicContext, M_rows: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> None:
        """C[rows] (dim, nv), l[rows], u[rows] (dim,) from :meth:`compute` at ``ctx.config``, ``ctx.dt``."""
        M_rows[:], lo[:], hi[:] = self.compute(ctx.config, ctx.dt)
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
    """Bounds :math:`lb ≤ v[indices] ≤ ub`, intersected by the controller in ``priority`` order
    (:meth:`intersect_into`)."""

    kind = "bounds"
    #: (k,) indices of v that are bounded.
    indices: np.ndarray
    #: intersection order; a box with a larger number yields to those before it (module docstring).
    priority: int = 0
    #: True: the bounds depend on neither the configuration nor dt (computed once by the controller).
    constant: bool = False

    @abstractmethod
    def compute(self, config: Configuration, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """Return (lb (k,), ub (k,)) with lb ≤ v[indices] ≤ ub."""

    def write(self, ctx: KinematicContext, M_rows, lo: np.ndarray, hi: np.ndarray) -> None:
        """This box's own bounds (k,) from :meth:`compute`, before any intersection (:meth:`intersect_into`)."""
        lo[:], hi[:] = self.compute(ctx.config, ctx.dt)

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


@dataclass
class IDContext:
    """Per-tick quantities shared by the constraints (written by the formulation before they are).

    Attributes:
        state: the dynamic state. dt: control period (s). nv: velocity dimension.
        JcT: (nv, 12 n_c) J_cᵀ = [J_kᵀ G_k]_k (LOCAL sole Jacobians; inactive contacts included).
        jacobians: contact name → (6, nv) LOCAL sole Jacobian of this tick.
        offsets: contact name → (6,) velocity-free part −J̇v − K_p e of its eq. 5 right-hand side
            (:meth:`~wbc.constraints.sole_contact.SoleContact.acceleration_offset`) of this tick; a contact missing
            here has it computed by its constraint.
    """

    state: DynamicsState
    dt: float
    nv: int
    JcT: np.ndarray
    jacobians: dict
    offsets: dict = field(default_factory=dict)


class IDConstraint(Constraint):
    """Base of the constraints of the inverse-dynamics QP (x = [v̇; f]; module docstring and the table of
    :mod:`wbc.constraints`).

    Attributes:
        name: label in reports. kind: ``equality``, ``inequality`` or ``bounds``. dim: rows (or bounded entries).
        relaxable: dropped by the relaxed solve. constant: written once (rows do not depend on the state).
        rows: slice of the constraint's rows in A (equality) or C (inequality), set by the formulation.
        indices: (dim,) indices of x bounded by a ``bounds`` constraint.

    :meth:`~Constraint.write` reads an :class:`IDContext`.
    """

    level = "acceleration"
    constant: bool = False
    rows: slice = slice(0, 0)
    indices: np.ndarray | None = None


class AxisBound(IDConstraint):
    """Base of the symmetric bounds on three world-axis quantities affine in v̇, y = J v̇ + d (force columns zero):

        −y_max − d ≤ J v̇ ≤ y_max − d        (three inequality rows, per world axis x, y, z)

    A subclass sets ``unit`` (for messages) and implements :meth:`axis_rows`; the limit, its validation and the
    rows are here (:class:`~wbc.constraints.momentum_rate.AngularMomentumRateBound`,
    :class:`~wbc.constraints.frame_acceleration.FrameAccelerationBound`).

    Attributes:
        limit: (3,) y_max per world axis (``unit``), a copy; assigning it (or :meth:`set_limit`) validates it.
    """

    kind = "inequality"
    dim = 3
    unit = ""

    def __init__(self, limit, *, name: str, relaxable: bool = True):
        self.name = str(name)
        self.relaxable = bool(relaxable)
        self._limit = np.zeros(3)
        self.set_limit(limit)

    @property
    def limit(self) -> np.ndarray:
        """(3,) y_max per world axis (``unit``), a copy."""
        return self._limit.copy()

    @limit.setter
    def limit(self, value) -> None:
        self.set_limit(value)

    def set_limit(self, limit) -> None:
        """Set y_max (``unit``): one number > 0 or (3,) of them (``math.inf``: free axis).

        Raises:
            InvalidInputError: another shape, or an entry not > 0 (NaN included).
        """
        try:
            value = np.broadcast_to(np.asarray(limit, dtype=float), (3,))
        except (TypeError, ValueError):
            raise InvalidInputError(f"{self.name}: limit must be one number or 3 ({self.unit}, world x, y, z), "
                                    f"got {limit!r}") from None
        if not (value > 0).all():  # NaN fails too
            raise InvalidInputError(f"{self.name}: limit must be > 0 ({self.unit}; math.inf leaves an axis free), "
                                    f"got {value.tolist()}")
        self._limit[:] = value

    @abstractmethod
    def axis_rows(self, state: DynamicsState) -> tuple[np.ndarray, np.ndarray]:
        """(J (3, nv), d (3,)) of y = J v̇ + d at the state of this tick (world axes)."""

    def write(self, ctx, C, l, u):
        J, drift = self.axis_rows(ctx.state)
        C[:, :ctx.nv] = J
        C[:, ctx.nv:] = 0.0
        np.subtract(-self._limit, drift, out=l)
        np.subtract(self._limit, drift, out=u)
