"""Exit codes shared by the in-house QP kernels (:mod:`wbc.solvers.active_set`, :mod:`wbc.solvers.compiled_id`,
:mod:`wbc.formulations.velocity_kernel`, :mod:`wbc.formulations.idkernel`).

A kernel returns a count ≥ 0 on success and one negative :class:`SolverStatus` otherwise (one code, one meaning);
compiled kernels read the module's plain ``int`` constants, which numba freezes at compile time.
"""

from __future__ import annotations

from enum import IntEnum

__all__ = ["DEPENDENT_EQUALITIES", "INFEASIBLE", "ITERATION_CAP", "NOT_POSITIVE_DEFINITE", "NOT_REDUCIBLE",
           "NOT_VERIFIED", "RESIDUAL", "SolverStatus"]


class SolverStatus(IntEnum):
    """Negative exit codes of the in-house QP kernels.

    Members:
        NOT_POSITIVE_DEFINITE: a Hessian (or reduced Hessian) factorisation failed.
        DEPENDENT_ROWS: an equality or working-set row is (numerically) dependent on the others.
        ITERATION_CAP: the active-set loop reached its iteration cap.
        NOT_REDUCIBLE: the floating base cannot be eliminated (kinematic tick: a bound on a base velocity, a
            singular eliminating block).
        RESIDUAL: the solution's equality or inequality residual is above the tolerance (kinematic tick).
        INFEASIBLE: a violated constraint that no working row can make room for (the constraints admit no
            solution, up to the kernel's tolerance; the caller's general solver decides).
        NOT_VERIFIED: the final KKT check (multiplier signs, residuals) did not pass (inverse-dynamics tick).
    """

    NOT_POSITIVE_DEFINITE = -1
    DEPENDENT_ROWS = -2
    ITERATION_CAP = -3
    NOT_REDUCIBLE = -4
    RESIDUAL = -5
    INFEASIBLE = -6
    NOT_VERIFIED = -7


#: the :class:`SolverStatus` values as plain ints; DEPENDENT_EQUALITIES is ``DEPENDENT_ROWS``
NOT_POSITIVE_DEFINITE = int(SolverStatus.NOT_POSITIVE_DEFINITE)
DEPENDENT_EQUALITIES = int(SolverStatus.DEPENDENT_ROWS)
ITERATION_CAP = int(SolverStatus.ITERATION_CAP)
NOT_REDUCIBLE = int(SolverStatus.NOT_REDUCIBLE)
RESIDUAL = int(SolverStatus.RESIDUAL)
INFEASIBLE = int(SolverStatus.INFEASIBLE)
NOT_VERIFIED = int(SolverStatus.NOT_VERIFIED)
