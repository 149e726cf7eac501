"""Velocity-level formulation: the kinematic QP (:class:`VelocityQP`), solved once per control tick.

With v ∈ R^nv the generalized velocity (floating base included) over a tick of period dt (s):

    min_v   Σ_i ‖ diag(√w_i) (J_i v − v*_i) ‖²  +  ε ‖v‖²          (soft tasks, ``level=None``)
    s.t.    A v = b                                                 (equality constraints, hard tasks J v = v*;
                                                                     stance contacts J_c v = −K_c e_c)
            l ≤ C v ≤ u                                             (inequality constraints)
            lb ≤ v ≤ ub                                             (bound constraints intersected in priority order)

with, for each task i: error e_i(q), Jacobian J_i = ∂e_i/∂q, gain K_i (1/s), feed-forward ė*_i, weights w_i and
v*_i = ė*_i − K_i e_i (:mod:`wbc.tasks`); the rows of :mod:`wbc.constraints` (``write``/``compute`` on v); ε
(``damping``) keeps H = Σ J_iᵀ W_i J_i + ε I positive definite, g = −Σ J_iᵀ W_i v*_i. Strict levels (``level=k``)
keep their rows √w J, √w v* apart (:func:`wbc.formulations.velocity_kernel.weighted_rows`) for the lexicographic
cascade of :mod:`wbc.solvers.hierarchy`. The next configuration is q⁺ = pin.integrate(q, v dt).

:meth:`VelocityQP.assemble` writes (H, g, A, b, C, l, u, lb, ub) into preallocated buffers, one set per constraint
layout, which every route of the tick solves. What the controller does around this QP (contact hold, relaxations,
budget, safe command, compiled tick) is in :mod:`wbc.controllers.kinematic` and ``docs/kinematic-controller.md``."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from wbc.configuration import Configuration
from wbc.constraints.base import BoxConstraint, EqualityConstraint, InequalityConstraint
from wbc.constraints.contact import ContactConstraint
from wbc.constraints.limits import JointPositionLimit
from wbc.constraints.task import TaskConstraint
from wbc.formulations.velocity_kernel import (NO_KERNEL_BOX, KernelBox, form_qp, kinematic_pack, kinematic_views,
                                              rows_pack, task_rows, weighted_rows)
from wbc.solvers.qp_data import QPData
from wbc.tasks.base import Task
from wbc.tasks.posture import PostureTask


#: controller attributes that make up one constraint layout (``KinematicController._update_layout``)
LAYOUT_ATTRS = ("_constraints", "_box", "_feedback", "_box_sel", "_relaxable", "_contacts", "_contact_rows",
                 "_const_prefix", "_const_box", "_box_rows", "_eq_blocks", "_A", "_b", "_contact_blocks", "_in_blocks",
                 "_C", "_l", "_u", "_lb", "_ub", "_not_hard_task", "_H", "_g", "_eliminating_row", "_qp_pack",
                 "_contact_writes", "_other_eq_blocks", "_contact_factors", "_contact_factor_values", "_contact_starts",
                 "_relaxable_blocks", "_contact_pair", "_qp")


def row_blocks(constraints) -> tuple[list, int]:
    """``([(constraint, first row, end row)...], total rows)`` of constraints stacked in order."""
    blocks, row = [], 0
    for c in constraints:
        blocks.append((c, row, row + c.dim))
        row += c.dim
    return blocks, row


class VelocityQP:
    """The kinematic QP of the module docstring: its row layouts and buffers (cached per constraint list and per
    soft-task list) and their assembly (:meth:`assemble`). :class:`wbc.controllers.kinematic.KinematicController`
    derives from it and owns the task and constraint lists, the robot and ``damping``."""

    #: counted solves added to a tick that builds a new row layout: the build and the tick's first solves on fresh
    #: buffers and solver workspaces (docs/kinematic-controller.md, tick budget)
    LAYOUT_WORK = 4

    def _update_layout(self) -> None:
        """Row layout of the equality and inequality blocks and their buffers (redone when ``_layout_ok`` is False),
        kept per constraint list (the same objects in the same order and row counts): a support switch back to an
        earlier set of contacts reuses its layout, buffers and the intersection of its constant boxes."""
        if self._layout_ok:
            return
        key = tuple((id(c), c.dim) for c in self.constraints)
        state = self.__dict__
        if self._layout_key is not None:  # keep the current layout (with what _intersect_boxes cached since)
            self._layouts[self._layout_key] = {a: state[a] for a in LAYOUT_ATTRS if a in state}
            while len(self._layouts) > 16:
                self._layouts.pop(next(iter(self._layouts)))
        cached = self._layouts.get(key)  # (its constraints kept alive by the layout: no id reused while it is kept)
        if cached is None or key in self._prepared:  # a new layout, or one built ahead by prepare_layouts: its
            self._work.add(self.LAYOUT_WORK)  # first tick counts it as built there
        self._prepared.discard(key)
        self._layout_key = key
        if cached is not None:
            state.update(cached)
            self._layout_ok = True
            return
        self._constraints = list(self.constraints)
        self._const_box = None
        self._box = sorted((c for c in self.constraints if isinstance(c, BoxConstraint)), key=lambda c: c.priority)
        self._feedback = [c for c in self.constraints if c.needs_previous_command]
        self._box_sel = []  # (box, its indices as a slice when contiguous: views instead of fancy indexing)
        for c in self._box:
            idx = np.asarray(c.indices)
            contiguous = idx.size and np.array_equal(idx, np.arange(idx[0], idx[0] + idx.size))
            self._box_sel.append((c, slice(int(idx[0]), int(idx[0]) + idx.size) if contiguous else idx))
        self._relaxable = [c for c in self.constraints if c.relaxable]
        self._contacts = [c for c in self.constraints if isinstance(c, ContactConstraint)]
        self._const_prefix = None  # number of leading constant boxes, cached by _intersect_boxes
        self._eq_blocks, n_eq = row_blocks([c for c in self.constraints if isinstance(c, EqualityConstraint)])
        contact_ids = set(map(id, self._contacts))
        self._contact_blocks = [blk for blk in self._eq_blocks if id(blk[0]) in contact_ids]  # order of _contacts
        self._contact_rows = np.array([i for _, r0, r1 in self._contact_blocks for i in range(r0, r1)], dtype=int)
        self._in_blocks, n_in = row_blocks([c for c in self.constraints if isinstance(c, InequalityConstraint)])
        relax = set(map(id, self._relaxable))  # their row blocks, one list (boxes: re-intersected without them)
        self._relaxable_blocks = [blk for blk in (*self._eq_blocks, *self._in_blocks) if id(blk[0]) in relax]
        # the compiled solver eliminates the floating base (a free flyer at v[0:6] no box bounds) by the first
        # contact's rows
        model = self.robot.model
        free_flyer = model.njoints > 1 and model.joints[1].shortname() == "JointModelFreeFlyer" and \
            model.joints[1].idx_v == 0
        base_bounded = any(np.size(c.indices) and int(np.min(c.indices)) < 6 for c in self._box)
        first = [r0 for c, r0, _ in self._contact_blocks if type(c) is ContactConstraint]
        self._eliminating_row = first[0] if first and free_flyer and not base_bounded else -1
        # the QP's buffers, packed with the compiled solver's workspace: every route reads them
        self._qp_pack = kinematic_pack(self.nv, n_eq, n_in, self._eliminating_row)
        self._qp, self._box_rows, *_ = kinematic_views.py_func(*self._qp_pack)  # numpy views; _box_rows: (lb, ub)
        self._H, self._g, self._A, self._b, self._C, self._l, self._u, self._lb, self._ub = self._qp
        # each contact's rows written in place (views of A, b), and its factor dt − 1/K ((1 − K dt) e = factor · b)
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
        self._not_hard_task = np.array([not isinstance(c, TaskConstraint) for c, r0, r1 in self._eq_blocks
                                        for _ in range(r0, r1)], dtype=bool)  # equality rows kept by the fallback
        self._layout_ok = True

    def _update_soft_layout(self) -> None:
        """The soft tasks' stacked rows (:class:`SoftRows`), redone when ``tasks`` changes and kept per task list
        (the same task objects in the same order and sizes): a swing task that comes back reuses its layout."""
        if self._soft_tasks == self.tasks:
            return
        key = tuple((id(t), t.dim) for t in self.tasks)
        cached = self._soft_layouts.get(key)
        if cached is not None:  # (the same task objects: kept alive by it)
            self._soft_tasks, self._soft = cached.tasks, cached
            return
        soft = SoftRows(self.tasks, self.nv, own_costs=True)
        self._soft_tasks, self._soft = soft.tasks, soft
        self._soft_layouts[key] = soft
        while len(self._soft_layouts) > 16:
            self._soft_layouts.pop(next(iter(self._soft_layouts)))

    def assemble(self, config: Configuration, dt: float, form_cost: bool = True, boxes: bool = True) -> QPData:
        """Build the QP at ``config`` over a tick of ``dt`` seconds (module docstring): the one assembly that every
        route solves. Returns :class:`~wbc.solvers.qp_data.QPData` (H (nv, nv), g (nv,), A, b, C, l, u, lb, ub (nv,)):
        views of the controller's buffers, overwritten at the next call. The posture's q ⊖ q* and gain are kept in
        ``_posture_diff``, ``_posture_gain``; ``form_cost`` False leaves H and g to the compiled tick, ``boxes``
        False lb and ub too."""
        self._update_layout()
        self._update_soft_layout()
        H, g, A, b, C, l, u, lb, ub = self._qp
        soft = self._soft
        soft.gather(config)
        posture = soft.posture
        if posture is not None:
            diff, pgain = posture.row_difference(config.q), posture.gain
            if posture.weight is not soft.pw:
                posture.share_weight(soft.pw)
        else:
            diff, pgain = soft.no_diff, 0.0
        self._posture_diff, self._posture_gain = diff, pgain
        if form_cost:
            form_qp(soft.fb, soft.ib, diff, pgain, self.damping, H, g)
        for task in soft.own:
            task.add_cost(config, H, g)
        if self._level_order:  # the strict levels' rows, gathered the same way, weights applied (weighted_rows)
            key = tuple((k, id(t), t.dim) for k in self._level_order for t in self.levels[k])
            if key != self._level_key:
                self._level_key = key
                self._level_rows = [SoftRows(self.levels[k], self.nv, own_costs=False) for k in self._level_order]
            for level in self._level_rows:
                level.gather(config)
                weighted_rows(level.J, level.e, level.rowp, level.wJ, level.wr)
        ctx = self._context
        ctx.config, ctx.dt = config, dt
        factors, values, inv = self._contact_factors, self._contact_factor_values, 1.0 / dt
        pair = self._contact_pair
        if pair is not None:
            first, second, row, second_row = pair
            first.write_pair(second, ctx, A, b, row, second_row)
        for i, (c, A_rows, b_rows) in enumerate(self._contact_writes):
            if pair is None:
                c.write(ctx, A_rows, b_rows, None)
            f = dt - 1.0 / (inv if inv < (k := c.gain) else k)  # dt − 1 / min(K, 1/dt)
            if f != values[i]:
                factors[i] = values[i] = f
        for c, r0, r1 in self._other_eq_blocks:
            c.write(ctx, A[r0:r1], b[r0:r1], None)
        if self._in_solve:  # (1 − K dt) e of each contact at this tick's configuration, from b = −K e, K = min(K, 1/dt)
            self._contact_expected = [b[r0:r1] * factors[i] for i, (c, r0, r1) in enumerate(self._contact_blocks)]
        for c, r0, r1 in self._in_blocks:
            c.write(ctx, C[r0:r1], l[r0:r1], u[r0:r1])
        if boxes:
            self._intersect_boxes(config, dt)
        return self._qp

    def _kernel_box(self, config: Configuration, dt: float) -> KernelBox:
        """The compiled tick's box argument for the current layout: its constant boxes and one JointPositionLimit
        after them, else ``NO_KERNEL_BOX`` (lb, ub assembled here)."""
        if self._const_prefix is None:
            self._intersect_boxes(config, dt)  # the constant boxes' intersection, once per layout
        rest = self._box_sel[self._const_prefix:]
        if self._const_prefix and len(rest) == 1 and type(rest[0][0]) is JointPositionLimit:
            return KernelBox(*rest[0][0].packed(), self._const_box)
        return NO_KERNEL_BOX

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
            if first:  # the first box meets ±inf only
                lb[sel], ub[sel] = c.compute(config, dt)
                first = False
            else:
                c.intersect_into(config, dt, lb, ub)  # in place: the box's own intersection (compiled where it has one)
            if record is not None:
                record.append((c.name, c.indices, np.array(lb[sel]), np.array(ub[sel])))


class SoftRows:
    """The stacked rows of one task list: ``J`` (mt, nv), ``e`` (mt,), ``rowp`` (3, mt) = gain, weight, feed-forward
    per row; ``wJ``, ``wr``: a strict level's rows with the weights applied; ``rows``, per task with the generic cost,
    (task, e, J, weight, gain, feed-forward views, index, plain velocity target); the posture task (``posture``, its
    weights ``pw`` and velocity indices ``prow``); the tasks with their own cost (``own``). ``own_costs`` (the soft
    level): one plain :class:`~wbc.tasks.PostureTask` becomes the diagonal term of
    :func:`wbc.formulations.velocity_kernel.form_qp` and the tasks with their own ``add_cost`` (added to H, g after it)
    are listed apart; else (a strict level) every task is a stack of rows (its own velocity target: :meth:`gather`)."""

    def __init__(self, tasks: list[Task], nv: int, own_costs: bool):
        self.tasks = list(tasks)
        dense, self.own, self.posture = [], [], None
        row = 0
        for task in tasks:
            if not own_costs or type(task).add_cost is Task.add_cost:
                dense.append((task, row, row + task.dim, type(task).velocity_target is Task.velocity_target))
                row += task.dim
            elif type(task) is PostureTask and self.posture is None:
                self.posture = task
            else:
                self.own.append(task)
        prow = np.zeros(0, np.int64) if self.posture is None else np.asarray(self.posture.rows, np.int64)
        self.fb, self.ib = rows_pack(row, nv, prow)  # what the compiled tick reads (kinematic_tick_packed)
        self.J, self.e, self.rowp, self.pw, self.prow, _ = task_rows.py_func(self.fb, self.ib)  # numpy views
        self.wJ = np.zeros((row, nv))  # a strict level's rows with the weights applied (weighted_rows)
        self.wr = np.zeros(row)
        self.rows = []
        for k, (task, r0, r1, plain) in enumerate(dense):
            self.rows.append((task, self.e[r0:r1], self.J[r0:r1], self.rowp[1, r0:r1], self.rowp[0, r0:r1],
                              self.rowp[2, r0:r1], k, plain))
            if not plain:  # v* written as the error: K = −1, ė* = 0
                self.rowp[0, r0:r1] = -1.0
        self.gains = [None] * len(dense)
        self.has_ff = [True] * len(dense)
        self.no_diff = np.zeros(nv)

    def gather(self, config: Configuration) -> None:
        """Write each task's rows at ``config`` into its stacked buffers (``compute_into``: e, J) with, per row, its
        gain, weight and feed-forward (a task's ``weight`` becomes a view of the stacked weights: in-place changes are
        seen, a new array assigned is copied in); a task with its own velocity target writes v* as e (K = −1)."""
        gains, has_ff = self.gains, self.has_ff
        for task, e, J, w, gain_rows, ff_rows, k, plain in self.rows:
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
