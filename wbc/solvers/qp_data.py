"""The QP every backend of :mod:`wbc.solvers` solves, as a formulation hands it over (:class:`QPData`), and a
solver's answer (:class:`QPSolution`):

    min_x ½ xᵀ H x + gᵀ x   s.t.   A x = b,   l ≤ C x ≤ u,   lb ≤ x ≤ ub,   x ∈ R^n.

The arrays are the formulation's own buffers (views), overwritten at its next assembly; a solver never writes them.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

__all__ = ["QPData", "QPSolution"]


class QPData(NamedTuple):
    """One QP (module docstring); unpacks as ``H, g, A, b, C, l, u, lb, ub``.

    Attributes:
        H: (n, n) symmetric positive (semi)definite cost matrix.
        g: (n,) cost vector.
        A: (m_eq, n) equality rows; b: (m_eq,) their right-hand sides.
        C: (m_in, n) inequality rows; l, u: (m_in,) their lower and upper bounds (±inf for a free side).
        lb, ub: (n,) box on x (±inf for a free entry).
    """

    H: np.ndarray
    g: np.ndarray
    A: np.ndarray
    b: np.ndarray
    C: np.ndarray
    l: np.ndarray  # noqa: E741 (the QP's own name for the lower row bounds)
    u: np.ndarray
    lb: np.ndarray
    ub: np.ndarray


class QPSolution(NamedTuple):
    """A solver's answer to one :class:`QPData`; unpacks as ``x, solver, step``.

    Attributes:
        x: (n,) the minimiser.
        solver: name of the solver that produced it (e.g. ``daqp``, ``quadprog``).
        step: the step of a :class:`~wbc.solvers.fallback.FallbackChain` that answered (e.g. ``attempt``,
            ``scaled call``, ``quadprog``, ``retries``, ``second opinion``); ``attempt`` for a backend's own answer.
    """

    x: np.ndarray
    solver: str
    step: str = "attempt"
