"""Strict priorities: an upper level is unaffected by the levels below; a lower level is optimal within it."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest
import scipy.linalg
from scipy.optimize import minimize

from wbc.configuration import Configuration
from wbc.constraints import ContactConstraint, JointVelocityLimit
from wbc.controllers.kinematic import KinematicController
from wbc.exceptions import InvalidInputError
from wbc.solvers.qp_data import QPData
from wbc.tasks import ComTask, DampingTask, FrameTask, PositionTask, PostureTask

DT = 0.002


def residual(task, config, v):
    """‖√W (J v − v*)‖ of a task at config (weights applied, as the level's cost)."""
    error, jac = task.compute(config)
    return float(np.linalg.norm(np.sqrt(task.weight) * (jac @ v - task.velocity_target(error))))


def build(robot, config, *, hand_level, com_level, limits=True):
    """Contacts (+ joint velocity limits); a hand target out of reach at the velocity limits and a CoM shift
    that pulls the other way; each task on the given level ("off" = not added)."""
    contacts = [ContactConstraint(robot, f) for f in (robot.left_sole, robot.right_sole)]
    for c in contacts:
        c.set_placement_from_configuration(config)
    # the oracles below re-solve the assembled QP: the second-order contact correction (which moves the contact
    # rows' right-hand sides within the tick) and the drift trust region are off here (tested in test_solve_core)
    ctrl = KinematicController(robot, [PostureTask(robot, weight=1e-3)],
                               [*contacts, *([JointVelocityLimit(robot)] if limits else [])],
                               contact_correction=0.0, sole_drift_tolerance=None,
                               budget=math.inf)  # every level solved, whatever the machine's load
    hand = PositionTask(robot, robot.right_hand, gain=20.0, name="hand")
    hand.set_target(config.frame_placement(hand.frame_id).translation + [0.6, -0.4, 0.3])
    com = ComTask(gain=20.0)
    com.set_target(config.com + [-0.1, 0.1, -0.05])
    for task, level in ((hand, hand_level), (com, com_level)):
        if level != "off":
            ctrl.add_task(task, level=level)
    return ctrl, hand, com


def level_optimum(J, t, E, e, lb, ub, v_start):
    """min ½‖J v − t‖² s.t. E v = e, lb ≤ v ≤ ub by scipy's SLSQP from the feasible ``v_start`` (an independent
    solver, no cascade): the residual ‖J v − t‖ at its optimum."""
    bounds = [(lo if np.isfinite(lo) else None, hi if np.isfinite(hi) else None) for lo, hi in zip(lb, ub)]
    out = minimize(lambda x: 0.5 * np.sum((J @ x - t) ** 2), v_start, jac=lambda x: J.T @ (J @ x - t),
                   method="SLSQP", bounds=bounds, options={"ftol": 1e-14, "maxiter": 2000},
                   constraints=[{"type": "eq", "fun": lambda x: E @ x - e, "jac": lambda x: E}])
    # status 8 ("positive directional derivative in line search"): no descent left at the tolerance
    assert out.status in (0, 8) and np.max(np.abs(E @ out.x - e)) < 1e-9, out.message
    return float(np.linalg.norm(J @ out.x - t))


def test_upper_level_same_as_alone_and_lower_level_optimal_within(robots):
    """Level 0: hand (unreachable at the velocity limits: nonzero residual); level 1: CoM (conflicting).

    Every tick of a 60-tick closed loop: the hand's residual and its image J_hand v equal those of the hand solved
    alone to 1e-6; the CoM level's residual equals the optimum within the hand's optimal set computed by an
    independent solver (scipy SLSQP) to 1e-6; and
    the conflict is real: the weighted (flat) mix degrades the hand, the hierarchy degrades the CoM.
    """
    robot = robots("talos")
    config = Configuration(robot)
    hier, hand, com = build(robot, config, hand_level=0, com_level=1)
    alone, hand_alone, _ = build(robot, config, hand_level=0, com_level="off")
    com_only, _, com_solo = build(robot, config, hand_level="off", com_level=0)
    flat, hand_flat, _ = build(robot, config, hand_level=None, com_level=None)
    worst_upper = worst_image = worst_lower = 0.0
    for k in range(60):
        rh, ra, rc, rf = (c.solve(config, DT) for c in (hier, alone, com_only, flat))
        assert rh.ok and ra.ok and rc.ok and rf.ok, (rh.message, ra.message)
        r_up, r_alone = residual(hand, config, rh.v), residual(hand_alone, config, ra.v)
        worst_upper = max(worst_upper, abs(r_up - r_alone))
        J0 = hand.compute(config)[1]
        worst_image = max(worst_image, float(np.max(np.abs(J0 @ rh.v - J0 @ ra.v))))
        # lower level: min ‖J1 v − v1*‖ s.t. contacts, J0 v = J0 v_alone, velocity bounds — by SLSQP, started
        # from v_alone (feasible), compared with the hierarchy's level-1 residual
        _, _, A, b, _, _, _, lb, ub = hier.assemble(config, DT)
        e1, J1 = com.compute(config)
        t1 = com.velocity_target(e1)
        ref = level_optimum(J1, t1, np.vstack([A, J0]), np.r_[b, J0 @ ra.v], lb, ub, ra.v)
        worst_lower = max(worst_lower, abs(float(np.linalg.norm(J1 @ rh.v - t1)) - ref))
        if k == 0:
            assert r_alone > 1.0  # the hand target is out of reach: level 0 is not trivially satisfied
            assert residual(hand_flat, config, rf.v) > r_alone + 0.5  # weighted mixing degrades the hand
            assert residual(com, config, rh.v) > residual(com_solo, config, rc.v) + 1.0  # CoM gives way
        config.update(config.integrate(rh.v, DT))
    print(f"\nmax |upper residual − alone| = {worst_upper:.2e}, max |J0 v − J0 v_alone| = {worst_image:.2e}, "
          f"max |level-1 residual − SLSQP optimum within level 0| = {worst_lower:.2e}")
    assert worst_upper < 1e-6
    assert worst_image < 1e-6
    assert worst_lower < 1e-6


def test_lower_level_matches_closed_form_nullspace_projection(robots):
    """Without inequalities the cascade has a closed form (Siciliano & Slotine, ICAR 1991): with N the null
    space of [J_c; J_0], v = v_0 + N (J_1 N)⁺ (v*_1 − J_1 v_0). Level 0: hand pose (6 rows); level 1: posture
    (every joint; conflicts with the hand); the contacts hard."""
    robot = robots("talos")
    config = Configuration(robot)
    contacts = [ContactConstraint(robot, f) for f in (robot.left_sole, robot.right_sole)]
    for c in contacts:
        c.set_placement_from_configuration(config)
    hand = FrameTask(robot, robot.right_hand, gain=5.0)
    target = config.frame_placement(hand.frame_id).copy()
    target.translation += [0.2, -0.1, 0.15]
    hand.set_target(target)
    posture = PostureTask(robot, weight=1.0, gain=5.0)
    q_far = robot.q_ref.copy()
    q_far[7:] += 0.3
    posture.set_target(q_far)
    # closed form of the assembled rows: no in-tick contact correction, no trust region (see build())
    ctrl = KinematicController(robot, [], contacts, contact_correction=0.0, sole_drift_tolerance=None,
                               budget=math.inf)
    ctrl.add_task(hand, level=0)
    ctrl.add_task(posture, level=1)
    worst0 = worst1 = 0.0
    for _ in range(20):
        res = ctrl.solve(config, DT)
        assert res.ok, res.message
        _, _, A, b, *_ = ctrl.assemble(config, DT)
        e0, J0 = hand.compute(config)
        e1, J1 = posture.compute(config)
        t0, t1 = hand.velocity_target(e0), posture.velocity_target(e1)
        Nc = scipy.linalg.null_space(A)
        v_c = np.linalg.lstsq(A, b, rcond=None)[0]
        v0 = v_c + Nc @ np.linalg.lstsq(J0 @ Nc, t0 - J0 @ v_c, rcond=None)[0]
        N = scipy.linalg.null_space(np.vstack([A, J0]))
        v1 = v0 + N @ np.linalg.lstsq(J1 @ N, t1 - J1 @ v0, rcond=None)[0]
        worst0 = max(worst0, float(np.max(np.abs(J0 @ res.v - t0))))  # level 0 is reachable: residual 0
        worst1 = max(worst1, abs(np.linalg.norm(J1 @ res.v - t1) - np.linalg.norm(J1 @ v1 - t1)))
        config.update(config.integrate(res.v, DT))
    print(f"\nlevel-0 residual ≤ {worst0:.2e}; |level-1 residual − closed form| ≤ {worst1:.2e}")
    assert worst0 < 1e-6
    assert worst1 < 1e-6


def test_levels_api(robots):
    robot = robots("humanoid15")
    ctrl = KinematicController(robot, budget=math.inf)
    damping = DampingTask(robot)
    com = ComTask()
    ctrl.add_task(com, level=2)
    ctrl.add_task(damping, level=0)
    assert ctrl._level_order == [0, 2]
    with pytest.raises(InvalidInputError):
        ctrl.add_task(ComTask(), level=-1)
    with pytest.raises(InvalidInputError):
        ctrl.add_task(ComTask(), level=1, hard=True)
    ctrl.remove_task(com)
    ctrl.remove_task(damping)
    assert ctrl.levels == {} and ctrl._level_order == []
    with pytest.raises(ValueError):
        ctrl.remove_task(com)
    # a single strict level, no weighted task: the hierarchy path still solves (soft level = damping only)
    config = Configuration(robot)
    com.set_target(config.com + [0.01, 0, 0])
    ctrl.add_task(com, level=0)
    res = ctrl.solve(config, DT)
    assert res.ok and np.allclose(config.com_jacobian @ res.v, -com.gain * (config.com - com.target), atol=1e-6)


def test_infeasible_top_level_met_in_least_squares_lower_level_still_optimised(robots):
    """Level 0 holds two CoM tasks that contradict each other (targets 5 cm apart along x, weights 1 and 3): no v
    meets both, so level 0 must be met as well as possible — in least squares the CoM velocity is the weighted
    mean of the two targets, v*_x = (1·t_a + 3·t_b)/4 (closed form), the other axes met exactly. Level 1 (torso
    orientation, conflicting with the CoM motion) is still optimised within level 0's optimal set: its residual
    equals the closed-form null-space solution v₁ = v₀ + N (J₁N)⁺ (t₁ − J₁v₀), N = null([J_c; J_com]), to 1e-6
    relative to ‖t₁‖. The
    contacts stay hard (A v = b to 1e-9; Talos: its contact rows are independent)."""
    robot = robots("talos")
    config = Configuration(robot)
    contacts = [ContactConstraint(robot, f) for f in (robot.left_sole, robot.right_sole)]
    for c in contacts:
        c.set_placement_from_configuration(config)
    com_a, com_b = ComTask(gain=10.0, weight=1.0, name="com_a"), ComTask(gain=10.0, weight=3.0, name="com_b")
    com_a.set_target(config.com + [0.05, 0.0, -0.01])
    com_b.set_target(config.com + [-0.0, 0.0, -0.01])
    torso = FrameTask(robot, robot.torso, position_weight=0.0, orientation_weight=1.0, gain=10.0, name="torso")
    tilted = config.frame_placement(torso.frame_id).copy()
    tilted.rotation = tilted.rotation @ pin.rpy.rpyToMatrix(0.0, 0.3, 0.2)
    torso.set_target(tilted)
    ctrl = KinematicController(robot, [], contacts, contact_correction=0.0, sole_drift_tolerance=None,
                               budget=math.inf)
    ctrl.add_task(com_a, level=0)
    ctrl.add_task(com_b, level=0)
    ctrl.add_task(torso, level=1)
    worst_mean = worst_level1 = worst_hard = 0.0
    for _ in range(10):
        res = ctrl.solve(config, DT)
        assert res.ok, res.message
        _, _, A, b, *_ = ctrl.assemble(config, DT)
        ea, Jc = com_a.compute(config)
        eb, _ = com_b.compute(config)
        ta, tb = com_a.velocity_target(ea), com_b.velocity_target(eb)
        c_star = (1.0 * ta + 3.0 * tb) / 4.0  # least-squares optimum of the two CoM tasks
        worst_mean = max(worst_mean, float(np.max(np.abs(Jc @ res.v - c_star))))
        assert np.linalg.norm(ta - tb) > 0.1  # the conflict is real: the two targets differ
        e1, J1 = torso.compute(config)
        t1 = torso.velocity_target(e1)
        E = np.vstack([A, Jc])
        v0 = np.linalg.lstsq(E, np.concatenate([b, c_star]), rcond=None)[0]
        N = scipy.linalg.null_space(E)
        v1 = v0 + N @ np.linalg.lstsq(J1 @ N, t1 - J1 @ v0, rcond=None)[0]
        # relative to the level's target (rad/s): the solvers stop at a relative precision of ~1e-6
        worst_level1 = max(worst_level1, abs(np.linalg.norm(J1 @ res.v - t1) - np.linalg.norm(J1 @ v1 - t1))
                           / max(1.0, float(np.linalg.norm(t1))))
        worst_hard = max(worst_hard, float(np.max(np.abs(A @ res.v - b))))
        config.update(config.integrate(res.v, DT))
    print(f"\n|J_com v − weighted mean| ≤ {worst_mean:.2e}; |level-1 residual − closed form| / ‖t₁‖ ≤ "
          f"{worst_level1:.2e}; "
          f"contacts ≤ {worst_hard:.2e}")
    assert worst_mean < 1e-6
    assert worst_level1 < 1e-6
    assert worst_hard < 1e-9


def _random_problem(rng, n=12, m_eq=4, m_level=8):
    """Hard equalities A v = b (m_eq rows), one full-rank level J v ≈ t (m_level rows, m_eq + m_level = n: the
    two fix every direction of v), box bounds far away, a random soft level."""
    A, b = rng.normal(size=(m_eq, n)), rng.normal(size=m_eq)
    J, t = rng.normal(size=(m_level, n)), rng.normal(size=m_level)
    M = rng.normal(size=(n, n))
    H, g = M @ M.T + np.eye(n), rng.normal(size=n)
    return A, b, J, t, H, g


def test_levels_below_a_determined_point_are_not_solved_and_the_answer_is_the_closed_form():
    """Hard equalities of rank m and a level of rank n − m fix v: the soft level below has nothing left to optimise,
    is skipped (``last_determined``), and v is the equality-constrained least-squares solution of the level,
    computed here from the KKT system with numpy (no QP solver): [JᵀJ Aᵀ; A 0] [v; λ] = [Jᵀt; b]."""
    from wbc.solvers import DaqpBackend
    from wbc.solvers.hierarchy import solve_lexicographic

    rng = np.random.default_rng(3)
    for _ in range(5):
        A, b, J, t, H, g = _random_problem(rng)
        n, m = A.shape[1], A.shape[0]
        C, l, u = np.zeros((0, n)), np.zeros(0), np.zeros(0)
        lb, ub = np.full(n, -1e3), np.full(n, 1e3)
        final = DaqpBackend()
        v, res = solve_lexicographic([(J, t)], QPData(H, g, A, b, C, l, u, lb, ub), [DaqpBackend(eps_prox=1e-3)], final)
        assert solve_lexicographic.last_determined == 1  # the soft level (index len(levels)) was not solved
        K = np.block([[J.T @ J, A.T], [A, np.zeros((m, m))]])
        ref = np.linalg.solve(K, np.concatenate([J.T @ t, b]))[:n]
        # the level's own solve (DAQP's proximal-point iterations on the semidefinite JᵀJ) ends ≈ 2e-5 relative from
        # the exact minimiser on these random problems: the bound is on that, the skip itself adds nothing
        assert np.max(np.abs(v - ref)) < 1e-4 * max(1.0, np.max(np.abs(ref)))
        # with one level row fewer v is not determined: the soft level is solved (and nothing is skipped)
        v2, _ = solve_lexicographic([(J[:-1], t[:-1])], QPData(H, g, A, b, C, l, u, lb, ub),
                                    [DaqpBackend(eps_prox=1e-3)], DaqpBackend())
        assert solve_lexicographic.last_determined is None


def test_memo_starts_a_level_with_the_retry_that_solved_it_and_forgets_a_failed_hint():
    """``memo``: a level recorded as solved by its damped retry starts with that retry (one backend call instead
    of the failing undamped one first); a hint that fails is dropped and the full sequence runs. Counted with a
    backend that records the Hessians it is called with; the answers agree with the memo-less cascade."""
    from wbc.solvers import DaqpBackend
    from wbc.solvers.hierarchy import solve_lexicographic

    class Recording(DaqpBackend):
        def __init__(self, **kw):
            super().__init__(**kw)
            self.calls = []

        def solve(self, H, g, *args, **kw):
            self.calls.append(H.copy())
            return super().solve(H, g, *args, **kw)

    rng = np.random.default_rng(4)
    A, b, J, t, H, g = _random_problem(rng, n=12, m_eq=3, m_level=4)
    n = A.shape[1]
    C, l, u = np.zeros((0, n)), np.zeros(0), np.zeros(0)
    lb, ub = np.full(n, -1e3), np.full(n, 1e3)
    J2, t2 = rng.normal(size=(2, n)), rng.normal(size=2)
    levels = [(J, t), (J2, t2)]
    plain, _ = solve_lexicographic(levels, QPData(H, g, A, b, C, l, u, lb, ub), [DaqpBackend(eps_prox=1e-3)] * 2,
                                   DaqpBackend())
    memo = {(1, 2): "damped"}
    lvl = Recording(eps_prox=1e-3)
    v, _ = solve_lexicographic(levels, QPData(H, g, A, b, C, l, u, lb, ub), [DaqpBackend(eps_prox=1e-3), lvl],
                               DaqpBackend(), memo=memo)
    mu = 1e-9 * max(1.0, float(np.max(np.diag(J2.T @ J2))))
    assert len(lvl.calls) == 1 and np.allclose(lvl.calls[0], J2.T @ J2 + mu * np.eye(n), rtol=0, atol=1e-15)
    assert memo == {(1, 2): "damped"}
    assert np.max(np.abs(v - plain)) < 1e-6
    memo = {(1, 2): "wide"}  # level 0 has no band to widen... level 1's wide-band hint is tried, kept if it solves
    v3, _ = solve_lexicographic(levels, QPData(H, g, A, b, C, l, u, lb, ub), [DaqpBackend(eps_prox=1e-3)] * 2,
                                DaqpBackend(), memo=memo)
    assert np.max(np.abs(v3 - plain)) < 1e-5


def test_conflicting_strict_level_is_least_squares_and_lower_level_still_optimised():
    """Level 0 asks x0 = 1 and x0 = −1 (conflict) and x1 = 5 beyond its bound |x1| ≤ 1; level 1 asks x2 = 0.5,
    under the hard row x0 + x3 = 0.2. Level 0's residual equals the bounded least-squares optimum of that level
    alone under the constraints (scipy.optimize.lsq_linear after eliminating x3), and level 1 is met exactly."""
    import scipy.optimize

    from wbc.solvers import DaqpBackend
    from wbc.solvers.hierarchy import solve_lexicographic

    n = 4
    J0, t0 = np.array([[1.0, 0, 0, 0], [1.0, 0, 0, 0], [0, 1.0, 0, 0]]), np.array([1.0, -1.0, 5.0])
    J1, t1 = np.array([[0, 0, 1.0, 0]]), np.array([0.5])
    A, b = np.array([[1.0, 0, 0, 1.0]]), np.array([0.2])
    lb, ub = -np.ones(n), np.ones(n)
    e = np.zeros((0, n))
    v, res = solve_lexicographic([(J0, t0), (J1, t1)], QPData(np.eye(n) * 1e-6, np.zeros(n), A, b, e, np.zeros(0),
                                                              np.zeros(0), lb, ub),
                                 [DaqpBackend(eps_prox=1e-3), DaqpBackend(eps_prox=1e-3)], DaqpBackend())
    # x3 = 0.2 − x0 ∈ [−1, 1] ⇔ x0 ∈ [−0.8, 1]: level 0 alone as a bounded least-squares problem in (x0, x1, x2)
    ref = scipy.optimize.lsq_linear(J0[:, :3], t0, bounds=([-0.8, -1, -1], [1, 1, 1]))
    assert abs(res[0] - np.linalg.norm(ref.fun)) < 1e-6
    assert abs(v[2] - 0.5) < 1e-6 and res[1] < 1e-6
    assert abs(A @ v - b)[0] < 1e-9 and np.all(v >= lb) and np.all(v <= ub)


def test_far_target_level_solved_in_one_call_per_cascade_within_the_tick_budget(robots):
    """G1 standing on both soles, CoM on level 0, a hand target 1e6 m away (gain 1e4: |g| ~ 1e11 on level 1) and
    the posture on level 1 — the kinematic fuzz's episode whose level-1 DAQP calls cycled unscaled. After one tick
    at an unlimited budget (the new layout's: at the default budget its work leaves no room for the cascade and its
    contact correction, ``_plan_levels``, and that tick would answer with the weighted form of the
    levels), with the default budget (the tick's dt, counted in solves) every tick of a 12-tick closed loop is ok,
    the first with every level of its cascade solved (no level cut; its contact correction may stop at the cascade's
    share of the budget, ``KinematicController.WEIGHTED_RESERVE``, after which that tick is answered by the weighted
    form and the next ticks may be too, ``levels+weighted``); each stance sole ends where its contact row sends
    it to 5e-5 m (Pinocchio forward kinematics); the CoM level's residual equals its optimum under the contacts and
    bounds computed by an independent solver (scipy SLSQP) to 1e-4 m/s."""
    from wbc.constraints import JointPositionLimit

    robot = robots("g1")
    config = Configuration(robot)
    contacts = [ContactConstraint(robot, f) for f in (robot.left_sole, robot.right_sole)]
    for c in contacts:
        c.set_placement_from_configuration(config)
    ctrl = KinematicController(robot, [], [*contacts, JointPositionLimit(robot), JointVelocityLimit(robot)])
    com = ComTask(gain=10.0)
    com.set_target(config.com + [0.02, -0.01, -0.02])
    hand = FrameTask(robot, "left_wrist_roll_joint", gain=1e4, position_weight=1.0, orientation_weight=0.0,
                     name="hand")
    target = config.frame_placement(hand.frame_id).copy()
    target.translation += 1e6 * np.array([0.6, 0.0, 0.8])
    hand.set_target(target)
    ctrl.add_task(com, level=0)
    ctrl.add_task(hand, level=1)
    ctrl.add_task(PostureTask(robot, weight=0.1), level=1)
    data = robot.model.createData()
    ctrl.budget = math.inf
    assert ctrl.solve(config, DT).path == "levels"  # the new layout's tick (the loop starts from the same state)
    ctrl.budget = None
    for k in range(12):
        res = ctrl.solve(config, DT)
        assert res.ok and "priority levels" not in res.message, (k, str(res.path), res.message)
        # the first tick solves every level; its answer may be the weighted form's only after the count stopped the
        # cascade's contact correction (a stage that would end past the cascade's share of the budget)
        assert k > 0 or not res.path.weighted or "the cascade's contact correction" in res.message, res.message
        # level 0 against SLSQP on the tick's assembled hard set; the tick's second-order contact correction
        # re-solves with the contact rows' right-hand sides moved by the soles' drift / dt, which shifts the CoM
        # level's reachable optimum by up to ~3e-5 m/s here: compared to 1e-4 m/s absolute (+ 1e-6 relative)
        _, _, A, b, _, _, _, lb, ub = ctrl.assemble(config, DT)
        e0, J0 = com.compute(config)
        t0 = com.velocity_target(e0)
        ref = level_optimum(J0, t0, A, b, lb, ub, np.zeros(robot.model.nv))
        if not res.path.weighted:  # the cascade's level 0 (the weighted form trades it against the levels below)
            assert abs(float(np.linalg.norm(J0 @ res.v - t0)) - ref) <= 1e-6 * max(1.0, ref) + 1e-4, (k, ref)
        # the soles by forward kinematics: where each ends vs placement · exp((1 − K dt) e)
        q_next = pin.integrate(robot.model, config.q, res.v * DT)
        pin.forwardKinematics(robot.model, data, q_next)
        for c in contacts:
            e = pin.log6(c.placement.actInv(config.frame_placement(c.frame_id))).vector
            sent = c.placement * pin.exp6(e * (1.0 - min(c.gain, 1.0 / DT) * DT))
            end = pin.updateFramePlacement(robot.model, data, c.frame_id)
            assert np.linalg.norm(end.translation - sent.translation) <= 5e-5, (k, c.name)
        config.update(q_next)
