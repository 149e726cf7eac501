"""Solve core of the kinematic controller: zero-width joint ranges treated as locked joints, no latching after a
failed tick, soles held on ok ticks (second-order contact correction, dependent contact rows, the safe command of a
failed tick), and the fuzz ticks that once failed or held."""

from __future__ import annotations

import math

import copy

import numpy as np
import pytest
import scipy.optimize

from conftest import standing_controller
from wbc.configuration import Configuration

DT = 0.002


def test_zero_width_velocity_ranges_are_locked_and_ticks_solve(robots):
    """humanoid15 with the velocity limit of 6 joints set to 0 and both knees' position ranges of zero width
    (the 5e-7 bound crossing that failed every tick): reported once as locked (a warning and
    ``locked_joints``), every tick of a CoM shift is ok, the locked joints do not move, the CoM moves."""
    robot = copy.copy(robots("humanoid15"))
    robot.model = robot.model.copy()
    arm = [j for j in range(2, robot.model.njoints)][-6:]
    for j in arm:
        robot.model.velocityLimit[robot.model.joints[j].idx_v] = 0.0
    legs = [j for j in range(2, robot.model.njoints) if "knee" in robot.model.names[j]]
    for j in legs:  # zero-width position range at the reference posture
        iq = robot.model.joints[j].idx_q
        robot.model.lowerPositionLimit[iq] = robot.model.upperPositionLimit[iq] = robot.q_ref[iq]
    locked_names = {robot.model.names[j] for j in arm + legs}
    assert legs
    config = Configuration(robot)
    with pytest.warns(UserWarning, match="locked"):
        ctrl, com = standing_controller(robot, config)
    assert set(ctrl.locked_joints) == locked_names
    q0 = config.q.copy()
    c0 = config.com.copy()
    com.set_target(c0 + np.array([0.02, 0.01, -0.01]))
    for _ in range(100):
        res = ctrl.solve(config, DT)
        assert res.ok, res.message
        assert res.consecutive_failures == 0
        config.update(config.integrate(res.v, DT))
    for j in arm + legs:
        iq = robot.model.joints[j].idx_q
        assert config.q[iq] == q0[iq]
    assert np.linalg.norm(config.com - c0) > 5e-3


def test_stance_soles_hold_on_ok_ticks_g1(robots):
    """G1 (velocity limits up to 37 rad/s) with a wrist target up to 1 m away at gain 1000: without the trust
    region a stance sole moved 2.7 mm in one ok tick (benchmarks/sole_drift.py). Measured here independently
    (sole position from forward kinematics before/after pin.integrate): every ok tick moves each sole ≤ 0.1 mm
    (drift ≤ 0.05 mm plus the drift correction K e dt), and the soles end ≤ 1 mm from their contact placement."""
    from wbc.tasks import FrameTask

    robot = robots("g1")
    rng = np.random.default_rng(3)
    config = Configuration(robot)
    ctrl, com = standing_controller(robot, config)
    ctrl.sole_drift_tolerance = 5e-5
    contacts = ctrl.constraints[:2]
    hand = FrameTask(robot, "left_wrist_roll_joint", gain=1000.0, position_weight=100.0, name="hand")
    ctrl.add_task(hand)
    n_ok = 0
    for k in range(150):
        if k % 50 == 0:
            target = config.frame_placement(hand.frame_id).copy()
            target.translation += rng.uniform(-1.0, 1.0, 3)
            hand.set_target(target)
        before = [config.frame_placement(c.frame_id).translation.copy() for c in contacts]
        res = ctrl.solve(config, DT)
        config.update(config.integrate(res.v, DT))
        if res.ok:
            n_ok += 1
            for c, p0 in zip(contacts, before):
                assert np.linalg.norm(config.frame_placement(c.frame_id).translation - p0) <= 1e-4
    assert n_ok >= 140
    for c in contacts:
        assert np.linalg.norm(config.frame_placement(c.frame_id).translation - c.placement.translation) <= 1e-3


