"""Bounds on a sole's corner forces in the inverse-dynamics QP (eq. 8 of :mod:`wbc.formulations.acceleration`):
unilateral normal forces (the CoP inside the sole) while the contact is active, zero forces while it is not."""

from __future__ import annotations

import numpy as np

from wbc.constraints.base import IDConstraint
from wbc.constraints.sole_contact import SoleContact

__all__ = ["Unilaterality"]


class Unilaterality(IDConstraint):
    """Bounds on a sole's 12 corner forces (eq. 8; N): f_min ≤ f_z ≤ f_max and tangential free while active —
    the unilateral contact, which keeps the CoP inside the sole rectangle (:mod:`wbc.constraints.sole_contact`) —, all
    zero while inactive."""

    kind = "bounds"
    dim = 12

    def __init__(self, contact: SoleContact, offset: int):
        self.contact = contact
        self.name = f"unilaterality:{contact.name}"
        self.indices = np.arange(offset, offset + 12)
        #: :meth:`key` of the bounds last written by the formulation (None: never).
        self.written: tuple | None = None

    def key(self) -> tuple:
        """What the bounds depend on: (active, f_min, f_max) — rewritten only when it changes."""
        c = self.contact
        return (c.active, c.f_min, c.f_max)

    def write(self, ctx, _, lb, ub):
        c = self.contact
        if c.active:
            lb.fill(-np.inf)
            ub.fill(np.inf)
            lb[2::3], ub[2::3] = c.normal_force_bounds  # min(f_min, f_max) ≤ f_z ≤ f_max: never crossed
        else:
            lb.fill(0.0)
            ub.fill(0.0)
