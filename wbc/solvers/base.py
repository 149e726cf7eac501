"""The interface every QP backend implements (:class:`QPBackend`: the QP of :mod:`wbc.solvers.qp_data`, the answer
checked against every constraint, polished, re-solved independently before a failure stands) and the counted work of
a tick (:class:`TickWork`). The backends :class:`QPBackend` builds itself (ProxQP, qpsolvers, DAQP) name their role
in their class statement (``class DaqpBackend(QPBackend, role="daqp")``): their modules import this one.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from time import thread_time

import numpy as np
import qpsolvers

from wbc.exceptions import InfeasibleProblemError, SolverError
from wbc.solvers.linalg import scaled_row_violation

__all__ = ["INFINITE_BOUND", "ITERATIONS_PER_SOLVE", "POLISH_RANGE", "PROX_ITERATIONS_PER_SOLVE", "QPBackend",
           "TickWork"]

#: stands for an infinite bound where a backend needs a finite number
INFINITE_BOUND = 1e10
#: :class:`TickWork` solves an independent re-solve of :meth:`QPBackend.confirm` counts (1 unless listed): ProxQP's
#: cold solve of an infeasible QP runs to its cap (200 × 100), ≈ 580 solves of a humanoid tick's QP
_CONFIRM_WORK = {"proxqp": 580}
#: active-set iterations counted as one more :class:`TickWork` solve (a kinematic QP solve takes about as long as
#: this many DAQP iterations); PROX_: DAQP's proximal iterations (``eps_prox`` > 0), each about twice as costly
ITERATIONS_PER_SOLVE = 150
PROX_ITERATIONS_PER_SOLVE = 75
#: Largest scaled violation of a solver's answer that :meth:`QPBackend.polish` tries to repair.
POLISH_RANGE = 1e-3
#: The backend classes :class:`QPBackend` builds, by role (``"daqp"``, ``"proxqp"``, ``"qpsolvers"``).
_BACKEND_CLASSES: dict[str, type] = {}


def cpu_time() -> float:
    """CPU time (s) of the calling thread (``time.thread_time``, looked up at each call)."""
    return thread_time()


class TickWork:
    """Work of one control tick: the QP solves done so far, against a cap.

    A controller shares one instance with all its backends (``QPBackend.work``) and resets it each tick; every solve
    attempt and independent re-solve adds one to ``solves`` (an attempt one more per :data:`ITERATIONS_PER_SOLVE`
    iterations): a count keeps a tick's answer a function of its inputs. Clock guard (``clock``: s of CPU time
    counted as one solve; ``math.inf``: off): ``solves`` reads max(count, CPU time since :meth:`reset` / ``clock``),
    so every limit on the count also holds on the tick's CPU time (and the answer then depends on the machine).

    Attributes:
        solves: work of the current tick, in solves (≥ 0; a float once the clock guard counts).
        cap: solves after which the tick's optional stages stop (≥ 0, ``math.inf``: no cap).
        reserve: solves held back for a later stage of the tick (≥ 0; 0 after :meth:`reset`), counted as done.
        ticks: calls of :meth:`reset` so far. timer: the CPU clock read (s; default :func:`cpu_time`).
    """

    __slots__ = ("_solves", "cap", "_clock", "_t0", "reserve", "ticks", "timer")

    def __init__(self, cap: float = math.inf, clock: float = math.inf, timer=None):
        self.timer = cpu_time if timer is None else timer
        self.ticks = -1  # (reset counts itself)
        self.reset(cap, clock)

    @property
    def solves(self) -> float:
        """Counted solves of the tick, or (clock guard) the tick's CPU time in solves when that is larger."""
        if self._clock < math.inf:
            return max(self._solves, (self.timer() - self._t0) / self._clock)
        return self._solves

    @solves.setter
    def solves(self, value: float) -> None:
        self._solves = value

    def add(self, n: float = 1) -> None:
        """``solves += n`` (with the clock guard: the count becomes :attr:`solves` + n)."""
        self._solves = self.solves + n

    def reset(self, cap: float, clock: float = math.inf) -> None:
        """Start a tick: no solve yet, ``cap`` solves allowed; ``clock``: as the class docstring (``math.inf``: the
        clock is not read, a system call saved)."""
        self.ticks += 1
        self._solves = 0
        self.cap = cap
        self._clock = clock
        self._t0 = self.timer() if clock < math.inf else None
        self.reserve = 0.0

    def seconds(self) -> float:
        """CPU time (s) since :meth:`reset` with the clock guard; without it since the tick's first call of this method
        (0.0 at that call)."""
        if self._t0 is None:
            self._t0 = self.timer()
            return 0.0
        return self.timer() - self._t0

    def spent(self, factor: float = 1.0, ahead: float = 0.0) -> bool:
        """``factor`` × cap solves are done (``reserve`` counted), or would be after ``ahead`` more (a stage about to
        start; 0: none)."""
        if ahead:
            return self.solves + self.reserve + ahead > factor * self.cap
        return self.solves + self.reserve >= factor * self.cap


