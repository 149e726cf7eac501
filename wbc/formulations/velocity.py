"""Velocity-level formulation: the kinematic QP whole-body controller (:class:`KinematicController`).

It assembles the shared task objects of :mod:`wbc.tasks` as (J_i, v*_i) — the acceleration-level formulation
(:mod:`wbc.formulations.acceleration`) uses the same objects as (J_i, a*_i − J̇_i v) — and the constraint objects
of :mod:`wbc.constraints` (their ``compute`` rows on v). The optimisation problem, solved once per control tick of period dt (s), with v ∈ R^nv the generalized
velocity (floating base included):

    min_v   Σ_i ‖ diag(√w_i) (J_i v − v*_i) ‖²  +  ε ‖v‖²                     (weighted tasks)
    s.t.    A_k v = b_k                       for each equality constraint k  (e.g. stance feet: J_c v = −K_c e_c)
            l_k ≤ C_k v ≤ u_k                 for each inequality constraint k
            lb ≤ v ≤ ub                       (intersection of all bound constraints: joint position and velocity
                                               limits over dt)

Equality rows that are (numerically) linearly dependent on others are dropped before the solve and their
residual is checked after it (``dependent_residual``): above ``dependent_row_tolerance`` the rank is recomputed
on the current rows and, if rows have become independent since it was last computed, the tick is solved again
with them; if not, the dependent rows contradict the kept ones and the tick fails (diagnosis and safe command
below). Example: a leg whose hip-roll → hip-pitch →
knee → ankle-pitch → ankle-roll chain is in gimbal lock when the sole is flat cannot change the foot's yaw
relative to the pelvis, so two flat stance feet fix the base yaw twice. The independent set is chosen by QR
with column pivoting of Aᵀ (numerical rank: |R_ii| > ``rank_rtol`` · |R_00|), once per change of the
constraint set, and again after a failed tick. Dropped rows that are only nearly dependent (their residual
above the tolerance while the rank is unchanged) are put back as band rows |A_d v − b_d| ≤
``dependent_row_tolerance``/2 and the tick is solved again; only when that has no solution do the hard
equalities contradict each other.

Contacts (:class:`~wbc.constraints.ContactConstraint`) hold to second order at dt. (1) When the contact rows
are rank deficient (the example above) and the tick fails, their drift corrections −K e are projected onto the
range of J_c (least squares: two feet never ask contradictory corrections of the same direction) and the tick is
solved again. (2) After the solve
the contact frames are placed at q⁺ = pin.integrate(q, v dt) by forward kinematics; if one drifts from its
expected placement by more than ``contact_correction`` (m), the contact rows' right-hand sides are corrected by
the measured drift and the tick is solved again (a Newton step on e⁺(v) = (1 − K dt) e, ≤ 3 iterations: only
the contact targets move, every task and priority is kept; when the contact rows are rank deficient the corrected
right-hand sides are projected onto the range of J_c, least squares, as in (1)). (3) A tick whose drift still exceeds
``sole_drift_tolerance`` is solved in a trust region, else reported not ok (``TickResult.sole_drift``).

with, for each task i: error e_i(q), Jacobian J_i = ∂e_i/∂q, gain K_i (1/s), feed-forward ė*_i, and
v*_i = ė*_i − K_i e_i. ε (``damping``) keeps H positive definite. The next configuration is
q⁺ = pin.integrate(q, v dt).

Priorities (``add_task``):

* ``level=None`` (default): the task joins the weighted soft level above.
* ``hard=True``: the task becomes an equality constraint J v = v* (:class:`~wbc.constraints.TaskConstraint`,
  named after the task in conflict reports).
* ``level=k`` (int ≥ 0; 0 is the highest priority): strict hierarchy. Levels are optimised in increasing k, each
  only within the optimal set of those above, and the weighted soft level (with ε) comes last — the lexicographic
  cascade of :mod:`wbc.solvers.hierarchy`. That path is taken only when at least one integer level exists; otherwise the
  single QP above is solved as before.

Bounds are intersected in ``BoxConstraint.priority`` order, lower priorities yielding (see
:mod:`wbc.constraints.base`); constraints that need the previous command (``needs_previous_command``) receive
``TickResult.v`` after every tick. Constraints marked ``relaxable`` (joint acceleration limits: a smoothness
preference) are left out of a tick whose QP is infeasible with them, and the tick is solved again
(``TickResult.relaxed`` names them) before anything is declared failed. Then, when joints are outside their
position limits, their return rate (:class:`~wbc.constraints.JointPositionLimit`: min(distance/dt, v_max) back)
is relaxed: it ranks below every other hard constraint and above the tasks, and is scaled by α: α = 0 first (it
only forbids moving further out; no solution there, none at any α), then 1/1000, 1/100, 1/10, 1/2 while they solve
and the budget lasts, the largest that solved kept (``TickResult.relaxed`` names α). When even α = 0 has no
solution, the contacts' drift corrections rank below it: their rows become J_c v = 0 (``relaxed`` says so) and
the same ladder is solved; the tick's sole-drift check still measures from where the full correction would send
each contact frame.

Output guard: an ok tick's command is finite and within the box and inequality rows to the backend's tolerance
(checked against the constraint objects' bounds recomputed at the tick, not read from the solver), its contacts
within ``sole_drift_tolerance``, and every number of its QP finite (targets, weights, q, placements written in
place are caught there); else the tick fails (``TickResult.reason``) and the safe command below is returned.

Tick budget (``budget``, default the tick's dt, seconds of CPU time), counted in QP solves: a tick may do
⌊budget / ``KinematicController.SOLVE_COST``⌋ solves (every solve attempt, cold retry and independent re-solve
counts one, plus one per ``QPBackend.iterations_per_solve`` active-set iterations of its solver — 150, 75 for DAQP's
proximal-point iterations of a strict level —, and a tick that builds a new row layout counts ``LAYOUT_WORK`` (4)
more for the build and its first solves on fresh workspaces, :class:`wbc.solvers.base.TickWork`) — a count, not a
clock, so a tick's answer is a function of its inputs (and of the controller's history: its layouts and warm
starts) and never of the machine's load. A stage starts only when it fits: at the counted work of the largest
re-solve of the tick's QP so far (of the largest strict level, for the next level) it would end within its limit
(one budget for a failed tick's optional stages and the return-rate ladder, ``STAGE_FACTOR`` budgets for a solved
tick's stages). Past it, a failed tick stops its optional stages (independent
confirmation — inside a tick the active-set solvers quadprog and DAQP first, ProxQP last —,
relaxations, diagnosis) and returns the safe command (``TickResult.over_budget``). A solved tick checks the count
between its stages — before each level of the strict cascade, each second-order contact correction and each trust
region — and starts none of them that would end past ``STAGE_FACTOR`` (1.75) times its budget (above): it keeps the command of the last stage it finished (the
least-drifting correction's), which must still pass the output guard and the sole-drift
check (else the tick fails and returns the safe command); ``TickResult.path`` then ends in '+budget' and
``message`` names the stages it skipped. Inside a stage, each DAQP call may take only the iterations that keep the
count below :data:`wbc.solvers.daqp.WORK_LIMIT_FACTOR` (1.9) times the budget
(:meth:`wbc.solvers.daqp.DaqpBackend.call_limit`); a call stopped there is a failed solve (never an unconverged answer),
and a strict level that fails so is cut like a level not started. ``TickResult.path`` names the route every tick took.

Strict levels degrade to one QP when their cascade does not fit the count. Each level of the cascade counts
``LEVEL_WORK`` (0.5) solves besides its QP's (the work around it: the rows of the levels above, their rank check
and bands). A tick of the cascade holds
``WEIGHTED_RESERVE`` (0.75) budgets back (:attr:`wbc.solvers.base.TickWork.reserve`): its levels, contact corrections
and trust regions stop at ``STAGE_FACTOR`` − 0.75 = 1 budget, its DAQP calls at ``WORK_LIMIT_FACTOR`` − 0.75 = 1.15
budgets. Once the count stops a level, the tick answers with the weighted form of the levels (level k of p scaled by
``WEIGHTED_LEVEL_RATIO`` ** (p − k) over the soft level: one QP, then its contact correction and trust region within
the reserve, to ``STAGE_FACTOR`` budgets); when it stops the cascade's correction or trust region and the cascade's
command leaves a contact frame past ``sole_drift_tolerance``, the tick is answered again by the weighted form
(taken when it keeps the contacts; else the tick fails as before). Either way the path is ``levels+budget+weighted``
and the next ``WEIGHTED_TICKS`` ticks solve the weighted form directly (``levels+weighted``, one QP per re-solve), then
the cascade again once a weighted tick's counted solves times p + 1 fit in the cascade's 1 budget (with the clock
guard also its CPU time times 2 (p + 1) in one budget). A cascade that fails after the count is spent is retried
(the least-squares retry of dependent contact rows, the relaxations below) with the weighted form as well
(``levels+budget+weighted``). The trigger and the exit are counts (and the same inputs give
the same answers); a command of a cut cascade that keeps the contacts is kept (``levels+budget``).

With ``clock_guard=True`` (constructor) the tick's CPU time also counts as work (one budget of CPU time =
``CLOCK_WEIGHT`` × the cap; :class:`wbc.solvers.base.TickWork`), so each of these limits also holds on the clock,
whatever a counted solve costs on the machine and problem: the tick time is bounded (stages stop at ``STAGE_FACTOR`` /
``CLOCK_WEIGHT`` = 1.25 budgets of CPU time), and a tick that reaches a limit by its clock has an answer that depends on
the machine's speed and load (off by default). The guard also bounds what the count leaves unbounded — the
relaxations, the diagnosis and the safe command of a failed tick, each strict level — by costs timed in the tick
itself: every such stage after the tick's first solve starts only when the tick's CPU time plus the CPU time of the
longest stage of its kind so far in this tick (a re-solve of the tick's QP, a strict level, a solve of the safe command
and its checks; the safe command's from the last tick until one is timed) stays within ``STAGE_DEADLINE`` (1.5)
budgets (``RESCUE_DEADLINE``, 1.7, for the least-squares re-solve of dependent contact rows); a relaxation that does
not fit fails the tick, a safe command that does not fit is not tried (``hold``; the message says what was skipped),
so that a failed tick ends within twice its budget of CPU time however slow its solves are on the machine, unless its
first solve alone takes that long. With the guard, a strict level that its clock stops also degrades the tick to
the weighted form (above), when that QP, at the CPU time of the longest level so far, fits.

When the tick cannot be solved (infeasible hard constraints, numerical failure, any exception other than a typed
input error), ``solve`` does not raise and never returns NaN:

1. diagnosis (:mod:`wbc.solvers.diagnosis`): a slack-relaxed solve of the hard set names the conflicting constraints and
   the violation of each (``TickResult.conflicts``, largest first);
2. safe command: the weighted soft level (tasks with ``level=None`` + ε) subject to the constraint objects only —
   hard tasks, strict levels and relaxable constraints left out — solved on a fresh backend, its contacts held to
   second order like an ok tick's (correction, then trust region; ``TickResult.sole_drift`` is its drift), taken
   only when that drift is ≤ ``sole_drift_tolerance``: ``fallback="constraints_only"``;
3. if the constraints themselves conflict (or step 2's drift is too large) and contacts are among them, the same with each contact frame held
   where it was when the current run of failed ticks began, its correction towards there scaled by 1, 1/10 or 0
   (J_c v = 0: kept where it is rather than pulled back onto its placement; e.g. a
   sub-millimetre sole drift whose correction, near a singular leg posture, needs joint velocities past their
   limits): ``fallback="contacts_held"``, taken only when it keeps each frame within ``sole_drift_tolerance`` of
   where its rows send it (forward kinematics; at β = 0, solved to its solver's own iteration limit however much of
   the tick's count is spent, then scaled down by 0.9 √(tolerance / drift), at most 1/2, up to 8 times, until it
   does; each check counts ``CHECK_WORK`` solves and starts only while the count stays below
   ``wbc.solvers.daqp.WORK_LIMIT_FACTOR`` times its cap, else v = 0); when the tick's count was spent before its failure handling began, step 3 comes first and with β = 0
   only, each of its DAQP calls at most ``HELD_ITERATIONS`` iterations, and step 2 only after it;
   steps 2 and 3 are taken only when they also leave each contact frame within ``SAFE_COMMAND_RADIUS`` of where
   the run of failed ticks began (or no farther from there than it is), so that a run of failed ticks never walks
   a stance sole away one tolerated drift at a time;
4. else v = 0, hold the current posture: ``fallback="hold"`` (a stop: it may exceed acceleration limits, it moves
   no joint further out).

``ok`` is False for such a tick and ``message`` says why.

One assembly. Every route solves the QP that :meth:`KinematicController.assemble` writes into the controller's
buffers: the soft tasks' rows gathered into stacked buffers (each task's ``compute_into``: J, e, and per row K, w,
ė*), the cost (H, g) formed from them by one compiled call (:func:`wbc.formulations.velocity_kernel.form_qp`; one plain
:class:`~wbc.tasks.PostureTask` enters it as a diagonal, other tasks with their own cost add it after), the
constraint rows written by each constraint, the box intersected from each bound constraint's own bounds. The tasks
of strict levels are gathered the same way, and each level's rows √w J, √w v* formed by the same formula
(:func:`wbc.formulations.velocity_kernel.weighted_rows`) for the cascade and its weighted form.

Compiled tick. With the default backend (``solver="fast"``, :class:`~wbc.solvers.fast.FastBackend`) and no strict level,
that assembled QP — the same arrays, which the solver reads and never writes — is solved by one compiled call,
:func:`wbc.formulations.velocity_kernel.kinematic_solve`: the floating base eliminated through the first contact's 6
equality rows (v_b = c − T v_j substituted into H, g and the other rows; a solver strategy, the QP is not changed) and
the exact optimum of an active set warm-started from the previous tick. When the kernel gives up on the reduced QP
(iteration cap, dependent equalities), DAQP solves the same reduced QP and the tick is completed from its answer
(:meth:`KinematicController._fused_rescue`; the kernel's next tick starts from DAQP's working set). The tick then goes
on as above (contact drift measured at q⁺); whenever no solver ends at a KKT point within the backend's tolerance,
the equality rows are rank deficient, a contact drifts above ``contact_correction``, or anything raises, the tick is
solved again by the general path described above (DAQP fallback, correction, trust region, diagnosis), so results
and failure handling are those of the general path; the compiled call counts one solve of that tick's budget, and on
every tick without strict levels a kernel attempt of :class:`~wbc.solvers.fast.FastBackend` that gives up counts one
too (``FastBackend.count_give_ups``). Soft tasks with their own cost or velocity target (other than
one plain :class:`~wbc.tasks.PostureTask`) take the general path. A task's ``weight`` array becomes a view of the
controller's stacked weights on its first assembly (in-place changes of it are seen, a new array assigned is copied
in).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field, replace
from time import perf_counter

import numpy as np
import pinocchio as pin

from wbc.compiled import specialise
from wbc.configuration import LOCAL_WORLD_ALIGNED, Configuration
from wbc.constraints.base import (BoxConstraint, Constraint, EqualityConstraint, InequalityConstraint,
                                  KinematicContext)
from wbc.constraints.contact import ContactConstraint
from wbc.constraints.limits import JointPositionLimit, JointVelocityLimit, bounded_joints
from wbc.constraints.task import TaskConstraint
from wbc.exceptions import InvalidInputError, SolverError
from wbc.geometry import Flag
from wbc.formulations.velocity_kernel import (NO_KERNEL_BOX, NONFINITE_RHS, command_within_box, command_within_rows,
                                              contact_drift, contact_pair_drift, ensure_compiled, form_qp,
                                              kinematic_finish_packed, kinematic_pack, kinematic_reduced_packed,
                                              kinematic_tick_packed, rotation_gap, rows_pack, translation_gap,
                                              weighted_rows)
from wbc.solvers import DEFAULT_SOLVER, DaqpBackend, FastBackend, QPBackend, TickWork, make_backend
from wbc.solvers.daqp import WORK_LIMIT_FACTOR
from wbc.solvers.diagnosis import diagnose
from wbc.solvers.hierarchy import independent_rows, solve_lexicographic
from wbc.solvers.linalg import clip_box_into
from wbc.solvers.status import DEPENDENT_EQUALITIES, INFEASIBLE, ITERATION_CAP, NOT_POSITIVE_DEFINITE
from wbc.robot import Robot
from wbc.tasks.base import Task
from wbc.tasks.posture import PostureTask
from wbc.tick import TickPath, TickResultBase

__all__ = ["KinematicController", "TickResult"]

#: exit codes of :func:`wbc.formulations.velocity_kernel.kinematic_solve` after which its reduced QP is handed to DAQP
#: (:meth:`KinematicController._fused_rescue`)
#: the default largest angle (rad) a contact frame may turn per tick away from where its row sends it on an ok tick
#: (``KinematicController(sole_rotation_tolerance=…)``)
SOLE_ROTATION_TOLERANCE = 3e-4
_KERNEL_GAVE_UP = (DEPENDENT_EQUALITIES, ITERATION_CAP, NOT_POSITIVE_DEFINITE, INFEASIBLE)


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
            'compiled' (the compiled tick's kernel; solver 'daqp': its reduced QP solved by DAQP), 'general'
            (the general path's flat QP; solver: the backend's name), 'levels' (strict hierarchy), with
            ``return_rate`` when the return rate of joints outside their limits was relaxed and ``budget`` when
            1.75 times the tick's budget stopped its cascade, contact correction or trust region (``message`` names what
            was skipped); on failure 'fallback' (``path.fallback`` = ``fallback``). Its string form is
            ``compiled``, ``compiled+daqp``, ``general:<backend>``, ``levels`` (each of the last two possibly
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


def _solved_result(v: np.ndarray, timings: dict[str, float], sole_drift: float, path: TickPath) -> TickResult:
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


class KinematicController:
    """Velocity-level whole-body QP (see module docstring).

    Args:
        robot: the robot.
        tasks: weighted tasks (order irrelevant).
        constraints: equality, inequality and bound constraints.
        solver: QP backend name (default ``wbc.solvers.DEFAULT_SOLVER``, DAQP: an active-set method, so bounds hold
            exactly) or a :class:`~wbc.solvers.base.QPBackend`.
        damping: ε, weight of ‖v‖² (s²·task units), > 0.
        rank_rtol: relative tolerance of the numerical rank of the equality rows.
        dependent_row_tolerance: largest residual of a dropped equality row (its units: m/s, rad/s) accepted
            without recomputing the rank within the tick.
        contact_correction: second-order contact correction threshold (m; default 1e-6, 0 = off). The contact
            rows J v = −K e hold the sole to first order in v dt only; when the distance a contact frame at
            q⁺ = pin.integrate(q, v dt) is from where its row sends it exceeds this threshold, the contact rows'
            right-hand sides are corrected by the measured drift, b ← b − (e⁺ − (1 − K dt) e)/dt, and the tick
            is solved again (a Newton step on the exact contact condition e⁺(v) = (1 − K dt) e; at most 3
            iterations). This keeps every objective and priority of the QP: only the contact target moves.
        sole_drift_tolerance: the largest contact-frame drift per tick (m, default 5e-5) on an ok tick, or None
            (drift measured in ``TickResult.sole_drift``, not enforced). A tick whose (corrected) solution still
            drifts more is solved again inside a trust region |v_i| ≤ ρ, up to 8 regions, each ρ the last one's
            times clip(0.8 · tolerance / its drift, 1/16, 1/2) starting from max|v| (the drift taken linear in ρ:
            one region where halving needed four); if none drifts less, the tick is not ok.
        sole_rotation_tolerance: the largest angle (rad, default ``SOLE_ROTATION_TOLERANCE`` = 3e-4: at a lever of
            1/6 m, sole_drift_tolerance's 5e-5 m) a contact frame may turn per tick away from where its row sends
            it on an ok tick, or None (the distance alone); enforced with sole_drift_tolerance, as part of the same
            drift (``TickResult.sole_drift``: the angle times sole_drift_tolerance / sole_rotation_tolerance when
            that is larger than the distance), by the same trust region. Both soles of a stance turned alike on an
            ok tick leave a common error that dependent contact rows with unequal gains K correct in contradicting
            ways on the next tick. The second-order correction (``contact_correction``) is started and judged on the
            distance alone. Raises InvalidInputError unless None or finite and > 0.
        budget: CPU time (s) a tick may use before its optional stages are skipped, or None (default): the tick's
            dt; counted in QP solves, ⌊budget / ``SOLVE_COST``⌋ of them (module docstring: deterministic, never
            read from a clock). Past it, a failed solve is not confirmed by independent solvers (it is still retried once cold), the
            diagnosis is skipped, the safe command's correction and trust region stop, and the tick returns the
            safe command (``TickResult.over_budget``); the relaxations (relaxable constraints: one solve; return
            rate: α = 0, with and without the contacts' corrections, always tried — with the clock guard only
            when they fit, ``clock_guard`` below —, unconfirmed; the larger α only
            while the budget lasts, one solver call each) are bounded by their counts. The failure time is
            then the budget plus at most the stage in progress and the safe command's solves. A solved tick starts
            no further strict level, contact correction or trust region past ``STAGE_FACTOR`` (1.75) times the
            budget and returns the last finished stage's command (module docstring, '+budget' path): its work is
            1.75 times the budget plus at most the stage in progress (one cascade) and its checks. Strict levels
            stop at 1 budget (``WEIGHTED_RESERVE``) and degrade to their weighted form (module docstring). ``math.inf``: no budget (every failure-handling stage runs,
            independent of the machine's load: offline analysis and tests).
        clock_guard: also count the tick's CPU time (``time.thread_time``) as work, ``CLOCK_WEIGHT`` × ⌊budget /
            ``SOLVE_COST``⌋ solves per budget of CPU time (:class:`wbc.solvers.base.TickWork`, clock guard): every limit
            above then holds on the CPU time too — a solved tick starts no further stage past
            ``STAGE_FACTOR`` / ``CLOCK_WEIGHT`` times its budget of CPU time, a DAQP call stops at
            ``wbc.solvers.daqp.WORK_LIMIT_FACTOR`` / ``CLOCK_WEIGHT`` times it, a failed tick's optional stages at
            1 / ``CLOCK_WEIGHT`` times it — whatever one counted solve costs on this machine and problem; and no
            stage after the first solve (relaxation, strict level, correction, trust region, diagnosis, safe command)
            starts unless its CPU time, as timed in this tick, ends it by ``STAGE_DEADLINE`` times the budget
            (module docstring). Default
            False: the answer is a function of the tick's inputs (reproducible simulations, tests). True (a robot's
            real-time loop): the tick time is bounded, and a tick that reaches a limit by its clock has an answer
            that depends on the machine's speed and load; a tick under every limit answers as with False; strict
            levels whose cascade does not fit the budget's CPU time are answered by their weighted form (module
            docstring, path ``levels+weighted``). Settable
            as an attribute.

    Raises:
        UnknownSolverError: unknown backend name.
        InvalidInputError: damping ≤ 0, budget not None nor finite and > 0, or an object that is not a
            Task/Constraint.
    """

    clock_guard = Flag("The tick's CPU time also counts as work (constructor docstring).")

    #: nominal CPU time (s) of one QP solve of a humanoid tick (nv ≤ 38, ≤ 120 rows, dense active-set solver, one
    #: core; the median CPU time per counted solve over the kinematic fuzz): the budget becomes a count of
    #: ⌊budget / SOLVE_COST⌋ solves per tick (constructor, ``budget``).
    SOLVE_COST = 2.5e-4
    #: a solved tick starts no further optional stage (strict level, contact correction, trust region) once
    #: STAGE_FACTOR × its budget (in counted solves) is spent, so that the stage in progress, the output guard and
    #: the drift checks still end within twice the budget (benchmarks/README.md, kinematic fuzz)
    STAGE_FACTOR = 1.75
    #: with ``clock_guard``, one budget of the tick's CPU time counts as CLOCK_WEIGHT × ⌊budget / SOLVE_COST⌋
    #: solves: > 1 leaves the stage in progress, the output guard and the safe command a share of twice the budget
    CLOCK_WEIGHT = 1.4
    #: with ``clock_guard``: a stage (a strict level, a re-solve of a relaxation, correction or trust region, the
    #: diagnosis, each solve of the safe command) starts only when the tick's CPU time plus that stage's CPU time
    #: timed in this tick (the longest such stage so far) stays within STAGE_DEADLINE × its budget; the
    #: rest of twice the budget is left to the checks that follow it and to ``hold``
    STAGE_DEADLINE = 1.5
    #: with ``clock_guard``: the one stage that may end later, by RESCUE_DEADLINE × the budget: the re-solve of a
    #: failed tick with its dependent contact rows' corrections made consistent (least squares), which decides
    #: whether the hard set has a solution at all (cutting it failed ticks that the weighted levels solve)
    RESCUE_DEADLINE = 1.7
    #: after a tick of the strict cascade that a budget cut (a level, a contact correction or a trust region not run;
    #: by the count, or the clock guard's clock), the next WEIGHTED_TICKS ticks solve the strict levels as one
    #: weighted QP (path ``levels+weighted``; one solve per re-solve instead of one per level), then the cascade is
    #: tried again (module docstring)
    WEIGHTED_TICKS = 25
    #: the weighted form of the strict levels: level k of p (0 highest) enters the soft level's cost with its rows
    #: (task weights applied) scaled by WEIGHTED_LEVEL_RATIO ** (p − k)
    WEIGHTED_LEVEL_RATIO = 100.0
    #: a tick of the strict cascade keeps WEIGHTED_RESERVE × its budget (in counted solves) for the weighted form of
    #: its levels: the cascade's levels, contact corrections and trust regions stop at (STAGE_FACTOR −
    #: WEIGHTED_RESERVE) budgets and its DAQP calls at (``wbc.solvers.daqp.WORK_LIMIT_FACTOR`` − WEIGHTED_RESERVE)
    #: budgets (``TickWork.reserve``); a cascade stopped there is answered by the weighted form within the rest
    WEIGHTED_RESERVE = 0.75
    #: counted solves added per level of the strict cascade for the work around its QP (the fixed rows of the
    #: levels above, their rank check and bands, the cost's scaling: uncounted otherwise, it makes a cascade
    #: level cost more CPU time than a flat solve), ``solve_lexicographic(level_work=…)``
    LEVEL_WORK = 0.5
    #: a safe command ('constraints_only', 'contacts_held') is taken only when it leaves every contact frame within
    #: SAFE_COMMAND_RADIUS (m) of where the current run of failed ticks began, or no farther from there than the
    #: frame already is: the per-tick drift bound alone lets a run of failed ticks walk a sole away (humanoid15,
    #: 0.036 mm per tick in one direction for 47 ticks); with it a run of failed ticks moves a stance sole at most
    #: this far (``hold``, v = 0, moves none)
    SAFE_COMMAND_RADIUS = 5e-4
    #: counted solves added to a tick that builds a new row layout (the controller's first tick, or the first after
    #: a change of its constraints that no earlier layout matches): the build and the tick's first solves on fresh
    #: buffers and solver workspaces, uncounted otherwise (module docstring, tick budget)
    LAYOUT_WORK = 4
    #: counted solves added per check of a 'contacts_held' command (forward kinematics of the command's tick, the
    #: frames' drift and run radius: uncounted otherwise, up to 9 of them as β = 0 is scaled down); a check starts
    #: only while the tick's count stays below ``wbc.solvers.daqp.WORK_LIMIT_FACTOR`` times its cap (else: hold)
    CHECK_WORK = 0.25
    #: DAQP iterations of each call of the 'contacts_held' QP at β = 0 when the tick's count was spent before its
    #: failure handling began (``_recover``: then that QP is the first safe command tried, β = 1 and 1/10 are not)
    HELD_ITERATIONS = 150

    def __init__(self, robot: Robot, tasks: list[Task] = (), constraints: list[Constraint] = (), *,
                 solver: str | QPBackend = DEFAULT_SOLVER, damping: float = 1e-6, rank_rtol: float = 1e-3,
                 dependent_row_tolerance: float = 1e-3, sole_drift_tolerance: float | None = 5e-5,
                 sole_rotation_tolerance: float | None = SOLE_ROTATION_TOLERANCE, contact_correction: float = 1e-6,
                 budget: float | None = None, clock_guard: bool = False):
        self.clock_guard = clock_guard
        if isinstance(damping, bool) or not (np.isfinite(damping) and damping > 0):
            raise InvalidInputError(f"damping must be finite and > 0, got {damping!r}")
        self.robot = robot
        self.nv = robot.model.nv
        self.damping = float(damping)
        self.rank_rtol = float(rank_rtol)
        self.dependent_row_tolerance = float(dependent_row_tolerance)
        if sole_drift_tolerance is not None and not (math.isfinite(sole_drift_tolerance) and sole_drift_tolerance > 0):
            raise InvalidInputError(f"sole_drift_tolerance must be None or finite and > 0 (m; e.g. 5e-5), got "
                                    f"{sole_drift_tolerance!r}")
        self.sole_drift_tolerance = sole_drift_tolerance
        if sole_rotation_tolerance is not None and not (math.isfinite(sole_rotation_tolerance)
                                                        and sole_rotation_tolerance > 0):
            raise InvalidInputError(f"sole_rotation_tolerance must be None or finite and > 0 (rad; e.g. 3e-4), got "
                                    f"{sole_rotation_tolerance!r}")
        self.sole_rotation_tolerance = sole_rotation_tolerance
        if not (math.isfinite(contact_correction) and contact_correction >= 0):
            raise InvalidInputError(f"contact_correction must be finite and ≥ 0 (m; 0 switches the second-order "
                                    f"contact correction off, e.g. 1e-6), got {contact_correction!r}")
        self.contact_correction = float(contact_correction)
        self.budget = budget
        self._work = TickWork()  # the tick's QP solves, shared with every backend of the controller (budget)
        self._cut: list[str] = []
        #: second-order contact corrections (re-solves) done by the last tick.
        self.contact_corrections = 0
        self._drift_data = robot.model.createData()
        self.backend = make_backend(solver) if isinstance(solver, str) else solver
        self.tasks: list[Task] = []
        self.levels: dict[int, list[Task]] = {}
        self.constraints: list[Constraint] = []
        self._hard: dict[int, TaskConstraint] = {}
        # tasks and constraints already checked against this robot (_check_robot), by id: a support switch that
        # adds back a sole's contact or swing task does not check it again (at most _CHECKED_SIZE kept)
        self._checked: dict[int, object] = {}
        self._level_order: list[int] = []
        self._level_backends: list[QPBackend] = []
        self._level_memo: dict = {}  # the cascade's retries that solved a level (hierarchy.solve_lexicographic)
        self._weighted_left = 0  # clock guard: ticks still answered by the weighted form of the strict levels
        self._weighted_tick = False  # the current tick solves the strict levels as one weighted QP
        self._weighted_qp: tuple | None = None  # (H, g) of that QP at the current tick
        self._fallback_backend: QPBackend | None = None
        self._final_backend: QPBackend | None = None
        self._band_backend: QPBackend | None = None
        #: ‖J_k v − v*_k‖ of each strict level at the last hierarchical tick (weights applied).
        self.level_residuals: list[float] = []
        self._layout_ok = False
        self._context = KinematicContext()  # what Constraint.write reads (assemble)
        self._layout_key: tuple | None = None
        self._layouts: dict[tuple, dict] = {}
        self._soft_layouts: dict[tuple, tuple] = {}
        self._fused: _FusedPlan | None = None  # the compiled tick's plan of the current layouts (solve)
        self._fused_plans: dict[tuple, _FusedPlan] = {}
        self._fused_states: dict[int, _FusedPlan] = {}  # the last plan per number of variables (its working set)
        self._prepared: set[tuple] = set()  # layouts built by prepare_layouts, not yet used by a tick
        self._eq_rows: np.ndarray | None = None
        #: largest residual (m/s, rad/s) of the dropped dependent equality rows at the last flat solve.
        self.dependent_residual = 0.0
        #: failed ticks in a row up to the last tick (0 after an ok tick).
        self.consecutive_failures = 0
        #: joints whose position range or velocity limit has zero width (locked: their bounds pin v to 0);
        #: found at build and reported once with a warning.
        self.locked_joints = self._find_locked_joints(robot)
        if self.locked_joints:
            warnings.warn(f"{len(self.locked_joints)} joint(s) have a zero-width position or velocity range and "
                          f"are treated as locked: {', '.join(self.locked_joints)}", stacklevel=2)
        for t in tasks:
            self.add_task(t)
        for c in constraints:
            self.add_constraint(c)
        self.last_result = TickResult(np.zeros(self.nv))
        self._soft_tasks: list[Task] | None = None
        self._level_key: tuple | None = None  # the strict levels' tasks of _level_rows
        self._level_rows: list[_SoftRows] = []
        self._in_solve, self._drift_cache = False, None
        self._work_stamp: tuple | None = None  # the backends _start_work last gave the tick's work to
        self._contact_expected: list[np.ndarray] | None = None
        self._svd_cache: tuple | None = None  # (J_c, U, S) of _contact_svd
        # clock guard: CPU time (s) of the longest re-solve of the tick's QP, strict level, check of a held safe
        # command in the current tick, and of the safe command's solve (this tick's longest, else the last one's)
        self._resolve_cost = self._level_cost = self._check_cost = self._safe_cost = 0.0
        self._safe_fresh = False  # _safe_cost was timed in the current tick
        self._safe_stage_cost = 0.0  # the last 'constraints_only' stage (solve, correction, trust region, checks)
        self._level_mark = 0.0  # CPU time of the tick at the last level boundary of the cascade
        self._level_count = 0.0  # counted solves of the tick at the last level boundary of the cascade
        self._resolve_work = self._level_work = 0.0
        ensure_compiled()  # the compiled assembly is loaded here, not inside the first tick

    @property
    def budget(self) -> float | None:
        """CPU time (s) of a tick before it falls back, counted in QP solves (constructor docstring), or None: the
        tick's dt.

        Raises:
            InvalidInputError: on assignment, not None and not a finite number > 0.
        """
        return self._budget

    @budget.setter
    def budget(self, value) -> None:
        if value is not None and (isinstance(value, bool) or not isinstance(value, (int, float, np.floating,
                                                                                        np.integer))
                                  or not (value > 0)):
            raise InvalidInputError(f"budget must be None (the tick's dt) or a number of seconds > 0 (math.inf: "
                                    f"no budget), got {value!r}")
        self._budget = None if value is None else float(value)
        self._budget_s = math.nan
        self._held_anchors = None  # contact frames' placements when the current run of failed ticks began

    def _late(self) -> bool:
        """The current tick's budget (counted in QP solves) is spent, or would be by one more re-solve of the
        tick's QP at the counted work of the largest so far (``_resolve_work``)."""
        return self._work.spent() or self._work.spent(1.0, self._resolve_work)

    def _stage_late(self) -> bool:
        """A solved tick starts no further stage: STAGE_FACTOR times its budget (in QP solves) is spent, or would
        be by the stage's re-solve at the counted work of the tick's largest re-solve so far (``_resolve_work``)."""
        return self._work.spent(self.STAGE_FACTOR, self._resolve_work)

    def _fits(self, cost: float, deadline: float | None = None) -> bool:
        """A stage of ``cost`` seconds of CPU time (as timed in this tick) started now ends by ``deadline``
        (default ``STAGE_DEADLINE``) times the tick's budget (clock guard; always True without it)."""
        factor = self.STAGE_DEADLINE if deadline is None else deadline
        return not self.clock_guard or self._work.seconds() + cost <= factor * self._budget_s

    def _safe_estimate(self) -> float:
        """CPU time (s) expected of one solve of the safe command: this tick's longest, else the last tick's, else
        the longest re-solve of this tick's QP."""
        return self._safe_cost or self._resolve_cost

    def _level_stop(self) -> bool:
        """``stop`` of the strict cascade (``solve_lexicographic``): STAGE_FACTOR times the budget spent (in QP
        solves), or (clock guard) the next level, at the CPU time of the longest level so far, would not end by
        ``STAGE_DEADLINE`` times the budget."""
        solves = self._work.solves
        self._level_work = max(self._level_work, solves - self._level_count)
        self._level_count = solves
        late = self._work.spent(self.STAGE_FACTOR, self._level_work)  # the next level ends past STAGE_FACTOR
        if self.clock_guard:
            now = self._work.seconds()
            self._level_cost = max(self._level_cost, now - self._level_mark)
            self._level_mark = now
            return late or not self._fits(self._level_cost)
        return late

    def _start_work(self, budget_s: float, plan=None) -> None:
        """Reset the tick's solve count, cap ⌊budget / ``SOLVE_COST``⌋, shared with every QP backend (with
        ``clock_guard``: budget / (CLOCK_WEIGHT × cap) seconds of CPU time count as one solve)."""
        cap = math.floor(budget_s / self.SOLVE_COST) if math.isfinite(budget_s) else math.inf
        clock = budget_s / (self.CLOCK_WEIGHT * max(cap, 1)) if self.clock_guard and math.isfinite(cap) else math.inf
        work = self._work
        work.reset(cap, clock)
        stamp = (self.backend, self._fallback_backend, self._final_backend, self._band_backend,
                 None if plan is None else plan.rescue)
        if self._level_backends:
            stamp += tuple(self._level_backends)
        # written only when the backends changed since the last tick that wrote them, or when that tick (or a
        # later one) took the general path, which changes their ``independent`` (solve: _work_stamp = None)
        if stamp != self._work_stamp or self.backend.work is not work:
            for b in stamp:
                if b is not None:
                    b.work = work
                    b.independent = _CONFIRM_ORDER
            self._work_stamp = stamp

    @staticmethod
    def _find_locked_joints(robot: Robot) -> list[str]:
        model = robot.model
        locked = []
        for j in range(1, model.njoints):
            joint = model.joints[j]
            if joint.nv == 0 or joint.shortname() == "JointModelFreeFlyer":
                continue
            iq, iv = joint.idx_q, joint.idx_v
            lo, hi = model.lowerPositionLimit[iq:iq + joint.nq], model.upperPositionLimit[iq:iq + joint.nq]
            vmax = model.velocityLimit[iv:iv + joint.nv]
            if np.any(np.isfinite(lo) & (hi - lo <= 0)) or np.any(vmax <= 0):
                locked.append(model.names[j])
        return locked

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
        if not isinstance(task, Task):
            raise InvalidInputError(f"expected a wbc Task, got {type(task).__name__}")
        self._check_once(task, "task")
        if hard:
            if level is not None:
                raise InvalidInputError("a task is either hard or on a priority level, not both")
            wrapper = TaskConstraint(task)
            self._hard[id(task)] = wrapper
            self.add_constraint(wrapper)
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
            index: its position in :attr:`constraints` (``list.insert``: 0 first, ``len(constraints)`` last);
                None (default): appended. The order of the constraints is the order of their rows in the QP:
                a caller that removes and adds back the same constraints (e.g. contacts at support switches)
                keeps one order per set of constraints by inserting them where they were, so that the set's
                row layout is built once and reused (:meth:`_build_layout`).

        Raises:
            InvalidInputError: not a wbc Constraint, built for another robot (other model, frame ids or nv), or
                ``index`` not an integer in [0, len(constraints)].
        """
        if index is not None and (isinstance(index, bool) or not isinstance(index, (int, np.integer))
                                  or not 0 <= index <= len(self.constraints)):
            raise InvalidInputError(f"constraint index must be an integer in [0, {len(self.constraints)}], "
                                    f"got {index!r}")
        if not isinstance(constraint, (EqualityConstraint, InequalityConstraint, BoxConstraint)):
            if isinstance(constraint, Constraint):  # e.g. an IDConstraint: rows in [v̇; f], not in v
                raise InvalidInputError(
                    f"{type(constraint).__name__} {constraint.name!r} is a constraint of the {constraint.level} level; "
                    f"a KinematicController takes velocity-level constraints (EqualityConstraint, "
                    f"InequalityConstraint, BoxConstraint of wbc.constraints)")
            raise InvalidInputError(f"expected a wbc Constraint, got {type(constraint).__name__}")
        self._check_once(constraint, "constraint")
        if index is None:
            self.constraints.append(constraint)
        else:
            self.constraints.insert(int(index), constraint)
        self._eq_rows = None
        self._layout_ok = False
        return constraint

    def _check_once(self, obj, what: str) -> None:
        """:meth:`_check_robot` for an object not already checked by this controller (a contact or swing task added
        back at a support switch is the same object, checked when first added)."""
        if self._checked.get(id(obj)) is not obj:
            self._check_robot(obj, what)
            if len(self._checked) >= _CHECKED_SIZE:
                self._checked.clear()
            self._checked[id(obj)] = obj

    def _check_robot(self, obj, what: str) -> None:
        """Raise InvalidInputError when ``obj`` (task or constraint) was built for another robot: a model that is
        not this robot's (other nq, nv or joint names), a frame id whose name differs in this model, a Jacobian
        or an index set sized for another nv."""
        model = self.robot.model
        name = getattr(obj, "name", type(obj).__name__)
        here = f"this controller's robot is {model.name!r} (nq {model.nq}, nv {model.nv})"

        def foreign(why: str) -> InvalidInputError:
            return InvalidInputError(f"{what} {name!r} was built for another robot ({why}); {here}: build it "
                                     f"with the controller's robot")

        if isinstance(obj, TaskConstraint):
            self._check_robot(obj.task, what)
        other = getattr(obj, "model", None)
        if other is None and getattr(obj, "robot", None) is not None:
            other = getattr(obj.robot, "model", None)
        if isinstance(other, pin.Model) and other is not model and (
                other.nq != model.nq or other.nv != model.nv or list(other.names) != list(model.names)):
            raise foreign(f"model {other.name!r}, nq {other.nq}, nv {other.nv}")
        for id_attr, name_attr in (("frame_id", "frame"), ("reference_id", "reference_frame")):
            fid, fname = getattr(obj, id_attr, None), getattr(obj, name_attr, None)
            if isinstance(fid, (int, np.integer)) and isinstance(fname, str) and (
                    not 0 <= fid < model.nframes or model.frames[fid].name != fname):
                raise foreign(f"its frame {fname!r} has id {fid}, which is "
                              + (f"{model.frames[fid].name!r} here" if 0 <= fid < model.nframes else
                                 f"beyond this model's {model.nframes} frames"))
        if isinstance(getattr(obj, "nv", None), (int, np.integer)) and obj.nv != model.nv:
            raise foreign(f"nv {obj.nv}")
        indices = getattr(obj, "indices", None)
        if indices is not None and np.size(indices) and int(np.max(indices)) >= model.nv:
            raise foreign(f"velocity index {int(np.max(indices))} ≥ nv")
        if isinstance(obj, (JointPositionLimit, JointVelocityLimit)):
            expected = bounded_joints(model)[1] if isinstance(obj, JointPositionLimit) else np.arange(6, model.nv)
            if not np.array_equal(np.asarray(obj.indices), expected):
                raise foreign(f"limits on {np.size(obj.indices)} velocity indices, this robot has {expected.size}")

    def remove_constraint(self, constraint: Constraint) -> None:
        """Remove a constraint added with :meth:`add_constraint`.

        Raises:
            ValueError: the constraint is not in the controller.
        """
        self.constraints.remove(constraint)
        self._eq_rows = None
        self._layout_ok = False

    @staticmethod
    def independent_rows(A: np.ndarray, rtol: float = 1e-3) -> np.ndarray:
        """Indices of a maximal linearly independent subset of the rows of A (QR with pivoting of Aᵀ)."""
        return independent_rows(A, rtol)

    # -- assembly -------------------------------------------------------------------------------------------
    def _build_layout(self) -> None:
        """Row layout of the equality and inequality blocks and their buffers (redone when constraints change).

        Layouts are kept per constraint list (the same objects in the same order, with the same row counts), so
        that a support switch that returns to an earlier set of contacts reuses its layout, buffers and the
        intersection of its constant boxes instead of building them again."""
        key = tuple((id(c), c.dim) for c in self.constraints)
        state = self.__dict__
        if self._layout_key is not None:  # keep the current layout (with what _intersect_boxes cached since)
            self._layouts[self._layout_key] = {a: state[a] for a in _LAYOUT_ATTRS if a in state}
            while len(self._layouts) > 16:
                self._layouts.pop(next(iter(self._layouts)))
        cached = self._layouts.get(key)
        if cached is not None and len(cached["_constraints"]) == len(self.constraints) and all(
                a is b for a, b in zip(cached["_constraints"], self.constraints)):
            state.update(cached)
            self._layout_key = key
            self._layout_ok = True
            if key in self._prepared:  # built ahead by prepare_layouts: its first tick counts it as built there
                self._prepared.discard(key)
                self._work.add(self.LAYOUT_WORK)
            return
        # a new layout (a controller's first tick, new constraints): its build and the first solves on its fresh
        # buffers and solver workspaces count LAYOUT_WORK solves of the tick's budget
        self._work.add(self.LAYOUT_WORK)
        self._prepared.discard(key)
        self._layout_key = key
        self._constraints = list(self.constraints)
        self._const_box = None
        eq = [c for c in self.constraints if isinstance(c, EqualityConstraint)]
        ineq = [c for c in self.constraints if isinstance(c, InequalityConstraint)]
        self._box = sorted((c for c in self.constraints if isinstance(c, BoxConstraint)), key=lambda c: c.priority)
        self._feedback = [c for c in self.constraints if c.needs_previous_command]
        self._box_sel = []  # (box, its indices as a slice when contiguous: views instead of fancy indexing)
        for c in self._box:
            idx = np.asarray(c.indices)
            contiguous = idx.size and np.array_equal(idx, np.arange(idx[0], idx[0] + idx.size))
            self._box_sel.append((c, slice(int(idx[0]), int(idx[0]) + idx.size) if contiguous else idx))
        self._relaxable = [c for c in self.constraints if c.relaxable]
        self._contacts = [c for c in self.constraints if isinstance(c, ContactConstraint)]
        self._contact_rows = np.zeros(0, dtype=int)  # equality rows of the contacts (set below)
        self._const_prefix: int | None = None  # number of leading constant boxes, cached by _intersect_boxes
        self._eq_blocks, n_eq = _row_blocks(eq)
        contact_ids = set(map(id, self._contacts))
        self._contact_blocks = [blk for blk in self._eq_blocks if id(blk[0]) in contact_ids]  # order of _contacts
        self._contact_rows = np.array([i for c, r0, r1 in self._eq_blocks if id(c) in contact_ids
                                       for i in range(r0, r1)], dtype=int)
        self._in_blocks, n_in = _row_blocks(ineq)
        relax = set(map(id, self._relaxable))  # their row blocks, one list (boxes: re-intersected without them)
        self._relaxable_blocks = [blk for blk in (*self._eq_blocks, *self._in_blocks) if id(blk[0]) in relax]
        # the floating base is eliminated through the first contact's 6 rows by the compiled solver: a free flyer at
        # v[0:6] that no box bounds (kinematic_solve)
        model = self.robot.model
        free_flyer = model.njoints > 1 and model.joints[1].shortname() == "JointModelFreeFlyer" and \
            model.joints[1].idx_v == 0
        base_bounded = any(np.size(c.indices) and int(np.min(c.indices)) < 6 for c in self._box)
        first = [r0 for c, r0, _ in self._contact_blocks if type(c) is ContactConstraint]
        self._eliminating_row = first[0] if first and free_flyer and not base_bounded else -1
        # the QP's buffers (H, g, A, b, C, l, u, lb, ub), packed with the compiled solver's workspace: every route
        # reads the QP where assemble wrote it
        self._qp_pack = kinematic_pack(self.nv, n_eq, n_in, self._eliminating_row)
        views = self._qp_pack[2]
        self._H, self._g, self._A, self._b = views["H"], views["g"], views["A"], views["b"]
        self._C, self._l, self._u, self._lb, self._ub = views["C"], views["l"], views["u"], views["lb"], views["ub"]
        self._box_rows = views["box"]  # (lb, ub)
        # each contact's rows written in place (Constraint.write into views of A, b), and its factor dt − 1/K (the
        # contact's expected error (1 − K dt) e = factor · b)
        self._contact_writes = [(c, self._A[r0:r1], self._b[r0:r1]) for c, r0, r1 in self._contact_blocks]
        # two contacts of the class itself (a biped's soles): their rows in one compiled call (write_pair)
        self._contact_pair = None
        if len(self._contact_blocks) == 2 and all(type(c) is ContactConstraint for c, _, _ in self._contact_blocks):
            (ca, ra, _), (cb, rb, _) = self._contact_blocks
            self._contact_pair = (ca, cb, ra, rb)
        self._other_eq_blocks = [blk for blk in self._eq_blocks if id(blk[0]) not in contact_ids]
        self._contact_factors = np.zeros(len(self._contact_blocks))
        self._contact_factor_values = [math.nan] * len(self._contact_blocks)  # the same as floats: written on change
        self._contact_starts = np.array([r0 for _, r0, _ in self._contact_blocks], np.int64)
        self._not_hard_task = np.ones(self._A.shape[0], dtype=bool)  # equality rows kept by the fallback
        for c, r0, r1 in self._eq_blocks:
            if isinstance(c, TaskConstraint):
                self._not_hard_task[r0:r1] = False
        self._layout_ok = True

    def _build_soft_layout(self) -> None:
        """Stacked rows of the soft tasks, gathered by :meth:`assemble` and turned into the cost by one compiled
        call (:func:`wbc.formulations.velocity_kernel.form_qp`): the Jacobians J, the errors e and, per row, gain K,
        weight w and feed-forward ė* (v* = ė* − K e; a task with its own velocity target writes v* as e with K = −1, ė*
        = 0), and one plain :class:`~wbc.tasks.PostureTask` as the diagonal term of ``form_qp``; the other tasks with
        their own cost (``Task.add_cost``) add it after. Redone when ``tasks`` changes; kept per task list (the same
        task objects in the same order and sizes) so that a swing task that comes back reuses its layout."""
        key = tuple((id(t), t.dim) for t in self.tasks)
        cached = self._soft_layouts.get(key)
        if cached is not None and all(a is b for a, b in zip(cached.tasks, self.tasks)):
            self._soft_tasks, self._soft = cached.tasks, cached
            return
        soft = _stack_rows(self.tasks, self.nv, own_costs=True)
        self._soft_tasks, self._soft = soft.tasks, soft
        self._soft_layouts[key] = soft
        while len(self._soft_layouts) > 16:
            self._soft_layouts.pop(next(iter(self._soft_layouts)))

    def assemble(self, config: Configuration, dt: float):
        """Build (H, g, A, b, C, l, u, lb, ub) of the QP at ``config`` (module docstring): the one assembly that
        every route solves (the compiled solver reads these very buffers).

        The task rows are gathered into stacked buffers (each task's ``compute_into``) and the cost formed from them
        by one compiled call (:func:`wbc.formulations.velocity_kernel.form_qp`); the constraint rows are written by each
        constraint (:meth:`~wbc.constraints.base.Constraint.write`, in place) and the box is the intersection of each bound
        constraint's own bounds (``_intersect_boxes``). The arrays are buffers owned by the controller, overwritten at
        the next call.
        """
        return self._assemble(config, dt, True)

    def _assemble(self, config: Configuration, dt: float, form_cost: bool, boxes: bool = True):
        """:meth:`assemble`; with ``form_cost`` False, H and g are left to the caller: the posture's q ⊖ q* and gain
        are kept in ``_posture_diff``, ``_posture_gain`` for :func:`~wbc.formulations.velocity_kernel.form_qp` (the
        compiled tick forms the cost inside :func:`~wbc.formulations.velocity_kernel.kinematic_tick_packed`); with
        ``boxes`` False, lb and ub are left to the caller too (the compiled tick's box, :meth:`_kernel_box`)."""
        if not self._layout_ok:
            self._build_layout()
        if self._soft_tasks != self.tasks:
            self._build_soft_layout()
        H, g = self._H, self._g
        soft = self._soft
        _gather_rows(soft, config)
        posture = soft.posture
        if posture is not None:
            diff, pgain = pin.difference(self.robot.model, posture.target, config.q), posture.gain
            if posture.weight is not soft.pw:
                posture.share_weight(soft.pw)
        else:
            diff, pgain = soft.no_diff, 0.0
        if form_cost:
            self._cost_check = form_qp(soft.J, soft.e, soft.rowp, diff, soft.pw, soft.prow, pgain, self.damping, H, g)
        else:
            self._posture_diff, self._posture_gain = diff, pgain
        for task in soft.own:
            task.add_cost(config, H, g)
        if self._level_order:  # the strict levels' rows, gathered the same way, weights applied (weighted_rows)
            key = tuple((k, id(t), t.dim) for k in self._level_order for t in self.levels[k])
            if key != self._level_key:
                self._level_key = key
                self._level_rows = [_stack_rows(self.levels[k], self.nv, own_costs=False) for k in self._level_order]
            for level in self._level_rows:
                _gather_rows(level, config)
                weighted_rows(level.J, level.e, level.rowp, level.wJ, level.wr)
        A, b = self._A, self._b
        ctx = self._context
        ctx.config, ctx.dt = config, dt
        factors, values = self._contact_factors, self._contact_factor_values
        pair = self._contact_pair
        if pair is not None:
            first, second, row, second_row = pair
            first.write_pair(second, ctx, A, b, row, second_row)
        for i, (c, A_rows, b_rows) in enumerate(self._contact_writes):
            if pair is None:
                c.write(ctx, A_rows, b_rows, None)
            f = dt - 1.0 / min(c.gain, 1.0 / dt)
            if f != values[i]:
                factors[i] = values[i] = f
        for c, r0, r1 in self._other_eq_blocks:
            c.write(ctx, A[r0:r1], b[r0:r1], None)
        if self._in_solve:  # (1 − K dt) e of each contact at this tick's configuration, from b = −K e, K = min(K, 1/dt)
            self._contact_expected = [b[r0:r1] * factors[i] for i, (c, r0, r1) in enumerate(self._contact_blocks)]
        C, l, u = self._C, self._l, self._u
        for c, r0, r1 in self._in_blocks:
            c.write(ctx, C[r0:r1], l[r0:r1], u[r0:r1])
        if boxes:
            self._intersect_boxes(config, dt)
        return H, g, A, b, C, l, u, self._lb, self._ub

    def _kernel_box(self, config: Configuration, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The box arguments of :func:`~wbc.formulations.velocity_kernel.kinematic_tick_packed` for the current
        layout: (idx, limits, constant box (2, nv)) when the boxes are constant ones followed by one
        :class:`~wbc.constraints.JointPositionLimit` (the kernel then writes lb, ub as :meth:`_intersect_boxes`
        does), else empty arrays (lb, ub assembled here)."""
        if self._const_prefix is None:
            self._intersect_boxes(config, dt)  # the constant boxes' intersection, once per layout
        rest = self._box_sel[self._const_prefix:]
        if self._const_prefix and len(rest) == 1 and type(rest[0][0]) is JointPositionLimit:
            return (*rest[0][0].packed(), self._const_box)
        return NO_KERNEL_BOX[1:]

    def _intersect_boxes(self, config: Configuration, dt: float, record: list | None = None,
                         skip: set | None = None) -> None:
        """lb, ub = intersection of the boxes in priority order, each clipped into the running box (so it
        yields where it would empty it). ``record`` receives (name, indices, lo, hi) effective bounds; boxes
        whose id is in ``skip`` are left out."""
        lb, ub = self._lb, self._ub
        boxes = self._box_sel
        first = True
        if skip is None and record is None:
            # leading constant boxes (e.g. velocity limits) are intersected once per layout
            if self._const_prefix is None:
                n_const = 0
                while n_const < len(boxes) and boxes[n_const][0].constant:
                    n_const += 1
                self._const_prefix = n_const
                self._intersect_boxes(config, dt, skip={id(c) for c, _ in boxes[n_const:]})
                self._const_box = self._box_rows.copy()  # (lb, ub)
            if self._const_prefix:
                self._box_rows[:] = self._const_box  # lb and ub in one copy
                boxes = boxes[self._const_prefix:]
                first = False
        if first:
            lb.fill(-np.inf)
            ub.fill(np.inf)
        for c, sel in boxes:
            if skip and id(c) in skip:
                continue
            if not first and record is None:  # in place: the box's own intersection (compiled where it has one)
                if isinstance(sel, slice) and type(c).intersect_into is BoxConstraint.intersect_into:
                    lo, hi = c.compute(config, dt)
                    clip_box_into(lb, ub, sel.start, lo, hi)  # the generic clip, compiled on a contiguous block
                else:
                    c.intersect_into(config, dt, lb, ub)
                continue
            lo, hi = c.compute(config, dt)
            if not first:  # clip into the running box (the first box meets ±inf only)
                cur_lo, cur_hi = lb[sel], ub[sel]
                lo = np.minimum(np.maximum(lo, cur_lo), cur_hi)
                hi = np.maximum(np.minimum(hi, cur_hi), cur_lo)
            first = False
            lb[sel] = lo
            ub[sel] = hi
            if record is not None:
                record.append((c.name, c.indices, np.array(lb[sel]), np.array(ub[sel])))

    def prepare_layouts(self, arrangements, config: Configuration, dt: float) -> None:
        """Build ahead, outside the ticks, what the first tick of each arrangement of tasks and constraints would
        build: its row layout and buffers, its soft tasks' stacked rows and, for the compiled tick, its plan, box and
        specialised kernel; the controller's own tasks, constraints and rank decision are left as they were. A
        later tick whose tasks and constraints are one of these arrangements (the same objects in the same order)
        then reuses them (e.g. the support phases of a walk plan, each switch otherwise building its phase's
        layout on the first switch to it). The answers of the ticks are unchanged.

        Args:
            arrangements: iterable of (tasks, constraints) lists, each a list of the controller's own task and
                constraint objects (soft tasks; constraints in QP row order).
            config: a configuration of the controller's robot (the argument types of the compiled kernel and the
                constant boxes are taken at it).
            dt: the control period (s) of the coming ticks.

        Raises:
            InvalidInputError: an object that is not a task or a velocity-level constraint, one built for another
                robot (the checks of :meth:`add_task` / :meth:`add_constraint`), or ``dt`` not finite and > 0.
        """
        if not (math.isfinite(dt) and dt > 0):
            raise InvalidInputError(f"dt must be a finite number of seconds > 0, got {dt!r}")
        saved = (list(self.tasks), list(self.constraints), self._eq_rows, self._layout_ok, self._layout_key)
        try:
            for tasks, constraints in arrangements:
                for t in tasks:
                    if not isinstance(t, Task):
                        raise InvalidInputError(f"expected a wbc Task, got {type(t).__name__}")
                    self._check_once(t, "task")
                for c in constraints:
                    if not isinstance(c, (EqualityConstraint, InequalityConstraint, BoxConstraint)):
                        raise InvalidInputError(f"expected a velocity-level wbc Constraint, got {type(c).__name__}")
                    self._check_once(c, "constraint")
                self.tasks[:], self.constraints[:] = tasks, constraints
                key = tuple((id(c), c.dim) for c in self.constraints)
                if key != self._layout_key or not self._layout_ok:
                    known = key in self._layouts
                    self._layout_ok = False
                    self._build_layout()
                    if not known:
                        self._prepared.add(key)
                if self._soft_tasks != self.tasks:
                    self._build_soft_layout()
                self._prepare_fused(config, float(dt))
        finally:
            self.tasks[:], self.constraints[:] = saved[0], saved[1]
            if saved[4] is not None and saved[3]:
                self._layout_ok = False
                self._build_layout()  # back to the controller's layout (kept: no build)
                if self._soft_tasks != self.tasks:
                    self._build_soft_layout()
            else:
                self._layout_ok = False
            self._eq_rows = saved[2]

    def _prepare_fused(self, config: Configuration, dt: float) -> None:
        """The compiled tick's plan of the current layouts with its box and specialised kernel (prepare_layouts),
        kept where :meth:`_fused_plan` finds it; the working-set hand-over is left to the tick."""
        if self._level_order or not isinstance(self.backend, FastBackend):
            return
        plan = self._kept_fused_plan()
        if not plan.supported:
            return
        if plan.box is None:
            plan.box = self._kernel_box(config, dt)
        q = config.q
        if plan.tick_kernel is None and type(q) is np.ndarray and q.ndim == 1 and q.flags.c_contiguous \
                and q.flags.writeable:
            soft, backend = self._soft, self.backend
            fb, ib, _ = self._qp_pack
            pgain = 0.0 if soft.posture is None else soft.posture.gain
            args = (fb, ib, soft.fb, soft.ib, soft.no_diff, pgain, self.damping, plan.states, np.empty(self.nv),
                    float(dt), backend.tolerance, backend.max_iter, q) + plan.box
            plan.tick_kernel = specialise(kinematic_tick_packed, *args)

    # -- compiled tick (wbc.formulations.velocity_kernel.kinematic_solve on the assembled QP) ------------------------
    def _fused_plan(self, config: Configuration, dt: float) -> _FusedPlan | None:
        """The compiled tick's plan for the current constraint and task layouts (built once per layout, kept
        with it), or None when the problem is outside what it covers: strict levels, a backend other than
        :class:`~wbc.solvers.fast.FastBackend`, a soft task with its own cost or velocity target other than one plain
        :class:`~wbc.tasks.PostureTask`, a contact of a subclass with rows of its own."""
        if self._level_order or not isinstance(self.backend, FastBackend):
            return None
        if not self._layout_ok:
            self._build_layout()
        if self._soft_tasks != self.tasks:
            self._build_soft_layout()
        plan = self._kept_fused_plan()
        if plan.supported:
            nr = plan.state.shape[0]
            owner = self._fused_states.get(nr)  # the plan of nr variables that solved last
            if owner is not plan:
                if owner is not None:
                    plan.state[:] = owner.state  # the joint working set, kept across support switches
                self._fused_states[nr] = plan
            plan.layout_key = self._layout_key  # the identity checked every tick
            self._fused = plan
            return plan
        return None

    def _kept_fused_plan(self) -> _FusedPlan:
        """The :class:`_FusedPlan` kept for the current layouts, built (:meth:`_build_fused_plan`) when there is
        none (at most 16 kept)."""
        key = (self._layout_key, tuple(map(id, self._soft_tasks)), id(self.backend))
        plan = self._fused_plans.get(key)
        if plan is None or plan.layout_key != self._layout_key or plan.soft_tasks is not self._soft_tasks:
            plan = self._fused_plans[key] = self._build_fused_plan()
            while len(self._fused_plans) > 16:
                self._fused_plans.pop(next(iter(self._fused_plans)))
        return plan

    def _build_fused_plan(self) -> _FusedPlan:
        """A new :class:`_FusedPlan` for the current layouts (``supported`` False when the compiled tick does not
        cover them, :meth:`_fused_plan`)."""
        plan = _FusedPlan()
        plan.layout_key = self._layout_key
        plan.soft_tasks = self._soft_tasks
        plan.backend = self.backend
        soft = self._soft
        if soft.own or any(not plain for *_, plain in soft.rows):
            return plan  # a task with its own cost (other than one posture task) or velocity target
        if any(type(c) is not ContactConstraint for c in self._contacts):
            return plan  # a contact with rows of its own
        nv = self.nv
        nr = nv - 6 if self._eliminating_row >= 0 else nv
        # the joint working set (kept across support switches: _fused_plan) then the rows', one array for the kernel
        plan.states = np.zeros(nr + self._C.shape[0], np.int8)
        plan.state, plan.rstate = plan.states[:nr], plan.states[nr:]
        plan.vdt = self._qp_pack[2]["vdt"]
        plan.logs = np.zeros((len(self._contacts), 6))
        plan.contact_logs = list(zip(self._contacts, plan.logs))  # each contact with its row of logs (a view)
        plan.pair_rows = tuple(int(r0) for r0 in self._contact_starts)  # a pair's starts as ints (contact_pair_drift)
        plan.rescue = None  # DAQP on the reduced QP when the kernel gives up (_fused_rescue), made on first use
        plan.box = None  # the kernel's box arguments (_kernel_box), on the first tick
        plan.supported = True
        return plan

    def _fused_tick(self, plan: _FusedPlan, config: Configuration, dt: float, t0: float) -> TickResult | None:
        """One tick through the compiled solver (:func:`wbc.formulations.velocity_kernel.kinematic_solve`): the QP
        assembled by :meth:`assemble` — the same buffers the general path solves — with the floating base eliminated and
        solved exactly. Returns None when the solver does not end at a KKT point within tolerance, when the equality
        rows are rank deficient, or when a contact drifts above ``contact_correction`` / ``sole_drift_tolerance``: the
        caller then solves the tick by the general path (DAQP fallback, correction, trust region, diagnosis)."""
        if self._eq_rows is not None and self._eq_rows.size != self._A.shape[0]:
            return None  # dependent equality rows (known since the last rank computation): the general path
        model = self.robot.model
        q = config.q
        box = plan.box
        if box is None:  # the plan's first tick
            box = plan.box = self._kernel_box(config, dt)
        # the cost (and the box, when the kernel writes it) are formed by the kernel below
        H, g, A, b, C, l, u, lb, ub = self._assemble(config, dt, False, box[2].shape[0] == 0)
        if self._eq_rows is None:
            self._eq_rows = independent_rows(A, self.rank_rtol)
        if self._eq_rows.size != A.shape[0]:
            return None  # dependent equality rows: dropped and checked by the general path
        t1 = perf_counter()
        v = np.empty(self.nv)
        backend = self.backend
        fb, ib, _ = self._qp_pack
        tol = backend.tolerance
        soft = self._soft
        # one compiled call: the cost (form_qp); every number of the cost and the contact targets finite (targets,
        # weights, gains written in place, q, placements: NaN and inf propagate into these sums; else None, the
        # general path meets them and fails the tick); the solve; the output guard's compiled screens: v finite and
        # inside the box of the constraint objects and the inequality rows, to the backend's tolerance (the assembled
        # bounds: the solver reads them, never writes them)
        args = (fb, ib, soft.fb, soft.ib, self._posture_diff, self._posture_gain, self.damping, plan.states, v,
                float(dt), tol, backend.max_iter, q) + box  # box: a tuple (_kernel_box)
        kernel = plan.tick_kernel
        if not (type(q) is np.ndarray and q.ndim == 1 and q.flags.c_contiguous and q.flags.writeable):
            kernel = kinematic_tick_packed  # a configuration's q of another type: numba's dispatch
        elif kernel is None:  # the plan's first tick: the types of its buffers (and of q, checked above) are fixed
            kernel = plan.tick_kernel = specialise(kinematic_tick_packed, *args)
        it, guard = kernel(*args)
        # a solve attempt like any other (TickWork): counted, so that a tick the general path takes over from here
        # has it in its count (its CPU time is about one solve's)
        self._work.add(1)
        if it == NONFINITE_RHS:
            return None
        backend.last_kernel_iterations = it
        rescued = it in _KERNEL_GAVE_UP and C.shape[0] > 0
        if rescued:
            it = self._fused_rescue(plan, v, dt)
            guard = it >= 1 and command_within_box(v, lb, ub, tol) and (
                C.shape[0] == 0 or command_within_rows(v, C, l, u, tol))
        if it < 1:
            return None  # the general path: diagnosis, relaxation, safe command
        if not guard and self._command_fault(v, lb, ub, C, l, u):  # the compiled screens pass only where it returns ''
            return None
        drift = 0.0
        if self._contacts:
            # the kinematics at the next configuration, computed once: the configuration's lookahead, which its
            # step with this v adopts (Configuration.lookahead); each contact frame placed (data.oMf), what
            # error_into reads
            ndata = config.lookahead(plan.vdt)
            lever = self._drift_lever()
            if ndata is None:  # a configuration subclass with its own update: the frames' supporting joints only
                ndata = self._drift_data
                q_next = pin.integrate(model, q, plan.vdt)
                for c, log in plan.contact_logs:
                    pin.computeFrameJacobian(model, ndata, q_next, c.frame_id, LOCAL_WORLD_ALIGNED)
                    c.error_into(ndata, log)
                far, drift = contact_drift(plan.logs, b, self._contact_starts, self._contact_factors, lever)
            elif len(plan.contact_logs) == 2:  # a biped's two soles: one compiled call (contact_pair_drift)
                (ca, _), (cb, _) = plan.contact_logs
                pin.updateFramePlacement(model, ndata, ca.frame_id)
                pin.updateFramePlacement(model, ndata, cb.frame_id)
                (ra, rb), (f_a, f_b) = plan.pair_rows, self._contact_factor_values
                args = ca.log_operands(ndata) + cb.log_operands(ndata) + (plan.logs, b, ra, rb, f_a, f_b, lever)
                if plan.drift_kernel is None:  # Pinocchio's views and the plan's buffers: fixed types
                    plan.drift_kernel = specialise(contact_pair_drift, *args)
                far, drift = plan.drift_kernel(*args)
                if drift < 0.0:  # a half-turn error: Pinocchio's log6 (error_into)
                    ca.error_into(ndata, plan.logs[0])
                    cb.error_into(ndata, plan.logs[1])
                    far, drift = contact_drift(plan.logs, b, self._contact_starts, self._contact_factors, lever)
            else:
                for c, log in plan.contact_logs:
                    pin.updateFramePlacement(model, ndata, c.frame_id)
                    c.error_into(ndata, log)
                far, drift = contact_drift(plan.logs, b, self._contact_starts, self._contact_factors, lever)
            if (self.contact_correction > 0 and far > self.contact_correction) or (
                    self.sole_drift_tolerance is not None and drift > self.sole_drift_tolerance):
                return None  # second-order correction / trust region: the general path
        if not rescued:
            backend.kernel_solves += 1
        self.dependent_residual = 0.0
        self.contact_corrections = 0
        result = _solved_result(v, {"assembly": t1 - t0, "solve": perf_counter() - t1}, drift,
                                _COMPILED_DAQP if rescued else _COMPILED)
        for c in self._feedback:
            c.set_previous(v)
        self.consecutive_failures = 0
        self.last_result = result
        return result

    def _fused_rescue(self, plan: _FusedPlan, v: np.ndarray, dt: float) -> int:
        """The compiled solver gave up on its reduced QP (dependent active rows — e.g. self-collision rows of the
        thighs, whose motion the contacts fix, nearly parallel — or its iteration cap): that same QP
        (:func:`wbc.formulations.velocity_kernel.kinematic_reduced_packed`) is solved by DAQP, whose dual active set
        handles dependent constraints, and the tick completed from its solution
        (:func:`wbc.formulations.velocity_kernel.kinematic_finish_packed`: base velocity, every original row checked).
        The kernel's next tick is warm-started from DAQP's working set (its nonzero multipliers: linearly independent
        rows), from which it converges again. Returns 1 on success, else the kernel's exit code (the general path then
        solves the tick)."""
        backend = self.backend
        rescue = plan.rescue
        if rescue is None:
            rescue = plan.rescue = DaqpBackend(tolerance=backend.tolerance, **backend.settings)
            rescue.work = self._work
        fb, ib, _ = self._qp_pack
        H, g, A, b, C, l, u, lb, ub = kinematic_reduced_packed(fb, ib)
        try:  # unconfirmed: a failure here sends the tick to the general path, which solves it again
            x = rescue.solve(H, g, A, b, C, l, u, lb, ub, confirm=False)
        except SolverError:
            return backend.last_kernel_iterations
        if not kinematic_finish_packed(fb, ib, x, v, float(dt), backend.tolerance):
            return backend.last_kernel_iterations
        lam = rescue.last_multipliers
        n, m = H.shape[0], A.shape[0]
        if lam is not None and lam.shape[0] == n + m + C.shape[0]:
            plan.state[:] = np.sign(lam[:n])
            plan.rstate[:] = np.sign(lam[n + m:])
        else:  # no multipliers (an independent solver answered): the bounds and rows x touches
            plan.state[:] = (x >= ub) * 1 - (x <= lb)
            cx = C @ x
            plan.rstate[:] = (cx >= u - 1e-12) * 1 - (cx <= l + 1e-12)
        backend.fallbacks += 1
        backend.reduced_fallbacks += 1
        return 1

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
        self._budget_s = dt if self._budget is None else self._budget
        self._start_work(self._budget_s, self._fused)  # counted in QP solves: deterministic
        self._resolve_cost = self._level_cost = self._check_cost = 0.0
        self._resolve_work = self._level_work = 0.0  # counted solves of the largest re-solve / strict level so far
        self._safe_fresh = False
        plan = self._fused
        if plan is None or not (self._layout_ok and plan.layout_key is self._layout_key and self._soft_tasks == self.tasks
                                and plan.soft_tasks is self._soft_tasks and plan.backend is self.backend
                                and not self._level_order):
            plan = self._fused_plan(config, dt)
        if plan is not None:
            if plan.rescue is not None:
                plan.rescue.work = self._work
            try:
                result = self._fused_tick(plan, config, dt, t0)
            except InvalidInputError:
                raise
            except Exception:  # noqa: BLE001 — the general path below meets it again and handles it
                result = None
            if result is not None:
                return result
        self._work_stamp = None  # the general path may change the backends' ``independent``: _start_work
        if isinstance(self.backend, FastBackend):
            # the general path of a flat QP's tick counts the kernel attempts that give up (and skips the kernel on
            # its later problems of that shape; the compiled tick above uses no FastBackend): uncounted, a return-rate ladder and trust region on joints held at their limits spent
            # twice the budget (kinematic fuzz seed 550037 episode 189). The strict cascade's stages keep their
            # calibrated count (LEVEL_WORK, WEIGHTED_RESERVE)
            self.backend.count_give_ups = not self._level_order
            # the weighted form of strict levels (self.backend's only QP on their ticks) skips the kernel on the
            # tick's later problems of a shape it gave up on, uncounted: its contact correction repeated a give-up
            # of up to 100 iterations on each re-solve (kinematic fuzz seed 550004 episode 366 tick 0)
            self.backend.skip_give_ups = bool(self._level_order)
        t1 = None
        self._assembled = False
        self._in_solve, self._drift_cache, self._contact_expected = True, None, None
        self._projected_contacts = []
        weighted_start = bool(self._level_order) and self._weighted_left > 0
        self._weighted_tick = weighted_start
        self._weighted_qp = None
        if self._level_order and not weighted_start and math.isfinite(self._work.cap):
            # the cascade's stages stop WEIGHTED_RESERVE budgets early: the rest is its weighted form's
            self._work.reserve = self.WEIGHTED_RESERVE * self._work.cap
        return_rate, held = None, False
        try:
            H, g, A, b, C, l, u, lb, ub = self.assemble(config, dt)
            self._assembled = True
            fault = self._data_fault()
            if fault:
                raise SolverError(f"non-finite numbers in the tick's QP: {fault}")
            t1 = perf_counter()
            try:
                v = self._solve_assembled(config)
                relaxed = []
            except SolverError as first_failure:
                v = None
                self._work.reserve = 0.0  # the relaxations count as before
                # clock guard: no relaxation would end in time (the least-squares re-solve below, which decides
                # whether the hard set has a solution at all, by RESCUE_DEADLINE budgets)
                if not self._fits(self._resolve_cost, self.RESCUE_DEADLINE):
                    raise SolverError(f"{first_failure}; relaxations skipped: tick budget spent (clock guard)") \
                        from None
                if self._level_order and not self._weighted_tick and self._late():
                    # the failed cascade spent the tick's count: its retries below are answered by the weighted
                    # form of its levels (one QP each, as a cascade cut by the count is; fuzz seed 100014 episode
                    # 176 tick 39: the least-squares retry's cascade took 6 more solves, no correction was left)
                    self._weighted_tick, self._weighted_qp = True, None
                    self._cut.append("priority levels of the retries (their weighted form's command)")
                if self._contact_rows.size and self._consistent_contact_rhs():
                    # dependent contact rows asked contradictory corrections: once more in least squares (one
                    # solve or cascade, not cut by the budget: a strict cascade that had spent it failed ticks the
                    # weighted level solves, kinematic fuzz seed 410002)
                    try:
                        v = self._solve_assembled(config)
                        relaxed = []
                    except SolverError:
                        v = None
                relaxed = []
                if v is None and self._relaxable:  # (one solve: not cut by the count)
                    if not self._fits(self._resolve_cost):
                        raise SolverError(f"{first_failure}; relaxations skipped: tick budget spent (clock guard)")
                    self._relax(config, dt)
                    relaxed = [c.name for c in self._relaxable]
                    try:
                        v = self._solve_assembled(config)
                    except SolverError:
                        v = None
                if v is None:
                    v, return_rate, held = self._relax_return_rate(config, first_failure)  # raises if not
                    relaxed.append(f"joint_position_limit return rate × {return_rate:g}")
                    if held:
                        relaxed.append("contact drift correction × 0 (J_c v = 0)")
            if self.contact_correction > 0 and self._contacts and not held:
                v = self._correct_contacts(config, dt, v)
            result = self._hold_contacts(config, dt, v, relaxed)
            if (not result.ok and self._cut and self._level_order and not self._weighted_tick
                    and return_rate is None and not held):
                result = self._weighted_answer(config, dt, relaxed) or result
            if not result.ok and return_rate is not None and not held:
                result, return_rate = self._slower_return(config, dt, relaxed, return_rate, result)
            if result.ok:
                fault = self._command_fault(result.v, self._lb, self._ub, self._C, self._l, self._u)
                if fault:
                    raise SolverError(f"output guard: {fault}")
                result.path = (TickPath("levels", weighted=self._weighted_tick) if self._level_order
                               else TickPath("general", self.backend.name))
                if return_rate is not None:
                    result.path = replace(result.path, return_rate=True)
            else:  # no trust region kept the contacts: that command is not taken either (the safe command is)
                raise _DriftFailure(result.message)
            if not result.ok and self._projected_contacts:
                # the hard set had no solution until the dependent contact rows were made consistent: name them
                result.conflicts = list(self._projected_contacts)
                worst = max(d for _, d in self._projected_contacts)
                names = [name for name, _ in self._projected_contacts]
                result.message += (f"; the contacts {names} ask contradictory corrections of dependent "
                                   f"directions (projected by up to {worst:.3g} in their rows' units)")
        except InvalidInputError:
            self._in_solve, self._drift_cache = False, None
            raise
        except Exception as exc:  # noqa: BLE001 — no failure may escape the control tick (module docstring)
            t1 = t1 or perf_counter()
            self._eq_rows = None  # the rank may have changed: recompute next tick
            self._work.reserve = 0.0
            result = self._recover(config, dt, exc)
        self._in_solve, self._drift_cache = False, None
        if self._level_order:
            # a cascade that did not fit (its levels or the stages after it stopped by the budget): the next ticks
            # answer with the weighted form (one QP), at least WEIGHTED_TICKS of them and until one is cheap enough
            # for the cascade (_cascade_fits)
            if weighted_start:
                self._weighted_left -= 1
                if self._weighted_left <= 0 and not self._cascade_fits():
                    self._weighted_left = 1
            elif self._cut:
                self._weighted_left = self.WEIGHTED_TICKS
        t2 = perf_counter()
        result.timings = {"assembly": t1 - t0, "solve": t2 - t1}
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

    def _data_fault(self) -> str:
        """'' when the assembled QP's numbers are finite (bounds may be ±inf, never NaN), else what is not."""
        what = [name for name, x in (("cost H", self._H), ("cost g", self._g), ("equality rows A", self._A),
                                     ("equality rhs b", self._b), ("inequality rows C", self._C))
                if not np.isfinite(x).all()]
        what += [name for name, x in (("inequality bounds", self._l), ("inequality bounds", self._u),
                                      ("box lb", self._lb), ("box ub", self._ub)) if np.isnan(x).any()]
        return ", ".join(dict.fromkeys(what))

    def _command_fault(self, v: np.ndarray, lb: np.ndarray, ub: np.ndarray, C: np.ndarray, l: np.ndarray,
                       u: np.ndarray) -> str:
        """Output guard of an ok tick: '' when v is finite, within [lb, ub] and l ≤ C v ≤ u to the backend's
        tolerance (each bound or row scaled by max(1, |bound|), as :meth:`wbc.solvers.base.QPBackend.scaled_violation`),
        else what it violates. The contact rows are held by the sole-drift check (``sole_drift_tolerance``)."""
        if not math.isfinite(float(v @ v)):
            return "the command v is not finite"
        tol = self.backend.tolerance
        over = np.maximum(lb - v, v - ub)
        if not (over.max(initial=-math.inf) <= tol):
            excess = over / np.maximum(1.0, np.maximum(np.abs(np.where(np.isfinite(lb), lb, 0.0)),
                                                       np.abs(np.where(np.isfinite(ub), ub, 0.0))))
            k = int(np.nanargmax(np.where(np.isnan(excess), np.inf, excess)))
            if not excess[k] <= tol:
                return (f"v[{k}] = {v[k]:.6g} outside its bounds [{lb[k]:.6g}, {ub[k]:.6g}] (tolerance {tol:.3g})")
        if C.shape[0]:
            cv = C @ v
            scale = np.maximum(1.0, np.abs(C) @ np.abs(v))
            over = np.maximum(l - cv, cv - u) / np.maximum(scale, np.maximum(
                np.abs(np.where(np.isfinite(l), l, 0.0)), np.abs(np.where(np.isfinite(u), u, 0.0))))
            if not (over.max() <= tol):
                k = int(np.nanargmax(np.where(np.isnan(over), np.inf, over)))
                return f"inequality row {k}: C v = {cv[k]:.6g} outside [{l[k]:.6g}, {u[k]:.6g}] (tolerance {tol:.3g})"
        return ""

    def _outside_limits(self, config: Configuration) -> tuple[np.ndarray, np.ndarray]:
        """(indices into v of the joints below their lower position limit whose box asks a return, the same above
        the upper limit), from the assembled box (``_relax_return_rate``)."""
        entries = []
        for c in self._box:
            if isinstance(c, JointPositionLimit):
                q = config.q[c.idx_q]
                idx = np.asarray(c.indices)
                entries.append(idx[(q < c.q_min) & (self._lb[idx] > 0)])
                entries.append(idx[(q > c.q_max) & (self._ub[idx] < 0)])
        if not entries:
            return np.zeros(0, int), np.zeros(0, int)
        return np.concatenate(entries[0::2]), np.concatenate(entries[1::2])

    def _relax_return_rate(self, config: Configuration, failure: SolverError) -> tuple[np.ndarray, float, bool]:
        """Solve the tick again with the return rate of the joints outside their position limits relaxed.

        A joint outside its range must return at min(distance/dt, v_max) (:class:`JointPositionLimit`); with
        several such joints and both soles in contact that can be impossible while a slower return is not. The
        return rate ranks below every other hard constraint and above the tasks: the required return velocity of
        each such joint is scaled by α in ``_RETURN_RATE_SCALES`` (1/2, 1/10, 1/100, 1/1000, 0; α = 0 only forbids
        moving further out). α = 0 is solved first: the feasible sets are nested (larger as α falls), so when it has
        no solution no α has. Then the larger scales from 1/1000 up, each started only while the tick's counted
        budget lasts, until one has no solution (nor has any larger): the largest that solved is kept. These trial
        solves are unconfirmed and not retried (``QPBackend.cold_retry``): a failure only ends the climb.

        When even α = 0 has no solution and contacts are held, their drift corrections −K e rank below it: the
        contact rows become J_c v = 0 (each contact frame kept where it is, to first order, instead of pulled back
        onto its placement; the correction of a stance sole's accumulated drift can ask a joint held at α = 0 to
        move further out) and the ladder above is solved with them. The tick's sole-drift check still measures the
        drift from where the full correction would send the frame, so an ok tick keeps its bound. With the clock
        guard each of these solves starts only when a re-solve of the tick's QP still fits (``_fits``).

        Returns:
            (v, α, held): held is True when the contacts' corrections were dropped (J_c v = 0). The controller's
            buffers hold the problem of the returned command (output guard, trust region).

        Raises:
            SolverError: ``failure`` (the tick's) when no joint is outside its limits, or α = 0 has no solution
                (with the contacts held either).
        """
        low, high = self._outside_limits(config)
        if not (low.size or high.size):
            raise failure
        if not self._fits(self._resolve_cost):
            raise SolverError(f"{failure}; return-rate relaxation skipped: tick budget spent (clock guard)")
        lb0, ub0 = self._lb[low].copy(), self._ub[high].copy()
        backends = [b for b in (self.backend, self._final_backend, *self._level_backends) if b is not None]
        independent = [b.independent for b in backends]
        held = False
        try:
            for b in backends:  # a failed α needs no independent confirmation: the next α is tried
                b.independent = ()
            self._lb[low] = 0.0
            self._ub[high] = 0.0
            try:
                v0 = self._solve_assembled(config)
            except SolverError:
                v0 = None
            if v0 is None and self._contact_rows.size and self._fits(self._resolve_cost):
                self._b[self._contact_rows] = 0.0  # the contacts held where they are: J_c v = 0
                try:
                    v0 = self._solve_assembled(config)
                    held = True
                except SolverError:
                    v0 = None
            if v0 is None:
                raise SolverError(f"{failure}; no solution either with the joints outside their limits held where "
                                  f"they are (return rate 0)" + (", nor with the contacts held where they are"
                                                                  if self._contact_rows.size else ""))
            for b in backends:  # a failed α only sends the ladder to the next one: no cold retry either
                b.cold_retry = False
            v, best = v0, 0.0
            for alpha in reversed(_RETURN_RATE_SCALES[:-1]):  # from the slowest return up
                if self._late() or not self._fits(self._resolve_cost):
                    break
                self._lb[low] = alpha * lb0
                self._ub[high] = alpha * ub0
                try:
                    v, best = self._solve_assembled(config), alpha
                except SolverError:
                    break  # (feasible sets nested: no larger α has a solution)
            self._lb[low] = best * lb0  # the buffers hold the problem of the returned command
            self._ub[high] = best * ub0
            self._return_bounds = (low, high, lb0, ub0)
            return v, best, held
        finally:
            for b, ind in zip(backends, independent):
                b.independent = ind
                b.cold_retry = True

    def _slower_return(self, config: Configuration, dt: float, relaxed: list, alpha: float,
                       result: TickResult) -> tuple[TickResult, float]:
        """After the return-rate ladder (``_relax_return_rate``) kept α but no trust region held the contacts:
        the smaller scales of ``_RETURN_RATE_SCALES`` down to 0, each solved and held by the trust region, while the
        tick's stages last. The sole-drift bound of an ok tick ranks above the return rate: a return whose own
        motion drifts a stance sole past ``sole_drift_tolerance`` is slowed until it does not (α = 0 only forbids
        moving further out, and its trust region can shrink v to 0); last, α = 0 with the contacts' drift
        corrections dropped (J_c v = 0, as the ladder's last step), whose drift is still measured from where the full
        correction would send each frame.

        Returns:
            (result, α) of the first scale whose tick is ok, else (``result``, ``alpha``) unchanged with the
            buffers holding α's problem again.
        """
        low, high, lb0, ub0 = self._return_bounds
        backends = [b for b in (self.backend, self._final_backend, *self._level_backends) if b is not None]
        independent = [b.independent for b in backends]
        try:
            for b in backends:  # (as in the ladder: an unconfirmed failure only sends it to the next scale)
                b.independent = ()
            for a in (x for x in _RETURN_RATE_SCALES if x < alpha):
                if self._stage_late() or not self._fits(self._resolve_cost):
                    self._cut.append(f"slower returns below × {alpha:g}")
                    break
                self._lb[low] = a * lb0
                self._ub[high] = a * ub0
                try:
                    v = self._solve_assembled(config)
                except SolverError:
                    continue
                if self.contact_correction > 0 and self._contacts:
                    v = self._correct_contacts(config, dt, v)
                r = self._hold_contacts(config, dt, v, relaxed)
                if r.ok:
                    relaxed[-1] = f"joint_position_limit return rate × {a:g}"
                    return r, a
            if self._contact_rows.size and not self._stage_late() and self._fits(self._resolve_cost):
                # α = 0 with the contacts held where they are (J_c v = 0), as the ladder's last step: the drift
                # from where the full correction would send a frame is then K dt e plus second order in v dt
                b0 = self._b[self._contact_rows].copy()
                self._lb[low], self._ub[high] = 0.0, 0.0
                self._b[self._contact_rows] = 0.0
                try:
                    r = self._hold_contacts(config, dt, self._solve_assembled(config), relaxed)
                except SolverError:
                    r = None
                if r is not None and r.ok:
                    relaxed[-1] = "joint_position_limit return rate × 0"
                    relaxed.append("contact drift correction × 0 (J_c v = 0)")
                    return r, 0.0
                self._b[self._contact_rows] = b0
            elif self._contact_rows.size:
                self._cut.append(f"slower returns below × {alpha:g}")
            self._lb[low] = alpha * lb0
            self._ub[high] = alpha * ub0
            return result, alpha
        finally:
            for b, ind in zip(backends, independent):
                b.independent = ind

    def sole_drift(self, config: Configuration, v: np.ndarray, dt: float) -> float:
        """Largest drift (m) of the contact frames over one tick of dt (s) with v (nv,): by forward kinematics at
        pin.integrate(q, v dt), the larger of the distance from where each frame ends to where its contact row
        sends it (placement · exp((1 − K dt) e)) and the angle between the two (rad) times
        sole_drift_tolerance / sole_rotation_tolerance (constructor; the distance alone when either is None);
        ``TickResult.sole_drift``."""
        if not self._layout_ok:
            self._build_layout()
        return self._contact_drifts(config, v, dt)[2]

    def _contact_drifts(self, config: Configuration, v: np.ndarray,
                        dt: float) -> tuple[float, list[np.ndarray], float]:
        """(largest distance (m), [(6,) e⁺ − (1 − K dt) e per contact], largest drift (m)) over one tick with v:
        the distance of a contact frame from where it ends (placement · exp(e⁺)) to where its row sent it
        (placement · exp((1 − K dt) e)); its drift the larger of that distance and the lever times their angle
        (:meth:`sole_drift`)."""
        if not self._contacts:
            return 0.0, [], 0.0
        cache = self._drift_cache  # within one solve(): the drift of the same v is not computed twice
        if cache is not None and cache[0] is v and cache[1] is config.q and cache[2] == dt:
            return cache[3]
        model, data = self.robot.model, self._drift_data
        pin.forwardKinematics(model, data, pin.integrate(model, config.q, v * dt))
        far = worst = 0.0
        lever = self._drift_lever()
        drifts = []
        expected = self._contact_expected if self._in_solve else None  # assembled at this config within solve()
        for i, c in enumerate(self._contacts):
            after = pin.log6(c.placement.actInv(pin.updateFramePlacement(model, data, c.frame_id))).vector
            target = c.compute_error(config) * (1.0 - min(c.gain, 1.0 / dt) * dt) if expected is None else expected[i]
            drifts.append(after - target)
            d = translation_gap(after, 1.0, target, 1.0)  # the distance, not the twists' gap
            far = max(far, d)
            if lever > 0:
                d = max(d, lever * rotation_gap(after, 1.0, target, 1.0))
            worst = max(worst, d)
        if self._in_solve:
            self._drift_cache = (v, config.q, dt, (far, drifts, worst))
        return far, drifts, worst

    def _drift_lever(self) -> float:
        """m per rad: a contact frame's drift is the larger of its distance and this times its angle, so that an
        angle of sole_rotation_tolerance counts as a distance of sole_drift_tolerance (0, the distance alone, when
        either is None)."""
        tol, turn = self.sole_drift_tolerance, self.sole_rotation_tolerance
        return 0.0 if tol is None or turn is None else tol / turn

    def _consistent_contact_rhs(self) -> bool:
        """Drift corrections of dependent contact rows made consistent (least squares); True when b changed.

        When the contact rows J_c are rank deficient (two flat 5-DoF legs in gimbal lock both fix the base yaw),
        their drift corrections −K e may disagree in the dependent directions (the feet's yaw errors differ after
        a finite step), which no v can meet. After such a failed solve, b_c is replaced by its projection
        U_r U_rᵀ b_c onto the range of J_c (truncated SVD, singular values > ``rank_rtol`` · the largest): the
        corrections are averaged where the contacts are dependent and unchanged where they are not."""
        rows = self._contact_rows
        U, S = self._contact_svd()
        rank = int(np.sum(S > self.rank_rtol * max(S[0], 1.0))) if S.size else 0
        if rank == rows.size:
            return False
        Ur = U[:, :rank]
        projected = Ur @ (Ur.T @ self._b[rows])
        changed = not np.array_equal(projected, self._b[rows])
        change = np.abs(projected - self._b[rows])
        self._projected_contacts = []  # (contact name, largest change of its rows' rhs) for the report
        for c, r0, r1 in self._eq_blocks:
            if isinstance(c, ContactConstraint):
                sel = (rows >= r0) & (rows < r1)
                if sel.any() and change[sel].max() > 1e-9:
                    self._projected_contacts.append((c.name, float(change[sel].max())))
        self._b[rows] = projected
        self._eq_rows = None  # recompute the independent rows for the retry
        return changed

    def _contact_svd(self) -> tuple[np.ndarray, np.ndarray]:
        """(U, S) of the thin SVD of the contact rows J_c in the assembled buffers, kept while J_c is unchanged: a
        failed tick asks it of the same rows several times (its retry, contact corrections, trust regions and safe
        command), each an SVD otherwise uncounted."""
        Jc = self._A[self._contact_rows]
        cached = self._svd_cache
        if cached is None or cached[0].shape != Jc.shape or not np.array_equal(cached[0], Jc):
            U, S, _ = np.linalg.svd(Jc, full_matrices=False)
            U.setflags(write=False)
            S.setflags(write=False)
            cached = self._svd_cache = (Jc, U, S)
        return cached[1], cached[2]

    def _contact_range_basis(self) -> np.ndarray | None:
        """Orthonormal basis U_r (rows of the contacts × rank) of the range of the contact rows J_c when they are
        rank deficient (truncated SVD, singular values > ``rank_rtol`` · max(the largest, 1)), else None."""
        rows = self._contact_rows
        if self._eq_rows is not None and self._eq_rows.size == self._A.shape[0]:
            return None  # every equality row independent (rank computed on this constraint set)
        U, S = self._contact_svd()
        rank = int(np.sum(S > self.rank_rtol * max(S[0], 1.0))) if S.size else 0
        return None if rank == rows.size else U[:, :rank]

    def _correct_contacts(self, config: Configuration, dt: float, v: np.ndarray, solve=None,
                          bounded: bool = False) -> np.ndarray:
        """Second-order contact correction (constructor docstring, ``contact_correction``); ``solve(config)``
        re-solves the problem in the buffers (default: the tick's QP)."""
        solve = solve or self._solve_assembled
        cost = self._safe_estimate if solve == self._solve_constraints_only else lambda: self._resolve_cost
        self.contact_corrections = 0
        worst, drifts, _ = self._contact_drifts(config, v, dt)
        if worst <= self.contact_correction:
            return v
        blocks = {id(c): (r0, r1) for c, r0, r1 in self._eq_blocks}
        rows = [blocks[id(c)] for c in self._contacts]
        range_basis = self._contact_range_basis()
        b0 = self._b.copy()
        try:
            for k in range(3):
                # the refinement stops at the tick budget (the safe command's) or STAGE_FACTOR times it (a solved tick's); the
                # best command so far is kept
                if (self._late() if bounded else self._stage_late()) or not self._fits(cost()):
                    if not bounded:
                        self._cut.append(f"contact correction after {k} of 3 re-solves")
                    break
                for (r0, r1), d in zip(rows, drifts):
                    self._b[r0:r1] -= d / dt
                if range_basis is not None:
                    # dependent contact rows (two flat feet both fixing the base yaw): the feet's second-order
                    # drifts differ in the dependent directions, so the corrected right-hand sides would contradict
                    # each other (measured on humanoid15: the corrected solve failed or was not better, the
                    # correction was dropped and the soles slid 0.03 mm per ok tick, > 1 mm over a stance).
                    # Least squares instead: the corrections projected onto the range of J_c.
                    cr = self._contact_rows
                    self._b[cr] = range_basis @ (range_basis.T @ self._b[cr])
                try:
                    v_new = solve(config)
                except SolverError:
                    break  # keep the last solution (the trust region of _hold_contacts takes over)
                self.contact_corrections += 1
                new_worst, new_drifts, _ = self._contact_drifts(config, v_new, dt)
                if new_worst >= worst:
                    break  # not converging (e.g. a dropped dependent row): keep the better solution
                ratio = new_worst / worst
                v, worst, drifts = v_new, new_worst, new_drifts
                if worst <= self.contact_correction:
                    break
                tol = self.sole_drift_tolerance
                if tol is not None and worst * ratio ** (2 - k) > tol:
                    # contracting too slowly to end within sole_drift_tolerance in the re-solves left (a large
                    # step, far outside the linear range of J_c): the trust region's smaller steps take over, with
                    # the budget these re-solves would spend (a strict cascade's re-solve costs one solve per level)
                    break
        finally:
            np.copyto(self._b, b0)
        return v

    def _hold_contacts(self, config: Configuration, dt: float, v: np.ndarray, relaxed: list, solve=None,
                       bounded: bool = False) -> TickResult:
        """Trust region on v until the contact frames drift ≤ sole_drift_tolerance (constructor docstring);
        ``solve(config)`` re-solves the problem in the buffers (default: the tick's QP).

        When the contact rows are rank deficient their right-hand sides are first made consistent (projected onto
        the range of J_c, as after a failed solve): nearly dependent rows whose corrections disagree otherwise ask
        a large v in the nearly singular direction and their
        ±dependent_row_tolerance/2 bands leave no solution inside a smaller region. Each region's solution gets
        the second-order correction (``contact_correction``) before its drift is measured."""
        solve = solve or self._solve_assembled
        cost = self._safe_estimate if solve == self._solve_constraints_only else lambda: self._resolve_cost
        drift = self.sole_drift(config, v, dt)
        if self.sole_drift_tolerance is None or drift <= self.sole_drift_tolerance:
            return TickResult(v, relaxed=relaxed, sole_drift=drift)
        lb0, ub0, b0 = self._lb.copy(), self._ub.copy(), self._b.copy()
        best_v, best = v, drift
        rho = float(np.max(np.abs(v)))
        basis = self._contact_range_basis() if self._contact_rows.size else None
        n_radii = 8 + (basis is not None)
        radius, last = rho, drift  # the last region's radius and the drift of its solution
        try:
            if basis is not None:
                cr = self._contact_rows
                self._b[cr] = basis @ (basis.T @ self._b[cr])
            for k in range(n_radii):
                # the trust region stops at the tick budget (the safe command's) or STAGE_FACTOR times it (a solved
                # tick's); the least drifting command is kept
                if (self._late() if bounded else self._stage_late()) or not self._fits(cost()):
                    if not bounded:
                        self._cut.append(f"trust region after {k} of at most {n_radii} radii")
                    break
                if basis is not None and k == 0:
                    radius = math.inf  # first the whole box, with consistent contact rows
                else:
                    # the next radius from the last drift, taken linear in the radius (measured: the drift of a
                    # region's corrected solution fell about in proportion to its radius, G1 at dt = 5 ms), with a
                    # 0.8 margin: ρ ← ρ · clip(0.8 · tolerance / drift, 1/16, 1/2) — halving when the drift is
                    # near the tolerance, one region instead of four when it is ten times over
                    radius = (rho if math.isinf(radius) else radius) * min(
                        0.5, max(1.0 / 16.0, 0.8 * self.sole_drift_tolerance / max(last, 1e-300)))
                np.clip(lb0, -radius, radius, out=self._lb)
                np.clip(ub0, -radius, radius, out=self._ub)
                np.maximum(self._lb, np.minimum(lb0, ub0), out=self._lb)  # never tighter than a pinned bound
                np.minimum(self._ub, np.maximum(lb0, ub0), out=self._ub)
                try:
                    v_tr = solve(config)
                except SolverError:
                    break  # the contact rows cannot be met inside this region: keep the best so far
                if self.contact_correction > 0:
                    v_tr = self._correct_contacts(config, dt, v_tr, solve, bounded)
                d = last = self.sole_drift(config, v_tr, dt)
                if d < best:
                    best_v, best = v_tr, d
                if best <= self.sole_drift_tolerance:
                    break
        finally:
            np.copyto(self._lb, lb0)
            np.copyto(self._ub, ub0)
            np.copyto(self._b, b0)
        if best <= self.sole_drift_tolerance:
            return TickResult(best_v, relaxed=relaxed, sole_drift=best)
        return TickResult(best_v, ok=False, relaxed=relaxed, sole_drift=best, fallback="trust_region",
                          message=f"contact frame drifts {best:.3g} m over the tick (> sole_drift_tolerance "
                                  f"{self.sole_drift_tolerance:.3g} m) even inside a trust region" + (
                                      f" (tick budget spent: {'; '.join(self._cut)} skipped)" if self._cut else ""))

    def _solve_assembled(self, config: Configuration) -> np.ndarray:
        """Solve the QP held in the controller's buffers (flat, or the hierarchy when levels exist); with the clock
        guard its CPU time is recorded (the cost of the tick's next re-solve, ``_fits``)."""
        args = (self._H, self._g, self._A, self._b, self._C, self._l, self._u, self._lb, self._ub)
        solves = self._work.solves
        t = self._work.seconds() if self.clock_guard else 0.0
        try:
            return self._solve_levels(config, *args) if self._level_order else self._solve_flat(*args)
        finally:
            # the counted work of the largest re-solve so far: the stages after it start only when one more fits
            self._resolve_work = max(self._resolve_work, self._work.solves - solves)
            if self.clock_guard:
                self._resolve_cost = max(self._resolve_cost, self._work.seconds() - t)

    def _relax(self, config: Configuration, dt: float) -> None:
        """Drop the relaxable constraints from the assembled buffers by their kind (equality rows made void,
        inequality rows unbounded, boxes re-intersected without them), as the ID QP's relaxed solve does."""
        for c, r0, r1 in self._relaxable_blocks:
            if c.kind == "equality":
                self._A[r0:r1] = 0.0
                self._b[r0:r1] = 0.0
            elif c.kind == "inequality":
                self._l[r0:r1] = -np.inf
                self._u[r0:r1] = np.inf
        self._intersect_boxes(config, dt, skip=set(map(id, self._relaxable)))
        self._eq_rows = None

    def _solve_flat(self, H, g, A, b, C, l, u, lb, ub) -> np.ndarray:
        fresh = self._eq_rows is None
        if fresh:
            self._eq_rows = independent_rows(A, self.rank_rtol)
        while True:
            full_rank = self._eq_rows.size == A.shape[0]
            A_kept, b_kept = (A, b) if full_rank else (A[self._eq_rows], b[self._eq_rows])
            v = self.backend.solve(H, g, A_kept, b_kept, C, l, u, lb, ub)
            self.dependent_residual = 0.0 if full_rank else float(np.max(np.abs(A @ v - b)))
            if self.dependent_residual <= self.dependent_row_tolerance:
                return v
            rows = None if fresh else independent_rows(A, self.rank_rtol)
            if rows is None or np.array_equal(rows, self._eq_rows):
                # the dropped rows are only nearly dependent (or their right-hand sides disagree): solve again
                # with them as band rows |A_d v − b_d| ≤ dependent_row_tolerance / 2 (a well-posed inequality
                # for the active-set solver); if that has no solution the hard equalities contradict each other
                return self._solve_banded(H, g, A, b, C, l, u, lb, ub)
            # the dropped rows have become independent since the rank was computed: solve again with them
            fresh = True
            self._eq_rows = rows

    def _solve_banded(self, H, g, A, b, C, l, u, lb, ub) -> np.ndarray:
        """Flat solve with the dropped dependent equality rows as band inequalities (``_solve_flat``)."""
        dropped = np.setdiff1d(np.arange(A.shape[0]), self._eq_rows)
        half = 0.5 * self.dependent_row_tolerance
        if self._band_backend is None:
            self._band_backend = self._new_backend()
        residual = self.dependent_residual
        try:
            v = self._band_backend.solve(H, g, A[self._eq_rows], b[self._eq_rows], np.vstack([C, A[dropped]]),
                                         np.concatenate([l, b[dropped] - half]),
                                         np.concatenate([u, b[dropped] + half]), lb, ub)
        except SolverError as exc:
            raise SolverError(f"dependent equality rows violated by {residual:.3g} after the solve, and no "
                              f"solution holds them within ±{half:.3g} (contradictory hard equalities): {exc}") \
                from None
        self.dependent_residual = float(np.max(np.abs(A @ v - b)))
        return v

    def _new_backend(self, **daqp_settings) -> QPBackend:
        """A fresh backend of the same kind as ``self.backend`` (own warm start)."""
        if isinstance(self.backend, DaqpBackend):
            backend = DaqpBackend(tolerance=self.backend.tolerance, **{**self.backend.settings, **daqp_settings})
        else:
            backend = make_backend(self.backend.name)
        backend.work = self._work
        backend.independent = _CONFIRM_ORDER
        return backend

    def _solve_levels(self, config, H, g, A, b, C, l, u, lb, ub) -> np.ndarray:
        if self._weighted_tick and self._in_solve:
            if self._weighted_qp is None:
                self._weighted_qp = self._weighted_levels(config, H, g)
            return self._solve_flat(*self._weighted_qp, A, b, C, l, u, lb, ub)
        levels = [(level.wJ, level.wr) for level in self._level_rows]  # gathered by assemble
        while len(self._level_backends) < len(levels):
            # semidefinite J_kᵀJ_k: DAQP's proximal-point iterations; a weight of 1e-3 on the proximal term was
            # reliable where the default (1e-6) reported degenerate feasible levels as infeasible
            self._level_backends.insert(0, self._new_backend(eps_prox=1e-3))
        if self._final_backend is None:
            self._final_backend = self._new_backend()
        self._level_mark = self._work.seconds()
        self._level_count = self._work.solves
        v, self.level_residuals = solve_lexicographic(
            levels, H, g, A, b, C, l, u, lb, ub, self._level_backends[:len(levels)], self._final_backend,
            rank_rtol=self.rank_rtol, dependent_row_tolerance=self.dependent_row_tolerance,
            stop=self._level_stop if self._in_solve else None, memo=self._level_memo if self._in_solve else None,
            level_work=self.LEVEL_WORK)
        cut = solve_lexicographic.last_cut
        if cut is not None:
            if self._in_solve and self._fits(self._level_cost):
                # the cascade does not fit the tick (its count, or the clock guard's CPU time); the weighted form of
                # the levels (one QP, with the reserve the cascade left: WEIGHTED_RESERVE) answers this tick and its
                # re-solves instead of the last solved level's command (which ignores the levels below it)
                self._work.reserve = 0.0
                try:
                    qp = self._weighted_levels(config, H, g)
                    v = self._solve_flat(*qp, A, b, C, l, u, lb, ub)
                    self._weighted_tick, self._weighted_qp = True, qp
                except SolverError:
                    pass  # the last solved level's command (a point of the hard set)
            self._cut.append(f"priority levels after the first {cut} of {len(levels) + 1} (" + (
                "their weighted form's command)" if self._weighted_tick else "the last solved level's command)"))
        return v

    def _weighted_answer(self, config: Configuration, dt: float, relaxed: list) -> TickResult | None:
        """The tick answered again by the weighted form of its strict levels (one QP, its contact correction and
        trust region, with the solves the cascade left: ``WEIGHTED_RESERVE``), after the cascade's command kept a
        contact frame past ``sole_drift_tolerance`` because the budget stopped its correction or trust region;
        None when that answer drifts too (or its QP fails): the cascade's failure stands."""
        if not self._fits(self._resolve_cost):
            return None
        self._work.reserve = 0.0
        self._weighted_tick, self._weighted_qp = True, None
        cascade_cut, self._cut = self._cut, []
        try:
            v = self._solve_assembled(config)
            if self.contact_correction > 0 and self._contacts:
                v = self._correct_contacts(config, dt, v)
            result = self._hold_contacts(config, dt, v, relaxed)
        except SolverError:
            result = None
        if result is not None and result.ok:
            self._cut = [f"the cascade's {stage}" for stage in cascade_cut] + self._cut
            return result
        self._weighted_tick, self._cut = False, cascade_cut
        return None

    def _cascade_fits(self) -> bool:
        """After a tick answered by the weighted form of p strict levels: is it cheap enough to try the cascade
        again? Its counted solves times p + 1 (one QP per level instead of one) fit in the cascade's share of the
        budget, (``STAGE_FACTOR`` − ``WEIGHTED_RESERVE``) budgets; with the clock guard also its CPU time times
        2 (p + 1) in one budget."""
        n = len(self._level_order) + 1
        if n * self._work.solves > (self.STAGE_FACTOR - self.WEIGHTED_RESERVE) * self._work.cap:
            return False
        return not self.clock_guard or 2 * n * self._work.seconds() <= self._budget_s

    def _weighted_levels(self, config, H, g) -> tuple[np.ndarray, np.ndarray]:
        """(H, g) of the strict levels' weighted form: the soft level's cost plus, for level k of p (0 highest),
        WEIGHTED_LEVEL_RATIO ** (p − k) × ‖J_k v − v*_k‖² (task weights applied); (nv, nv), (nv,)."""
        Hw, gw = H.copy(), g.copy()
        p = len(self._level_order)
        for i, level in enumerate(self._level_rows):  # gathered by assemble, weights applied
            c = self.WEIGHTED_LEVEL_RATIO ** (p - i)
            Hw += c * (level.wJ.T @ level.wJ)
            gw -= c * (level.wJ.T @ level.wr)
        return Hw, gw

    # -- failure handling -------------------------------------------------------------------------------------
    def _recover(self, config: Configuration, dt: float, exc: Exception) -> TickResult:
        """Diagnosis + safe command after a failed tick (module docstring). Never raises.

        Every safe command other than v = 0 is taken only when it is finite and within the box, and when it keeps
        the contact frames as an ok tick must (sole drift ≤ ``sole_drift_tolerance``; for 'contacts_held', whose
        rows ask no motion, the frames' displacement over the tick); 'contacts_held' is scaled down (by
        0.9 √(tolerance / drift), at most 1/2, up to 8 times: the displacement is second order in v dt, and J_c v = 0
        is kept) until it does, each check counted (``CHECK_WORK``) and started only below
        ``wbc.solvers.daqp.WORK_LIMIT_FACTOR`` times the tick's cap, else v = 0."""
        message = str(exc) if isinstance(exc, SolverError) else f"{type(exc).__name__}: {exc}"
        over_budget = False
        reason = ("sole_drift" if isinstance(exc, _DriftFailure) else
                  "output_guard" if message.startswith("output guard") else
                  "nonfinite" if message.startswith("non-finite") else
                  "infeasible" if isinstance(exc, SolverError) else "exception")
        conflicts: list[tuple[str, float]] = []
        if not self._assembled:
            return TickResult(np.zeros(self.nv), ok=False, message=f"assembly failed: {message}", fallback="hold",
                              path=TickPath("fallback", fallback="hold"), reason="exception")
        data_fault = self._data_fault()
        late = self._late()  # the tick's count spent before its failure handling
        # (clock guard: the diagnosis re-assembles the QP and solves a larger one: two re-solves' time)
        if not self._late() and self._fits(2.0 * max(self._resolve_cost, self._safe_estimate())):
            self._work.solves += 1  # the diagnosis: one least-squares QP
            try:
                conflicts = self.diagnose(config, dt, include_relaxable=False)
            except Exception as dexc:  # noqa: BLE001
                message += f"; diagnosis failed: {type(dexc).__name__}: {dexc}"
            if conflicts:
                message += "; conflicting hard constraints: " + ", ".join(f"{n} ({v:.3g})" for n, v in conflicts)
        else:
            over_budget = True
            message += "; diagnosis skipped: tick budget spent (KinematicController.diagnose(config, dt) names the " \
                       "conflict off the control path)"
        v, fallback = np.zeros(self.nv), "hold"
        tol = self.sole_drift_tolerance
        if self._contacts and (self.consecutive_failures == 0 or self._held_anchors is None
                               or set(self._held_anchors) != set(map(id, self._contacts))):
            # where the contact frames were when this run of failed ticks began (their anchors)
            self._held_anchors = {id(c): config.frame_placement(c.frame_id).copy() for c in self._contacts}
        anchors = [self._held_anchors[id(c)] for c in self._contacts]
        skipped = ""  # clock guard: the safe commands not tried, the tick's budget spent
        count_stop = False  # the count stopped the checks of 'contacts_held' (hold, nothing more tried)
        # the tick's count spent before its safe command (late): J_c v = 0 first, the cheapest command that keeps the
        # contacts (β = 0 only, each DAQP call at most HELD_ITERATIONS iterations), 'constraints_only' only after it
        held_first = late and bool(self._contact_rows.size) and not data_fault
        if not held_first and not data_fault and not self._fits(max(self._safe_stage_cost, self._safe_estimate())):
            skipped = "constraints_only"
        elif not held_first and not data_fault:  # (non-finite QP data: hold)
            v, fallback = self._safe_constraints_only(config, dt, anchors)
        if fallback == "hold" and self._contact_rows.size and not data_fault and not skipped:
            scales = (0.0,) if held_first else _HELD_CORRECTION_SCALES
            # step 3: the contacts held where they were when this run of failed ticks began (their anchors), with
            # the correction towards the anchors scaled by β = 1, 1/10, 0 (J_c v = 0)
            b0 = self._b.copy()
            if held_first and self._fallback_backend is None:
                self._fallback_backend = self._new_backend()
            backend = self._fallback_backend
            independent = backend.independent if backend is not None else ()
            placements = [c.placement for c in self._contacts]
            try:
                if backend is not None:
                    backend.independent = ()  # a failed β needs no confirmation: the next one is tried
                for c, anchor, (_, r0, r1) in zip(self._contacts, anchors, self._contact_blocks):
                    c.placement = anchor
                    self._b[r0:r1] = c.compute(config, dt)[1]
                anchored = self._b[self._contact_rows].copy()
                # dependent contact rows (two flat feet both fixing the base yaw) ask the same direction twice:
                # their corrections are made consistent (least squares onto the range of J_c, as after a failed
                # solve: _consistent_contact_rhs)
                U, S = self._contact_svd()
                rank = int(np.sum(S > self.rank_rtol * max(S[0], 1.0))) if S.size else 0
                if rank < anchored.size:
                    anchored = U[:, :rank] @ (U[:, :rank].T @ anchored)
                tried = []  # (β, what became of its command) for the message
                for beta in scales:
                    if not self._fits(self._safe_estimate() + self._check_cost):
                        skipped = f"contacts_held from β = {beta:g}"
                        break
                    self._b[self._contact_rows] = beta * anchored
                    try:
                        # β = 0 (J_c v = 0; v = 0 is a solution when the box holds it): the last command before a
                        # hold gets its solver's own iteration limit, not the few iterations a spent tick count
                        # leaves (its solves still counted)
                        v_h = self._solve_constraints_only(config) if beta else self._solve_uncapped(config, held_first)
                    except Exception as qexc:  # noqa: BLE001 — they conflict even so: next β, then hold
                        capped = getattr(self._fallback_backend, "iterations_capped", False)
                        tried.append(f"β = {beta:g}: {type(qexc).__name__}"
                                     + (" (DAQP stopped at its iteration limit)" if capped else ""))
                        continue
                    if self._command_fault(v_h, self._lb, self._ub, self._C, self._l, self._u):
                        tried.append(f"β = {beta:g}: outside the constraints")
                        continue
                    d = math.nan
                    for _ in range(9 if beta == 0.0 else 1):
                        counted_out = self._work.spent(WORK_LIMIT_FACTOR, self.CHECK_WORK)
                        if counted_out or not self._fits(self._check_cost):
                            skipped = "contacts_held (its last scalings)"
                            count_stop = counted_out
                            break
                        self._work.add(self.CHECK_WORK)
                        t = self._work.seconds()
                        d = 0.0 if tol is None else self._held_drift(config, v_h, dt, beta, anchors)
                        held = (tol is None or d <= tol) and self._within_run_radius(config, v_h, dt, anchors)
                        self._check_cost = max(self._check_cost, self._work.seconds() - t)
                        if held:
                            v, fallback = v_h, "contacts_held"
                            break
                        # β = 0: J_c v = 0 kept, the drift is second order in v dt: scaled by 0.9 √(tol / drift)
                        # (at most 1/2; 1/2 when the frames left the run's radius instead)
                        scale = 0.5 if tol is None or d <= tol else min(0.5, 0.9 * math.sqrt(tol / d))
                        v_h = scale * v_h
                    tried.append(f"β = {beta:g}: drift {d:.3g} m")
                    if fallback != "hold" or skipped:
                        break
                if fallback == "hold" and not skipped:
                    message += (f"; contacts_held not taken: no command with the contacts' correction scaled by "
                                f"{scales} keeps them within sole_drift_tolerance {tol:.3g} m "
                                f"and {self.SAFE_COMMAND_RADIUS:.3g} m of where the failed ticks began "
                                f"({'; '.join(tried)})")
            except Exception:  # noqa: BLE001 — never raises: hold
                pass
            finally:
                for c, placement in zip(self._contacts, placements):
                    c.placement = placement
                np.copyto(self._b, b0)
                if backend is not None:
                    backend.independent = independent
        if held_first and fallback == "hold" and not count_stop:
            v, fallback = self._safe_constraints_only(config, dt, anchors)
        if skipped:
            over_budget = True
            message += f"; {skipped} not tried: tick budget spent ({'count' if count_stop else 'clock guard'})"
        try:
            drift = self.sole_drift(config, v, dt)
        except Exception:  # noqa: BLE001 — never raises (module docstring)
            drift = float("nan")
        return TickResult(v, ok=False, message=message, conflicts=conflicts, fallback=fallback, sole_drift=drift,
                          path=TickPath("fallback", fallback=fallback), reason=reason, over_budget=over_budget)

    def _within_run_radius(self, config: Configuration, v: np.ndarray, dt: float, anchors) -> bool:
        """True when one tick with v leaves every contact frame within ``SAFE_COMMAND_RADIUS`` of its anchor (where
        the run of failed ticks began), or no farther from it than the frame is now (forward kinematics)."""
        model, data = self.robot.model, self._drift_data
        pin.forwardKinematics(model, data, pin.integrate(model, config.q, v * dt))
        for c, anchor in zip(self._contacts, anchors):
            after = float(np.linalg.norm(pin.updateFramePlacement(model, data, c.frame_id).translation
                                         - anchor.translation))
            before = float(np.linalg.norm(config.frame_placement(c.frame_id).translation - anchor.translation))
            if after > max(self.SAFE_COMMAND_RADIUS, before):
                return False
        return True

    def _held_drift(self, config: Configuration, v: np.ndarray, dt: float, beta: float, anchors) -> float:
        """Largest drift (m) of a contact frame over one tick with v from where its correction towards its anchor
        scaled by β sends it: ‖t(exp(e⁺)) − t(exp((1 − β K dt) e))‖, e = log₆(anchor⁻¹ oMf), e⁺ at
        pin.integrate(q, v dt) by forward kinematics (β = 0: the frame's displacement)."""
        model, data = self.robot.model, self._drift_data
        pin.forwardKinematics(model, data, pin.integrate(model, config.q, v * dt))
        worst = 0.0
        for c, anchor in zip(self._contacts, anchors):
            e1 = pin.log6(anchor.actInv(pin.updateFramePlacement(model, data, c.frame_id))).vector
            e0 = pin.log6(anchor.actInv(config.frame_placement(c.frame_id))).vector
            worst = max(worst, translation_gap(e1, 1.0, e0, 1.0 - beta * min(c.gain, 1.0 / dt) * dt))
        return worst

    def _solve_constraints_only(self, config: Configuration) -> np.ndarray:
        """The safe command of a failed tick (module docstring): the weighted soft level under the constraint
        objects held in the buffers (hard tasks left out), on the fallback backend; with the clock guard its CPU
        time is recorded (``_safe_estimate``). Raises SolverError."""
        if not self.clock_guard:
            return self._constraints_only_qp()
        t = self._work.seconds()
        try:
            return self._constraints_only_qp()
        finally:
            spent = self._work.seconds() - t
            self._safe_cost = max(self._safe_cost, spent) if self._safe_fresh else spent
            self._safe_fresh = True

    def _safe_constraints_only(self, config: Configuration, dt: float, anchors) -> tuple[np.ndarray, str]:
        """(v, 'constraints_only') when the safe command of step 2 (module docstring) is taken, else (zeros, 'hold'):
        the constraint objects' QP, its contacts held to second order like an ok tick's (correction, trust region,
        bounded by the tick's count), taken when finite, within the constraints, within ``sole_drift_tolerance`` and
        within the run's radius (:meth:`_within_run_radius`). Never raises."""
        tol = self.sole_drift_tolerance
        t_stage = self._work.seconds()
        v, fallback = np.zeros(self.nv), "hold"
        try:
            v_c = self._solve_constraints_only(config)
            # the safe command holds the contacts to second order like an ok tick (correction, trust region)
            if self.contact_correction > 0 and self._contacts:
                v_c = self._correct_contacts(config, dt, v_c, self._solve_constraints_only, bounded=True)
            v_c = self._hold_contacts(config, dt, v_c, [], self._solve_constraints_only, bounded=True).v
            if not self._command_fault(v_c, self._lb, self._ub, self._C, self._l, self._u) and (
                    tol is None or self.sole_drift(config, v_c, dt) <= tol) and \
                    self._within_run_radius(config, v_c, dt, anchors):
                v, fallback = v_c, "constraints_only"
        except Exception:  # noqa: BLE001 — the constraints themselves conflict (or their contacts' correction)
            pass
        if self.clock_guard:
            self._safe_stage_cost = self._work.seconds() - t_stage
        return v, fallback

    def _solve_uncapped(self, config: Configuration, bounded: bool = False) -> np.ndarray:
        """:meth:`_solve_constraints_only` with the QP backends' iteration limit not lowered by the tick's spent
        count (:meth:`wbc.solvers.daqp.DaqpBackend.call_limit`); its solves are counted as usual. ``bounded``: each
        DAQP call of the fallback backend at most ``HELD_ITERATIONS`` iterations (a count: the same answer at any
        load) instead of its solver's own limit. Raises SolverError."""
        cap = self._work.cap
        self._work.cap = math.inf
        backend = self._fallback_backend
        calls = getattr(backend, "call_iterations", None)
        if bounded and isinstance(backend, DaqpBackend):
            backend.call_iterations = self.HELD_ITERATIONS
        try:
            return self._solve_constraints_only(config)
        finally:
            self._work.cap = cap
            if bounded and isinstance(backend, DaqpBackend):
                backend.call_iterations = calls

    def _constraints_only_qp(self) -> np.ndarray:
        """The QP of :meth:`_solve_constraints_only`, solved (SolverError when it has no solution)."""
        H, g, A, b, C, l, u, lb, ub = self._H, self._g, self._A, self._b, self._C, self._l, self._u, \
            self._lb, self._ub
        if not self._not_hard_task.all():
            A, b = A[self._not_hard_task], b[self._not_hard_task]
        keep = independent_rows(A, self.rank_rtol)
        if self._fallback_backend is None:
            self._fallback_backend = self._new_backend()
        v_safe = self._fallback_backend.solve(H, g, A[keep], b[keep], C, l, u, lb, ub)
        if keep.size < A.shape[0] and np.max(np.abs(A @ v_safe - b)) > self.dependent_row_tolerance:
            # nearly dependent rows: once more with them as band rows (as _solve_banded), else hold
            drop = np.setdiff1d(np.arange(A.shape[0]), keep)
            half = 0.5 * self.dependent_row_tolerance
            v_safe = self._fallback_backend.solve(H, g, A[keep], b[keep], np.vstack([C, A[drop]]),
                                                  np.concatenate([l, b[drop] - half]),
                                                  np.concatenate([u, b[drop] + half]), lb, ub)
        return v_safe

    def diagnose(self, config: Configuration, dt: float, *, include_relaxable: bool = True) -> list[tuple[str, float]]:
        """Conflicting hard constraints at ``config``: [(name, violation in its units)], largest first, from the
        slack-relaxed solve of :mod:`wbc.solvers.diagnosis` (empty when the hard set is feasible). Tasks whose cost
        has non-finite numbers are reported with violation nan. ``include_relaxable=False`` leaves out the
        relaxable constraints (as a failed tick does). The controller's buffers are left holding that problem."""
        H, g, A, b, C, l, u, lb, ub = self.assemble(config, dt)
        skip = set() if include_relaxable else set(map(id, self._relaxable))
        if skip:
            self._relax(config, dt)
        record: list = []
        self._intersect_boxes(config, dt, record, skip)
        conflicts, _ = diagnose(
            A, b, C, l, u, lb, ub, [(c.name, r0, r1) for c, r0, r1 in self._eq_blocks if id(c) not in skip],
            [(c.name, r0, r1) for c, r0, r1 in self._in_blocks if id(c) not in skip], record)
        if not (np.isfinite(H).all() and np.isfinite(g).all()):
            tasks = [*self.tasks, *(t for k in self._level_order for t in self.levels[k])]
            conflicts += [(t.name, float("nan")) for t in tasks
                          if not all(np.isfinite(x).all() for x in t.compute(config))]
        return conflicts


