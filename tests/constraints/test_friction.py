"""The friction pyramid of a sole's corner forces (wbc.constraints.friction): its rows hold exactly the forces inside
the pyramid inscribed in the cone of μ (|f_x|, |f_y| ≤ μ/√2 f_z, closed form), at the contact's columns of x;
free while the contact is inactive; rewritten when μ changes."""

from __future__ import annotations

import math

import numpy as np

from wbc.constraints.friction import FrictionPyramid
from wbc.constraints.sole_contact import SoleContact


def test_rows_hold_exactly_the_inscribed_pyramid(robots):
    robot = robots("talos")
    contact = SoleContact(robot, robot.left_sole, mu=0.6)
    offset, n = 40, 60
    con = FrictionPyramid(contact, offset)
    C, l, u = np.full((16, n), 7.0), np.zeros(16), np.zeros(16)  # stale numbers: write must overwrite them
    con.write(None, C, l, u)
    assert not C[:, :offset].any() and not C[:, offset + 12:].any() and (l == -np.inf).all() and (u == 0).all()
    rng = np.random.default_rng(3)
    for _ in range(200):
        f = rng.uniform(-1.0, 1.0, 12) * np.tile([1.0, 1.0, 0.0], 4) + np.tile([0.0, 0.0, 1.0], 4)
        x = np.zeros(n)
        x[offset:offset + 12] = f
        inside = all(max(abs(f[3 * k]), abs(f[3 * k + 1])) <= 0.6 / math.sqrt(2.0) * f[3 * k + 2] for k in range(4))
        assert (C @ x <= u).all() == inside
    contact.mu = 1.2
    con.write(None, C, l, u)
    x = np.zeros(n)
    x[offset:offset + 12] = np.tile([0.8, -0.8, 1.0], 4)  # inside for μ = 1.2 (0.85), outside for μ = 0.6
    assert (C @ x <= u).all()
    contact.active = False
    con.write(None, C, l, u)
    assert (u == np.inf).all()
