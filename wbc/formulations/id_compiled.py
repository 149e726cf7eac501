"""The compiled inverse-dynamics tick as one more solver of the ID QP (:class:`CompiledIDTick`).

:func:`wbc.formulations.idkernel.id_tick` assembles the QP of :mod:`wbc.formulations.acceleration` from the tick's
gathered rows (:class:`~wbc.formulations.id_rows.IDProblemRows`) into the formulation's own arrays — the same
numbers, bit for bit, as the formulation's constraints write — and solves it (an equality step, else
Goldfarb–Idnani's dual active set), then forms the torques and wrenches. The formulation hands this object the data
of a tick (:meth:`CompiledIDTick.solve`); when the call ends in no solution within the tolerance, the formulation
hands the same arrays, as :class:`~wbc.solvers.qp_data.QPData`, to its fallback chain
(:class:`~wbc.solvers.fallback.FallbackChain`), and the chain's answer warm-starts the next call
(:meth:`CompiledIDTick.warm`).
"""

from __future__ import annotations

import numpy as np

from wbc.constraints.contact_acceleration import DEPENDENT_CONTACT_RATIO
from wbc.formulations.id_rows import IDProblemRows
from wbc.formulations.idkernel import (IDArrays, IDDynamics, IDLimits, IDTickBuffers, PAR_BRAKING, PAR_EPS_A,
                                       PAR_EXTRA_ROWS, PAR_JOINT_LIMITS, PAR_MAX_ITER, PAR_SPEED_HORIZON, id_tick,
                                       id_tick_buffers, tick_outputs)
from wbc.solvers.status import SolverStatus

__all__ = ["CompiledIDTick", "KERNEL_ITERATIONS_AFTER_GIVE_UP"]

#: iteration cap of the compiled ID tick on the tick after one whose compiled call gave up (DAQP answered it): the
#: call starts from DAQP's working set, so a tick one working-set change away from the last answer stays in the
#: compiled tick; one that needs more is as hard as the last and goes to DAQP after this short attempt.
KERNEL_ITERATIONS_AFTER_GIVE_UP = 2

_STATUS_CODES = {int(code) for code in SolverStatus}

#: :func:`~wbc.formulations.idkernel.id_tick` has been loaded in this process (:meth:`CompiledIDTick._load`)
_ID_TICK_LOADED = False


