"""The kinematic whole-body controller: targets → the velocity QP (:class:`wbc.formulations.velocity.VelocityQP`)
→ solver route → safe command, once per control tick (:class:`KinematicController`, result
:class:`wbc.tick.TickResult`).

Its parts, one module each: the compiled tick (:mod:`wbc.controllers.compiled_tick`), the second-order contact hold
(:mod:`wbc.controllers.contact_hold`), the relaxation ladder (:mod:`wbc.controllers.relaxation`) and the recovery of
a failed tick (:mod:`wbc.controllers.recovery`). Priorities (``add_task``): ``level=None`` (default) joins the
weighted soft level; ``hard=True`` makes the task an equality constraint; ``level=k`` (0 highest) a strict
hierarchy solved lexicographically. Dependent equality rows, the output guard, the tick budget and the route of
each tick (``TickResult.path``) are described in ``docs/kinematic-controller.md``."""

from __future__ import annotations

import math
import warnings
from dataclasses import replace
from time import perf_counter

import numpy as np

from wbc.configuration import Configuration
from wbc.constraints.base import BoxConstraint, Constraint, EqualityConstraint, InequalityConstraint, KinematicContext
from wbc.constraints.task import TaskConstraint
from wbc.exceptions import InvalidInputError, SolverError
from wbc.geometry import Flag
from wbc.formulations.velocity_kernel import load_kinematic_kernels
from wbc.solvers import DEFAULT_SOLVER, FastBackend, QPBackend, make_backend
from wbc.robot import Robot
from wbc.tasks.base import Task
from wbc.tick import TickPath, TickResult
from wbc.controllers.budget import TickBudget
from wbc.controllers.general_route import CONFIRM_ORDER, GeneralRoute
from wbc.controllers.robot_check import RobotCheck, zero_range_joints
from wbc.controllers.output_guard import command_fault, qp_data_fault
from wbc.controllers.compiled_tick import CompiledTick, FusedPlan
from wbc.controllers.contact_hold import ContactHold, ContactRange, DriftFailure, DriftMeter
from wbc.controllers.recovery import Recovery
from wbc.controllers.relaxation import Relaxation
from wbc.formulations.velocity import SoftRows, VelocityQP


#: the default largest angle (rad) a contact frame may turn per tick away from where its row sends it on an ok tick
#: (``KinematicController(sole_rotation_tolerance=…)``)
SOLE_ROTATION_TOLERANCE = 3e-4


