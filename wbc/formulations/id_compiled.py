"""The compiled assembly of the inverse-dynamics QP (:class:`CompiledIDAssembly`):
:func:`wbc.formulations.idkernel.id_assemble` writes the QP of :mod:`wbc.formulations.acceleration` from the tick's
gathered rows (:class:`~wbc.formulations.id_rows.IDProblemRows`) into the formulation's own arrays — the same
numbers, bit for bit, as the formulation's constraints write.
"""

from __future__ import annotations

import numpy as np

from wbc.compiled import CHECK_TYPES, specialise
from wbc.constraints.contact_acceleration import DEPENDENT_CONTACT_RATIO
from wbc.formulations.id_rows import IDProblemRows
from wbc.formulations.idkernel import (IDArrays, IDAssemblyWork, IDDynamics, IDLimits, PAR_BRAKING, PAR_EPS_A,
                                       PAR_EXTRA_ROWS, PAR_JOINT_LIMITS, PAR_SPEED_HORIZON, id_assemble)
from wbc.exceptions import SolverError
from wbc.solvers.compiled_id import CompiledIDSolver
from wbc.solvers.qp_data import QPData

__all__ = ["CompiledIDAssembly"]

#: the compiled kernels have been loaded in this process (:meth:`CompiledIDAssembly._load`)
_COMPILED_ID_LOADED = False


class CompiledIDAssembly:
    """The limits, settings and workspace of :func:`~wbc.formulations.idkernel.id_assemble` for one QP.

    Args:
        qp: the :class:`~wbc.formulations.acceleration.InverseDynamicsQP` (its sizes, limits and settings).
        rows: its gathered rows. blocks: its (H, g, A, b, C, l, u, lb, ub, JcT) arrays, written by each call.
        solver: the chain's compiled solver, loaded with the assembly (once per process).
    """

    def __init__(self, qp, rows: IDProblemRows, blocks: tuple[np.ndarray, ...], solver: CompiledIDSolver):
        tl = qp.torque_limits
        jl = qp.joint_acceleration_limits
        self.par = np.array([qp.eps_a, jl.braking_acceleration, float(qp.joint_limits), DEPENDENT_CONTACT_RATIO,
                             jl.speed_horizon, 0.0])
        idx = np.concatenate([tl.velocity_indices, jl.iq, jl.iv]).astype(np.int64)
        self.limits = IDLimits(idx, tl.limits.copy(), self.par, jl.qmin, jl.qmax, jl.vmax)
        self.arrays = IDArrays(*blocks)
        self.work = IDAssemblyWork(rows.Hw, rows.gw, rows.gram, rows.gram_y, np.zeros(jl.dim), np.zeros(jl.dim))
        self._entry = None  # id_assemble specialised to these buffers and a DynamicsState's arrays (first call)
        self._load(qp, rows, solver)

    def assemble(self, rows: IDProblemRows, dynamics: IDDynamics, settings: tuple, extra_rows: int) -> int:
        """The compiled assembly of one tick on the gathered ``rows`` at ``dynamics``; ``settings``: (ε_a, a_brk,
        joint limits on, speed horizon in ticks) of the formulation, read every tick; ``extra_rows``: equality rows
        the formulation wrote after the active contacts' (its gathered entries). Returns m, the equality rows
        assembled, or :data:`~wbc.formulations.idkernel.PROJECT_CONTACT_RHS`."""
        par = self.par
        par[PAR_EPS_A], par[PAR_BRAKING], par[PAR_JOINT_LIMITS], par[PAR_SPEED_HORIZON] = settings
        par[PAR_EXTRA_ROWS] = extra_rows
        args = (rows.tasks, dynamics, rows.contacts, self.limits, self.arrays, self.work)
        if self._entry is None:  # the buffers' and the state's types are fixed: no per-call type resolution (with
            # kernel type checks on, the dispatcher's, which resolves them on every call)
            self._entry = id_assemble if CHECK_TYPES else specialise(id_assemble, *args)
        return self._entry(*args)

    def _load(self, qp, rows: IDProblemRows, solver: CompiledIDSolver) -> None:
        """Load the assembly and the solver at construction, once per process: one call of each on these buffers at
        a neutral state (M = I column-major as a :class:`~wbc.state.DynamicsState`'s, h = 0, v = 0, no contact
        active), every buffer they write restored afterwards."""
        global _COMPILED_ID_LOADED
        if _COMPILED_ID_LOADED:
            return
        if rows.layout is None:
            rows.relayout(qp)
        nv = qp.nv
        arrays = [a for a in (*rows.tasks, *rows.contacts, *self.limits, *self.arrays, *self.work, *solver.buffers)
                  if isinstance(a, np.ndarray)]
        saved = [a.copy() for a in arrays]
        try:
            m = id_assemble(rows.tasks, IDDynamics(np.asfortranarray(np.eye(nv)), np.zeros(nv), qp.robot.q_ref.copy(),
                                                   np.zeros(nv), 0.002), rows.contacts, self.limits, self.arrays,
                            self.work)
            H, g, A, b, C, l, u, lb, ub, _ = self.arrays
            try:
                solver.solve(QPData(H, g, A[:max(m, 6)], b[:max(m, 6)], C, l, u, lb, ub))
            except SolverError:  # any answer loads the kernel; this neutral QP's own is not used
                pass
            _COMPILED_ID_LOADED = True
        finally:
            for a, a0 in zip(arrays, saved):
                np.copyto(a, a0)
