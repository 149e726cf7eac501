"""Contact switching: ramps are linear and end in a release / an unbounded contact; touch-down from the state."""

import math

import numpy as np
import pytest

from wbc.dynamics import IDBalanceController
from wbc.dynamics.contact_switching import ContactSwitcher
from wbc.exceptions import InvalidInputError
from wbc.robot import load_robot


@pytest.fixture(scope="module")
def robot():
    return load_robot("talos")


def _unloading_right(robot, **options):
    """(balance controller, q, v, switcher with ``options``) of a Talos standing at its reference posture whose
    right sole started unloading at t = 0."""
    c = IDBalanceController(robot)
    q = robot.q_ref.copy()
    v = np.zeros(robot.nv)
    c.reset(q, v)
    sw = ContactSwitcher(c, ramp_time=0.04, **options)
    sw.unload("right", 0.0)
    return c, q, v, sw


def test_ramp_out_release_touchdown_ramp_in(robot):
    c, q, v, sw = _unloading_right(robot, full_force=1000.0)
    sw.update(0.02, q, v)
    assert c.contacts["right"].f_max * 4 == pytest.approx(500.0)  # half way down the linear ramp
    assert c.contacts["right"].active
    sw.update(0.04, q, v)
    assert sw.phase("right") == "swing" and not c.contacts["right"].active
    assert c.feet["right"] in c.qp.tasks
    # Armed at q_ref (sole on the floor, at rest): touch-down is detected at once from the state.
    sw.arm("right")
    q_up = q.copy()
    q_up[2] += 0.05  # whole robot 5 cm up: sole above the threshold, no touch-down
    sw.update(0.05, q_up, v)
    assert sw.phase("right") == "swing"
    v_up = v.copy()
    v_up[2] = 0.5  # on the floor but rising: not a touch-down
    sw.update(0.052, q, v_up)
    assert sw.phase("right") == "swing"
    sw.update(0.054, q, v)
    assert sw.phase("right") == "loading" and c.contacts["right"].active
    assert c.feet["right"] not in c.qp.tasks
    assert c.contacts["right"].f_max == pytest.approx(0.0)
    sw.update(0.074, q, v)
    assert c.contacts["right"].f_max * 4 == pytest.approx(500.0)
    sw.update(0.1, q, v)
    assert sw.phase("right") == "stance" and math.isinf(c.contacts["right"].f_max)
    assert [e[2] for e in sw.events] == ["unload", "release", "touchdown", "loaded"]


def test_kinematics_of_the_caller_read_as_its_own_forward_pass(robot):
    """update(..., kinematics=data) with a Data on which pin.centerOfMass(q, v) ran (its forward pass) reads the
    armed sole's height and vertical speed bit for bit as the switcher's own forward pass, and detects the same
    touch-down; the Data of the caller is then the one sole_height_velocity reads."""
    import pinocchio as pin

    rng = np.random.default_rng(3)
    model = robot.model
    for trial in range(5):
        _, q, v, own = _unloading_right(robot, full_force=1000.0)
        _, _, _, shared = _unloading_right(robot, full_force=1000.0)
        q = pin.integrate(model, q, rng.normal(0.0, 0.02, robot.nv))
        v = rng.normal(0.0, 0.05, robot.nv)
        q[2] += 0.002 * trial  # the sole from the floor to 8 mm above it: both sides of the threshold
        for sw in (own, shared):
            sw.update(0.04, q, v)
            sw.arm("right")
        data = model.createData()
        pin.centerOfMass(model, data, q, v)
        own.update(0.042, q, v)
        shared.update(0.042, q, v, None, data)
        assert shared.sole_height_velocity("right") == own.sole_height_velocity("right")
        assert shared.phase("right") == own.phase("right")
        assert shared.events == own.events


def test_bad_input(robot):
    c = IDBalanceController(robot)
    with pytest.raises(InvalidInputError, match="ramp_time"):
        ContactSwitcher(c, ramp_time=0.0)
    sw = ContactSwitcher(c)
    with pytest.raises(InvalidInputError, match="side"):
        sw.unload("middle", 0.0)


