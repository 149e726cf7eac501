"""The output check of an inverse-dynamics solution (:class:`IDOutputCheck`), independent of the solver that produced
it: every entry finite; corner normal forces within their bounds (``unilaterality:<c>``, N); the friction pyramids
(``friction:<c>``, N); the torque limits (``torque_limits``, N·m); the floating-base rows of the equations of motion
(``floating_base_dynamics``, N, N·m). Each violation is measured in the constraint's units and compared with a
relative tolerance times the row's scale — max(1, |bound|) for a bound, max(1, |f_t| + μ/√2 |f_z|) for a friction
row (the size of its terms), the largest |h_u| entry for the dynamics rows — the scaling of
:meth:`wbc.solvers.base.QPBackend.scaled_violation`, so that a solution the solver accepted is not rejected for a
tolerance measured on another scale.
"""

from __future__ import annotations

import numpy as np

from wbc.compiled import CHECK_TYPES, specialise
from wbc.formulations.idkernel import IDOutputBuffers, output_inputs, output_violations

__all__ = ["IDOutputCheck", "nonfinite_references"]


class IDOutputCheck:
    """The output check (module docstring) of the solutions of one QP, with its preallocated buffers.

    Args:
        contacts: the QP's sole contacts. torque_limits: its :class:`~wbc.constraints.torque_limits.TorqueLimits`.
        force_lb, force_ub: (12 n_c,) views of the QP's bounds on the corner forces (written by the constraints).
    """

    def __init__(self, contacts, torque_limits, force_lb: np.ndarray, force_ub: np.ndarray):
        nc = len(contacts)
        self.contacts = contacts
        self.torque_limits = torque_limits
        self.force_lb, self.force_ub = force_lb, force_ub
        # output_violations' inputs: friction rows, activity, results; no limited joint (relaxed)
        self._friction, self._active = np.zeros((nc, 16, 12)), np.zeros(nc, np.bool_)
        self._out = np.zeros((2 * nc + 2, 2))
        self._no_joints = np.zeros(0, np.int64)
        self._buffers = IDOutputBuffers(force_lb, force_ub, self._friction, self._active, self._out)
        self._kernel = None  # violations' compiled call, specialised at its first call

    def violations(self, h: np.ndarray, sol, tol: float, relaxed: bool) -> list[tuple[str, float]] | None:
        """[(constraint name, violation in its units)] of the solution ``sol`` (an
        :class:`~wbc.formulations.acceleration.IDSolution`) at a state of nonlinear effects ``h`` (nv,), largest
        scaled first, at relative tolerance ``tol``; the torque limits skipped when ``relaxed``. [] when it passes;
        None when an entry of the solution is not finite."""
        friction, active, out = self._friction, self._active, self._out
        contacts = self.contacts
        for k, c in enumerate(contacts):  # copies: a contact's friction rows are rewritten in place when μ is set
            friction[k] = c.friction_matrix
            active[k] = c.active
        tl = self.torque_limits
        joints = self._no_joints if relaxed or not tl.joints.size else tl.joints
        args = (sol.dv, sol.forces, sol.tau, float(sol.dynamics_residual), h, joints, tl.limits, tol, self._buffers)
        kernel = self._kernel
        if kernel is None:  # for a solution and h of any strides (wbc.compiled.specialise; with kernel type checks on,
            # the dispatcher); the torque limits' arrays and the buffers are of fixed types
            dv, f, tau, h_any = output_inputs(8, 1, strided=True)  # (types only: any sizes)
            kernel = self._kernel = output_violations if CHECK_TYPES else specialise(
                output_violations, dv, f, tau, args[3], h_any, *args[5:])
        status = kernel(*args)
        if status <= 0:
            return None if status < 0 else []
        found = []  # (scaled, name, violation)
        for k, c in enumerate(contacts):
            if out[2 * k, 0] > tol:
                found.append((float(out[2 * k, 0]), f"unilaterality:{c.name}", float(out[2 * k, 1])))
            if out[2 * k + 1, 0] > tol:
                found.append((float(out[2 * k + 1, 0]), f"friction:{c.name}", float(out[2 * k + 1, 1])))
        nc = len(contacts)
        if out[2 * nc, 0] > tol:
            found.append((float(out[2 * nc, 0]), "torque_limits", float(out[2 * nc, 1])))
        if out[2 * nc + 1, 0] > tol:
            found.append((float(out[2 * nc + 1, 0]), "floating_base_dynamics", float(out[2 * nc + 1, 1])))
        found.sort(key=lambda item: -item[0])
        return [(name, v) for _, name, v in found]



def nonfinite_references(references) -> list[tuple[str, float]]:
    """``(task:<name>, nan)`` for every acceleration reference whose error (at the last assembly), weights or
    acceleration feed-forward are not finite — e.g. a target or weight array written in place with a NaN."""
    out = []
    for ref in references:
        ff = ref.feedforward_acceleration
        if not (np.isfinite(ref.last_error).all() and np.isfinite(ref.weight).all()
                and (ff is None or np.isfinite(ff).all())):
            out.append((f"task:{ref.name}", float("nan")))
    return out