def _g1_reach_run(robots, **controller_options):
    """G1 standing, a wrist target up to 1 m away at gain 1000 (new target every 50 ticks), 150 ticks. Returns
    (ok ticks, largest sole displacement over one ok tick (m), largest sole offset from its contact placement
    (m), final offset (m)) measured by forward kinematics of the integrated configuration (independent of the
    controller's own drift estimate)."""
    from wbc.controllers.kinematic import KinematicController
    from wbc.tasks import FrameTask

    robot = robots("g1")
    rng = np.random.default_rng(3)
    config = Configuration(robot)
    base, com = standing_controller(robot, config)
    ctrl = KinematicController(robot, base.tasks, base.constraints, **controller_options)
    contacts = ctrl.constraints[:2]
    hand = FrameTask(robot, "left_wrist_roll_joint", gain=1000.0, position_weight=100.0, name="hand")
    ctrl.add_task(hand)
    n_ok, moved, offset = 0, 0.0, 0.0
    for k in range(150):
        if k % 50 == 0:
            target = config.frame_placement(hand.frame_id).copy()
            target.translation += rng.uniform(-1.0, 1.0, 3)
            hand.set_target(target)
        before = [config.frame_placement(c.frame_id).translation.copy() for c in contacts]
        res = ctrl.solve(config, DT)
        config.update(config.integrate(res.v, DT))
        if res.ok:
            n_ok += 1
            for c, p0 in zip(contacts, before):
                p = config.frame_placement(c.frame_id).translation
                moved = max(moved, float(np.linalg.norm(p - p0)))
                offset = max(offset, float(np.linalg.norm(p - c.placement.translation)))
    final = max(float(np.linalg.norm(config.frame_placement(c.frame_id).translation - c.placement.translation))
                for c in contacts)
    return n_ok, moved, offset, final


def test_second_order_contact_correction_holds_soles_without_trust_region(robots):
    """The contact rows hold the sole to first order only: with the correction and the trust region both off a
    stance sole moves more than 0.05 mm in an ok tick (measured 2.7 mm earlier). With the second-order
    correction alone (trust region off) every tick is ok, each sole moves ≤ 0.05 mm per tick and stays ≤ 1 mm
    from its contact placement."""
    n_ok, moved, offset, _ = _g1_reach_run(robots, contact_correction=0.0, sole_drift_tolerance=None)
    print(f"\nno correction: ok {n_ok}/150, max displacement per tick {1e3 * moved:.4f} mm")
    assert moved > 5e-5
    n_ok, moved, offset, final = _g1_reach_run(robots, sole_drift_tolerance=None)
    print(f"correction: ok {n_ok}/150, max displacement per tick {1e3 * moved:.4f} mm, max offset "
          f"{1e3 * offset:.4f} mm, final {1e3 * final:.4f} mm")
    assert n_ok == 150
    assert moved <= 5e-5
    assert offset <= 1e-3


def test_fuzz_seed_1328_feasible_tick_solves_and_does_not_hold(robots):
    """The fuzz state that failed 10 ticks in a row (seed 1328, episode 14, tick 40: G1, CoM gain 1758, a wrist
    target 1e6 m away at gain 531 and weight 270, so |g| = 1.3e11): every solver answered 3.2e-5 rad/s past a
    32 rad/s velocity bound, the least-squares polish could not hold the 12 contact rows with the 21 free
    entries (rank 11), the safe command failed the same way and the robot held (v = 0) with the state unchanged.
    An independent LP (scipy HiGHS, tolerance 1e-9) finds the hard set feasible; the tick must be ok, within the
    velocity limits (model, 1e-9) and move each sole ≤ 0.05 mm (forward kinematics)."""
    from wbc.tasks import FrameTask

    robot = robots("g1")
    config = Configuration(robot)  # episode start: the reference posture
    ctrl, com = standing_controller(robot, config)
    com.gain, com.weight = 1758.1889846507397, 0.10829436327180514
    com.set_target(np.array([0.6629961487879527, 0.2704955473603578, 0.7615997946254517]))
    for contact, gain in zip(ctrl.constraints[:2], (247.8717747952035, 3.6010787841248466)):
        contact.gain = gain
    hand = FrameTask(robot, "left_wrist_roll_joint", gain=530.6302744760818, position_weight=270.4792155328829,
                     orientation_weight=0.0, name="hand")
    target = config.frame_placement(hand.frame_id).copy()
    target.translation = np.array([560443.6800666036, 322084.2593146328, -762996.4315212069])
    hand.set_target(target)
    ctrl.add_task(hand)
    q = np.array([
        5.4277182626974452e-01, 9.5441949758798217e-02, 3.5216375378062642e-01, 8.8606362790079080e-04,
        9.2653362131231287e-01, 2.1811672013676915e-03, 3.7620460653582993e-01, -1.3923457994984909e+00,
        -1.8712088577994423e-01, -1.9034533211444898e-01, -8.7266998999999873e-02, -8.7266999899999997e-01,
        2.6141302300484620e-01, -1.3922981656035358e+00, -1.8739103984377214e-01, -1.9061744172850226e-01,
        -8.7266998999999984e-02, -8.7266999899999975e-01, 2.6179999899999989e-01, -5.1199996614708065e-01,
        2.4000000005960515e-01, -2.4000000000000080e-01, -2.8119999999999989e+00, 1.0880000121641313e+00,
        -1.4799999630050487e-01, 1.1919999833475119e+00, -8.9882755690737809e-02, -5.2480550228124623e-01,
        1.8320664193543160e-01, 1.2662259616135028e+00, -5.4827628364942205e-01, 9.1091772552356964e-01,
        1.0331456236114704e+00, -3.7428045235001137e-02, 8.5424112747164591e-02, 8.1679212223381606e-02])
    config.update(q)
    _, _, A, b, _, _, _, lb, ub = ctrl.assemble(config, DT)
    lp = scipy.optimize.linprog(np.zeros(robot.model.nv), A_eq=A, b_eq=b, method="highs",
                                bounds=[(lo if np.isfinite(lo) else None, hi if np.isfinite(hi) else None)
                                        for lo, hi in zip(lb, ub)],
                                options={"primal_feasibility_tolerance": 1e-9})
    assert lp.status == 0  # the independent solver: feasible
    soles = [config.frame_placement(c.frame_id).translation.copy() for c in ctrl.constraints[:2]]
    for k in range(3):  # and it stays solved (no hold, no latch)
        res = ctrl.solve(config, DT)
        assert res.ok and res.fallback == "" and res.consecutive_failures == 0, res.message
        vmax = robot.model.velocityLimit[6:]
        assert np.all(np.abs(res.v[6:]) <= vmax + 1e-9)
        config.update(config.integrate(res.v, DT))
        for c, p0 in zip(ctrl.constraints[:2], soles):
            p = config.frame_placement(c.frame_id).translation
            assert np.linalg.norm(p - p0) <= 5e-5 * (k + 1)


