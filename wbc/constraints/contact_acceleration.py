"""Contact rows of the inverse-dynamics QP: an active sole does not accelerate (eq. 5 of
:mod:`wbc.formulations.acceleration`), J_k v̇ = −J̇_k v − K_d J_k v − K_p e_k, and the treatment of stacked contact rows
that are (nearly) dependent (two flat soles on legs without hip yaw).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from wbc.compiled import FASTMATH
from wbc.constraints.base import IDConstraint
from wbc.constraints.sole_contact import SoleContact

__all__ = ["ContactAcceleration", "contact_acceleration_rows", "DEPENDENT_CONTACT_RATIO", "consistent_contact_rhs", "independent_contact_rows"]


class ContactAcceleration(IDConstraint):
    """The sole of an active contact does not accelerate (eq. 5; m/s², rad/s², LOCAL). No rows while inactive."""

    kind = "equality"
    dim = 6

    def __init__(self, contact: SoleContact):
        self.contact = contact
        self.name = f"contact:{contact.name}"

    @property
    def enabled(self) -> bool:
        return self.contact.active

    def write(self, ctx, A, b, _):
        c = self.contact
        J = ctx.jacobians[c.name]
        offset = ctx.offsets.get(c.name)
        if offset is None:
            offset = c.acceleration_offset(ctx.state)
        contact_acceleration_rows(J, offset, float(c.kd), ctx.state.v, A, b, 0)


@nb.njit(cache=True, nogil=True, fastmath=FASTMATH, inline="always")
def contact_acceleration_rows(J, offset, kd, v, A, b, row):
    """Rows ``row .. row + 5`` of A x = b: eq. 5 of an active contact, J v̇ = offset − K_d J v (force columns zero;
    offset = −J̇v − K_p e, m/s², rad/s², LOCAL).

    Args:
        J (6, nv): LOCAL sole Jacobian. offset (6,). kd: K_d (1/s). v (nv,). A (≥ row + 6, n), b: out.
    """
    nv = J.shape[1]
    n = A.shape[1]
    for r in range(6):
        s = 0.0
        for j in range(nv):
            s += J[r, j] * v[j]
        for j in range(nv):
            A[row + r, j] = J[r, j]
        for j in range(nv, n):
            A[row + r, j] = 0.0
        b[row + r] = offset[r] - kd * s


#: σ/σ_max below which a direction of the stacked rows of the active contacts counts as dependent
#: (:func:`consistent_contact_rhs`): it lies between the double support of 6-DoF legs (well conditioned) and that of
#: legs without hip yaw, whose relative foot yaw is rank deficient (the ratios per robot: ``benchmarks/README.md``).
DEPENDENT_CONTACT_RATIO = 1e-2


def consistent_contact_rhs(J: np.ndarray, b: np.ndarray, ratio: float = DEPENDENT_CONTACT_RATIO) -> int:
    """Make the stacked contact equalities ``J v̇ = b`` (eq. 5 of every active contact) consistent, in place.

    Two flat soles of a robot whose legs cannot yaw the foot (humanoid15: 5-DoF legs) fix the relative yaw of the
    feet twice: the 12 rows of the two soles have rank 11 at a flat stance (σ_min / σ_max = 8e-19) and stay
    nearly dependent while walking (≤ 5e-3). The component of ``b`` along such a direction u (−uᵀJ̇v − K_d uᵀJv:
    a relative foot yaw the legs can only produce through second-order roll–pitch coupling, non-zero after a
    touch-down with some foot velocity) either makes the equalities infeasible (exact dependence: the controller
    fell back to the relaxed QP with kN forces and the robot fell) or demands an acceleration of order |uᵀb|/σ.
    Here ``b`` is replaced by its projection onto the span of the left singular vectors of ``J`` whose singular
    value is ≥ ``ratio`` σ_max, the least-squares consistent right-hand side of the well-conditioned rows; the rows
    themselves are kept. An exactly dependent row with a consistent right-hand side is then satisfied by the
    solution of the others; a nearly dependent one (σ > 0) is not: it still forbids the motion along its right
    singular vector, which is why the ID QP drops such directions instead (:func:`independent_contact_rows`).
    Singular vectors from the eigen-decomposition of the (m, m) Gram matrix J Jᵀ (σ² = λ).

    Args:
        J: (m, nv) stacked contact rows. b: (m,) right-hand side, modified in place.
        ratio: relative singular-value threshold (dimensionless, in [0, 1)).

    Returns:
        The number of directions projected out (0: ``b`` unchanged).
    """
    lam, U = np.linalg.eigh(J @ J.T)  # ascending
    keep = lam >= (ratio * ratio) * lam[-1]
    n_out = int(J.shape[0] - np.count_nonzero(keep))
    if n_out:
        Uk = U[:, keep]
        b[:] = Uk @ (Uk.T @ b)
    return n_out


def independent_contact_rows(A: np.ndarray, b: np.ndarray, ratio: float = DEPENDENT_CONTACT_RATIO) -> int:
    """Replace the stacked contact equalities ``A x = b`` (eq. 5 of every active contact) by their well-conditioned
    directions, in place: the rows of ``A`` and ``b`` are rotated onto the left singular vectors u_i of ``A`` with
    σ_i ≥ ``ratio`` σ_max, ``u_iᵀ A x = u_iᵀ b``, written in the first r rows; the other m − r rows (the dependent
    directions) are dropped by the caller.

    Keeping a nearly dependent row with a consistent right-hand side (:func:`consistent_contact_rhs`) still forbids
    the motion along its right singular vector v: the row reads σ vᵀv̇ = 0, a hard constraint whatever σ is. For
    two flat soles on 5-DoF legs (humanoid15, no hip yaw) that motion is a pitch and roll of the pelvis over the
    fixed feet (σ / σ_max 1e-4–5e-3 in double support: the second-order relative foot yaw it produces), so the
    QP could not command any pelvis orientation correction while standing, and a disturbance the plant followed
    (soft contacts, model errors) tipped the pelvis past 30°. Dropping the direction leaves the pelvis free along
    v, at the cost of a relative foot yaw acceleration ≤ ``ratio`` σ_max |vᵀv̇| that the contact friction resists.
    Directions from the eigen-decomposition of the (m, m) Gram matrix A Aᵀ (σ² = λ), as in
    :func:`consistent_contact_rhs`.

    Args:
        A: (m, n) stacked contact rows (columns beyond the accelerations, e.g. zero force columns, allowed),
            modified in place. b: (m,) right-hand side, modified in place.
        ratio: relative singular-value threshold (dimensionless, in [0, 1)).

    Returns:
        r, the number of rows kept (m: ``A`` and ``b`` unchanged).
    """
    lam, U = np.linalg.eigh(A @ A.T)  # ascending
    keep = lam >= (ratio * ratio) * lam[-1]
    r = int(np.count_nonzero(keep))
    if r < A.shape[0]:
        Uk = U[:, keep]
        rows, rhs = Uk.T @ A, Uk.T @ b
        A[:r], b[:r] = rows, rhs
    return r
