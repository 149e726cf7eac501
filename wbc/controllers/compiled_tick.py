"""The compiled tick of the kinematic controller: with the default backend (``solver="fast"``) and no strict level,
the assembled flat QP (:meth:`wbc.formulations.velocity.VelocityQP.assemble`) solved by one compiled call,
:func:`wbc.formulations.velocity_kernel.kinematic_solve`. Whenever the kernel gives up or ends off a KKT point, a
contact drifts above ``contact_correction`` or anything raises, the general path solves the tick
(``docs/kinematic-controller.md``)."""

from __future__ import annotations

import math
from time import perf_counter

import numpy as np
import pinocchio as pin

from wbc.compiled import specialise
from wbc.configuration import LOCAL_WORLD_ALIGNED, Configuration
from wbc.constraints.contact import ContactConstraint
from wbc.exceptions import InvalidInputError
from wbc.controllers.output_guard import command_fault
from wbc.formulations.velocity_kernel import (NO_KERNEL_BOX, NONFINITE_RHS, TickBuffers, contact_drift,
                                              contact_pair_drift, kinematic_tick_packed, kinematic_views)
from wbc.solvers import FastBackend
from wbc.solvers.hierarchy import independent_rows
from wbc.tick import TickPath, TickResult, solved_result


#: the compiled tick's path (TickPath is frozen: one instance shared by every result)
_COMPILED = TickPath("compiled")


