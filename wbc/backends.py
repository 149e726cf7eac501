"""QP backends by name: the generic ones of :mod:`wbc.qp` and the compiled ``fast`` one of :mod:`wbc.fastqp`.

Kept apart from :mod:`wbc.qp` because :mod:`wbc.fastqp` builds on :class:`wbc.qp.DaqpBackend`: the name → backend
table sits above both, so neither imports the other back.
"""

from __future__ import annotations

from wbc.exceptions import UnknownSolverError
from wbc.qp import TIGHT_SETTINGS, DaqpBackend, ProxQPBackend, QPBackend, QpsolversBackend, available_solvers

__all__ = ["make_backend"]


def make_backend(name: str, **settings) -> QPBackend:
    """Create a backend by name: ``fast`` (compiled exact kernel with DAQP fallback, :mod:`wbc.fastqp`), ``daqp``
    (DAQP workspace, warm-started), ``proxqp`` (warm-started proxsuite) or any other installed qpsolvers backend.

    Args:
        name: backend name (:func:`available_solvers`).
        **settings: solver settings passed to the backend (e.g. ``primal_tol=1e-9`` for daqp).

    Raises:
        UnknownSolverError: the name is not installed; the message lists the available ones.
    """
    if name == "fast":  # compiled exact kernel with DAQP fallback; imported here: numba takes ~1 s to import
        from wbc.fastqp import FastBackend

        return FastBackend(**settings)
    if name not in available_solvers():
        raise UnknownSolverError(f"unknown or uninstalled QP solver {name!r}; available: {available_solvers()}")
    if name == "proxqp":
        return ProxQPBackend(**settings)
    if name == "daqp":
        return DaqpBackend(**settings)
    return QpsolversBackend(name, **{**TIGHT_SETTINGS.get(name, {}), **settings})
