"""The compiled exact backend, ``fast``: :class:`FastBackend`, the in-house active-set kernels with DAQP as fallback.

A QP goes to :func:`wbc.solvers.active_set.solve_qp_into` (Goldfarb–Idnani), warm-started. It ends only at a KKT
point (the exact optimum); a call that does not (iteration cap, H not positive definite, dependent equalities) goes
to the :class:`~wbc.solvers.daqp.DaqpBackend` it extends.
"""

from __future__ import annotations

import numpy as np

from wbc.solvers.active_set import kinematic_settings, load_active_set_kernels, qp_ws_sizes, solve_qp_into
from wbc.solvers.daqp import DaqpBackend

__all__ = ["FastBackend"]


class FastBackend(DaqpBackend):
    """The compiled kernels of the module docstring, then DAQP for every call they do not answer.

    Args:
        tolerance: largest constraint violation accepted (constraint units).
        max_iter: working-set iterations before handing the problem to DAQP.
        kernel_rows: problems with inequality rows go to the kernel first (True) or to DAQP at once (False: the
            inverse-dynamics QP, where DAQP is cheaper: benchmarks/README.md, "Tick time bounded at both levels").
        **settings: DAQP settings for the fallback.

    Attributes:
        count_give_ups (bool): under a tick's counted work (``work``), a kernel attempt that gives up counts one
            solve and the tick's later problems of its shape go to DAQP at once. Default False.
        skip_give_ups (bool): the same without counting the attempt.
        last_kernel_iterations: working-set iterations of the last kernel call (negative: its exit code).
        kernel_solves / fallbacks: calls answered by the kernel / by DAQP.
    """

    name = "fast"

    def __init__(self, tolerance: float = 1e-6, max_iter: int = 100, kernel_rows: bool = True, **settings):
        super().__init__(tolerance=tolerance, **settings)
        self.max_iter = int(max_iter)
        self.kernel_rows = bool(kernel_rows)
        self._n = self._p = -1  # variables and rows of the kernel's working sets
        self._eq_residual = np.empty(1)
        self.last_kernel_iterations = 0
        self.kernel_solves = 0
        self.fallbacks = 0
        self._rows_failed = False
        self.count_give_ups = False
        self.skip_give_ups = False
        self._gave_up: tuple | None = None  # (the tick's work, its tick, the problem's shape) of the last give-up
        load_active_set_kernels()  # compile / load the kernel here, once per process, not in a controller's first tick

    def _kernel(self, H, g, A, b, C, l, u, lb, ub) -> bool:
        """One warm-started kernel call; True when it ended at a KKT point within ``tolerance`` (x in ``self._x``),
        else its working sets are cleared. The bounds' working set is kept while n stays, the rows' while n and p
        stay; the workspaces are kept per shape (a support switch revisits a few)."""
        n, m, p = H.shape[0], A.shape[0], C.shape[0]
        if n != self._n:
            self._n, self._p, self._ws = n, -1, {}
            self._state, self._x, self._z = np.zeros(n, np.int8), np.empty(n), np.zeros(n)
        if p != self._p:
            self._p, self._rstate, self._mu = p, np.zeros(p, np.int8), np.zeros(p)
        ws = self._ws.get((m, p))
        if ws is None:
            fsize, isize = qp_ws_sizes(n, m, p)
            ws = self._ws[m, p] = (np.zeros(m), np.empty(fsize), np.empty(isize, np.int64))
        self._nu, fw, iw = ws
        # plain tuples (QPData, QPWarmArrays, ActiveSetSettings): numba types them faster (4.3 µs a call, namedtuples
        # 9.7 µs)
        it = solve_qp_into((H, g, A, b, C, l, u, lb, ub), (self._state, self._rstate, self._x, self._nu, self._mu,
                                                           self._z, self._eq_residual), kinematic_settings(self.max_iter),
                           fw, iw)
        self.last_kernel_iterations = it
        if it > 0 and self._eq_residual[0] <= self.tolerance:
            self.kernel_solves += 1
            return True
        self._state[:] = 0
        self._rstate[:] = 0
        return False

    def solve(self, H, g, A, b, C, l, u, lb, ub, *, confirm: bool = True) -> np.ndarray:
        """As :meth:`wbc.solvers.base.QPBackend.solve`: a kernel solution (its residual within ``tolerance``) as is,
        else DAQP's, through the general check.

        Raises:
            SolverError: the DAQP fallback failed.
        """
        p = C.shape[0]
        if p and not self.kernel_rows:
            return super().solve(H, g, A, b, C, l, u, lb, ub, confirm=confirm)
        work = self.work
        shape = (H.shape[0], A.shape[0], p)
        if (self.count_give_ups or self.skip_give_ups) and work is not None \
                and self._gave_up == (work, work.ticks, shape):
            pass  # the kernel gave up on a problem of this shape earlier in this tick: its re-solves go to DAQP
        elif p and self._rows_failed:
            # the kernel failed on the previous call with rows (degenerate rows defeat it for stretches of ticks):
            # this one goes to DAQP, the next to the kernel again
            self._rows_failed = False
        elif self._kernel(H, g, A, b, C, l, u, lb, ub):
            if self.work is not None:
                self.work.solves += 1  # a solve attempt like any other (TickWork): a re-solve loop is counted
            return self._x.copy()
        else:
            self._rows_failed = p > 0
            if (self.count_give_ups or self.skip_give_ups) and work is not None:
                if self.count_give_ups:
                    work.solves += 1  # the attempt that gave up: a solve attempt like any other (TickWork)
                self._gave_up = (work, work.ticks, shape)
        self.fallbacks += 1
        x = super().solve(H, g, A, b, C, l, u, lb, ub, confirm=confirm)
        if H.shape[0] == self._n:
            # warm start the kernel's next call from the bounds (and rows) DAQP found active (upper side first)
            self._state[:] = np.where(x >= ub - 1e-12, 1, np.where(x <= lb + 1e-12, -1, 0))
            if p and self._p == p:
                cx = C @ x
                self._rstate[:] = np.where(cx >= u - 1e-12, 1, np.where(cx <= l + 1e-12, -1, 0))
        return x