class QPBackend(ABC):
    """Common interface. ``tolerance`` is the largest constraint violation accepted (in constraint units)."""

    name: str = ""
    tolerance: float = 1e-6

    def __init_subclass__(cls, role: str = "", **kwargs):
        """``role``: this subclass is the one :meth:`confirm` and :meth:`polish` build for it."""
        super().__init_subclass__(**kwargs)
        if role:
            _BACKEND_CLASSES[role] = cls

    @abstractmethod
    def _solve(self, H, g, A, b, C, l, u, lb, ub) -> np.ndarray | None:
        """Raw solution, or None on failure."""

    #: active-set iterations of the last solve attempt, every solver call it made (0: a backend that reports none).
    last_iterations: int = 0
    #: iterations counted as one more :class:`TickWork` solve
    iterations_per_solve: int = ITERATIONS_PER_SOLVE
    #: solutions rescued by the independent re-solve; solutions accepted after :meth:`polish`.
    rescues: int = 0
    polished: int = 0
    #: the independent solvers that ran in the last :meth:`confirm` (and found no solution, when it failed)
    last_confirmers: tuple | list = ()
    #: the current tick's counted work (:class:`TickWork`, shared by a controller's backends), or None: no limit.
    work: "TickWork | None" = None
    #: retry a failed solve cold (:meth:`_solve_cold`) before declaring it failed; off: one solver call per solve
    cold_retry: bool = True
    #: names of the independent solvers of :meth:`confirm`, in the order they are tried.
    independent: tuple[str, ...] = ("proxqp", "quadprog", "daqp")

    def solve(self, H, g, A, b, C, l, u, lb, ub, *, confirm: bool = True) -> np.ndarray:
        """Solve the QP (:mod:`wbc.solvers.qp_data`; A/C may have 0 rows, ±inf for free bounds).

        Tolerance policy (every backend): the answer's largest scaled violation (:meth:`scaled_violation`) is at most
        ``tolerance``; within :data:`POLISH_RANGE` it is polished (:meth:`polish`); bound excess is projected onto
        [lb, ub]. Before a failure is declared the independent solvers re-solve it (:meth:`confirm`; skipped with
        ``confirm=False``, and those past ``work``'s cap).

        Returns:
            x (n,), within [lb, ub] exactly.

        Raises:
            SolverError: no backend found an x meeting every row to tolerance (the message gives the largest scaled
                violation); an InfeasibleProblemError when ``confirm`` is True and an independent solver ran and
                failed too (``last_confirmers``).
        """
        # a warm start can mislead an active-set solver: once more from scratch before declaring failure
        for attempt in (self._solve, self._solve_cold) if self.cold_retry else (self._solve,):
            self.last_iterations = 0
            x = attempt(H, g, A, b, C, l, u, lb, ub)
            if self.work is not None:
                # one, plus one per iterations_per_solve iterations the attempt took (a DAQP call that ran to its
                # iteration cap costs several solves' time: counted so, the tick's later stages stop sooner)
                self.work.solves += 1 + int(self.last_iterations) // self.iterations_per_solve
            xc, worst = self._checked(x, A, b, C, l, u, lb, ub, counted=True)
            if xc is not None:
                return xc
        self.last_confirmers = ()
        x_ind, confirmed = self.confirm(H, g, A, b, C, l, u, lb, ub) if confirm else (None, "")
        if x_ind is not None:
            self.rescues += 1
            return x_ind
        what = ("found no solution" if not math.isfinite(worst) else
                f"returned a solution violating constraints by {worst:.3g} (largest row violation, max-norm, "
                f"scaled by max(1, |rhs|); tolerance {self.tolerance:.3g})")
        if confirm and self.last_confirmers:  # (none ran — none asked, installed or within the count: unconfirmed)
            raise InfeasibleProblemError(f"QP backend {self.name!r} {what}; infeasibility confirmed by {confirmed}")
        raise SolverError(f"QP backend {self.name!r} {what} (not confirmed by an independent solver)")

    def _checked(self, x, A, b, C, l, u, lb, ub, counted: bool) -> tuple[np.ndarray | None, float]:
        """(x as the tolerance policy of :meth:`solve` accepts it, or None; x's largest scaled violation, inf for no or
        a non-finite x). ``counted``: the polish counts one ``work`` solve, and ``polished`` when it answers."""
        if x is None or not np.isfinite(x).all():
            return None, math.inf
        xc = np.minimum(np.maximum(x, lb), ub)
        worst = self.scaled_violation(x, xc, A, b, C, l, u, lb, ub)
        if worst <= self.tolerance:
            return xc, worst
        if worst <= POLISH_RANGE:
            if counted and self.work is not None:
                self.work.solves += 1  # the polish: a least-squares correction, then a projection QP
            xp = self.polish(x, A, b, C, l, u, lb, ub)
            if xp is not None:
                self.polished += counted
                return xp, worst
        return None, worst

    def polish(self, x, A, b, C, l, u, lb, ub) -> np.ndarray | None:
        """Primal polish of a near-feasible solution: bounds within 1e-6 (scaled) of x or crossed are fixed, violated
        or active rows held at that side, and the least-squares correction of the free entries makes those rows and
        the equalities hold (of the size of the solver's error: the cost changes at second order). When the free
        entries do not span the rows, x is projected onto the hard set instead (min ½‖y − x‖², DAQP).

        Returns:
            the polished x (within [lb, ub], every row to ``tolerance``), or None.
        """
        x0 = x
        x = np.minimum(np.maximum(x, lb), ub)
        for _ in range(2):
            near = 1e-6 * np.maximum(1.0, np.abs(x))
            free = ~((x <= lb + near) | (x >= ub - near))
            rows, rhs = [A], [b]
            if C.shape[0]:
                cx = C @ x
                with np.errstate(invalid="ignore"):  # an infinite bound: inf - inf = nan compares False (inactive)
                    act_l = cx <= l + 1e-6 * np.maximum(1.0, np.abs(l))
                    act_u = cx >= u - 1e-6 * np.maximum(1.0, np.abs(u))
                act = act_l | act_u
                rows.append(C[act])
                rhs.append(np.where(act_l, l, u)[act])
            M = np.vstack(rows)
            if M.shape[0] == 0 or not free.any():
                break
            r = np.concatenate(rhs) - M @ x
            dx = np.linalg.lstsq(M[:, free], r, rcond=None)[0]
            x = x.copy()
            x[free] += dx
            x = np.minimum(np.maximum(x, lb), ub)
            if self.scaled_violation(x, x, A, b, C, l, u, lb, ub) <= self.tolerance:
                return x
        try:  # the projection of x onto the hard set
            y = _BACKEND_CLASSES["daqp"](tolerance=self.tolerance).raw_solve(
                np.eye(x.shape[0]), -np.where(np.isfinite(x0), x0, 0.0), A, b, C, l, u, lb, ub)
        except Exception:  # noqa: BLE001 — a failed projection polishes nothing
            return None
        return None if y is None else self.accepted(y, A, b, C, l, u, lb, ub, self.tolerance)

    def raw_solve(self, H, g, A, b, C, l, u, lb, ub) -> np.ndarray | None:
        """One call of this backend's solver (warm start kept): its raw x (n,), unchecked and uncounted, or None."""
        return self._solve(H, g, A, b, C, l, u, lb, ub)

    def _solve_cold(self, H, g, A, b, C, l, u, lb, ub) -> np.ndarray | None:
        """Solve without any warm start (default: the same as ``_solve``)."""
        return self._solve(H, g, A, b, C, l, u, lb, ub)

    def confirm(self, H, g, A, b, C, l, u, lb, ub) -> tuple[np.ndarray | None, str]:
        """Independent re-solve by the solvers of ``independent`` other than this one (quadprog only when H is
        positive definite), each counted in ``work`` while it fits under the cap.

        Returns:
            (x, '') when one of them meets the check of :meth:`solve`, else (None, 'names of the solvers that failed',
            '' when none ran).
        """
        tried = self.last_confirmers = []  # the independent solvers that ran (read by solve: confirmed or not)
        for name in self.independent:
            if name == self.name or name not in qpsolvers.available_solvers:
                continue
            if self.work is not None:
                cost = _CONFIRM_WORK.get(name, 1)
                if self.work.solves + cost > self.work.cap:
                    return None, ", ".join(tried) + (" (then the tick's solve count was spent)" if tried else "")
                self.work.solves += cost
            try:
                if name == "quadprog" and np.linalg.eigvalsh(H)[0] <= 1e-12 * max(1.0, np.abs(H).max()):
                    continue  # quadprog needs H positive definite
                backend = (_BACKEND_CLASSES["proxqp"](tolerance=self.tolerance, max_iter=200) if name == "proxqp" else
                           _BACKEND_CLASSES["qpsolvers"](name, tolerance=self.tolerance))
                x = backend.raw_solve(H, g, A, b, C, l, u, lb, ub)
            except Exception:  # noqa: BLE001 — a crashing independent solver confirms nothing either way
                x = None
            tried.append(name)
            x = self._checked(x, A, b, C, l, u, lb, ub, counted=False)[0]
            if x is not None:
                return x, ""
        return None, ", ".join(tried)

    @staticmethod
    def accepted(x, A, b, C, l, u, lb, ub, tolerance: float) -> np.ndarray | None:
        """x (n,) projected onto [lb, ub] when it is finite and meets every row to ``tolerance``
        (:meth:`scaled_violation`), else None."""
        if not np.isfinite(x).all():
            return None
        xc = np.minimum(np.maximum(x, lb), ub)
        return xc if QPBackend.scaled_violation(x, xc, A, b, C, l, u, lb, ub) <= tolerance else None

    @staticmethod
    def scaled_violation(x, xc, A, b, C, l, u, lb, ub) -> float:
        """Largest row violation in the max-norm, each row divided by max(1, |its right-hand side|, Σ_j |a_ij x_j|);
        bounds measured on x (scaled by the bound), rows on its projection ``xc`` onto them
        (:func:`wbc.solvers.linalg.scaled_row_violation`, on float64 copies of other arrays). NaN/inf give inf."""
        try:
            worst = scaled_row_violation(x, xc, A, b, C, l, u, lb, ub)
        except TypeError:  # not float64 arrays of the compiled signature
            worst = scaled_row_violation(*(np.asarray(a, dtype=float) for a in (x, xc, A, b, C, l, u, lb, ub)))
        return worst if math.isfinite(worst) else math.inf