def test_touchdown_from_measured_force(robot):
    """A sole the state puts 4 mm up (as a 0.9° tilt error of an estimated base does over 0.25 m) touches down when
    the measured normal force reaches ``touchdown_force``, not before, and not from 5 cm up (the height gate)."""
    c, q, v, sw = _unloading_right(robot, touchdown_force=40.0)
    sw.update(0.04, q, v)
    sw.arm("right")
    q_4mm, q_5cm = q.copy(), q.copy()
    q_4mm[2] += 0.004
    q_5cm[2] += 0.05
    sw.update(0.042, q_4mm, v)  # no forces given: the state test alone, 4 mm > 3 mm
    assert sw.phase("right") == "swing"
    sw.update(0.044, q_4mm, v, np.array([800.0, 39.0]))  # below the threshold
    assert sw.phase("right") == "swing"
    sw.update(0.046, q_5cm, v, np.array([800.0, 60.0]))  # a force read 5 cm up is the foot's inertia, not contact
    assert sw.phase("right") == "swing"
    sw.update(0.048, q_4mm, v, np.array([800.0, 40.0]))
    assert sw.phase("right") == "loading" and c.contacts["right"].active
    with pytest.raises(InvalidInputError, match="touchdown_force"):
        ContactSwitcher(c, touchdown_force=0.0)
    with pytest.raises(InvalidInputError, match="touchdown_force_height"):
        ContactSwitcher(c, touchdown_force=10.0, touchdown_force_height=0.001)


@pytest.mark.parametrize("confirm_when_due", [False, True])
def test_height_test_needs_a_load_before_the_planned_landing_only(robot, confirm_when_due):
    """With ``contact_force``, a sole the state puts 2 mm up (within the 3 mm test) and the F/T reading 0 N is still
    in the air before its planned landing time; from that time on the state test alone sets it down, unless
    ``confirm_when_due`` (blind walks). A load confirms it at any time."""
    c, q, v, sw = _unloading_right(robot, touchdown_force=200.0, contact_force=30.0,
                                   confirm_when_due=confirm_when_due)
    sw.update(0.04, q, v)
    sw.arm("right")
    q_2mm = q.copy()
    q_2mm[2] += 0.002
    unloaded = np.array([800.0, 0.0])
    sw.set_landing_due("right", False)
    sw.update(0.042, q_2mm, v, unloaded)
    assert sw.phase("right") == "swing"
    sw.set_landing_due("right", True)
    sw.update(0.044, q_2mm, v, unloaded)
    assert sw.phase("right") == ("swing" if confirm_when_due else "loading")
    if confirm_when_due:
        sw.update(0.046, q_2mm, v, np.array([800.0, 30.0]))
        assert sw.phase("right") == "loading"
    with pytest.raises(InvalidInputError, match="side"):
        sw.set_landing_due("middle", True)


def test_a_sole_set_down_without_its_load_waits_for_it(robot):
    """A sole set down after its planned landing by the state test while the F/T reads 0 N (hovering 2 mm up):
    the QP may plan at most 2 contact_force on it, however long the load takes; the ramp-in starts at the first
    reading >= contact_force, from that bound on (no force jump). Without measured forces, or without
    ``await_load`` (the default), nothing waits."""
    c, q, v, sw = _unloading_right(robot, full_force=1000.0, touchdown_force=200.0, contact_force=30.0,
                                   await_load=True)
    sw.update(0.04, q, v)
    sw.arm("right")
    q_2mm = q.copy()
    q_2mm[2] += 0.002
    sw.set_landing_due("right", True)
    sw.update(0.044, q_2mm, v, np.array([800.0, 0.0]))
    assert sw.phase("right") == "loading" and c.contacts["right"].active
    sw.update(0.046, q_2mm, v, np.array([800.0, 0.0]))
    assert c.contacts["right"].f_max * 4 == pytest.approx(60.0)
    sw.update(0.2, q_2mm, v, np.array([800.0, 29.0]))  # 156 ms later, still short of the load: no ramp
    assert sw.phase("right") == "loading" and c.contacts["right"].f_max * 4 == pytest.approx(60.0)
    sw.update(0.202, q, v, np.array([800.0, 31.0]))
    assert (0.202, "right", "load") in sw.events
    assert c.contacts["right"].f_max * 4 == pytest.approx(60.0)
    sw.update(0.212, q, v, np.array([800.0, 100.0]))  # 10 ms of a 40 ms ramp to 1000 N
    assert c.contacts["right"].f_max * 4 == pytest.approx(60.0 + 250.0)
    sw.update(0.202 + 0.04, q, v, np.array([800.0, 300.0]))
    assert sw.phase("right") == "stance" and math.isinf(c.contacts["right"].f_max)
    # the state test alone (no F/T given): set down and ramped as before
    c, q, v, sw = _unloading_right(robot, full_force=1000.0, touchdown_force=200.0, contact_force=30.0)
    sw.update(0.04, q, v)
    sw.arm("right")
    sw.set_landing_due("right", True)
    sw.update(0.044, q_2mm, v)
    sw.update(0.064, q_2mm, v)
    assert c.contacts["right"].f_max * 4 == pytest.approx(500.0)
    # without await_load: ramped at once, the F/T reading 0 N
    c, q, v, sw = _unloading_right(robot, full_force=1000.0, touchdown_force=200.0, contact_force=30.0)
    sw.update(0.04, q, v)
    sw.arm("right")
    sw.set_landing_due("right", True)
    sw.update(0.044, q_2mm, v, np.array([800.0, 0.0]))
    sw.update(0.064, q_2mm, v, np.array([800.0, 0.0]))
    assert c.contacts["right"].f_max * 4 == pytest.approx(500.0)
