"""The compiled exact solver of the inverse-dynamics QP (:class:`CompiledIDSolver`), the first rung of the ID
formulation's :class:`~wbc.solvers.fallback.FallbackChain` (``solver="fast"``), warm-started from its last working
set. The QP is that of :mod:`wbc.formulations.acceleration`: H = blockdiag(H_vv, ε_f I) over x = [v̇; f].

The Goldfarb–Idnani dual active set (:func:`~wbc.solvers.active_set.dual_active_set` on a
:class:`~wbc.solvers.active_set.DenseSpace`) solves it from the previous tick's working set, the bounds with lb = ub
(the forces of an inactive contact) held from the start. The answer matches quadprog's on the same QP to ≈ 1e-11
(less along directions held by ε_a alone, κ(H_vv) ~ 1e8); closed-loop trajectories of two exact solvers still part,
so solvers are compared tick by tick (``tests/formulations/test_idkernel.py``).
"""

from __future__ import annotations

import numpy as np

from wbc.compiled import CHECK_TYPES, specialise
from wbc.exceptions import SolverError
from wbc.solvers.active_set import qp_ws_sizes, solve_qp_into
from wbc.solvers.qp_data import QPData, QPSolution
from wbc.solvers.status import SolverStatus

__all__ = ["CompiledIDSolver", "KERNEL_ITERATION_COST", "KERNEL_ITERATIONS_AFTER_GIVE_UP", "kernel_iterations"]

#: CPU time (s) of one working-set iteration of the ID solve with its share of the set-up (benchmarks/README.md,
#: "One active set for both QP levels"; :func:`kernel_iterations`)
KERNEL_ITERATION_COST = 2.5e-5

#: iteration cap on the tick after a call that gave up: it starts from the next rung's answer, one change away
KERNEL_ITERATIONS_AFTER_GIVE_UP = 2

_STATUS_CODES = {int(code) for code in SolverStatus}


def kernel_iterations(budget: float) -> int:
    """Iteration cap of :class:`CompiledIDSolver` for a tick budget of ``budget`` s of CPU time: a quarter of the
    budget at :data:`KERNEL_ITERATION_COST` per iteration, between 4 and 100 (100: unbounded). A count, not a clock."""
    if not np.isfinite(budget):
        return 100
    return int(min(100, max(4, budget / (4.0 * KERNEL_ITERATION_COST))))


