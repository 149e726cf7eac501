"""Recovery of a failed kinematic tick: diagnosis and the safe command (never a raise, never NaN).

1. diagnosis (:mod:`wbc.solvers.diagnosis`): the conflicting hard constraints, largest violation first;
2. ``constraints_only``: the soft level under the constraint objects only, its contacts held to second order;
3. ``contacts_held``: the same with each contact frame held where the run of failed ticks began, its correction
   scaled by 1, 1/10 or 0;
4. ``hold``: v = 0.
Steps 2 and 3 are taken only when they keep each contact frame within ``sole_drift_tolerance`` of where its rows
send it and within ``SAFE_COMMAND_RADIUS`` of where the run of failed ticks began (``docs/kinematic-controller.md``)."""

from __future__ import annotations

import math

import numpy as np

from wbc.configuration import Configuration
from wbc.exceptions import SolverError
from wbc.solvers import DaqpBackend
from wbc.solvers.daqp import WORK_LIMIT_FACTOR
from wbc.solvers.diagnosis import diagnose
from wbc.solvers.hierarchy import band_rows, independent_rows
from wbc.controllers.contact_hold import DriftFailure
from wbc.controllers.output_guard import command_fault, qp_data_fault
from wbc.tick import TickPath, TickResult


#: scales β of the contacts' drift correction tried in turn by the 'contacts_held' safe command
_HELD_CORRECTION_SCALES = (1.0, 0.1, 0.0)


