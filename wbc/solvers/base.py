"""The interface every QP backend implements (:class:`QPBackend`) and the counted work of a tick (:class:`TickWork`).

Every backend solves

    min_x ½ xᵀ H x + gᵀ x   s.t.   A x = b,   l ≤ C x ≤ u,   lb ≤ x ≤ ub

and returns x, or raises :class:`~wbc.exceptions.SolverError`. After a solve, the solution is checked against every
constraint (:meth:`QPBackend.solve`): a violation above the backend's tolerance is a failure; one below it is
projected onto the bounds so that integrating x never crosses a joint limit. Before a failure is declared, the
problem is re-solved by independent backends (:meth:`QPBackend.confirm`).

:class:`QPBackend` builds three backends of the sibling modules itself (ProxQP and qpsolvers for the independent
re-solve, DAQP for the projection of :meth:`QPBackend.polish`); as those modules import this one, each registers its
class here on import (:func:`register_backend_class`).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from time import thread_time
from typing import Callable

import numpy as np
import qpsolvers

from wbc.exceptions import InfeasibleProblemError, SolverError
from wbc.solvers.linalg import scaled_row_violation

__all__ = ["INFINITE_BOUND", "ITERATIONS_PER_SOLVE", "POLISH_RANGE", "PROX_ITERATIONS_PER_SOLVE", "QPBackend", "TickWork",
           "register_backend_class"]

#: stands for an infinite bound where a backend needs a finite number
INFINITE_BOUND = 1e10
#: work (:class:`TickWork` solves) an independent re-solve of :meth:`QPBackend.confirm` counts: ProxQP's cold solve
#: of an infeasible QP runs to its iteration cap (200 × 100), ≈ 580 solves of a humanoid tick's QP; the others one
_CONFIRM_WORK = {"proxqp": 580}


#: active-set iterations counted as one more :class:`TickWork` solve (a kinematic QP solve without them takes about
#: as long as this many DAQP iterations)
ITERATIONS_PER_SOLVE = 150
#: the same for DAQP's proximal-point iterations (``eps_prox`` > 0, the strict cascade's levels): each costs about
#: twice an iteration without the proximal term on a humanoid's kinematic QP
PROX_ITERATIONS_PER_SOLVE = 75


#: Largest scaled violation of a solver's answer that :meth:`QPBackend.polish` tries to repair.
POLISH_RANGE = 1e-3

#: The backend classes :class:`QPBackend` builds, by role (:func:`register_backend_class`).
_BACKEND_CLASSES: dict[str, type] = {}


def register_backend_class(role: str) -> Callable[[type], type]:
    """Class decorator: the decorated :class:`QPBackend` subclass is the one built for ``role`` (``"daqp"``,
    ``"proxqp"`` or ``"qpsolvers"``) by :meth:`QPBackend.confirm` and :meth:`QPBackend.polish`.

    Returns:
        The decorator (it returns the class unchanged).
    """

    def register(cls: type) -> type:
        _BACKEND_CLASSES[role] = cls
        return cls

    return register


def cpu_time() -> float:
    """CPU time (s) of the calling thread (``time.thread_time``, looked up at each call): what a tick computes, not
    the time other processes take the core from it."""
    return thread_time()


class TickWork:
    """Work of one control tick: the QP solves done so far, against a cap.

    A controller shares one instance with all its backends (``QPBackend.work``) and resets it at the start of each
    tick; every solve attempt (warm, cold retry) and every independent re-solve of :meth:`QPBackend.solve` adds
    one to ``solves`` (an attempt one more per :data:`ITERATIONS_PER_SOLVE` iterations its solver took): a count
    keeps a tick's answer a function of its inputs.

    Clock guard (``clock``: seconds of CPU time counted as one solve, ``math.inf`` by default: off): ``solves``
    reads max(counted solves, CPU time of the calling thread since :meth:`reset` / ``clock``), so every limit on the
    count (:meth:`spent`, :meth:`wbc.solvers.daqp.DaqpBackend.call_limit`) also holds on the tick's CPU time; a tick
    that reaches a limit by its clock first has an answer that depends on the machine's speed and load.

    Attributes:
        solves: work of the current tick, in solves (≥ 0; a float once the clock guard counts).
        cap: solves after which the tick's optional stages stop (≥ 0, ``math.inf``: no cap); an independent
            re-solve starts only when its count (:meth:`QPBackend.confirm`) fits under it.
        reserve: solves held back for a later stage of the tick (≥ 0, finite; 0 after :meth:`reset`), counted as
            done by :meth:`spent` and :meth:`wbc.solvers.daqp.DaqpBackend.call_limit`
            (``KinematicController.WEIGHTED_RESERVE``).
        ticks: calls of :meth:`reset` so far (a backend tells the ticks apart by it: ``FastBackend``'s give-ups).
        timer: the CPU clock read (s; default :func:`cpu_time`, the calling thread's; a test injects a fake one).
    """

    __slots__ = ("_solves", "cap", "_clock", "_t0", "reserve", "ticks", "timer")

    def __init__(self, cap: float = math.inf, clock: float = math.inf, timer=None):
        timer = cpu_time if timer is None else timer
        self.timer = timer
        self.ticks = 0
        self._solves = 0
        self.cap = cap
        self._clock = clock
        self._t0 = timer() if clock < math.inf else None
        self.reserve = 0.0

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
        """``solves += n`` (the same number) in one method call: with the clock guard on, the counted solves become
        :attr:`solves` (the larger of the count and the CPU time in solves) plus n; without it, the count plus n."""
        if self._clock < math.inf:
            self._solves = self.solves + n
        else:
            self._solves += n

    def reset(self, cap: float, clock: float = math.inf) -> None:
        """Start a tick: no solve yet, ``cap`` solves allowed; ``clock``: seconds of CPU time counted as one solve
        (``math.inf``: counted solves only; the clock is then not read here, a system call every tick)."""
        self.ticks += 1
        self._solves = 0
        self.cap = cap
        self._clock = clock
        self._t0 = self.timer() if clock < math.inf else None
        self.reserve = 0.0

    def seconds(self) -> float:
        """CPU time (s, ``time.thread_time`` of the calling thread) since :meth:`reset` with the clock guard; without
        it (``clock`` = ``math.inf``) since the tick's first call of this method (0.0 at that call): only the
        difference of two calls is meaningful then."""
        if self._t0 is None:
            self._t0 = self.timer()
            return 0.0
        return self.timer() - self._t0

    def spent(self, factor: float = 1.0, ahead: float = 0.0) -> bool:
        """``factor`` × cap solves are done (``reserve`` counted as done), or would be after ``ahead`` more (≥ 0:
        the counted work of a stage about to start, as the largest such stage so far counted; 0: none)."""
        if ahead:
            return self.solves + self.reserve + ahead > factor * self.cap
        return self.solves + self.reserve >= factor * self.cap


class QPBackend(ABC):
    """Common interface. ``tolerance`` is the largest constraint violation accepted (in constraint units)."""

    name: str = ""
    tolerance: float = 1e-6

    @abstractmethod
    def _solve(self, H, g, A, b, C, l, u, lb, ub) -> np.ndarray | None:
        """Raw solution, or None on failure."""

    #: active-set iterations of the last solver call (0 for a backend that does not report them).
    last_iterations: int = 0
    #: iterations of this backend's solver counted as one more :class:`TickWork` solve (:data:`ITERATIONS_PER_SOLVE`;
    #: :data:`PROX_ITERATIONS_PER_SOLVE` for DAQP with a proximal term)
    iterations_per_solve: int = ITERATIONS_PER_SOLVE
    #: tick solutions rescued by the independent re-solve (the backend's own solve failed or violated a row).
    rescues: int = 0
    #: how the last failure was confirmed ('' until one): the independent solvers that also found no solution.
    last_confirmation: str = ""
    #: the independent solvers that ran in the last :meth:`confirm` (names; empty when none ran)
    last_confirmers: tuple | list = ()
    #: the counted work of the current control tick (:class:`TickWork`, shared by a controller's backends; :meth:`solve`),
    #: or None (default): no count, no limit.
    work: "TickWork | None" = None
    #: retry a failed solve (from a cold start, :meth:`_solve_cold`, and a backend's own fallbacks) before declaring
    #: it failed; off: one solver call per solve (a trial whose failure is an answer, one step of a relaxation ladder)
    cold_retry: bool = True
    #: names of the independent solvers of :meth:`confirm`, in the order they are tried.
    independent: tuple[str, ...] = ("proxqp", "quadprog", "daqp")

    def solve(self, H, g, A, b, C, l, u, lb, ub, *, confirm: bool = True) -> np.ndarray:
        """Solve the QP (module docstring). A/C may have 0 rows; lb/ub are (n,) with ±inf for free entries.

        Tolerance policy (every backend, both controller levels): the answer's largest scaled violation
        (:meth:`scaled_violation`: each row against ``tolerance · max(1, |rhs|, Σ_j |a_ij x_j|)``) is at most
        ``tolerance``; within :data:`POLISH_RANGE` it is polished (:meth:`polish`); bound excess is projected onto
        [lb, ub]. Before a failure is declared the independent solvers re-solve it (:meth:`confirm`);
        ``confirm=False`` skips that (the inverse-dynamics controller: its time is unbounded), and once ``work``
        reaches its cap the ones not yet run are skipped (the failure then reported unconfirmed).

        Returns:
            x (n,), within [lb, ub] exactly.

        Raises:
            SolverError: no backend found an x meeting every row to tolerance; the message gives the largest
                scaled row violation (the number that was tested) and the independent solvers that confirmed.
                It is an InfeasibleProblemError only when ``confirm`` is True and at least one independent solver
                ran and failed too (``last_confirmers``); none run — ``independent`` empty, none installed, or the
                tick's count spent before the first — leaves it unconfirmed, as with ``confirm=False``.
        """
        # a warm start can mislead an active-set solver: once more from scratch before declaring failure
        for attempt in (self._solve, self._solve_cold) if self.cold_retry else (self._solve,):
            self.last_iterations = 0
            x = attempt(H, g, A, b, C, l, u, lb, ub)
            if self.work is not None:
                # one, plus one per iterations_per_solve iterations the attempt took (a DAQP call that ran to its
                # iteration cap costs several solves' time: counted so, the tick's later stages stop sooner)
                self.work.solves += 1 + int(self.last_iterations) // self.iterations_per_solve
            worst = math.inf
            if x is not None and np.isfinite(x).all():
                xc = np.minimum(np.maximum(x, lb), ub)
                worst = self.scaled_violation(x, xc, A, b, C, l, u, lb, ub)
                if worst <= self.tolerance:
                    return xc
                if worst <= POLISH_RANGE:
                    if self.work is not None:
                        self.work.solves += 1  # the polish: a least-squares correction, then a projection QP
                    xp = self.polish(x, A, b, C, l, u, lb, ub)
                    if xp is not None:
                        self.polished += 1
                        return xp
        self.last_confirmers = ()
        x_ind, confirmed = (self.confirm(H, g, A, b, C, l, u, lb, ub) if confirm
                            else (None, "nobody (independent re-solve skipped: confirm=False)"))
        if x_ind is not None:
            self.rescues += 1
            return x_ind
        self.last_confirmation = confirmed
        what = ("found no solution" if not math.isfinite(worst) else
                f"returned a solution violating constraints by {worst:.3g} (largest row violation, max-norm, "
                f"scaled by max(1, |rhs|); tolerance {self.tolerance:.3g})")
        if confirm and self.last_confirmers:  # (none ran — none asked, installed or within the count: unconfirmed)
            raise InfeasibleProblemError(f"QP backend {self.name!r} {what}; infeasibility confirmed by {confirmed}")
        raise SolverError(f"QP backend {self.name!r} {what} (not confirmed by an independent solver)")

    #: solutions accepted after :meth:`polish` (the solver's answer was within 1e-3 but above ``tolerance``).
    polished: int = 0

    def polish(self, x, A, b, C, l, u, lb, ub) -> np.ndarray | None:
        """Primal polish of a near-feasible solution: bounds within 1e-6 (scaled) of x or crossed are fixed at the
        bound, violated or active inequality rows at the crossed/active side, and the smallest correction of the
        free entries (least squares, ``numpy.linalg.lstsq``) makes the equality and those rows hold; then
        clipped to the bounds and checked like :meth:`solve`. The correction is of the size of the solver's error
        (cancellation in H⁻¹(g + Aᵀλ) for a large |g|), so the cost changes at second order.

        When that correction cannot hold the rows (the free entries do not span them: the feasible set is thin
        and some entry must leave the bound the solver put it on), x is projected onto the hard set instead:
        min ½‖y − x‖² subject to every row and bound (identity Hessian, DAQP's one-shot interface), which moves x by
        about the solver's error.

        Returns:
            the polished x (within [lb, ub], every row to ``tolerance``), or None.
        """
        x0 = x
        x = self._polish_lstsq(x, A, b, C, l, u, lb, ub)
        if x is not None:
            return x
        return self._project(x0, A, b, C, l, u, lb, ub)

    def _project(self, x, A, b, C, l, u, lb, ub) -> np.ndarray | None:
        """x projected onto the hard set (:meth:`polish`), or None when that fails the check of :meth:`solve`."""
        n = x.shape[0]
        try:
            y = _BACKEND_CLASSES["daqp"](tolerance=self.tolerance).raw_solve(
                np.eye(n), -np.where(np.isfinite(x), x, 0.0), A, b, C, l, u, lb, ub)
        except Exception:  # noqa: BLE001 — a failed projection polishes nothing
            return None
        if y is None or not np.isfinite(y).all():
            return None
        yc = np.minimum(np.maximum(y, lb), ub)
        return yc if self.scaled_violation(y, yc, A, b, C, l, u, lb, ub) <= self.tolerance else None

    def _polish_lstsq(self, x, A, b, C, l, u, lb, ub) -> np.ndarray | None:
        """Least-squares stage of :meth:`polish`."""
        x = np.minimum(np.maximum(x, lb), ub)
        for _ in range(2):
            near = 1e-6 * np.maximum(1.0, np.abs(x))
            fixed = (x <= lb + near) | (x >= ub - near)
            free = ~fixed
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
        return None

    def raw_solve(self, H, g, A, b, C, l, u, lb, ub) -> np.ndarray | None:
        """One call of this backend's solver on the QP (module docstring; warm start kept): its raw x (n,),
        unchecked (no row check, no bound projection, no retry, no count in ``work``), or None on failure. The
        independent re-solves of :meth:`confirm` and the projection of :meth:`polish` check it themselves."""
        return self._solve(H, g, A, b, C, l, u, lb, ub)

    def _solve_cold(self, H, g, A, b, C, l, u, lb, ub) -> np.ndarray | None:
        """Solve without any warm start (default: the same as ``_solve``)."""
        return self._solve(H, g, A, b, C, l, u, lb, ub)

    def confirm(self, H, g, A, b, C, l, u, lb, ub) -> tuple[np.ndarray | None, str]:
        """Independent re-solve: ProxQP (cold, eps_abs 1e-9) and one qpsolvers backend that is not this one
        (quadprog when H is positive definite, else DAQP one-shot with a relaxed primal tolerance).

        Returns:
            (x, '') with x projected onto the bounds when one of them meets every row to ``tolerance``
            (the check of :meth:`solve`), else (None, 'names of the solvers that failed').
        """
        tried = []
        self.last_confirmers = tried  # the independent solvers that ran (read by solve: confirmed or not)
        for name in self.independent:
            if name == self.name or name not in qpsolvers.available_solvers:
                continue
            if self.work is not None:
                cost = _CONFIRM_WORK.get(name, 1)
                if self.work.solves + cost > self.work.cap:
                    return None, (", ".join(tried) + " (then the tick's solve count was spent)" if tried else
                                  "no independent solver (tick budget spent: infeasibility not confirmed)")
                self.work.solves += cost
            try:
                if name == "proxqp":
                    backend = _BACKEND_CLASSES["proxqp"](tolerance=self.tolerance, max_iter=200)
                elif name == "quadprog":
                    if np.linalg.eigvalsh(H)[0] <= 1e-12 * max(1.0, np.abs(H).max()):
                        continue  # quadprog needs H positive definite
                    backend = _BACKEND_CLASSES["qpsolvers"]("quadprog", tolerance=self.tolerance)
                else:
                    backend = _BACKEND_CLASSES["qpsolvers"](name, tolerance=self.tolerance)
                x = backend.raw_solve(H, g, A, b, C, l, u, lb, ub)
            except Exception:  # noqa: BLE001 — a crashing independent solver confirms nothing either way
                x = None
            tried.append(name)
            if x is not None and np.isfinite(x).all():
                xc = np.minimum(np.maximum(x, lb), ub)
                worst = self.scaled_violation(x, xc, A, b, C, l, u, lb, ub)
                if worst <= self.tolerance:
                    return xc, ""
                if worst <= POLISH_RANGE:
                    xp = self.polish(x, A, b, C, l, u, lb, ub)
                    if xp is not None:
                        return xp, ""
        return None, ", ".join(tried) or ("no independent solver installed" if self.independent else
                                          "nobody (no independent solver asked: ``independent`` is empty)")

    @staticmethod
    def scaled_violation(x, xc, A, b, C, l, u, lb=None, ub=None) -> float:
        """Largest row violation of x in the max-norm, each row divided by max(1, |its right-hand side|,
        Σ_j |a_ij x_j|) (the row's own scale: the size of the terms whose sum is compared).

        Bounds are measured on x (excess over [lb, ub], scaled by the bound), the equality and inequality rows
        on its projection ``xc`` onto the bounds (the point that is returned). NaN/inf give inf. Float64 arrays with
        both bounds given go to the compiled body (:func:`wbc.solvers.linalg.scaled_row_violation`)."""
        if lb is not None and ub is not None:
            try:
                worst = scaled_row_violation(x, xc, A, b, C, l, u, lb, ub)
            except TypeError:  # not float64 arrays of the compiled signature: the numpy body below
                pass
            else:
                return worst if math.isfinite(worst) else math.inf
        worst = 0.0
        d = np.abs(x - xc)
        if d.size and d.max() > 0:
            ref = np.abs(np.where(x > xc, ub, lb)) if lb is not None else 0.0
            worst = float(np.max(d / np.maximum(1.0, ref)))
        if A.shape[0] or C.shape[0]:
            ax = np.abs(xc)
        if A.shape[0]:
            # row scale: max(1, |b_i|, Σ_j |A_ij x_j|) — the magnitude of the terms summed (floating-point error
            # of a_i·x is relative to it)
            r = np.abs(A @ xc - b) / np.maximum(np.maximum(1.0, np.abs(b)), np.abs(A) @ ax)
            worst = max(worst, float(r.max()))
        if C.shape[0]:
            cx = C @ xc
            ex = np.maximum(l - cx, cx - u)
            ref = np.where(l - cx > cx - u, np.abs(l), np.abs(u))
            ref = np.maximum(np.where(np.isfinite(ref), ref, 1.0), np.abs(C) @ ax)
            ex = np.where(ex > 0, ex, 0.0) / np.maximum(1.0, ref)
            worst = max(worst, float(ex.max()))
        return worst if math.isfinite(worst) else math.inf
