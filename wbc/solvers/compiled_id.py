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

from collections import namedtuple

import numba as nb
import numpy as np

from wbc.compiled import CHECK_TYPES, FASTMATH, specialise
from wbc.exceptions import SolverError
from wbc.solvers.active_set import ActiveSetArrays, ActiveSetSettings, carve_dense, dual_active_set, qp_ws_sizes
from wbc.solvers.qp_data import QPData, QPSolution
from wbc.solvers.status import SolverStatus

__all__ = ["CompiledIDSolver", "IDSolveBuffers", "KERNEL_ITERATION_COST",
           "KERNEL_ITERATIONS_AFTER_GIVE_UP", "id_solve", "kernel_iterations"]

#: the buffers of :func:`id_solve` (:func:`id_solve_buffers`)
IDSolveBuffers = namedtuple("IDSolveBuffers", "ws_s ws_f ws_i mult out")

#: squared sine (in the H⁻¹ metric) between a constraint and the span of the working set below which it counts as
#: dependent on it (the ID tick's :func:`~wbc.solvers.active_set.dual_active_set`)
DEPENDENCE_TOL = 1e-10
#: relative pivot of S² below which the working set counts as dependent (the kinematic tick's too)
PIVOT_TOL = 1e-24
#: violation (constraint units: m/s², N, N·m) beyond which a bound or row enters the working set (the same solve)
PRIMAL_TOL = 1e-11
#: largest constraint violation (m/s², N, N·m) of the solve's final KKT check (the same solve)
VERIFY_TOL = 1e-9

#: CPU time (s) of one working-set iteration of :func:`id_solve` with its share of the set-up (benchmarks/README.md,
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


def id_solve_buffers(n: int, p: int, me: int) -> tuple[np.ndarray, ...]:
    """The five zeroed buffers of :func:`id_solve` (:data:`IDSolveBuffers`) for n variables, p inequality rows and up
    to ``me`` equality rows: ``ws_s`` int8 (n + p,) the working set (state, rstate); ``ws_f`` float64, ``ws_i`` int64
    the workspaces of :func:`~wbc.solvers.active_set.carve_dense`; ``mult`` float64 (me + p,) ν then μ; ``out``
    float64 (1 + n,) the residual, then x."""
    fsize, isize = qp_ws_sizes(n, me, p)
    return (np.zeros(n + p, np.int8), np.zeros(fsize), np.zeros(isize, np.int64), np.zeros(me + p), np.zeros(1 + n))


@nb.njit(cache=True, nogil=True, fastmath=FASTMATH)
def id_solve(qp, max_iter, buffers):
    """The exact optimum of the ID QP ``qp`` (H, g, A, b, C, l, u, lb, ub) into ``buffers`` (:data:`IDSolveBuffers`:
    x, the residual, the working set read as warm start and written), by the module docstring's dual active set
    capped at ``max_iter`` iterations. Returns the iterations or a negative
    :class:`~wbc.solvers.status.SolverStatus` code."""
    H, g, A, b, C, l, u, lb, ub = qp
    ws_s, ws_f, ws_i, mult, out = buffers
    n, m, p = H.shape[0], A.shape[0], C.shape[0]
    space, lam_b, lam_r, z, rb, wout = carve_dense(ws_f, ws_i, n, m, p, PIVOT_TOL)
    it = dual_active_set((H, g, A, b, m, C, l, u, lb, ub), space,
                         ActiveSetArrays(ws_s[:n], ws_s[n:], out[1:], mult[:mult.size - p], mult[mult.size - p:],
                                         lam_b, lam_r, z, rb, wout),
                         ActiveSetSettings(max_iter, PRIMAL_TOL, 0.0, DEPENDENCE_TOL, 0.0, True, True, 1, VERIFY_TOL))
    out[0] = wout[0]
    return it


class CompiledIDSolver:
    """:func:`id_solve` behind the solver protocol: ``solve(QPData) → QPSolution``.

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
        self.buffers = IDSolveBuffers(*id_solve_buffers(n, p, me))
        self.state, self.rstate = self.buffers.ws_s[:n], self.buffers.ws_s[n:]
        self.residual, self.x = self.buffers.out[:1], self.buffers.out[1:]
        self.max_iterations = 100
        self.tolerance = 1e-6
        self.solves = 0
        self.fallbacks = 0
        self.gave_up = False
        self.cap = self.max_iterations  # the last call's iteration cap
        self._entry = None  # id_solve specialised to C-contiguous float64 arrays (wbc.compiled.specialise)
        self._solution = QPSolution(self.x, self.name)  # every answer: x is this view of the buffer
        self._checked: tuple = (None, False)  # (the last QPData, its arrays all C-contiguous)

    def solve(self, qp: QPData) -> QPSolution:
        """The exact optimum of ``qp`` (x a view of this solver's buffer, overwritten by the next call).

        Raises:
            SolverError: the call did not end in a KKT point within :attr:`tolerance` (the message names its status).
        """
        self.cap = min(self.max_iterations, KERNEL_ITERATIONS_AFTER_GIVE_UP) if self.gave_up else self.max_iterations
        self.gave_up = False
        if qp is not self._checked[0]:  # the formulation hands over the same QPData of views tick after tick
            self._checked = (qp, not CHECK_TYPES and all(a.flags.c_contiguous for a in qp))
        if self._checked[1]:
            if self._entry is None:
                self._entry = specialise(id_solve, qp, self.cap, self.buffers)
            it = self._entry(qp, self.cap, self.buffers)
        else:
            it = id_solve(qp, self.cap, self.buffers)
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
