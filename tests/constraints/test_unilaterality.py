"""Bounds on a sole's corner forces (wbc.constraints.unilaterality): f_min ≤ f_z ≤ f_max and free tangential forces
while the contact is active, all forces zero while it is inactive."""

from __future__ import annotations

import numpy as np

from wbc.constraints.sole_contact import SoleContact
from wbc.constraints.unilaterality import Unilaterality


def test_bounds_of_an_active_and_an_inactive_contact(robots):
    robot = robots("talos")
    contact = SoleContact(robot, robot.right_sole, f_min=5.0, f_max=900.0)
    con = Unilaterality(contact, 30)
    assert con.indices.tolist() == list(range(30, 42)) and con.kind == "bounds"
    lb, ub = np.zeros(12), np.zeros(12)
    con.write(None, None, lb, ub)
    assert (lb[2::3] == 5.0).all() and (ub[2::3] == 900.0).all()
    tangential = np.ones(12, bool)
    tangential[2::3] = False
    assert (lb[tangential] == -np.inf).all() and (ub[tangential] == np.inf).all()
    contact.active = False
    con.write(None, None, lb, ub)
    assert not lb.any() and not ub.any()