class CompiledTick:
    """The compiled-tick part of :class:`wbc.controllers.kinematic.KinematicController` (module docstring): its
    plans per layout (:class:`FusedPlan`), ``prepare_layouts`` and the tick itself (``_fused_tick``)."""

    def prepare_layouts(self, arrangements, config: Configuration, dt: float) -> None:
        """Build ahead, outside the ticks, what the first tick of each arrangement of tasks and constraints would
        build (row layout, buffers, compiled plan and kernel; e.g. for the support phases of a walk plan). The
        controller's own tasks, constraints and rank decision and the answers of the ticks are unchanged.

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
                    self._check_input(t)
                for c in constraints:
                    self._check_input(c, task=False)
                self.tasks[:], self.constraints[:] = tasks, constraints
                key = tuple((id(c), c.dim) for c in self.constraints)
                if key != self._layout_key or not self._layout_ok:
                    known = key in self._layouts
                    self._layout_ok = False
                    self._update_layout()
                    if not known:
                        self._prepared.add(key)
                self._update_soft_layout()
                if not self._level_order and isinstance(self.backend, FastBackend):
                    plan = self._kept_fused_plan()  # the compiled tick's plan of these layouts, with its box
                    if plan.supported and plan.box is None:
                        plan.box = self._kernel_box(config, float(dt))
        finally:
            self.tasks[:], self.constraints[:] = saved[0], saved[1]
            self._layout_ok = False
            if saved[4] is not None and saved[3]:
                self._update_layout()  # back to the controller's layout (kept: no build)
                self._update_soft_layout()
            self._eq_rows = saved[2]

    def _fused_plan(self) -> FusedPlan | None:
        """The compiled tick's plan for the current layouts, or None when it does not cover them (strict levels, a
        backend other than FastBackend, soft tasks with their own cost or target but a posture, a contact subclass)."""
        if self._level_order or not isinstance(self.backend, FastBackend):
            return None
        self._update_layout()
        self._update_soft_layout()
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

    def _kept_fused_plan(self) -> FusedPlan:
        """The :class:`FusedPlan` kept for the current layouts (at most 16), built when there is none (``supported``
        False when the compiled tick does not cover them, :meth:`_fused_plan`)."""
        key = (self._layout_key, tuple(map(id, self._soft_tasks)), id(self.backend))
        plan = self._fused_plans.get(key)
        if plan is not None and plan.layout_key == self._layout_key and plan.soft_tasks is self._soft_tasks:
            return plan
        plan = self._fused_plans[key] = FusedPlan()
        while len(self._fused_plans) > 16:
            self._fused_plans.pop(next(iter(self._fused_plans)))
        plan.layout_key, plan.soft_tasks, plan.backend = self._layout_key, self._soft_tasks, self.backend
        soft = self._soft
        if soft.own or any(not plain for *_, plain in soft.rows) or any(
                type(c) is not ContactConstraint for c in self._contacts):
            return plan  # a task with its own cost (but one posture task) or velocity target; a contact's own rows
        nv = self.nv
        nr = nv - 6 if self._eliminating_row >= 0 else nv
        # the joint working set (kept across support switches: _fused_plan) then the rows', one array for the kernel
        plan.states = np.zeros(nr + self._C.shape[0], np.int8)
        plan.state, plan.rstate = plan.states[:nr], plan.states[nr:]
        plan.vdt = kinematic_views.py_func(*self._qp_pack)[2][:nv]
        plan.logs = np.zeros((len(self._contacts), 6))
        plan.contact_logs = list(zip(self._contacts, plan.logs))  # each contact with its row of logs (a view)
        plan.pair_rows = tuple(int(r0) for r0 in self._contact_starts)  # a pair's starts as ints (contact_pair_drift)
        if FusedPlan.tick_kernel is None:  # the tick's argument types are fixed by construction (q: _fused_tick)
            FusedPlan.tick_kernel = specialise(kinematic_tick_packed, TickBuffers(
                *self._qp_pack, soft.fb, soft.ib, plan.states), soft.no_diff, 0.0, 0.0, np.empty(nv), 0.0, 0.0, 0,
                np.empty(nv), NO_KERNEL_BOX)
        if FusedPlan.pair_drift is None and len(plan.logs) == 2:  # log_operands' types: data.oMf's R is F-ordered
            frame, b = (np.zeros((4, 3)), np.zeros((3, 3), order="F"), np.zeros(3)), np.zeros(12)
            FusedPlan.pair_drift = specialise(contact_pair_drift, frame, frame, plan.logs, b, 0, 6, 0.0, 0.0, 0.0)
        plan.supported = True
        return plan

    def _fused_tick(self, plan: FusedPlan, config: Configuration, dt: float, t0: float) -> TickResult | None:
        """One compiled tick (module docstring) on the buffers :meth:`assemble` writes. Returns None when no solver
        ends at a KKT point within tolerance, the equality rows are rank deficient, or a contact drifts above
        ``contact_correction`` / ``sole_drift_tolerance``: the general path then solves the tick."""
        if self._eq_rows is not None and self._eq_rows.size != self._A.shape[0]:
            return None  # dependent equality rows (known since the last rank computation): the general path
        model = self.robot.model
        q = config.q
        box = plan.box
        if box is None:  # the plan's first tick
            box = plan.box = self._kernel_box(config, dt)
        # the cost (and the box, when the kernel writes it) are formed by the kernel below
        H, g, A, b, C, l, u, lb, ub = self.assemble(config, dt, False, box.const.shape[0] == 0)
        if self._eq_rows is None:
            self._eq_rows = independent_rows(A, self.rank_rtol)
        if self._eq_rows.size != A.shape[0]:
            return None  # dependent equality rows: dropped and checked by the general path
        t1 = perf_counter()
        v = np.empty(self.nv)
        backend = self.backend
        tol = backend.tolerance
        budget = self.tick_budget
        bufs, soft = plan.buffers, self._soft
        if bufs is None or bufs.fb is not self._qp_pack[0] or bufs.sfb is not soft.fb:  # made again for new arrays
            bufs = plan.buffers = TickBuffers(*self._qp_pack, soft.fb, soft.ib, plan.states)
        # one compiled call: the cost, its finite check and b's, the solve, the output guard's screens
        args = (bufs, self._posture_diff, self._posture_gain, self.damping, v, float(dt), tol,
                budget.iteration_cap(backend.max_iter) if budget.clock_guard else backend.max_iter, q, box)
        kernel = FusedPlan.tick_kernel
        if not (type(q) is np.ndarray and q.ndim == 1 and q.flags.c_contiguous and q.flags.writeable):
            kernel = kinematic_tick_packed  # a configuration's q of another type: numba's dispatch
        c0 = budget.work.seconds() if budget.clock_guard else 0.0
        it, guard = kernel(*args)
        if budget.clock_guard:  # the first solve's CPU time per iteration: the next ticks' caps (TickBudget)
            budget.note_first_solve(it, budget.work.seconds() - c0)
        # a solve attempt like any other (TickWork): a tick the general path takes over from here has it counted
        self._work.add(1)
        if it == NONFINITE_RHS:
            return None
        backend.last_kernel_iterations = it
        if it < 1:
            return None  # the kernel gave up: the general path (its DAQP fallback, relaxation, safe command)
        if not guard and command_fault(v, lb, ub, C, l, u, tol):  # the compiled screens pass only where it returns ''
            return None
        drift = 0.0
        if self._contacts:
            # the kinematics at the next configuration, computed once (Configuration.lookahead, adopted by its step
            # with this v); each contact frame placed (data.oMf), what error_into reads
            ndata = config.lookahead(plan.vdt)
            lever = self._drift_lever()
            if ndata is not None and len(plan.contact_logs) == 2:  # a biped's two soles: one compiled call
                (ca, _), (cb, _) = plan.contact_logs
                pin.updateFramePlacement(model, ndata, ca.frame_id)
                pin.updateFramePlacement(model, ndata, cb.frame_id)
                far, drift = FusedPlan.pair_drift(ca.log_operands(ndata), cb.log_operands(ndata), plan.logs, b,
                                                  *plan.pair_rows, *self._contact_factor_values, lever)
            else:
                # a configuration subclass with its own update (ndata None): the frames' supporting joints only
                q_next = pin.integrate(model, q, plan.vdt) if ndata is None else None
                ndata = self._drift_data if ndata is None else ndata
                for c, log in plan.contact_logs:
                    if q_next is None:
                        pin.updateFramePlacement(model, ndata, c.frame_id)
                    else:
                        pin.computeFrameJacobian(model, ndata, q_next, c.frame_id, LOCAL_WORLD_ALIGNED)
                    c.error_into(ndata, log)
                far, drift = contact_drift(plan.logs, b, self._contact_starts, self._contact_factors, lever)
            if (self.contact_correction > 0 and far > self.contact_correction) or (
                    self.sole_drift_tolerance is not None and drift > self.sole_drift_tolerance):
                return None  # second-order correction / trust region: the general path
        backend.kernel_solves += 1
        self.dependent_residual = 0.0
        self.contact_corrections = 0
        result = solved_result(v, {"assembly": t1 - t0, "solve": perf_counter() - t1}, drift, _COMPILED)
        for c in self._feedback:
            c.set_previous(v)
        self.consecutive_failures = 0
        self.last_result = result
        return result


class FusedPlan:
    """What the compiled tick keeps for one constraint layout and one list of soft tasks beyond the QP's buffers:
    ``states`` (nr + p,) int8, the working sets of the nr reduced variables (``state``) and the p inequality rows
    (``rstate``) (−1 / 0 / 1: at the lower bound / free / at the upper bound), the contacts' log buffer."""

    supported = False
    tick_kernel = None  # kinematic_tick_packed specialised, once per process, when the first plan is made
    buffers = None  # its TickBuffers (made on the first tick)
    pair_drift = None  # contact_pair_drift specialised, once per process, when the first biped's plan is made
    box = None  # the kernel's box arguments (_kernel_box), made on the first tick
