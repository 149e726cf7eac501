"""The route a control tick took, and the result base shared by both controllers.

Each level has four routes (``docs/architecture.md``, "Routes of a tick"):

* kinematic (:class:`wbc.controllers.kinematic.KinematicController`, :data:`KINEMATIC_ROUTES`):
  ``compiled`` (the assembled flat QP on the compiled solver, :func:`wbc.formulations.velocity_kernel.kinematic_solve`),
  ``general`` (the assembled flat QP on the controller's backend),
  ``levels`` (the strict hierarchy, :mod:`wbc.solvers.hierarchy`), ``fallback`` (a safe command: ``constraints_only``,
  ``contacts_held``, ``trust_region`` or ``hold``);
* inverse dynamics (:class:`wbc.controllers.inverse_dynamics.InverseDynamicsController`, :data:`ID_ROUTES`): ``kernel``
  (the compiled tick, :mod:`wbc.formulations.idkernel`), ``general`` (the assembled QP on the backend),
  ``relaxed`` (the QP without joint bounds and torque limits), ``fallback`` (``hold``, ``feasible`` or ``gravity``).

A route carries qualifiers as fields (:class:`TickPath`): the solver, the fallback kind, ``return_rate`` (the
return rate of joints outside their limits was relaxed) and ``budget`` (twice the tick's budget stopped its
optional stages; inverse dynamics: the clock guard cut a check of the failed full QP) and ``weighted`` (the
kinematic clock guard answered the strict levels with their weighted single-QP formulation). Its string form
(``str(path)``) is the one the logs, summaries and older code read:
``compiled``, ``general:<solver>[+return_rate][+budget]``,
``levels[+return_rate][+budget][+weighted]``,
``kernel``, ``relaxed:<solver>[+budget]``, ``fallback:<kind>``; :meth:`TickPath.parse` reads it back.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from wbc.exceptions import InvalidInputError

__all__ = ["KINEMATIC_ROUTES", "ID_ROUTES", "ROUTES", "PATH_DTYPE", "TickPath", "TickResult", "TickResultBase",
           "count_paths", "solved_result"]

#: The routes of a kinematic tick (``TickResult.path.route``).
KINEMATIC_ROUTES = ("compiled", "general", "levels", "fallback")
#: The routes of an inverse-dynamics tick (``IDCommand.path.route``).
ID_ROUTES = ("kernel", "general", "relaxed", "fallback")
#: Every route name of either level.
ROUTES = tuple(dict.fromkeys(KINEMATIC_ROUTES + ID_ROUTES))

#: numpy dtype of a per-tick log of path string forms (run logs: fixed-width text, no pickled objects).
PATH_DTYPE = "<U48"

_SOLVER_SEP = {"compiled": "+", "kernel": "+", "general": ":", "relaxed": ":"}


@dataclass(frozen=True, eq=False)
class TickPath:
    """The route of one tick and its qualifiers (module docstring).

    Attributes:
        route: one of :data:`ROUTES`.
        solver: the backend that solved the tick's QP (``general``, ``relaxed``: its name, e.g. ``daqp``);
            '' for ``compiled``/``kernel`` (the compiled solver itself: a QP it gives up goes to the ``general``
            route), ``levels`` and ``fallback``.
        fallback: the safe command of a ``fallback`` route (e.g. ``constraints_only``, ``hold``, ``gravity``);
            '' otherwise.
        return_rate: the return rate of joints outside their position limits was relaxed (kinematic level).
        budget: twice the tick's budget stopped its optional stages; the last finished stage's command was kept
            (kinematic level); the clock guard cut a check of the failed full QP before the relaxed QP answered
            (inverse dynamics, ``relaxed:<solver>+budget``).
        weighted: the strict levels were solved as one weighted QP (each level's rows scaled by
            ``KinematicController.WEIGHTED_LEVEL_RATIO`` per level above the soft level), not as a cascade: the
            kinematic controller's answer when a cascade did not fit the tick's counted budget (or the clock
            guard's CPU time), and for the ticks after it (``levels`` only).

    A path equals its string form and hashes as it (``path == "general:daqp"``), so counters keyed by either agree.

    Raises:
        InvalidInputError: an unknown route, a ``fallback`` route without its kind or a kind on another route,
            ``weighted`` on a route other than ``levels``.
    """

    route: str
    solver: str = ""
    fallback: str = ""
    return_rate: bool = False
    budget: bool = False
    weighted: bool = False

    def __post_init__(self):
        if self.route not in ROUTES:
            raise InvalidInputError(f"unknown tick route {self.route!r}; valid: {', '.join(ROUTES)}")
        if (self.route == "fallback") != bool(self.fallback):
            raise InvalidInputError(f"a fallback kind is given exactly on the 'fallback' route, got route "
                                    f"{self.route!r} with fallback {self.fallback!r}")
        if self.solver and self.route not in _SOLVER_SEP:
            raise InvalidInputError(f"route {self.route!r} names no solver, got {self.solver!r}")
        if self.weighted and self.route != "levels":
            raise InvalidInputError(f"only the 'levels' route has a weighted form, got route {self.route!r}")

    def __str__(self) -> str:
        if self.route == "fallback":
            return f"fallback:{self.fallback}"
        s = self.route + (_SOLVER_SEP[self.route] + self.solver if self.solver else "")
        return (s + ("+return_rate" if self.return_rate else "") + ("+budget" if self.budget else "")
                + ("+weighted" if self.weighted else ""))

    def __format__(self, spec: str) -> str:
        return format(str(self), spec)

    def __eq__(self, other) -> bool:
        if isinstance(other, TickPath):
            return str(self) == str(other)
        if isinstance(other, str):
            return str(self) == other
        return NotImplemented

    def __hash__(self) -> int:
        return hash(str(self))

    @classmethod
    def parse(cls, text: str) -> TickPath:
        """The path of a string form (module docstring), e.g. ``"general:daqp+return_rate"``.

        Raises:
            InvalidInputError: not the string form of a path.
        """
        if not isinstance(text, str) or not text:
            raise InvalidInputError(f"a tick path is a non-empty string such as 'general:daqp', got {text!r}")
        head, *quals = text.split("+")
        route, _, arg = head.partition(":")
        solver = fallback = ""
        if route == "fallback":
            fallback = arg
        else:
            solver = arg
        if route in ("compiled", "kernel") and quals and quals[0] not in ("return_rate", "budget", "weighted"):
            solver = quals.pop(0)
        unknown = set(quals) - {"return_rate", "budget", "weighted"}
        if unknown:
            raise InvalidInputError(f"unknown qualifier(s) {sorted(unknown)} in tick path {text!r}; valid: "
                                    "return_rate, budget, weighted")
        return cls(route, solver, fallback, "return_rate" in quals, "budget" in quals, "weighted" in quals)

    def with_budget(self) -> TickPath:
        """This path with ``budget`` set."""
        return TickPath(self.route, self.solver, self.fallback, self.return_rate, True, self.weighted)


@dataclass(kw_only=True)
class TickResultBase:
    """What every controller's tick result says (the kinematic :class:`~wbc.tick.TickResult`, the
    inverse-dynamics :class:`~wbc.formulations.acceleration.IDCommand`).

    Attributes:
        ok: the tick's QP was solved (else a safe command was returned).
        message: why the tick failed or what it skipped ('' when ok and complete).
        timings: seconds per stage of the tick (keys per controller).
        conflicts: (constraint name, violation in its units) of the conflicting hard constraints, largest first.
        path: the route the tick took (:class:`TickPath`); None only before a tick set it.
        over_budget: the tick used more than its budget.
    """

    ok: bool = True
    message: str = ""
    timings: dict[str, float] = field(default_factory=dict)
    conflicts: list[tuple[str, float]] = field(default_factory=list)
    path: TickPath | None = None
    over_budget: bool = False


def count_paths(paths) -> dict[str, dict[str, int]]:
    """Ticks per route and per path of a sequence of paths (:class:`TickPath` or their string forms; '' entries,
    ticks without a QP controller, are skipped).

    Returns:
        ``{"ticks_per_route": {route: n}, "ticks_per_path": {string form: n}}``, each by decreasing count.

    Raises:
        InvalidInputError: an entry that is not the string form of a path.
    """
    per_path: dict[str, int] = {}
    for p in paths:
        key = str(p)
        if key:
            per_path[key] = per_path.get(key, 0) + 1
    per_route: dict[str, int] = {}
    for key, n in per_path.items():
        route = TickPath.parse(key).route
        per_route[route] = per_route.get(route, 0) + n
    order = lambda d: dict(sorted(d.items(), key=lambda kv: (-kv[1], kv[0])))  # noqa: E731
    return {"ticks_per_route": order(per_route), "ticks_per_path": order(per_path)}


@dataclass
class TickResult(TickResultBase):
    """Outcome of one control tick (the fields ``ok``, ``message``, ``timings``, ``conflicts``, ``path``,
    ``over_budget`` are those of :class:`wbc.tick.TickResultBase`, shared with the inverse-dynamics command).

    Attributes:
        v: (nv,) commanded generalized velocity; always finite (the safe command when the solve failed).
        ok: the QP was solved.
        message: failure reason ('' when ok).
        timings: seconds spent in 'assembly' (tasks + constraints) and 'solve' (including the fallback).
        conflicts: after a failed solve, (constraint name, violation in its units) of the hard constraints that
            conflict, largest first (:mod:`wbc.solvers.diagnosis`); empty when ok.
        fallback: '' when ok, else the safe command returned: 'constraints_only' (soft level under the constraint
            objects, hard tasks and strict levels left out), 'contacts_held' (the same with each contact frame held
            where it was when the current run of failed ticks began, its correction towards there scaled by 1,
            1/10 or 0: J_c v = 0) or 'hold' (v = 0). Every safe command other than 'hold' keeps the contact frames
            within ``sole_drift_tolerance`` of where its rows send them over the tick.
        relaxed: names of the relaxable constraints (``Constraint.relaxable``, e.g. acceleration limits) that were
            left out of this tick because the hard set was infeasible with them (``ok`` stays True when the tick
            then solved).
        consecutive_failures: failed ticks in a row ending with this one (0 when ok). A failure never latches:
            every tick is solved afresh, so the first feasible tick after failures is ok again.
        sole_drift: largest second-order drift (m) of a contact frame over this tick: the larger of the distance
            ‖t(e⁺) − (1 − K dt) t(e)‖ and L times the angle (rad) between where the frame ends and where its
            row sends it, with e⁺ the contact error at pin.integrate(q, v dt), t(·) its translation part and
            L = sole_drift_tolerance / sole_rotation_tolerance (m; 0 when either is None) (what the linearised
            contact row J v = −K e cannot see). An ok tick has sole_drift ≤ ``sole_drift_tolerance``: its contact
            frames move ≤ sole_drift_tolerance and turn ≤ sole_rotation_tolerance from where their rows send them.
        path: the route the tick took (:class:`wbc.tick.TickPath`, one of :data:`wbc.tick.KINEMATIC_ROUTES`):
            'compiled' (the compiled tick's kernel), 'general'
            (the general path's flat QP; solver: the backend's name), 'levels' (strict hierarchy), with
            ``return_rate`` when the return rate of joints outside their limits was relaxed and ``budget`` when
            1.75 times the tick's budget stopped its cascade, contact correction or trust region (``message`` names what
            was skipped); on failure 'fallback' (``path.fallback`` = ``fallback``). Its string form is
            ``compiled``, ``general:<backend>``, ``levels`` (each of the last two possibly
            followed by ``+return_rate`` and ``+budget``), ``fallback:<fallback>``.
        reason: why the tick failed ('' when ok): 'infeasible' (no solution of the hard set found),
            'sole_drift' (solved, but no trust region kept the contact frames within ``sole_drift_tolerance``),
            'output_guard' (the command was not finite or crossed a
            bound), 'nonfinite' (non-finite numbers in the QP), 'exception' (anything else raised).
        over_budget: the tick's budget (``KinematicController.budget``, counted in QP solves) was spent before it
            finished: on a
            failed tick its optional stages (independent confirmation, diagnosis, the safe command's trust regions)
            were skipped and the safe command returned; on an ok tick ('+budget' path: 1.75 × the budget spent) the
            remaining strict levels, contact corrections or trust regions were skipped and the last finished stage's command returned.
    """

    v: np.ndarray
    fallback: str = ""
    relaxed: list[str] = field(default_factory=list)
    consecutive_failures: int = 0
    sole_drift: float = 0.0
    reason: str = ""


_new_instance = object.__new__


def solved_result(v: np.ndarray, timings: dict[str, float], sole_drift: float, path: TickPath) -> TickResult:
    """``TickResult(v, timings=timings, sole_drift=sole_drift, path=path)`` (an ok tick: every other field at its
    default) with the fields stored one by one, without the dataclass constructor's keyword and default-factory
    handling (the compiled tick's result, built every tick)."""
    r = _new_instance(TickResult)
    r.ok = True
    r.message = ""
    r.timings = timings
    r.conflicts = []
    r.path = path
    r.over_budget = False
    r.v = v
    r.fallback = ""
    r.relaxed = []
    r.consecutive_failures = 0
    r.sole_drift = sole_drift
    r.reason = ""
    return r
