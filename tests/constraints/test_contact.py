"""The contact constraint's gain: a finite number > 0, checked at construction and on assignment."""

from __future__ import annotations

import pytest


def test_contact_gain_must_be_positive(robots):
    from wbc.constraints import ContactConstraint
    from wbc.exceptions import InvalidInputError

    robot = robots("humanoid15")
    for bad in (0.0, -1.0, float("nan")):
        with pytest.raises(InvalidInputError, match="gain"):
            ContactConstraint(robot, robot.left_sole, gain=bad)
    contact = ContactConstraint(robot, robot.left_sole)
    for bad in (0.0, -5.0, float("inf"), "100", None, True):  # also on assignment
        with pytest.raises(InvalidInputError, match=r"contact gain must be a finite number > 0"):
            contact.gain = bad
    assert contact.gain == 100.0
    contact.gain = 50
    assert contact.gain == 50.0


@pytest.mark.parametrize("name", ["talos", "humanoid15"])
def test_contact_rows_are_the_frame_jacobian_and_the_scaled_log6(robots, name):
    """ContactConstraint.write (compiled log₆ of P⁻¹ oMf) and error_into against Pinocchio's LOCAL frame Jacobian and
    ``log6(P.actInv(oMf))``, at random configurations and placements, including a half-turn error (Pinocchio's)."""
    import numpy as np
    import pinocchio as pin

    from conftest import random_configuration
    from wbc.configuration import Configuration
    from wbc.constraints import ContactConstraint
    from wbc.constraints.base import KinematicContext

    robot = robots(name)
    rng = np.random.default_rng(3)
    config = Configuration(robot)
    contact = ContactConstraint(robot, robot.left_sole, gain=80.0)
    ctx = KinematicContext()
    A, b, err = np.empty((6, robot.nv)), np.empty(6), np.empty(6)
    for k in range(21):
        config.update(random_configuration(robot, rng))
        oMf = config.data.oMf[contact.frame_id]
        offset = pin.exp6(pin.Motion(rng.standard_normal(6) * 10.0 ** rng.uniform(-9, 0)))
        if k == 20:  # a half turn about x: Pinocchio's log6 is used there
            offset = pin.SE3(pin.exp3(np.array([np.pi - 1e-8, 0.0, 0.0])), np.zeros(3))
        contact.set_placement(oMf * offset)
        ctx.config, ctx.dt = config, 0.002
        contact.write(ctx, A, b)
        ref = pin.log6(contact.placement.actInv(oMf)).vector
        scale = max(1.0, np.abs(ref).max())
        assert np.array_equal(A, pin.getFrameJacobian(robot.model, config.data, contact.frame_id, pin.LOCAL))
        assert np.abs(b - (-80.0 * ref)).max() <= 1e-12 * 80.0 * scale
        contact.error_into(config.data, err)
        assert np.abs(err - ref).max() <= 1e-12 * scale
        assert np.array_equal(err, contact.compute_error(config)) or \
            np.abs(err - contact.compute_error(config)).max() <= 1e-12 * scale


@pytest.mark.parametrize("name", ["talos", "humanoid15"])
def test_two_contacts_written_in_one_call_are_each_contacts_rows(robots, name):
    """ContactConstraint.write_pair (both soles in one compiled call) writes the rows of the two contacts' own
    write bit for bit, where each lands in the stacked rows, including a half-turn error of either (Pinocchio's
    log6 then); rows of other blocks are left untouched."""
    import numpy as np
    import pinocchio as pin

    from conftest import random_configuration
    from wbc.configuration import Configuration
    from wbc.constraints import ContactConstraint
    from wbc.constraints.base import KinematicContext

    robot = robots(name)
    rng = np.random.default_rng(11)
    config = Configuration(robot)
    left = ContactConstraint(robot, robot.left_sole, gain=80.0)
    right = ContactConstraint(robot, robot.right_sole, gain=1e6)  # capped at 1/dt
    ctx = KinematicContext()
    half_turn = pin.SE3(pin.exp3(np.array([np.pi - 1e-8, 0.0, 0.0])), np.zeros(3))
    for k in range(12):
        config.update(random_configuration(robot, rng))
        for contact in (left, right):
            offset = pin.exp6(pin.Motion(rng.standard_normal(6) * 10.0 ** rng.uniform(-9, 0)))
            if (k, contact) in ((10, left), (11, right)):
                offset = half_turn
            contact.set_placement(config.data.oMf[contact.frame_id] * offset)
        ctx.config, ctx.dt = config, 0.002
        A, b = np.full((15, robot.nv), 7.0), np.full(15, 7.0)
        left.write_pair(right, ctx, A, b, 8, 1)
        ref_A, ref_b = np.empty((6, robot.nv)), np.empty(6)
        for contact, row in ((left, 8), (right, 1)):
            contact.write(ctx, ref_A, ref_b)
            assert np.array_equal(A[row:row + 6], ref_A) and np.array_equal(b[row:row + 6], ref_b)
        assert (A[[0, 7, 14]] == 7.0).all() and (b[[0, 7, 14]] == 7.0).all()