class Recovery:
    """The recovery part of :class:`wbc.controllers.kinematic.KinematicController` (module docstring):
    ``_recover`` and the safe commands it tries, and :meth:`diagnose`."""

    def _recover(self, config: Configuration, dt: float, exc: Exception) -> TickResult:
        """Diagnosis + safe command after a failed tick (module docstring; the conditions under which each safe
        command is taken, its scaling and its counted checks: ``docs/kinematic-controller.md``). Never raises."""
        message = str(exc) if isinstance(exc, SolverError) else f"{type(exc).__name__}: {exc}"
        if not self._assembled:
            return TickResult(np.zeros(self.nv), ok=False, message=f"assembly failed: {message}", fallback="hold",
                              path=TickPath("fallback", fallback="hold"), reason="exception")
        reason = ("sole_drift" if isinstance(exc, DriftFailure) else
                  "output_guard" if message.startswith("output guard") else
                  "nonfinite" if message.startswith("non-finite") else
                  "infeasible" if isinstance(exc, SolverError) else "exception")
        budget, work, tol = self.tick_budget, self._work, self.sole_drift_tolerance
        over_budget, conflicts = False, []
        data_fault = qp_data_fault(*self._qp)
        late = not budget.may_start("retry")  # the tick's count spent before its failure handling
        # (clock guard: the diagnosis re-assembles the QP and solves a larger one: two re-solves' time)
        if budget.may_start("retry", 2.0 * max(budget.resolve_cost, budget.safe_estimate())):
            work.solves += 1  # the diagnosis: one least-squares QP
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
        if self._contacts and (self.consecutive_failures == 0 or self._held_anchors is None
                               or set(self._held_anchors) != set(map(id, self._contacts))):
            # where the contact frames were when this run of failed ticks began (their anchors)
            self._held_anchors = {id(c): config.frame_placement(c.frame_id).copy() for c in self._contacts}
        anchors = [self._held_anchors[id(c)] for c in self._contacts]
        skipped = ""  # the safe commands not tried, the tick's budget spent
        count_stop = False  # the count (not the clock) stopped the checks of 'contacts_held'
        # past the tick's count (late): 'contacts_held' at β = 0 first (J_c v = 0, the cheapest command that keeps
        # the contacts, each DAQP call at most HELD_ITERATIONS iterations), 'constraints_only' only after it
        held_first = late and bool(self._contact_rows.size) and not data_fault
        if not held_first and not data_fault and not budget.fits(max(budget.safe_stage_cost, budget.safe_estimate())):
            skipped = "constraints_only"
        elif not held_first and not data_fault:  # (non-finite QP data: hold)
            v, fallback = self._safe_constraints_only(config, dt, anchors)
        if fallback == "hold" and self._contact_rows.size and not data_fault and not skipped:
            # 'contacts_held': each contact frame held at its anchor, the correction towards it scaled by β
            scales = (0.0,) if held_first else _HELD_CORRECTION_SCALES
            if held_first and self._fallback_backend is None:
                self._fallback_backend = self._new_backend()
            b0, placements = self._b.copy(), [c.placement for c in self._contacts]
            with self._unconfirmed([self._fallback_backend]):  # a failed β needs no confirmation: the next is tried
                try:
                    for c, anchor, (_, r0, r1) in zip(self._contacts, anchors, self._contact_blocks):
                        c.placement = anchor
                        self._b[r0:r1] = c.compute(config, dt)[1]
                    self._project_contact_rhs(self._contact_range_basis(near=True))
                    anchored = self._b[self._contact_rows].copy()
                    tried = []  # (β, what became of its command) for the message
                    for beta in scales:
                        if not budget.fits(budget.safe_estimate() + budget.check_cost):
                            skipped = f"contacts_held from β = {beta:g}"
                            break
                        self._b[self._contact_rows] = beta * anchored
                        try:
                            # β = 0 (v = 0 solves it when the box holds it): its solver's own iteration limit, not the
                            # few iterations a spent count leaves (its solves still counted)
                            v_h = self._solve_constraints_only(not beta, held_first)  # (uncapped, held)
                        except Exception as qexc:  # noqa: BLE001 — they conflict even so: next β, then hold
                            capped = getattr(self._fallback_backend, "iterations_capped", False)
                            tried.append(f"β = {beta:g}: {type(qexc).__name__}"
                                         + (" (DAQP stopped at its iteration limit)" if capped else ""))
                            continue
                        if command_fault(v_h, self._lb, self._ub, self._C, self._l, self._u, self.backend.tolerance):
                            tried.append(f"β = {beta:g}: outside the constraints")
                            continue
                        d = math.nan
                        for _ in range(9 if beta == 0.0 else 1):
                            counted_out = work.spent(WORK_LIMIT_FACTOR, self.CHECK_WORK)
                            if counted_out or not budget.fits(budget.check_cost):
                                skipped, count_stop = "contacts_held (its last scalings)", counted_out
                                break
                            work.add(self.CHECK_WORK)
                            t = work.seconds()
                            d, inside = self.drift_meter.held_drift(config, v_h, dt, self._contacts, anchors, beta,
                                                                    self.SAFE_COMMAND_RADIUS)
                            budget.check_cost = max(budget.check_cost, work.seconds() - t)
                            if (tol is None or d <= tol) and inside:
                                v, fallback = v_h, "contacts_held"
                                break
                            # β = 0: J_c v = 0 kept, the drift is second order in v dt: scaled by 0.9 √(tol / drift)
                            # (at most 1/2; 1/2 when the frames left the run's radius instead)
                            v_h = (0.5 if tol is None or d <= tol else min(0.5, 0.9 * math.sqrt(tol / d))) * v_h
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

    def _solve_constraints_only(self, uncapped: bool = False, held: bool = False) -> np.ndarray:
        """Step 2's QP (module docstring; nearly dependent rows as band rows) on the fallback backend; ``uncapped``: its
        iteration limit not lowered by the spent count (its solves still counted); ``held``: at most
        ``HELD_ITERATIONS`` per DAQP call. With the clock guard its CPU time is recorded. Raises SolverError."""
        cap, backend = self._work.cap, self._fallback_backend
        held = held and isinstance(backend, DaqpBackend)
        calls = getattr(backend, "call_iterations", None)
        if uncapped:
            self._work.cap = math.inf
        if held:
            backend.call_iterations = self.HELD_ITERATIONS
        t = self._work.seconds() if self.clock_guard else 0.0
        try:
            H, g, A, b, C, l, u, lb, ub = self._qp
            if not self._not_hard_task.all():
                A, b = A[self._not_hard_task], b[self._not_hard_task]
            keep = independent_rows(A, self.rank_rtol)
            if self._fallback_backend is None:
                self._fallback_backend = self._new_backend()
            v_safe = self._fallback_backend.solve(H, g, A[keep], b[keep], C, l, u, lb, ub)
            if keep.size < A.shape[0] and np.max(np.abs(A @ v_safe - b)) > self.dependent_row_tolerance:
                v_safe = self._fallback_backend.solve(H, g, *band_rows(A, b, C, l, u, keep,
                                                                       0.5 * self.dependent_row_tolerance), lb, ub)
            return v_safe
        finally:
            self._work.cap = cap
            if held:
                backend.call_iterations = calls
            if self.clock_guard:
                spent = self._work.seconds() - t
                budget = self.tick_budget
                budget.safe_cost = max(budget.safe_cost, spent) if budget.safe_fresh else spent
                budget.safe_fresh = True

    def _safe_constraints_only(self, config: Configuration, dt: float, anchors) -> tuple[np.ndarray, str]:
        """(v, 'constraints_only') when step 2's command (module docstring), its contacts held like an ok tick's, is
        taken, else (zeros, 'hold'). Never raises."""
        tol = self.sole_drift_tolerance
        t_stage = self._work.seconds()
        v, fallback = np.zeros(self.nv), "hold"
        try:
            v_c = self._held_command(config, dt, self._solve_constraints_only(), [], safe=True).v
            if not command_fault(v_c, self._lb, self._ub, self._C, self._l, self._u, self.backend.tolerance) and (
                    tol is None or self.sole_drift(config, v_c, dt) <= tol) and self.drift_meter.held_drift(
                    config, v_c, dt, self._contacts, anchors, 0.0, self.SAFE_COMMAND_RADIUS)[1]:
                v, fallback = v_c, "constraints_only"
        except Exception:  # noqa: BLE001 — the constraints themselves conflict (or their contacts' correction)
            pass
        if self.clock_guard:
            self.tick_budget.safe_stage_cost = self._work.seconds() - t_stage
        return v, fallback

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