def _commanded(contact, oMf_before):
    """Independent oracle of where the contact row J v = −K e sends a sole over one tick (Pinocchio):
    placement · exp((1 − K dt) e), e = log(placement⁻¹ · oMf) before the tick."""
    import pinocchio as pin

    e = pin.log6(contact.placement.actInv(oMf_before)).vector
    return contact.placement * pin.exp6(e * (1.0 - min(contact.gain, 1.0 / DT) * DT))


def test_fuzz_seed_1003_dependent_contact_rows_keep_soles_on_ok_ticks(robots):
    """Fuzz seed 1003, episode 41 (humanoid15, CoM gain 6.5e4, torso target 5 cm away at gain 1940): the two
    flat feet fix the base yaw twice (contact rows of rank 11 < 12); the feet's second-order drifts differ in
    that direction, the corrected right-hand sides contradicted each other, the correction was dropped and the
    soles slid ~0.03 mm on every ok tick, 1.21 mm from their placement after 50 ok ticks. Measured here by
    forward kinematics: every tick ok, each sole ≤ 0.05 mm from where its contact row sent it, ≤ 1 mm (in fact
    far less: 0.1 mm here) from its placement."""
    from wbc.tasks import FrameTask

    robot = robots("humanoid15")
    config = Configuration(robot)
    ctrl, com = standing_controller(robot, config)
    com.gain, com.weight = 65114.84788974869, 0.03530437186521772
    com.set_target(np.array([0.0217239036447486, 0.02703371463154508, 0.7088377814588085]))
    contacts = ctrl.constraints[:2]
    for contact, gain in zip(contacts, (2.8128763610069947, 52.14519612727255)):
        contact.gain = gain
    hand = FrameTask(robot, robot.torso, gain=1940.1131435694, position_weight=4.980474059710353,
                     orientation_weight=0.0, name="hand")
    target = config.frame_placement(hand.frame_id).copy()
    target.translation = np.array([-0.06905025071075976, 0.02101008456714527, 1.0022896264256023])
    hand.set_target(target)
    ctrl.add_task(hand)
    worst_drift = worst_offset = 0.0
    for _ in range(50):
        before = [config.frame_placement(c.frame_id).copy() for c in contacts]
        res = ctrl.solve(config, DT)
        assert res.ok, res.message
        config.update(config.integrate(res.v, DT))
        for c, oMf in zip(contacts, before):
            p = config.frame_placement(c.frame_id).translation
            worst_drift = max(worst_drift, np.linalg.norm(p - _commanded(c, oMf).translation))
            worst_offset = max(worst_offset, np.linalg.norm(p - c.placement.translation))
    print(f"\nmax drift per tick {1e3 * worst_drift:.5f} mm, max offset {1e3 * worst_offset:.5f} mm")
    assert worst_drift <= 5e-5
    assert worst_offset <= 1e-4