#: most tasks and constraints a controller remembers as checked against its robot (``_check_robot``)
_CHECKED_SIZE = 64

#: controller attributes that make up one constraint layout (``KinematicController._build_layout``)
_LAYOUT_ATTRS = ("_constraints", "_box", "_feedback", "_box_sel", "_relaxable", "_contacts", "_contact_rows",
                 "_const_prefix", "_const_box", "_box_rows", "_eq_blocks", "_A", "_b", "_contact_blocks", "_in_blocks",
                 "_C", "_l", "_u", "_lb", "_ub", "_not_hard_task", "_H", "_g", "_eliminating_row", "_qp_pack",
                 "_contact_writes", "_other_eq_blocks", "_contact_factors", "_contact_factor_values", "_contact_starts",
                 "_relaxable_blocks", "_contact_pair")


def _row_blocks(constraints) -> tuple[list, int]:
    """``([(constraint, first row, end row)...], total rows)`` of constraints stacked in order."""
    blocks, row = [], 0
    for c in constraints:
        blocks.append((c, row, row + c.dim))
        row += c.dim
    return blocks, row


#: independent solvers confirming a failed QP inside a tick (``QPBackend.independent``), each started only while the
#: tick's budget lasts: first the two dual active-set methods (Goldfarb–Idnani's quadprog, DAQP one-shot), a few
#: hundred µs each on a kinematic QP; ProxQP last (its iterations on an infeasible problem take tens of ms, but it
#: solves the semidefinite levels of a hierarchy that the others refuse)
_CONFIRM_ORDER = ("quadprog", "daqp", "proxqp")

