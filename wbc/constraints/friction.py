"""The friction pyramid of a sole's corner forces in the inverse-dynamics QP (eq. 7 of
:mod:`wbc.formulations.acceleration`)."""

from __future__ import annotations

import numpy as np

from wbc.constraints.base import IDConstraint
from wbc.constraints.sole_contact import SoleContact

__all__ = ["FrictionPyramid"]


class FrictionPyramid(IDConstraint):
    """Inscribed friction pyramid of a sole's 4 corner forces (eq. 7; N): ``friction_matrix @ f_k ≤ 0`` while the
    contact is active; free rows (−inf ≤ · ≤ inf) while it is inactive, where its bounds already hold f_k = 0 (the
    16 rows 0 ≤ 0 would be always active and dependent on those bounds: a degenerate set on which DAQP's dual
    active-set method reported feasible single-support problems infeasible). Constant between changes of the
    contact's μ or activity: the formulation rewrites it when :meth:`key` changes. ``offset`` is the first force
    variable of the contact in x."""

    kind = "inequality"
    dim = 16
    constant = True

    def __init__(self, contact: SoleContact, offset: int):
        self.contact = contact
        self.name = f"friction:{contact.name}"
        self.offset = int(offset)
        #: :meth:`key` of the rows last written by the formulation (None: never).
        self.written: tuple | None = None

    def key(self) -> tuple:
        """What the rows depend on: the contact's (μ, active)."""
        return (self.contact.mu, self.contact.active)

    def write(self, ctx, C, l, u):
        C[:] = 0.0
        C[:, self.offset:self.offset + 12] = self.contact.friction_matrix
        l[:] = -np.inf
        u[:] = 0.0 if self.contact.active else np.inf