class CompiledIDTick:
    """Preallocated solver state, outputs and workspace of :func:`~wbc.formulations.idkernel.id_tick` for one QP.

    Args:
        qp: the :class:`~wbc.formulations.acceleration.InverseDynamicsQP` (its sizes, limits and settings).
        rows: its gathered rows. blocks: its (H, g, A, b, C, l, u, lb, ub, JcT) arrays, written by each call.

    Attributes:
        state, rstate: (n,), (p,) the working set (bounds, inequality rows: −1 lower, +1 upper, 0 free).
        x (n,), tau (nv − 6,), wrench (nc, 6), residual (2,): the last call's outputs.
        solves, fallbacks, rejected: calls that answered, that did not (the chain answered), and whose answer
            failed the formulation's output check.
        gave_up: the last call did not answer: the next one is capped at :data:`KERNEL_ITERATIONS_AFTER_GIVE_UP`.
    """

    def __init__(self, qp, rows: IDProblemRows, blocks: tuple[np.ndarray, ...]):
        nv, n, nc = qp.nv, qp.n, len(qp.contacts)
        tl = qp.torque_limits
        jl = qp.joint_acceleration_limits
        self.par = np.array([qp.eps_a, jl.braking_acceleration, float(qp.joint_limits), 100.0,
                             DEPENDENT_CONTACT_RATIO, jl.speed_horizon, 0.0])
        p = blocks[4].shape[0]  # C (p, n): the inequality rows
        buffers = id_tick_buffers(n, nv, p, nc, jl.dim, blocks[2].shape[0])  # A (me, n): room for every equality row
        self.state, self.rstate = buffers[0][:n], buffers[0][n:]  # the working set, views of the kernel's buffer
        self.residual, self.tau, self.wrench, self.x = tick_outputs(buffers[-1], nv, nc)
        idx = np.concatenate([tl.velocity_indices, jl.iq, jl.iv]).astype(np.int64)
        # id_tick's arguments after the tick's rows and dynamics: (IDLimits, IDArrays, IDTickBuffers)
        self.tail = (IDLimits(idx, tl.limits.copy(), self.par, jl.qmin, jl.qmax, jl.vmax), IDArrays(*blocks),
                     IDTickBuffers(*buffers))
        self.solves = 0
        self.fallbacks = 0
        self.rejected = 0
        self.gave_up = False
        self._load(qp, rows)

    def solve(self, rows: IDProblemRows, dynamics: IDDynamics, settings: tuple, extra_rows: int,
              max_iterations: int) -> tuple[int, int]:
        """One compiled tick on the gathered ``rows`` at ``dynamics``.

        Args:
            settings: (ε_a, a_brk, joint limits on, speed horizon in ticks) of the formulation, read every tick.
            extra_rows: equality rows the formulation wrote after the active contacts' (its gathered entries).
            max_iterations: the working-set iteration cap (after a give-up, at most
                :data:`KERNEL_ITERATIONS_AFTER_GIVE_UP`).

        Returns:
            (status: > 0 iterations, else a :class:`~wbc.solvers.status.SolverStatus` or
            :data:`~wbc.formulations.idkernel.PROJECT_CONTACT_RHS`; m: the equality rows assembled).
        """
        par = self.par
        par[PAR_EPS_A], par[PAR_BRAKING], par[PAR_JOINT_LIMITS], par[PAR_SPEED_HORIZON] = settings
        par[PAR_EXTRA_ROWS] = extra_rows
        # after a give-up the call starts from DAQP's working set, one answer away: a short attempt
        par[PAR_MAX_ITER] = min(max_iterations, KERNEL_ITERATIONS_AFTER_GIVE_UP) if self.gave_up else max_iterations
        self.gave_up = False
        return id_tick(rows.tasks, dynamics, rows.contacts, *self.tail)

    def give_up(self) -> float:
        """Record a call that did not answer and clear the working set. Returns its iteration cap."""
        self.fallbacks += 1
        self.gave_up = True
        self.state[:] = 0
        self.rstate[:] = 0
        return float(self.par[PAR_MAX_ITER])

    @staticmethod
    def status_text(status: int, residual: float) -> str:
        """Why a call of ``status`` (and the solution's ``residual``) did not answer."""
        if status > 0:
            return f"kernel residual {residual:.1e} above the tolerance"
        return f"kernel status {SolverStatus(status).name if status in _STATUS_CODES else status}"

    def warm(self, x: np.ndarray, lam, m: int, lb: np.ndarray, ub: np.ndarray) -> None:
        """Warm start of the next call from another solver's answer ``x`` (n,) to the QP with ``m`` equality rows:
        its multipliers ``lam`` (bounds, equality rows, inequality rows; > 0 at an upper bound, < 0 at a lower one)
        when given with the QP's size, else the bounds of ``lb``, ``ub`` that ``x`` meets (to 1e-9 relative)."""
        n, p = self.state.shape[0], self.rstate.shape[0]
        if lam is not None and len(lam) == n + m + p:
            lam = np.asarray(lam)
            self.state[:] = np.sign(lam[:n])
            self.rstate[:] = np.sign(lam[n + m:])
        else:
            lo, hi = np.isfinite(lb), np.isfinite(ub)  # an infinite bound is never active
            self.state[lo & (x <= np.where(lo, lb, 0.0) + 1e-9 * np.maximum(1.0, np.abs(np.where(lo, lb, 0.0))))] = -1
            self.state[hi & (x >= np.where(hi, ub, 0.0) - 1e-9 * np.maximum(1.0, np.abs(np.where(hi, ub, 0.0))))] = 1

    def _load(self, qp, rows: IDProblemRows) -> None:
        """Load :func:`~wbc.formulations.idkernel.id_tick` here, at construction, not inside the first tick: once per
        process, one call on these buffers at a neutral state (M = I in the column-major order of a
        :class:`~wbc.state.DynamicsState`'s M, h = 0, v = 0, no contact active), every buffer it writes
        restored afterwards (the first tick starts exactly as without this call)."""
        global _ID_TICK_LOADED
        if _ID_TICK_LOADED:
            return
        if rows.layout is None:
            rows.relayout(qp)
        nv = qp.nv
        arrays = [a for a in (*rows.tasks, *rows.contacts, *(x for t in self.tail for x in t))
                  if isinstance(a, np.ndarray)]
        saved = [a.copy() for a in arrays]
        try:
            id_tick(rows.tasks, IDDynamics(np.asfortranarray(np.eye(nv)), np.zeros(nv), qp.robot.q_ref.copy(),
                                           np.zeros(nv), 0.002), rows.contacts, *self.tail)
            _ID_TICK_LOADED = True
        finally:
            for a, a0 in zip(arrays, saved):
                np.copyto(a, a0)