#: the compiled tick's paths (TickPath is frozen: one instance shared by every result)
_COMPILED, _COMPILED_DAQP = TickPath("compiled"), TickPath("compiled", "daqp")

#: scales α of the return rate of joints outside their limits tried in turn when the tick is infeasible
#: (``KinematicController._relax_return_rate``)
_RETURN_RATE_SCALES = (0.5, 0.1, 0.01, 0.001, 0.0)

#: scales β of the contacts' drift correction tried in turn by the 'contacts_held' safe command
_HELD_CORRECTION_SCALES = (1.0, 0.1, 0.0)


class _DriftFailure(SolverError):
    """The tick's QP solved, but no trust region kept the contact frames within ``sole_drift_tolerance``."""


def _stack_rows(tasks: list[Task], nv: int, own_costs: bool) -> _SoftRows:
    """Stacked-row buffers of ``tasks`` (``KinematicController._build_soft_layout``). ``own_costs``: one plain
    :class:`~wbc.tasks.PostureTask` becomes the diagonal term of :func:`wbc.formulations.velocity_kernel.form_qp` and
    the tasks with their own ``add_cost`` are listed apart (the soft level); else every task is a stack of rows (a
    strict level)."""
    soft = _SoftRows()
    soft.tasks = list(tasks)
    dense, soft.own, soft.posture = [], [], None
    row = 0
    for task in tasks:
        if not own_costs or type(task).add_cost is Task.add_cost:
            dense.append((task, row, row + task.dim, type(task).velocity_target is Task.velocity_target))
            row += task.dim
        elif type(task) is PostureTask and soft.posture is None:
            soft.posture = task
        else:
            soft.own.append(task)
    prow = np.zeros(0, np.int64) if soft.posture is None else np.asarray(soft.posture.rows, np.int64)
    # J, e, rowp (gain, weight, feed-forward of each stacked row), the posture's weights and indices: packed into two
    # arrays, what the compiled tick reads (kinematic_tick_packed)
    soft.fb, soft.ib, views = rows_pack(row, nv, prow)
    soft.J, soft.e, soft.rowp, soft.pw, soft.prow = views["J"], views["e"], views["rowp"], views["pw"], views["prow"]
    soft.wJ = np.zeros((row, nv))  # a strict level's rows with the weights applied (weighted_rows)
    soft.wr = np.zeros(row)
    soft.rows = []
    for k, (task, r0, r1, plain) in enumerate(dense):
        soft.rows.append((task, soft.e[r0:r1], soft.J[r0:r1], soft.rowp[1, r0:r1], soft.rowp[0, r0:r1],
                          soft.rowp[2, r0:r1], k, plain))
        if not plain:  # v* written as the error: K = −1, ė* = 0
            soft.rowp[0, r0:r1] = -1.0
    soft.gains = [None] * len(dense)
    soft.has_ff = [True] * len(dense)
    soft.no_diff = np.zeros(nv)
    return soft


