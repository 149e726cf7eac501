"""The floating-base rows of the inverse-dynamics QP: the unactuated rows of the equations of motion (eq. 4 of
:mod:`wbc.formulations.acceleration`), M_u v̇ − (J_cᵀ)_u f = −h_u, and the contact-force columns J_cᵀ they and the
torque rows share. Written by one compiled body each, called by :meth:`FloatingBaseDynamics.write` (the general
assembly) and by the compiled tick (:func:`wbc.formulations.idkernel.id_assemble`) alike.
"""

from __future__ import annotations

import numba as nb

from wbc.compiled import FASTMATH
from wbc.constraints.base import IDConstraint

__all__ = ["FloatingBaseDynamics", "contact_force_columns", "floating_base_rows"]


class FloatingBaseDynamics(IDConstraint):
    """Unactuated rows of the equations of motion (eq. 4): M_u v̇ − (J_cᵀ)_u f = −h_u (N, N·m)."""

    name = "floating_base_dynamics"
    kind = "equality"
    dim = 6

    def write(self, ctx, A, b, _):
        floating_base_rows(ctx.state.M, ctx.state.h, ctx.JcT, A, b, 0)


@nb.njit(cache=True, nogil=True, fastmath=FASTMATH, inline="always")
def contact_force_columns(J, G, JcT, col):
    """Write one contact's columns of J_cᵀ: JcT[:, col:col + 12] = Jᵀ G (G = [I; [c_i]×] per corner, the
    corner-force → sole-wrench map: its zero entries are skipped).

    Args:
        J (6, nv): LOCAL sole Jacobian. G (6, 12): corner map. JcT (nv, ≥ col + 12): out. col: first column.
    """
    nv = J.shape[1]
    for i in range(nv):
        for j in range(12):
            JcT[i, col + j] = 0.0
    for k in range(6):
        Jk = J[k]
        for j in range(12):
            gk = G[k, j]
            if gk == 0.0:
                continue
            for i in range(nv):
                JcT[i, col + j] += Jk[i] * gk


@nb.njit(cache=True, nogil=True, fastmath=FASTMATH, inline="always")
def floating_base_rows(M, h, JcT, A, b, row):
    """Rows ``row .. row + 5`` of A x = b: eq. 4, M_u v̇ − (J_cᵀ)_u f = −h_u (N, N·m).

    Args:
        M (nv, nv), h (nv,): mass matrix and nonlinear effects. JcT (nv, n − nv): J_cᵀ. A (≥ row + 6, n),
        b (≥ row + 6,): out.
    """
    nv = M.shape[0]
    nf = A.shape[1] - nv
    for r in range(6):
        for j in range(nv):
            A[row + r, j] = M[r, j]
        for j in range(nf):
            A[row + r, nv + j] = -JcT[r, j]
        b[row + r] = -h[r]