def test_safe_command_of_a_failed_tick_holds_contacts_to_second_order(robots):
    """A failed tick's safe command (constraints only) is a QP solution like any other: with G1's velocity limits
    (up to 37 rad/s) and a wrist target 1 m away at gain 1000, its first-order contact rows let a sole move
    > 0.05 mm per tick (measured 2.7 mm on ok ticks before the correction existed). A hard foot target 1 m away
    makes every tick fail; the safe command must keep each sole ≤ 0.05 mm from where its contact row sent it
    (forward kinematics) and ≤ 1 mm from its placement over 30 failed ticks."""
    from wbc.tasks import FrameTask

    robot = robots("g1")
    config = Configuration(robot)
    ctrl, com = standing_controller(robot, config)
    ctrl.budget = math.inf  # the safe command's refinement, independent of the machine's load
    contacts = ctrl.constraints[:2]
    rng = np.random.default_rng(3)
    hand = FrameTask(robot, "left_wrist_roll_joint", gain=1000.0, position_weight=100.0, name="hand")
    target = config.frame_placement(hand.frame_id).copy()
    target.translation += rng.uniform(-1.0, 1.0, 3)
    hand.set_target(target)
    ctrl.add_task(hand)
    foot = FrameTask(robot, robot.left_sole, gain=10.0, name="far_foot")
    far = config.frame_placement(foot.frame_id).copy()
    far.translation += [1.0, 0.0, 0.0]
    foot.set_target(far)
    ctrl.add_task(foot, hard=True)
    worst_drift = worst_offset = 0.0
    moved = 0.0
    for _ in range(30):
        before = [config.frame_placement(c.frame_id).copy() for c in contacts]
        res = ctrl.solve(config, DT)
        assert not res.ok and res.fallback == "constraints_only", res.fallback
        config.update(config.integrate(res.v, DT))
        moved = max(moved, float(np.abs(res.v[6:]).max()))
        for c, oMf in zip(contacts, before):
            p = config.frame_placement(c.frame_id).translation
            worst_drift = max(worst_drift, np.linalg.norm(p - _commanded(c, oMf).translation))
            worst_offset = max(worst_offset, np.linalg.norm(p - c.placement.translation))
    print(f"\nmax joint speed {moved:.3g} rad/s, max drift per tick {1e3 * worst_drift:.5f} mm, max offset "
          f"{1e3 * worst_offset:.5f} mm")
    assert moved > 1.0  # the safe command does move the robot (not a hold)
    assert worst_drift <= 5e-5
    assert worst_offset <= 1e-3


def test_fuzz_seed_1004_strict_levels_nearly_dependent_contacts_hold_without_failing(robots):
    """Fuzz seed 1004, episode 16 (humanoid15, strict: CoM on level 0, posture and a torso target at gain 2709 on
    level 1, contact gains 47 and 613): the flat feet's contact rows are nearly dependent and their corrections
    disagree in that direction, so the cascade asked 24 rad/s and the soles drifted 8.3e-5 m; the correction
    was not better and every smaller trust region had no solution (the dependent rows' bands), so tick 4 failed
    on drift alone. The same feasible situation must be solved ok with each sole ≤ 0.05 mm from where its
    contact row sent it (forward kinematics), as a weighted controller's would be."""
    from wbc.tasks import FrameTask, PostureTask

    robot = robots("humanoid15")
    config = Configuration(robot)
    ctrl, com = standing_controller(robot, config)
    com.gain, com.weight = 12.13563525091764, 399.28710729728107
    com.set_target(np.array([0.02874008069290959, -0.01636683973489159, 0.6887347697900775]))
    contacts = ctrl.constraints[:2]
    for contact, gain in zip(contacts, (47.32062983022001, 612.9587503390428)):
        contact.gain = gain
    hand = FrameTask(robot, robot.torso, gain=2709.247174830203, position_weight=761.6788091433795,
                     orientation_weight=0.0, name="hand")
    target = config.frame_placement(hand.frame_id).copy()
    target.translation = np.array([-0.0220423956132506, -0.03146626899018545, 0.9328541871789733])
    hand.set_target(target)
    ctrl.remove_task(com)
    ctrl.add_task(com, level=0)
    ctrl.add_task(PostureTask(robot, weight=3.2682029423729837), level=1)
    ctrl.add_task(hand, level=1)
    ctrl.budget = math.inf  # a level's failed solve is rescued by ProxQP's confirmation, whatever the machine's load
    worst = 0.0
    for _ in range(8):
        before = [config.frame_placement(c.frame_id).copy() for c in contacts]
        res = ctrl.solve(config, DT)
        assert res.ok, res.message
        config.update(config.integrate(res.v, DT))
        for c, oMf in zip(contacts, before):
            worst = max(worst, np.linalg.norm(config.frame_placement(c.frame_id).translation
                                              - _commanded(c, oMf).translation))
    assert worst <= 5e-5
