"""The per-tick inputs of the inverse-dynamics QP (:class:`IDProblemRows`), gathered once per tick into the stacked
buffers its assembly reads (:func:`wbc.formulations.idkernel.id_assemble`)."""

from __future__ import annotations

import numpy as np

from wbc.formulations.idkernel import (IDContactData, IDTaskRows, R_ACC_FF, R_DRIFT, R_ERROR, R_ERROR_RATE_FF, R_KD,
                                       R_KP, R_WEIGHT)
from wbc.state import DynamicsState
from wbc.tasks.posture import PostureTask

__all__ = ["IDProblemRows"]


class IDProblemRows:
    """The task rows of :func:`~wbc.formulations.idkernel.task_cost` (J, e, ė_ff, J̇v, ä_ff, Kp, Kd, w; re-laid out
    when the task list changes) and the contact data (LOCAL sole Jacobians, corner maps, −J̇v − K_p e, K_d, activity,
    sole rotations) of ``qp``, an :class:`~wbc.formulations.acceleration.InverseDynamicsQP`."""

    def __init__(self, qp):
        nv, nc = qp.nv, len(qp.contacts)
        shapes = ((6, nv), (6, 12), (3, 3), (6,), ())
        self.Jc, self.Gc, self.Rc, self.cdrift, self.ckd = (np.zeros((nc, *shape)) for shape in shapes)
        # per contact: its views of Jc, Gc, Rc, cdrift, ckd (an Ellipsis assignment into a view is the cheapest copy)
        self._contact_views = [(c, self.Jc[i], self.Gc[i], self.Rc[i], self.cdrift[i], self.ckd[i:i + 1])
                               for i, c in enumerate(qp.contacts)]
        self.active = np.zeros(nc, dtype=np.bool_)
        self.contacts = IDContactData(self.Jc, self.Gc, self.cdrift, self.ckd, self.active)
        self._rotations: tuple = (None, [])
        self.relayout(qp)

    def relayout(self, qp) -> None:
        """Lay the task rows out for ``qp.tasks`` (dense rows first, then the posture rows)."""
        dense = [t for t in qp.tasks if not isinstance(t.task, PostureTask)]
        posture = [t for t in qp.tasks if isinstance(t.task, PostureTask)]
        mt, mp = sum(t.dim for t in dense), sum(t.dim for t in posture)
        self.Jt, self.R = np.zeros((mt, qp.nv)), np.zeros((7, mt + mp))
        self.pidx = np.concatenate([np.zeros(0, np.int64), *(t.task.rows for t in posture)]).astype(np.int64)
        self.entries = []
        k = 0
        for ref in dense + posture:
            s = slice(k, k + ref.dim)
            # reference, its task, dense rows?, views of its J rows, e, ė_ff, J̇v, ä_ff, weights; its columns of R;
            # the (Kp, Kd) last written there; whether its ė_ff and ä_ff columns hold zeros
            self.entries.append([ref, ref.task, k < mt, self.Jt[s], self.R[R_ERROR, s], self.R[R_ERROR_RATE_FF, s],
                                 self.R[R_DRIFT, s], self.R[R_ACC_FF, s], self.R[R_WEIGHT, s], s, None, True, True])
            ref.last_error = self.R[R_ERROR, s]  # a view, rewritten every tick
            k += ref.dim
        self.tasks = IDTaskRows(self.Jt, self.R, self.pidx, np.zeros(mt + mp))
        self.layout = tuple(map(id, qp.tasks))

    def gather(self, qp, state: DynamicsState) -> None:
        """Task rows and contact data of this tick into the buffers (no validation: the tasks and contacts
        validated their targets when they were set)."""
        if tuple(map(id, qp.tasks)) != self.layout:
            self.relayout(qp)
        R = self.R
        for ent in self.entries:
            ref, task, dense, J, e, eff, drift, aff, w, s, gains, eff_zero, aff_zero = ent
            if dense:
                task.compute_with_drift_into(state, e, J, drift)
            else:
                e[...] = task.compute(state)[0]
                drift[...] = task.drift(state)
            ff = task.feedforward()  # ė_ff, then ä_ff, into their rows (None: zeros, written once)
            if ff is not None or not eff_zero:
                eff[...] = 0.0 if ff is None else ff
                ent[11] = ff is None
            ff = ref.feedforward_acceleration
            if ff is not None or not aff_zero:
                aff[...] = 0.0 if ff is None else ff
                ent[12] = ff is None
            w[...] = ref.weight
            kp, kd = ref.kp, ref.kd
            if gains is None or gains[0] != kp or gains[1] != kd:
                R[R_KP, s] = kp
                R[R_KD, s] = kd
                ent[10] = (kp, kd)
        data = state.kinematics_data  # each contact's frame placed by its jacobian below, before its rotation is read
        if self._rotations[0] is not data:  # views of Data's frame rotations (updated in place by Pinocchio)
            self._rotations = (data, [data.oMf[c.frame_id].rotation for c in qp.contacts])
        rotations = self._rotations[1]
        active = self.active
        for i, (c, Jc, Gc, Rc, cdrift, ckd) in enumerate(self._contact_views):
            Jc[...] = c.jacobian(state)
            Gc[...] = c.force_map()  # a partial foothold (SoleContact.set_support) moves its corners
            a = c.active
            active[i] = a
            if a:
                cdrift[...] = c.acceleration_offset(state)
                ckd[...] = c.kd
                Rc[...] = rotations[i]
