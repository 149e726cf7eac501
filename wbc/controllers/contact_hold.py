"""Second-order contact hold of the kinematic controller.

Contact rows J_c v = −K e hold a contact frame to first order in v dt only. After a solve the frames are placed at
q⁺ = pin.integrate(q, v dt); when one drifts from where its row sends it by more than ``contact_correction`` (m),
the contact rows' right-hand sides are corrected by the measured drift and the tick is solved again (a Newton step
on e⁺(v) = (1 − K dt) e, ≤ 3 iterations); dependent contact rows get right-hand sides projected onto the range of
J_c (least squares). A tick whose drift still exceeds ``sole_drift_tolerance`` is solved inside trust regions
|v_i| ≤ ρ (``_held_command``), else it fails with :class:`DriftFailure`."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from wbc.configuration import Configuration
from wbc.constraints.contact import ContactConstraint
from wbc.exceptions import SolverError
from wbc.lie import rotation_gap, translation_gap
from wbc.tick import TickResult


class DriftFailure(SolverError):
    """The tick's QP solved, but no trust region kept the contact frames within ``sole_drift_tolerance``."""


class DriftMeter:
    """Where contact frames end after one tick against where their contact rows send them (forward kinematics at
    q⁺ = pin.integrate(q, v dt) on a Data of its own).

    Args:
        model: the robot's Pinocchio model.
    """

    def __init__(self, model: pin.Model):
        self.model = model
        #: the Data the frames are placed in at q⁺ (the controller's compiled tick reuses it as scratch)
        self.data = model.createData()
        self._memo: tuple | None = None  # (v, q, dt, result) of the last measure(remember=True)

    def measure(self, config: Configuration, v: np.ndarray, dt: float, contacts: list[ContactConstraint],
                lever: float, expected: list[np.ndarray] | None = None, *,
                remember: bool = False) -> tuple[float, list[np.ndarray], float]:
        """(largest distance (m), [(6,) e⁺ − target per contact], largest drift (m)) over one tick of dt (s) with v
        (nv,) from ``config``: e⁺ = log6(placementᵀ · frame at q⁺); target = (1 − min(K, 1/dt) dt) e at ``config``
        (or ``expected[i]``, the contact rows' own targets); the distance that of the translations of exp(e⁺) and
        exp(target); a frame's drift the larger of its distance and ``lever`` (m/rad) times the angle between the
        two rotations (0: the distance alone). ``remember``: the answer returned again for the same v, q (the same
        arrays) and dt until :meth:`forget`."""
        if not contacts:
            return 0.0, [], 0.0
        memo = self._memo
        if memo is not None and memo[0] is v and memo[1] is config.q and memo[2] == dt:
            return memo[3]
        model, data = self.model, self.data
        pin.forwardKinematics(model, data, pin.integrate(model, config.q, v * dt))
        far = worst = 0.0
        drifts = []
        for i, c in enumerate(contacts):
            after = pin.log6(c.placement.actInv(pin.updateFramePlacement(model, data, c.frame_id))).vector
            target = c.compute_error(config) * (1.0 - min(c.gain, 1.0 / dt) * dt) if expected is None else expected[i]
            drifts.append(after - target)
            d = translation_gap(after, 1.0, target, 1.0)  # the distance, not the twists' gap
            far = max(far, d)
            if lever > 0:
                d = max(d, lever * rotation_gap(after, 1.0, target, 1.0))
            worst = max(worst, d)
        if remember:
            self._memo = (v, config.q, dt, (far, drifts, worst))
        return far, drifts, worst

    def held_drift(self, config: Configuration, v: np.ndarray, dt: float, contacts: list[ContactConstraint],
                   anchors: list[pin.SE3], beta: float, radius: float) -> tuple[float, bool]:
        """(largest drift (m), inside) of the contact frames over one tick of dt (s) with v (nv,): a frame's drift from
        where its correction towards its anchor (world placement) scaled by β sends it, ‖t(exp(e⁺)) −
        t(exp((1 − β K dt) e))‖, e = log₆(anchor⁻¹ oMf), e⁺ at pin.integrate(q, v dt) (β = 0: its displacement);
        inside: each frame ends within ``radius`` (m) of its anchor, or no farther from it than at ``config``."""
        model, data = self.model, self.data
        pin.forwardKinematics(model, data, pin.integrate(model, config.q, v * dt))
        worst, inside = 0.0, True
        for c, anchor in zip(contacts, anchors):
            after, before = pin.updateFramePlacement(model, data, c.frame_id), config.frame_placement(c.frame_id)
            e1, e0 = pin.log6(anchor.actInv(after)).vector, pin.log6(anchor.actInv(before)).vector
            worst = max(worst, translation_gap(e1, 1.0, e0, 1.0 - beta * min(c.gain, 1.0 / dt) * dt))
            inside = inside and not float(np.linalg.norm(after.translation - anchor.translation)) > max(
                radius, float(np.linalg.norm(before.translation - anchor.translation)))
        return worst, inside

    def forget(self) -> None:
        """Drop the remembered answer (:meth:`measure`)."""
        self._memo = None