def test_ramp_in_bound_never_below_the_measured_load(robot):
    """A sole that lands carrying part of the weight in the plant: the ramp-in bound is the larger of the linear
    ramp and the sole's measured normal force, so the QP never computes the leg's torques for less load than the
    sole carries; without measured forces the ramp alone."""
    c, q, v, sw = _unloading_right(robot, full_force=1000.0)
    sw.update(0.04, q, v)
    sw.arm("right")
    sw.update(0.042, q, v, np.array([300.0, 600.0]))  # height test: touch-down at t0 = 0.042 s
    assert sw.phase("right") == "loading"
    sw.update(0.046, q, v, np.array([300.0, 600.0]))  # ramp 1000 × 0.004 / 0.04 = 100 N < 600 N measured
    assert c.contacts["right"].f_max * 4 == pytest.approx(600.0)
    sw.update(0.062, q, v, np.array([880.0, 20.0]))  # ramp 500 N > 20 N measured
    assert c.contacts["right"].f_max * 4 == pytest.approx(500.0)
    sw.update(0.066, q, v)  # no measurement: ramp 600 N
    assert c.contacts["right"].f_max * 4 == pytest.approx(600.0)
    sw.update(0.082, q, v, np.array([0.0, 900.0]))
    assert sw.phase("right") == "stance" and math.isinf(c.contacts["right"].f_max)


def test_partial_foothold_confines_the_qp_cop(robot):
    """SoleContact.set_support (partial foothold): Talos standing, the CoM asked to accelerate backwards at 0.6 m/s²
    (a CoP ahead of the CoM, at x = +65 mm in the left sole with the whole sole); with the left sole's contact cut to
    x ≤ −0.03 m (sole frame) the QP's corner forces of that sole, still carrying ≥ 100 N, put its CoP at
    x ≤ −0.03 m (+ 0.5 mm); with the whole sole again (reset_support) the first answer comes back."""
    c = IDBalanceController(robot)
    q, v = robot.q_ref.copy(), np.zeros(robot.nv)
    c.reset(q, v)
    com = c.state.com.copy()
    c.set_com_reference(com, np.zeros(3), np.array([-0.6, 0.0, 0.0]))
    left = c.contacts["left"]
    k = list(c.contacts).index("left")

    def cop_x():
        f = c.solve(q, v).forces[12 * k:12 * k + 12]
        assert f[2::3].sum() >= 100.0
        return float(left.cop(f)[0])

    full = cop_x()
    left.set_support(-1.0, -0.03, -1.0, 1.0)
    assert left.support[1] == -0.03 and left.corners[:, 0].max() == -0.03
    cut = cop_x()
    left.reset_support()
    assert cop_x() == pytest.approx(full, abs=1e-6)
    assert cut <= -0.03 + 5e-4 < full
    with pytest.raises(InvalidInputError):
        left.set_support(0.05, 0.04, -1.0, 1.0)