def _gather_rows(soft: _SoftRows, config: Configuration) -> None:
    """Write each task's rows at ``config`` into its stacked buffers (``compute_into``: e, J) with, per row, its
    gain, weight and feed-forward (a task's ``weight`` becomes a view of the stacked weights: in-place changes are
    seen, a new array assigned is copied in); a task with its own velocity target writes v* as e (K = −1)."""
    gains, has_ff = soft.gains, soft.has_ff
    for task, e, J, w, gain_rows, ff_rows, k, plain in soft.rows:
        task.compute_into(config, e, J)
        if task.weight is not w:  # assigned (or first tick): copied into the stacked rows, which it becomes
            task.share_weight(w)
        if not plain:
            e[:] = task.velocity_target(e.copy())
            continue
        gain = task.gain
        if gain != gains[k]:
            gain_rows.fill(gain)
            gains[k] = gain
        ff = task.feedforward()
        if ff is not None:
            ff_rows[:] = ff
            has_ff[k] = True
        elif has_ff[k]:
            ff_rows.fill(0.0)
            has_ff[k] = False


class _SoftRows:
    """The stacked rows of one task list (:func:`_stack_rows`: the soft level, or a strict level): ``J`` (mt, nv),
    ``e`` (mt,), ``rowp`` (3, mt) = gain, weight, feed-forward per row, ``wJ``, ``wr``: a strict level's rows with the
    weights applied; ``rows``, per task with the generic cost,
    (task, e, J, weight, gain, feed-forward views, index, plain velocity target); the posture task taken as the
    diagonal of :func:`wbc.formulations.velocity_kernel.form_qp` (``posture``, its weights ``pw`` and velocity indices
    ``prow``); the tasks with their own cost (``own``)."""


class _FusedPlan:
    """What the compiled tick (:meth:`KinematicController._fused_tick`) keeps for one constraint layout and one
    list of soft tasks beyond the assembled QP's buffers: the solver's working sets (warm start), the contacts'
    log buffer and the DAQP rescue backend. ``states`` (nr + p,) int8: the working sets of the nr reduced variables
    (``state``, a view) and of the p inequality rows (``rstate``, a view), one array for the kernel
    (:func:`~wbc.formulations.velocity_kernel.kinematic_tick_packed`; −1 / 0 / 1: at its lower bound / free / at
    its upper bound)."""

    supported = False
    tick_kernel = None  # kinematic_tick_packed specialised to this plan's arguments (wbc.compiled.specialise)
    drift_kernel = None  # contact_pair_drift, likewise