class CompiledIDSolver:
    """:func:`~wbc.solvers.active_set.solve_qp_into` with the ID tick's :meth:`settings` behind the solver protocol:
    ``solve(QPData) → QPSolution``.

    Args:
        n, p: variables, inequality rows. me: the most equality rows a QP has.

    Attributes:
        state, rstate: (n,), (p,) the working set (bounds, inequality rows: −1 lower, +1 upper, 0 free).
        max_iterations: the iteration cap (:func:`kernel_iterations`; :data:`KERNEL_ITERATIONS_AFTER_GIVE_UP` after
            a call that gave up). tolerance: the largest constraint violation of an answer (the chain's backend's).
        solves, fallbacks: calls that answered, and that did not (the chain's next rung answered).
    """

    name = "kernel"

    def __init__(self, n: int, p: int, me: int):
        fsize, isize = qp_ws_sizes(n, me, p)
        self.state, self.rstate = np.zeros(n, np.int8), np.zeros(p, np.int8)
        self.x, self.residual = np.zeros(n), np.zeros(1)
        self._arrays = (self.state, self.rstate, self.x, np.zeros(me), np.zeros(p), np.zeros(n), self.residual)
        self._work = (np.zeros(fsize), np.zeros(isize, np.int64))
        self.max_iterations = 100
        self.tolerance = 1e-6
        self.solves = 0
        self.fallbacks = 0
        self.gave_up = False
        self.cap = self.max_iterations  # the last call's iteration cap
        self._entry = None  # solve_qp_into specialised to C-contiguous float64 arrays (wbc.compiled.specialise)
        self._solution = QPSolution(self.x, self.name)  # every answer: x is this view of the buffer
        self._checked: tuple = (None, (), False)  # (the last QPData, as a plain tuple, its arrays all C-contiguous)

    def settings(self, cap: int) -> tuple:
        """The ID tick's :data:`~wbc.solvers.active_set.ActiveSetSettings` at an iteration cap of ``cap``, a plain
        tuple: a bound or row enters the working set when violated by more than 1e-11 (m/s², N, N·m); a constraint
        counts as dependent on the working set below a squared sine of 1e-10 in the H⁻¹ metric; the bounds with
        lb = ub are held; x is refreshed after each full step; the final KKT check allows 1e-9; the pivot of S² below
        which the working set counts as dependent is 1e-24 (the kinematic tick's)."""
        return (int(cap), 1e-11, 0.0, 1e-10, 0.0, True, True, 1, 1e-9, 1e-24)

    def load(self, qp: QPData) -> None:
        """Compile (or load) the solve for the types of ``qp`` (C-contiguous arrays: the formulation's buffers) now,
        not in a controller's first tick."""
        self._entry = specialise(solve_qp_into, tuple(qp), self._arrays, self.settings(1), *self._work)

    def solve(self, qp: QPData) -> QPSolution:
        """The exact optimum of ``qp`` (x a view of this solver's buffer, overwritten by the next call).

        Raises:
            SolverError: the call did not end in a KKT point within :attr:`tolerance` (the message names its status).
        """
        self.cap = min(self.max_iterations, KERNEL_ITERATIONS_AFTER_GIVE_UP) if self.gave_up else self.max_iterations
        self.gave_up = False
        if qp is not self._checked[0]:  # the formulation hands over the same QPData of views tick after tick
            self._checked = (qp, tuple(qp), not CHECK_TYPES and all(a.flags.c_contiguous for a in qp))
        if self._checked[2] and self._entry is None:
            self.load(qp)
        entry = self._entry if self._checked[2] else solve_qp_into
        it = entry(self._checked[1], self._arrays, self.settings(self.cap), *self._work)
        if it > 0 and self.residual[0] <= self.tolerance:
            return self._solution
        raise SolverError(self.status_text(it, self.residual[0]))

    def give_up(self) -> float:
        """Record a call that did not answer and clear the working set. Returns its iteration cap."""
        self.fallbacks += 1
        self.gave_up = True
        self.clear()
        return float(self.cap)

    def clear(self) -> None:
        """Clear the working set (the next call starts cold)."""
        self.state[:] = 0
        self.rstate[:] = 0

    @staticmethod
    def status_text(status: int, residual: float) -> str:
        """Why a call of ``status`` (and the solution's ``residual``) did not answer."""
        if status > 0:
            return f"kernel residual {residual:.1e} above the tolerance"
        return f"kernel status {SolverStatus(status).name if status in _STATUS_CODES else status}"

    def warm(self, x: np.ndarray, lam, qp: QPData) -> None:
        """Warm start of the next call from another solver's answer ``x`` (n,) to ``qp``: the signs of its
        multipliers ``lam`` (bounds, equality rows, inequality rows; > 0 at an upper bound) when of the QP's size,
        else the bounds that ``x`` meets (to 1e-9 relative)."""
        n, p, m = self.state.shape[0], self.rstate.shape[0], qp.A.shape[0]
        if lam is not None and len(lam) == n + m + p:
            lam = np.asarray(lam)
            self.state[:] = np.sign(lam[:n])
            self.rstate[:] = np.sign(lam[n + m:])
        else:
            lb, ub = qp.lb, qp.ub
            lo, hi = np.isfinite(lb), np.isfinite(ub)  # an infinite bound is never active
            self.state[lo & (x <= np.where(lo, lb, 0.0) + 1e-9 * np.maximum(1.0, np.abs(np.where(lo, lb, 0.0))))] = -1
            self.state[hi & (x >= np.where(hi, ub, 0.0) - 1e-9 * np.maximum(1.0, np.abs(np.where(hi, ub, 0.0))))] = 1