class KinematicController(CompiledTick, ContactHold, Relaxation, Recovery, GeneralRoute, VelocityQP):
    """Velocity-level whole-body QP (see module docstring).

    Args:
        robot: the robot.
        tasks: weighted tasks (order irrelevant).
        constraints: equality, inequality and bound constraints.
        solver: QP backend name (default ``wbc.solvers.DEFAULT_SOLVER``, "fast": active-set kernels with DAQP as
            fallback, exact, so bounds hold exactly) or a :class:`~wbc.solvers.base.QPBackend`.
        damping: ε, weight of ‖v‖² (s²·task units), > 0.
        rank_rtol: relative tolerance of the numerical rank of the equality rows.
        dependent_row_tolerance: largest residual of a dropped equality row (its units: m/s, rad/s) accepted
            without recomputing the rank within the tick.
        contact_correction: drift (m) of a contact frame over the tick above which the tick is solved again with its
            contact rows corrected (:mod:`wbc.controllers.contact_hold`); default 1e-6, 0 = off.
        sole_drift_tolerance: largest contact-frame drift per tick (m, default 5e-5) of an ok tick, enforced by trust
            regions (:mod:`wbc.controllers.contact_hold`), else the tick is not ok; None: measured, not enforced.
        sole_rotation_tolerance: largest angle (rad, default ``SOLE_ROTATION_TOLERANCE`` = 3e-4: at a lever of 1/6 m,
            5e-5 m) a contact frame may turn per tick away from where its row sends it on an ok tick, or None (the
            distance alone): the drift is the larger of the distance and the angle times sole_drift_tolerance /
            sole_rotation_tolerance. The contact correction is started and judged on the distance alone.
        budget: CPU time (s) of a tick before its optional stages are skipped, or None (default): the tick's dt;
            counted in QP solves, ⌊budget / ``SOLVE_COST``⌋ of them (not a clock: deterministic); ``math.inf``: no
            budget. What each stage does when it is spent: ``docs/kinematic-controller.md``, "tick budget".
        clock_guard: also count the tick's CPU time as work (:class:`wbc.controllers.budget.TickBudget`; the answer
            then depends on the machine's load). Default False; on in ``wbc ros2 node``, ``--live``, ``--ros2``.

    Raises:
        UnknownSolverError: unknown backend name.
        InvalidInputError: damping ≤ 0, budget, sole_drift_tolerance or sole_rotation_tolerance not None nor finite
            and > 0, contact_correction not finite and ≥ 0, or an object that is not a Task/Constraint.
    """

    clock_guard = Flag("The tick's CPU time also counts as work (constructor docstring).")

    # the numbers' roles: docs/kinematic-controller.md (tick budget, clock guard, safe command)
    #: nominal CPU time (s) of one QP solve of a humanoid tick (nv ≤ 38, ≤ 120 rows, dense active set, one core)
    SOLVE_COST = 2.5e-4
    #: a solved tick starts no optional stage once STAGE_FACTOR × its budget is spent
    STAGE_FACTOR = 1.75
    #: with ``clock_guard``, one budget of CPU time counts as CLOCK_WEIGHT × ⌊budget / SOLVE_COST⌋ solves
    CLOCK_WEIGHT = 1.4
    #: with ``clock_guard``: a timed stage after the first solve must end by STAGE_DEADLINE × the budget
    STAGE_DEADLINE = 1.5
    #: with ``clock_guard``: the deadline of the least-squares re-solve of dependent contact rows (× the budget)
    RESCUE_DEADLINE = 1.7
    #: ticks answered by the weighted form of the strict levels after a cascade cut by the budget
    WEIGHTED_TICKS = 25
    #: level k of p (0 highest) enters the weighted form's cost scaled by WEIGHTED_LEVEL_RATIO ** (p − k)
    WEIGHTED_LEVEL_RATIO = 100.0
    #: budgets (counted solves) a tick of the strict cascade keeps for the weighted form (``TickWork.reserve``)
    WEIGHTED_RESERVE = 0.75
    #: counted solves per level of the strict cascade for the work around its QP
    LEVEL_WORK = 0.5
    #: counted solves expected of a contact hold's first re-solve of one QP (its later ones: the largest so far)
    FIRST_RESOLVE_WORK = 1.0
    #: contact rows' singular values under this × max(the largest, 1) count as dependent in a failed tick's retries
    NEAR_DEPENDENT_RTOL = 1e-2
    #: m: a safe command keeps each contact frame within this of where the run of failed ticks began
    SAFE_COMMAND_RADIUS = 5e-4
    #: counted solves per check of a 'contacts_held' command (forward kinematics, drift, radius)
    CHECK_WORK = 0.25
    #: DAQP iterations per call of the 'contacts_held' QP at β = 0 when the count was spent before the failure
    HELD_ITERATIONS = 150
    #: DAQP iterations per call of the flat QP's solves after the tick's first (its retries, contact corrections, trust
    #: regions): a warm workspace cycling to DAQP's 1000-iteration limit (7 counted solves) hands over after 1
    STAGE_ITERATIONS = 150

    def __init__(self, robot: Robot, tasks: list[Task] = (), constraints: list[Constraint] = (), *,
                 solver: str | QPBackend = DEFAULT_SOLVER, damping: float = 1e-6, rank_rtol: float = 1e-3,
                 dependent_row_tolerance: float = 1e-3, sole_drift_tolerance: float | None = 5e-5,
                 sole_rotation_tolerance: float | None = SOLE_ROTATION_TOLERANCE, contact_correction: float = 1e-6,
                 budget: float | None = None, clock_guard: bool = False):
        self.clock_guard = clock_guard
        if isinstance(damping, bool) or not (np.isfinite(damping) and damping > 0):
            raise InvalidInputError(f"damping must be finite and > 0, got {damping!r}")
        for name, value, unit in (("sole_drift_tolerance", sole_drift_tolerance, "m; e.g. 5e-5"),
                                  ("sole_rotation_tolerance", sole_rotation_tolerance, "rad; e.g. 3e-4")):
            if value is not None and not (math.isfinite(value) and value > 0):
                raise InvalidInputError(f"{name} must be None or finite and > 0 ({unit}), got {value!r}")
        if not (math.isfinite(contact_correction) and contact_correction >= 0):
            raise InvalidInputError(f"contact_correction must be finite and ≥ 0 (m; 0 switches the second-order "
                                    f"contact correction off, e.g. 1e-6), got {contact_correction!r}")
        self.robot, self.nv = robot, robot.model.nv
        self.damping, self.rank_rtol = float(damping), float(rank_rtol)
        self.dependent_row_tolerance = float(dependent_row_tolerance)
        self.sole_drift_tolerance, self.sole_rotation_tolerance = sole_drift_tolerance, sole_rotation_tolerance
        self.contact_correction = float(contact_correction)
        #: the tick's counted work, clock guard and stage costs (:class:`wbc.controllers.budget.TickBudget`)
        self.tick_budget = TickBudget()
        self._work = self.tick_budget.work  # the tick's QP solves, shared with every backend of the controller
        self.budget = budget
        #: second-order contact corrections (re-solves) done by the last tick.
        self.contact_corrections = 0
        #: the contact frames' drift over a tick (:class:`wbc.controllers.contact_hold.DriftMeter`)
        self.drift_meter = DriftMeter(robot.model)
        self._drift_data = self.drift_meter.data  # its Data: the compiled tick's scratch at q⁺
        #: the range of the contact rows (:class:`wbc.controllers.contact_hold.ContactRange`)
        self.contact_range = ContactRange()
        #: refuses tasks and constraints built for another robot (:class:`wbc.controllers.robot_check.RobotCheck`)
        self.robot_check = RobotCheck(robot.model)
        self.backend = make_backend(solver) if isinstance(solver, str) else solver
        self._fallback_backend = self._final_backend = self._band_backend = None  # built when first needed
        self._level_backends: list[QPBackend] = []
        self.tasks: list[Task] = []
        self.levels: dict[int, list[Task]] = {}
        self._level_order: list[int] = []
        self.constraints: list[Constraint] = []
        self._hard: dict[int, TaskConstraint] = {}
        self._level_memo: dict = {}  # the cascade's retries that solved a level (hierarchy.solve_lexicographic)
        self._weighted_left = 0  # clock guard: ticks still answered by the weighted form of the strict levels
        #: ‖J_k v − v*_k‖ of each strict level at the last hierarchical tick (weights applied).
        self.level_residuals: list[float] = []
        self._context = KinematicContext()  # what Constraint.write reads (assemble)
        self._layout_ok, self._layout_key, self._eq_rows = False, None, None
        self._layouts: dict[tuple, dict] = {}
        self._soft_layouts: dict[tuple, tuple] = {}
        self._fused: FusedPlan | None = None  # the compiled tick's plan of the current layouts (solve)
        self._fused_plans: dict[tuple, FusedPlan] = {}
        self._fused_states: dict[int, FusedPlan] = {}  # the last plan per number of variables (its working set)
        self._prepared: set[tuple] = set()  # layouts built by prepare_layouts, not yet used by a tick
        self._soft_tasks = self._level_key = None  # the soft level's tasks / the strict levels' of _level_rows
        self._level_rows: list[SoftRows] = []
        self._in_solve, self._contact_expected = False, None
        #: largest residual (m/s, rad/s) of the dropped dependent equality rows at the last flat solve.
        self.dependent_residual = 0.0
        #: failed ticks in a row up to the last tick (0 after an ok tick).
        self.consecutive_failures = 0
        self.last_result = TickResult(np.zeros(self.nv))
        #: joints whose position range or velocity limit has zero width (locked: their bounds pin v to 0);
        #: found at build and reported once with a warning.
        self.locked_joints = zero_range_joints(robot.model)
        if self.locked_joints:
            warnings.warn(f"{len(self.locked_joints)} joint(s) have a zero-width position or velocity range and "
                          f"are treated as locked: {', '.join(self.locked_joints)}", stacklevel=2)
        for t in tasks:
            self.add_task(t)
        for c in constraints:
            self.add_constraint(c)
        load_kinematic_kernels()  # the compiled assembly is loaded here, not inside the first tick

    @property
    def budget(self) -> float | None:
        """CPU time (s) of a tick, counted in QP solves (constructor docstring), or None: the tick's dt; setting it
        raises InvalidInputError unless None or a number > 0."""
        return self._budget

    @budget.setter
    def budget(self, value) -> None:
        if value is not None and (isinstance(value, bool) or not (isinstance(value, (int, float, np.floating,
                                                                                      np.integer)) and value > 0)):
            raise InvalidInputError(f"budget must be None (the tick's dt) or a number of seconds > 0 (math.inf: "
                                    f"no budget), got {value!r}")
        self._budget = None if value is None else float(value)
        self._held_anchors = None  # contact frames' placements when the current run of failed ticks began

    def _start_work(self, budget_s: float) -> None:
        """Start the tick's budget (:meth:`wbc.controllers.budget.TickBudget.start`, with the controller's numbers:
        class or instance attributes, they may change between ticks) and share its work with the tick's backend (the
        controller's other backends get it when made: ``_new_backend``)."""
        tb = self.tick_budget
        tb.clock_guard, tb.stage_factor, tb.stage_deadline = self.clock_guard, self.STAGE_FACTOR, self.STAGE_DEADLINE
        tb.start(budget_s, self.SOLVE_COST, self.CLOCK_WEIGHT)
        if self.backend.work is not self._work:  # the caller's backend (or one assigned since the last tick)
            self.backend.work = self._work
            self.backend.independent = CONFIRM_ORDER

    # -- problem definition -------------------------------------------------------------------------------
    def add_task(self, task: Task, *, level: int | None = None, hard: bool = False) -> Task:
        """Add a task (module docstring: priorities).

        Args:
            task: the task.
            level: None (default): weighted soft level; int ≥ 0: strict priority level (0 highest).
            hard: hold the task as an equality constraint J v = v* (not with ``level``).

        Raises:
            InvalidInputError: not a Task, a negative/non-integer level, both ``level`` and ``hard``, or a task
                built for another robot (other model, frame ids or nv).
        """
        self._check_input(task)
        if hard:
            if level is not None:
                raise InvalidInputError("a task is either hard or on a priority level, not both")
            self._hard[id(task)] = self.add_constraint(TaskConstraint(task))
        elif level is None:
            self.tasks.append(task)
        else:
            if isinstance(level, bool) or not isinstance(level, (int, np.integer)) or level < 0:
                raise InvalidInputError(f"priority level must be an int ≥ 0 (0 = highest), got {level!r}")
            self.levels.setdefault(int(level), []).append(task)
            self._level_order = sorted(self.levels)
        return task

    def remove_task(self, task: Task) -> None:
        """Remove a task from wherever it was added.

        Raises:
            ValueError: the task is not in the controller.
        """
        if task in self.tasks:
            self.tasks.remove(task)
            return
        if id(task) in self._hard:
            self.remove_constraint(self._hard.pop(id(task)))
            return
        for k, tasks in self.levels.items():
            if task in tasks:
                tasks.remove(task)
                if not tasks:
                    del self.levels[k]
                    self._level_order = sorted(self.levels)
                return
        raise ValueError(f"task {getattr(task, 'name', task)!r} is not in the controller")

    @property
    def hard_tasks(self) -> list[Task]:
        """Tasks added with ``hard=True``."""
        return [w.task for w in self._hard.values()]

    def add_constraint(self, constraint: Constraint, index: int | None = None) -> Constraint:
        """Add an equality, inequality or box constraint.

        Args:
            constraint: the constraint.
            index: its position in :attr:`constraints`, the order of their rows in the QP (``list.insert``); None
                (default): appended.

        Raises:
            InvalidInputError: not a wbc Constraint, built for another robot (other model, frame ids or nv), or
                ``index`` not an integer in [0, len(constraints)].
        """
        if index is not None and (isinstance(index, bool) or not isinstance(index, (int, np.integer))
                                  or not 0 <= index <= len(self.constraints)):
            raise InvalidInputError(f"constraint index must be an integer in [0, {len(self.constraints)}], "
                                    f"got {index!r}")
        self._check_input(constraint, task=False)
        self.constraints.insert(len(self.constraints) if index is None else int(index), constraint)
        self._eq_rows, self._layout_ok = None, False
        return constraint

    def _check_input(self, obj, task: bool = True) -> None:
        """Raise InvalidInputError unless ``obj`` is a Task (``task``) or a velocity-level constraint of this robot."""
        if task and not isinstance(obj, Task):
            raise InvalidInputError(f"expected a wbc Task, got {type(obj).__name__}")
        if not task and not isinstance(obj, (EqualityConstraint, InequalityConstraint, BoxConstraint)):
            if isinstance(obj, Constraint):  # e.g. an IDConstraint: rows in [v̇; f], not in v
                raise InvalidInputError(
                    f"{type(obj).__name__} {obj.name!r} is a constraint of the {obj.level} level; a "
                    f"KinematicController takes velocity-level constraints (EqualityConstraint, "
                    f"InequalityConstraint, BoxConstraint of wbc.constraints)")
            raise InvalidInputError(f"expected a wbc Constraint, got {type(obj).__name__}")
        self.robot_check.check(obj, "task" if task else "constraint")

    def remove_constraint(self, constraint: Constraint) -> None:
        """Remove a constraint added with :meth:`add_constraint`.

        Raises:
            ValueError: the constraint is not in the controller.
        """
        self.constraints.remove(constraint)
        self._eq_rows, self._layout_ok = None, False

    # -- one tick -------------------------------------------------------------------------------------------
    def solve(self, config: Configuration, dt: float) -> TickResult:
        """Solve one tick at ``config`` with control period ``dt`` (s).

        Returns:
            :class:`TickResult`; on failure ``ok`` is False, ``v`` is the safe command (``fallback``) and
            ``conflicts`` names the conflicting hard constraints (module docstring).

        Raises:
            InvalidInputError: dt not finite and > 0 (or another typed input error raised by a task/constraint).
        """
        if not (type(dt) is float and 0.0 < dt < math.inf) and (
                isinstance(dt, (bool, np.bool_)) or not (isinstance(dt, (float, int, np.floating, np.integer))
                                                         and math.isfinite(dt) and dt > 0)):
            raise InvalidInputError(f"dt must be a finite number of seconds > 0 (not a bool), got {dt!r}")
        t0 = perf_counter()
        self._cut = []  # stages of this tick stopped by its budget (TickResult.path '+budget')
        self._start_work(dt if self._budget is None else self._budget)
        plan = self._fused  # the compiled tick (:mod:`wbc.controllers.compiled_tick`), else the general path
        if plan is None or not (self._layout_ok and plan.layout_key is self._layout_key
                                and self._soft_tasks == self.tasks and plan.soft_tasks is self._soft_tasks
                                and plan.backend is self.backend and not self._level_order):
            plan = self._fused_plan()
        if plan is not None:
            try:
                result = self._fused_tick(plan, config, dt, t0)
            except InvalidInputError:
                raise
            except Exception:  # noqa: BLE001 — the general path meets it again and handles it
                result = None
            if result is not None:
                return result
        weighted_start = self._start_general()
        self._caller_calls = getattr(self.backend, "call_iterations", None)  # (restored at the tick's end)
        t1 = None
        try:
            self.assemble(config, dt)  # targets → the tick's QP, in the controller's buffers
            self._assembled = True
            fault = qp_data_fault(*self._qp)
            if fault:
                raise SolverError(f"non-finite numbers in the tick's QP: {fault}")
            t1 = perf_counter()
            self._plan_levels()  # strict levels whose cascade cannot fit: their weighted form
            try:  # → the solver route (flat or strict levels), then the relaxation ladder
                v, relaxed, return_rate, held = self._solve_assembled(), [], None, False
            except SolverError as first_failure:
                self._cap_calls(self.STAGE_ITERATIONS)  # (the tick's later solves, until its end)
                v, relaxed, return_rate, held = self._relaxation_ladder(config, dt, first_failure)
            self._cap_calls(self.STAGE_ITERATIONS)
            # its contacts held (second-order correction, trust region; slower returns, a cut cascade's weighted form)
            result = self._held_command(config, dt, v, relaxed, held=held)
            if not result.ok and not held:
                if return_rate is not None:
                    result, return_rate = self._slower_return(config, dt, relaxed, return_rate, result)
                elif self._cut and self._level_order and not self._weighted_tick:
                    result = self._weighted_answer(config, dt, relaxed) or result
            if not result.ok:  # no trust region kept the contacts: the safe command is taken instead
                raise DriftFailure(result.message)
            fault = command_fault(result.v, self._lb, self._ub, self._C, self._l, self._u, self.backend.tolerance)
            if fault:
                raise SolverError(f"output guard: {fault}")
            path = (TickPath("levels", weighted=self._weighted_tick) if self._level_order
                    else TickPath("general", self.backend.name))
            result.path = path if return_rate is None else replace(path, return_rate=True)
        except InvalidInputError:
            raise
        except Exception as exc:  # noqa: BLE001 — no failure may escape the control tick (module docstring)
            t1 = t1 or perf_counter()
            self._eq_rows = None  # the rank may have changed: recompute next tick
            self._work.reserve = 0.0
            result = self._recover(config, dt, exc)  # → the safe command
        finally:
            self._in_solve = False
            self._cap_calls(None)
            self.drift_meter.forget()
        return self._close_tick(result, weighted_start, t0, t1)

    def _start_general(self) -> bool:
        """Set up the general path of the tick (backends' give-up counting, the strict levels' weighted form and
        reserve); True when the tick starts on the weighted form of its strict levels."""
        if isinstance(self.backend, FastBackend):
            # a flat tick counts the kernel's give-ups (uncounted, a return-rate ladder and trust region spent twice
            # the budget); the strict cascade's stages keep their calibrated count (LEVEL_WORK, WEIGHTED_RESERVE),
            # and its weighted form skips the kernel, uncounted, on later problems of a shape it gave up on
            self.backend.count_give_ups = not self._level_order
            self.backend.skip_give_ups = bool(self._level_order)
        self._assembled, self._banded = False, None  # (_banded: the rows of the tick's last band solve, _solve_flat)
        self._in_solve, self._contact_expected = True, None  # (the drift meter forgot at the last tick's end)
        weighted_start = bool(self._level_order) and self._weighted_left > 0
        self._weighted_tick, self._weighted_qp = weighted_start, None  # (H, g) of the weighted form when made
        if self._level_order and not weighted_start and math.isfinite(self._work.cap):
            # the cascade's stages stop WEIGHTED_RESERVE budgets early: the rest is its weighted form's
            self._work.reserve = self.WEIGHTED_RESERVE * self._work.cap
        return weighted_start

    def _close_tick(self, result: TickResult, weighted_start: bool, t0: float, t1: float) -> TickResult:
        """The tick's bookkeeping after its answer: the strict levels' weighted ticks left, timings, the budget's
        marks, feedback constraints and the failure count."""
        if self._level_order:
            # a cascade cut by the budget: the next WEIGHTED_TICKS ticks, and until one is cheap enough for the
            # cascade, answer with the weighted form (one QP)
            if weighted_start:
                self._weighted_left -= 1
                if self._weighted_left <= 0 and not self.tick_budget.cascade_fits(
                        len(self._level_order), self.STAGE_FACTOR - self.WEIGHTED_RESERVE):
                    self._weighted_left = 1
            elif self._cut:
                self._weighted_left = self.WEIGHTED_TICKS
        result.timings = {"assembly": t1 - t0, "solve": perf_counter() - t1}
        result.over_budget = result.over_budget or bool(self._cut) or self._work.solves > self._work.cap
        if self._cut and result.ok:
            result.path = result.path.with_budget()
            result.message = f"tick budget spent: {'; '.join(self._cut)} skipped"
        for c in self._feedback:
            c.set_previous(result.v)
        self.consecutive_failures = 0 if result.ok else self.consecutive_failures + 1
        result.consecutive_failures = self.consecutive_failures
        self.last_result = result
        return result