class ContactRange:
    """The range of the contact rows J_c (rows of the contacts × nv), from their thin SVD, kept while J_c is unchanged
    (a failed tick asks it several times)."""

    def __init__(self):
        self._kept: tuple | None = None  # (J_c, U, S) of the last SVD

    def basis(self, Jc: np.ndarray, rank_rtol: float) -> np.ndarray:
        """Orthonormal basis U_r (rows × rank, read-only) of the range of ``Jc``: its numerical rank counts the singular
        values > ``rank_rtol`` · max(the largest, 1) (rank = rows: every contact row independent)."""
        kept = self._kept
        if kept is None or kept[0].shape != Jc.shape or not np.array_equal(kept[0], Jc):
            U, S, _ = np.linalg.svd(Jc, full_matrices=False)
            U.setflags(write=False)
            kept = self._kept = (Jc, U, S)
        U, S = kept[1], kept[2]
        rank = int(np.sum(S > rank_rtol * max(S[0], 1.0))) if S.size else 0
        return U[:, :rank]


class ContactHold:
    """The contact-hold part of :class:`wbc.controllers.kinematic.KinematicController` (module docstring)."""

    def sole_drift(self, config: Configuration, v: np.ndarray, dt: float) -> float:
        """Largest drift (m) of the contact frames over one tick of dt (s) with v (nv,), ``TickResult.sole_drift``:
        :meth:`DriftMeter.measure` against where their contact rows send them, its lever sole_drift_tolerance /
        sole_rotation_tolerance (constructor; the distance alone when either is None)."""
        self._update_layout()
        return self._contact_drifts(config, v, dt)[2]

    def _contact_drifts(self, config: Configuration, v: np.ndarray, dt: float) -> tuple[float, list[np.ndarray], float]:
        """:meth:`DriftMeter.measure` of this tick's contacts (remembered within a tick, against its targets)."""
        expected = self._contact_expected if self._in_solve else None
        return self.drift_meter.measure(config, v, dt, self._contacts, self._drift_lever(), expected,
                                        remember=self._in_solve)

    def _drift_lever(self) -> float:
        """sole_drift_tolerance / sole_rotation_tolerance (m per rad; 0, the distance alone, when either is None)."""
        tol, turn = self.sole_drift_tolerance, self.sole_rotation_tolerance
        return 0.0 if tol is None or turn is None else tol / turn

    def _consistent_contact_rhs(self) -> bool:
        """After a failed solve, the contact rows' right-hand sides made consistent (:meth:`_project_contact_rhs`);
        True when b changed."""
        basis = self._contact_range_basis(near=True)
        if basis is None:
            return False
        b0 = self._b[self._contact_rows]
        self._project_contact_rhs(basis)
        self._eq_rows = None  # recompute the independent rows for the retry
        return not np.array_equal(b0, self._b[self._contact_rows])

    def _contact_range_basis(self, near: bool = False) -> np.ndarray | None:
        """:meth:`ContactRange.basis` of the contact rows J_c when rank deficient at ``rank_rtol``, else None (also
        when the tick's rank check kept every row); ``near``: at max(rank_rtol, NEAR_DEPENDENT_RTOL), that unchecked."""
        rows = self._contact_rows
        if not near and self._eq_rows is not None and self._eq_rows.size == self._A.shape[0]:
            return None
        basis = self.contact_range.basis(self._A[rows], max(self.rank_rtol, self.NEAR_DEPENDENT_RTOL * near))
        return None if basis.shape[1] == rows.size else basis

    def _project_contact_rhs(self, basis: np.ndarray | None) -> None:
        """b_c ← U_r U_rᵀ b_c: the contact rows' right-hand sides projected onto the range of J_c (``basis`` U_r; None:
        full rank, unchanged), so that dependent rows' corrections agree (least squares)."""
        if basis is not None:
            rows = self._contact_rows
            self._b[rows] = basis @ (basis.T @ self._b[rows])

    def _may_resolve(self, safe: bool, stage: str) -> bool:
        """May a re-solve start: the safe command's (``safe``) as a 'retry', else as a 'stage' (its cut recorded as
        ``stage`` when not), at the CPU time of the longest such re-solve so far."""
        budget = self.tick_budget
        cost = budget.safe_estimate() if safe else budget.resolve_cost
        work = None  # the larger of the tick's first solve and largest re-solve (TickBudget.may_start)
        if self._weighted_tick or not self._level_order:  # one QP: a re-solve starts from the tick's answer
            work = budget.resolve_work if budget.resolves > 1 else min(budget.first_work, self.FIRST_RESOLVE_WORK)
        if budget.may_start("retry" if safe else "stage", cost, work=work):
            return True
        if not safe:
            self._cut.append(stage)
        return False

    def _correct_contacts(self, config: Configuration, dt: float, v: np.ndarray, safe: bool = False,
                          near: bool = False) -> np.ndarray:
        """Second-order contact correction (constructor docstring, ``contact_correction``; ``safe``: _held_command)."""
        solve = self._solve_constraints_only if safe else self._solve_assembled
        self.contact_corrections = 0
        worst, drifts, _ = self._contact_drifts(config, v, dt)
        if worst <= self.contact_correction:
            return v
        range_basis = self._contact_range_basis(near)
        b0 = self._b.copy()
        try:
            for k in range(3):
                if not self._may_resolve(safe, f"contact correction after {k} of 3 re-solves"):
                    break  # the best command is kept
                for (_, r0, r1), d in zip(self._contact_blocks, drifts):  # (in the order of _contacts, of drifts)
                    self._b[r0:r1] -= d / dt
                self._project_contact_rhs(range_basis)
                try:
                    v_new = solve()
                except SolverError:
                    break  # keep the last solution (the trust region takes over)
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
                    break  # too slow to reach tol in the re-solves left: the trust region's smaller steps take over
        finally:
            np.copyto(self._b, b0)
        return v

    def _held_command(self, config: Configuration, dt: float, v: np.ndarray, relaxed: list, safe: bool = False,
                      held: bool = False) -> TickResult:
        """v with its contacts held (module docstring): its correction (not when ``held``: J_c v = 0 asked), then,
        while it drifts past sole_drift_tolerance, trust regions, each solution corrected, the least drifting kept
        (contact rows projected first, :meth:`_project_contact_rhs`). ``safe``: re-solves of the safe command's QP."""
        solve = self._solve_constraints_only if safe else self._solve_assembled
        if self.contact_correction > 0 and self._contacts and not held:
            v = self._correct_contacts(config, dt, v, safe)
        drift = self.sole_drift(config, v, dt)
        if self.sole_drift_tolerance is None or drift <= self.sole_drift_tolerance:
            return TickResult(v, relaxed=relaxed, sole_drift=drift)
        box0, b0 = self._box_rows.copy(), self._b.copy()  # (lb, ub) as the rows of one array
        best_v, best = v, drift
        rho = float(np.max(np.abs(v)))
        basis = self._contact_range_basis(near=True) if self._contact_rows.size else None
        n_radii = 8 + (basis is not None)
        radius, last = rho, drift  # the last region's radius and the drift of its solution
        try:
            self._project_contact_rhs(basis)
            for k in range(n_radii):
                if not self._may_resolve(safe, f"trust region after {k} of at most {n_radii} radii"):
                    break  # the least drifting command is kept
                if basis is not None and k == 0:
                    radius = math.inf  # first the whole box, with consistent contact rows
                else:
                    # the next radius from the last drift, taken linear in the radius, with a 0.8 margin:
                    # ρ ← ρ · clip(0.8 · tolerance / drift, 1/16, 1/2)
                    radius = (rho if math.isinf(radius) else radius) * min(
                        0.5, max(1.0 / 16.0, 0.8 * self.sole_drift_tolerance / max(last, 1e-300)))
                np.clip(box0, -radius, radius, out=self._box_rows)
                np.maximum(self._lb, np.minimum(*box0), out=self._lb)  # never tighter than a pinned bound
                np.minimum(self._ub, np.maximum(*box0), out=self._ub)
                try:
                    v_tr = solve()
                except SolverError:
                    break  # the contact rows cannot be met inside this region: keep the best so far
                if self.contact_correction > 0:
                    v_tr = self._correct_contacts(config, dt, v_tr, safe, near=True)
                d = last = self.sole_drift(config, v_tr, dt)
                if d < best:
                    best_v, best = v_tr, d
                if best <= self.sole_drift_tolerance:
                    break
        finally:
            np.copyto(self._box_rows, box0)
            np.copyto(self._b, b0)
        if best <= self.sole_drift_tolerance:
            return TickResult(best_v, relaxed=relaxed, sole_drift=best)
        return TickResult(best_v, ok=False, relaxed=relaxed, sole_drift=best, fallback="trust_region",
                          message=f"contact frame drifts {best:.3g} m over the tick (> sole_drift_tolerance "
                                  f"{self.sole_drift_tolerance:.3g} m) even inside a trust region" + (
                                      f" (tick budget spent: {'; '.join(self._cut)} skipped)" if self._cut else ""))
