"""Each constraint's rows against independent geometry / finite differences, and the limit-recovery behaviour."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from conftest import CATALOG, random_configuration, standing_controller
from wbc.configuration import Configuration
from wbc.constraints import (ComPolygonConstraint, ContactConstraint, JointAccelerationLimit, JointPositionLimit,
                             JointVelocityLimit, SelfCollisionConstraint, TaskConstraint)
from wbc.constraints.limits import bounded_joints
from wbc.constraints.self_collision import default_collision_pairs
from wbc.controllers.kinematic import KinematicController
from wbc.exceptions import InvalidInputError
from wbc.geometry import convex_hull, signed_distance, sole_polygon
from wbc.tasks import ComTask, PostureTask

DT = 0.002




# -- joint limits ---------------------------------------------------------------------------------------------
KNEE = {"talos": "leg_left_4_joint", "g1": "left_knee_joint", "humanoid15": "left_knee"}
ELBOW = {"talos": "arm_right_4_joint", "g1": "right_elbow_joint", "humanoid15": "right_elbow"}


@pytest.mark.parametrize("name", CATALOG)
@pytest.mark.parametrize("variant", ["limits", "slow+acc"])
def test_joint_limit_recovery(robots, name, variant):
    """A knee and an elbow start 0.05 rad outside a limit: both are back inside within 0.5 s and stay inside, every
    tick solves, no NaN. Variant "slow+acc": velocity limits scaled by 0.5 and acceleration limits 20 rad/s² —
    the position recovery yields to the first and wins over the second, so the box never empties."""
    robot = robots(name)
    model = robot.model
    idx_q, _ = bounded_joints(model)
    q = robot.q_ref.copy()
    picked = []
    for pattern in (KNEE[name], ELBOW[name]):  # each pushed 0.05 rad past its limit nearest to q_ref
        iq = model.joints[robot.joint_id(pattern)].idx_q
        assert iq in idx_q
        lo, hi = model.lowerPositionLimit[iq], model.upperPositionLimit[iq]
        side = "upper" if hi - q[iq] < q[iq] - lo else "lower"
        q[iq] = hi + 0.05 if side == "upper" else lo - 0.05
        picked.append((pattern, iq, side))
    config = Configuration(robot, q)
    extra = [JointAccelerationLimit(robot, a_max=20.0)] if variant == "slow+acc" else []
    ctrl, _ = standing_controller(robot, config, *extra, vel_scale=0.5 if variant == "slow+acc" else 1.0)
    inside_at = {}
    relaxed = 0
    for k in range(int(0.6 / DT)):
        res = ctrl.solve(config, DT)
        assert res.ok, res.message
        relaxed += bool(res.relaxed)
        assert np.isfinite(res.v).all()
        config.update(config.integrate(res.v, DT))
        for jname, iq, _ in picked:
            ok = model.lowerPositionLimit[iq] <= config.q[iq] <= model.upperPositionLimit[iq]
            if ok:
                inside_at.setdefault(jname, (k + 1) * DT)
            else:
                assert jname not in inside_at, f"{jname} left its range again at t = {(k + 1) * DT:.3f} s"
    print(f"\n{name} {variant}: back inside after " + ", ".join(f"{j} {t * 1e3:.0f} ms" for j, t in inside_at.items())
          + f"; acceleration limits relaxed on {relaxed} ticks")
    assert set(inside_at) == {j for j, _, _ in picked}
    assert max(inside_at.values()) <= 0.5


def test_box_priority_yields_instead_of_emptying(robots):
    """Position recovery (priority 1) clipped into the scaled velocity box (0); acceleration limits (2) clipped
    into both: lb ≤ ub everywhere, the bounds are the documented ones."""
    robot = robots("humanoid15")
    model = robot.model
    idx_q, idx_v = bounded_joints(model)
    q = robot.q_ref.copy()
    q[idx_q[0]] = model.upperPositionLimit[idx_q[0]] + 0.05
    config = Configuration(robot, q)
    acc = JointAccelerationLimit(robot, a_max=10.0)
    acc.set_previous(np.zeros(robot.nv))
    vel = JointVelocityLimit(robot, scale=0.5)
    ctrl = KinematicController(robot, [], [acc, JointPositionLimit(robot), vel])
    *_, lb, ub = ctrl.assemble(config, DT)
    assert np.all(lb <= ub)
    j = idx_v[0]
    # recovery wants v ≤ −v_max (capped at the full limit); the velocity box allows −0.5 v_max; the acceleration
    # box [−0.02, 0.02] is clipped onto that bound: v = −0.5 v_max exactly
    assert lb[j] == ub[j] == pytest.approx(-0.5 * model.velocityLimit[j])
    others = np.setdiff1d(np.arange(6, robot.nv), [j])
    np.testing.assert_allclose(ub[others], np.minimum(10.0 * DT, 0.5 * model.velocityLimit[others]))


def test_acceleration_limit_smooths_a_step(robots):
    """A 3 cm CoM target step: every tick |Δv| ≤ a_max dt on the actuated joints (the controller feeds v_prev);
    without the constraint the first tick jumps far more."""
    robot = robots("talos")
    a_max = 30.0
    for with_limit in (True, False):
        config = Configuration(robot)
        extra = [JointAccelerationLimit(robot, a_max=a_max)] if with_limit else []
        ctrl, com = standing_controller(robot, config, *extra)
        com.set_target(config.com + [0.0, 0.03, 0.0])
        v_prev, worst = np.zeros(robot.nv), 0.0
        for _ in range(100):
            res = ctrl.solve(config, DT)
            assert res.ok, res.message
            worst = max(worst, float(np.max(np.abs(res.v[6:] - v_prev[6:]))))
            v_prev = res.v
            config.update(config.integrate(res.v, DT))
        if with_limit:
            assert worst <= a_max * DT + 1e-9
        else:
            assert worst > 5 * a_max * DT


def test_acceleration_limit_inputs(robots):
    robot = robots("g1")
    with pytest.raises(InvalidInputError):
        JointAccelerationLimit(robot, a_max=0.0)
    with pytest.raises(InvalidInputError):
        JointAccelerationLimit(robot, a_max=np.ones(3))
    acc = JointAccelerationLimit(robot, a_max=np.full(robot.nv - 6, 5.0))
    with pytest.raises(InvalidInputError):
        acc.set_previous(np.zeros(3))


@pytest.mark.parametrize("name", CATALOG)
def test_compiled_box_intersections_match_the_generic_clip(robots, name):
    """The compiled intersect_into of the acceleration and braking limits give the numbers of the generic
    BoxConstraint.intersect_into (compute, then the clip into the running box), bit for bit, on random running boxes
    (some emptying the box, some infinite) and random configurations and previous commands; their compute buffers
    hold the box's own bounds."""
    from wbc.constraints.base import BoxConstraint
    from wbc.constraints.braking import JointBrakingLimit

    robot = robots(name)
    rng = np.random.default_rng(11)
    nv = robot.nv
    boxes = [JointAccelerationLimit(robot, a_max=rng.uniform(5.0, 80.0, nv - 6)), JointBrakingLimit(robot, a_max=40.0)]
    for trial in range(20):
        config = Configuration(robot, random_configuration(robot, rng, spread=0.6 if trial % 2 else 0.05))
        boxes[0].set_previous(rng.uniform(-3.0, 3.0, nv))
        lb0 = rng.uniform(-4.0, 1.0, nv)
        ub0 = lb0 + rng.uniform(0.0, 5.0, nv)
        lb0[rng.random(nv) < 0.2], ub0[rng.random(nv) < 0.2] = -np.inf, np.inf
        for box in boxes:
            lb, ub = lb0.copy(), ub0.copy()
            box.intersect_into(config, 0.002, lb, ub)
            own_lb, own_ub = box._lb.copy(), box._ub.copy()
            ref_lb, ref_ub = lb0.copy(), ub0.copy()
            BoxConstraint.intersect_into(box, config, 0.002, ref_lb, ref_ub)
            assert np.array_equal(lb, ref_lb) and np.array_equal(ub, ref_ub)
            lo, hi = box.compute(config, 0.002)
            assert np.array_equal(own_lb, lo) and np.array_equal(own_ub, hi)


def test_position_limit_assignment_reaches_the_compiled_bounds(robots):
    """JointPositionLimit.q_min / q_max / v_max, assigned or changed in place after construction, are what the
    compiled intersect_into and compute use: bounds equal a numpy reference written here, lb = min((q_min − q)/dt,
    v_max), ub = max((q_max − q)/dt, −v_max) clipped into the running box; bad assignments raise."""
    robot = robots("talos")
    lim = JointPositionLimit(robot)
    rng = np.random.default_rng(3)
    config = Configuration(robot, random_configuration(robot, rng, spread=0.3))
    q = config.q[lim.idx_q]
    lim.q_min = q - rng.uniform(-0.01, 0.05, lim.dim)  # some joints outside their new range
    lim.q_max = np.maximum(lim.q_min, q + rng.uniform(-0.01, 0.05, lim.dim))
    lim.v_max = rng.uniform(0.5, 3.0, lim.dim)
    lim.v_max[:3] = 7.0  # in place
    dt = 0.002
    lo = np.minimum((lim.q_min - q) / dt, lim.v_max)
    hi = np.maximum((lim.q_max - q) / dt, -lim.v_max)
    got_lo, got_hi = lim.compute(config, dt)
    assert np.array_equal(got_lo, lo) and np.array_equal(got_hi, hi)
    lb, ub = np.full(robot.nv, -np.inf), np.full(robot.nv, np.inf)
    lim.intersect_into(config, dt, lb, ub)
    assert np.array_equal(lb[lim.indices], lo) and np.array_equal(ub[lim.indices], hi)
    with pytest.raises(InvalidInputError, match="q_min"):
        lim.q_min = np.zeros(3)
    with pytest.raises(InvalidInputError, match="q_min must be ≤ q_max"):
        lim.q_max = lim.q_min - 1.0
    with pytest.raises(InvalidInputError, match="v_max"):
        lim.v_max = np.zeros(lim.dim)
    with pytest.raises(InvalidInputError):
        lim.q_min = np.full(lim.dim, np.nan)


# -- CoM polygon ----------------------------------------------------------------------------------------------
def _support(robot, config, sides):
    frames = {"left": robot.left_sole, "right": robot.right_sole}
    return [config.frame_placement(robot.frame_id(frames[s])) for s in sides]


POLYGON_CASES = [(name, sides) for name in CATALOG for sides in (("left", "right"), ("left",))
                 # humanoid15's 5-DoF legs cannot yaw a flat foot: two flat contacts drift apart in yaw at second
                 # order under large CoM swings until their dependent rows disagree (controller docstring); its
                 # polygon rows are checked in single support
                 if (name, sides) != ("humanoid15", ("left", "right"))]


@pytest.mark.parametrize(("name", "sides"), POLYGON_CASES)
def test_com_polygon_step_lands_on_the_shrunk_boundary(robots, name, sides):
    """A CoM task pulls 0.3 m away (sideways, other side, forward-diagonal); the polygon rows stop it. Reference
    geometry built independently: sole rectangles from the frames' placements and their hull,
    ``signed_distance`` to it. Every tick the first-order step c + J v dt stays ≥ margin inside (1e-9) and lands
    exactly at distance ``margin`` (1e-9 m) when the row is active; the integrated CoM (second-order error of
    the step) never gets closer than margin − 1e-5 m and settles on the shrunk boundary to 1e-6 m."""
    robot = robots(name)
    config = Configuration(robot)
    margin = 0.015
    poly_c = ComPolygonConstraint(robot, margin=margin)
    soles = _support(robot, config, sides)
    poly_c.set_support(soles)
    corners = np.vstack([sole_polygon(M.translation[0], M.translation[1], math.atan2(M.rotation[1, 0], M.rotation[0, 0]),
                                      robot.sole_length, robot.sole_width) for M in soles])
    polygon = convex_hull(corners)
    frames = {"left": robot.left_sole, "right": robot.right_sole}
    contacts = [ContactConstraint(robot, frames[s]) for s in sides]  # single support: the other foot is free
    for c in contacts:
        c.set_placement_from_configuration(config)
    com = ComTask(weight=10.0, gain=3.0)
    ctrl = KinematicController(robot, [com, PostureTask(robot, weight=1e-2)], contacts)
    if len(sides) == 1:  # bring the CoM over the stance sole first
        com.set_target(np.r_[soles[0].translation[:2], config.com[2]])
        for _ in range(500):
            config.update(config.integrate(ctrl.solve(config, DT).v, DT))
    assert poly_c.shrunk_distance(config.com[:2]) > 0
    ctrl.add_constraint(poly_c)
    landed, worst = 0, np.inf
    for direction in ([0.0, 1.0], [0.0, -1.0], [1.0, 0.3]):
        direction = np.array(direction) / np.linalg.norm(direction)
        com.set_target(config.com + np.r_[0.3 * direction, 0.0])
        active_run = 0
        for _ in range(1000):  # until a polygon row has been active for 50 ticks
            res = ctrl.solve(config, DT)
            assert res.ok, res.message
            predicted = config.com[:2] + DT * (config.com_jacobian[:2] @ res.v)
            d_pred = signed_distance(predicted, polygon)
            assert d_pred >= margin - 1e-9
            C, _, u = poly_c.compute(config, DT)
            if np.any(np.abs(C @ res.v - u) < 1e-9):  # a polygon row is active: exactly on the boundary
                assert d_pred == pytest.approx(margin, abs=1e-9)
                landed += 1
                active_run += 1
            else:
                active_run = 0
            config.update(config.integrate(res.v, DT))
            worst = min(worst, signed_distance(config.com[:2], polygon) - margin)
            if active_run == 50:
                break
        assert active_run == 50, "the CoM never reached the shrunk boundary"
        assert signed_distance(config.com[:2], polygon) == pytest.approx(margin, abs=1e-6)
    print(f"\n{name} {sides}: integrated CoM at worst {-worst * 1e6:.2f} µm inside the margin line" if worst < 0
          else f"\n{name} {sides}: integrated CoM never crossed the margin line")
    assert worst >= -1e-5  # second order in the step (≤ 1 cm per tick here)
    assert landed > 100


def test_com_polygon_recovers_from_outside(robots):
    """CoM starts > 2 cm outside the shrunk single-support polygon: the QP stays feasible, the CoM moves back at
    ≤ recovery_speed along each violated edge normal and ends inside."""
    robot = robots("talos")
    config = Configuration(robot)
    poly_c = ComPolygonConstraint(robot, margin=0.01, recovery_speed=0.05)
    poly_c.set_support(_support(robot, config, ("left",)))
    start = poly_c.shrunk_distance(config.com[:2])
    assert start < -0.02
    contacts = [ContactConstraint(robot, f) for f in (robot.left_sole, robot.right_sole)]
    for c in contacts:
        c.set_placement_from_configuration(config)
    com = ComTask(weight=1.0)
    com.set_target(config.com)  # holds the CoM where it is: conflicts with the recovery
    ctrl = KinematicController(robot, [com, PostureTask(robot)], [*contacts, poly_c])
    previous = start
    for _ in range(int(1.5 / DT)):
        res = ctrl.solve(config, DT)
        assert res.ok, res.message
        config.update(config.integrate(res.v, DT))
        now = poly_c.shrunk_distance(config.com[:2])
        if previous < 0:
            assert now - previous <= 0.05 * DT * 1.01 + 1e-9 or now > 0  # bounded rate
            assert now >= previous - 1e-7
        previous = now
    assert previous > -1e-6


def test_com_polygon_inputs(robots):
    robot = robots("g1")  # sole width 0.05 m
    config = Configuration(robot)
    c = ComPolygonConstraint(robot, margin=0.03)
    with pytest.raises(InvalidInputError, match="too small"):
        c.set_support(_support(robot, config, ("left",)))
    c.set_support(_support(robot, config, ("left", "right")))  # the hull of both is wide enough
    with pytest.raises(InvalidInputError):
        c.set_support([])
    with pytest.raises(InvalidInputError):
        ComPolygonConstraint(robot, margin=-0.01)


# -- self-collision rows --------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", CATALOG)
def test_self_collision_rows_match_distance_rates(robots, name):
    """Each active row C_k equals the finite-difference rate of the coal distance of its pair along a random v
    (pairs at positive distance; central differences, ε = 1e-5), and the lower bound is the velocity damper."""
    robot = robots(name)
    rng = np.random.default_rng(11)
    q = random_configuration(robot, rng, spread=0.5)
    constraint = SelfCollisionConstraint(robot, activation_distance=0.15, max_active=24)
    config = Configuration(robot, q)
    C, l, u = (x.copy() for x in constraint.compute(config, DT))
    active = [(constraint.pair_names.index(a[:2]), a[2]) for a in constraint.active]
    assert active, "no pair within the activation distance"
    v = rng.standard_normal(robot.nv) * 0.2
    eps = 1e-5
    k_pairs = [k for k, _ in active]
    d_plus = constraint.distances(Configuration(robot, pin.integrate(robot.model, q, eps * v)), k_pairs)
    d_minus = constraint.distances(Configuration(robot, pin.integrate(robot.model, q, -eps * v)), k_pairs)
    rate = (d_plus - d_minus) / (2 * eps)
    checked = 0
    for row, (k, d) in enumerate(active):
        ds, gamma = constraint.min_distance + constraint.safety_margin, min(constraint.gain, 1 / DT)
        bound = -gamma * (d - ds) if d >= ds else min(gamma * (ds - d), constraint.recovery_speed)
        assert l[row] == pytest.approx(bound) and u[row] == np.inf
        if d > 1e-3:
            assert C[row] @ v == pytest.approx(rate[row], abs=1e-4 + 1e-3 * abs(rate[row])), constraint.active[row]
            checked += 1
    assert checked >= 3
    assert np.all(C[len(active):] == 0) and np.all(l[len(active):] == -np.inf)


def test_default_collision_pairs_honour_srdf_and_adjacency(robots):
    """talos: pairs listed in the SRDF's disable_collisions are absent; no pair on the same or adjacent joints.
    g1 has no SRDF: only adjacency filters."""
    import xml.etree.ElementTree as ET

    robot = robots("talos")
    model, gm = robot.model, robot.collision_model
    pairs = default_collision_pairs(robot)
    links = {(gm.geometryObjects[a].name.rsplit("_", 1)[0], gm.geometryObjects[b].name.rsplit("_", 1)[0])
             for a, b in pairs}
    disabled = [(e.get("link1"), e.get("link2")) for e in ET.parse(robot.srdf_path).getroot().iter("disable_collisions")]
    assert disabled and not any((a, b) in links or (b, a) in links for a, b in disabled)
    for a, b in pairs:
        ja, jb = gm.geometryObjects[a].parentJoint, gm.geometryObjects[b].parentJoint
        assert ja != jb and model.parents[ja] != jb and model.parents[jb] != ja
    g1 = robots("g1")
    n = g1.collision_model.ngeoms
    assert 0 < len(default_collision_pairs(g1)) < n * (n - 1) // 2


def test_task_constraint_rows(robots):
    robot = robots("humanoid15")
    config = Configuration(robot)
    com = ComTask(gain=7.0)
    com.set_target(config.com + [0.01, 0.0, 0.0])
    A, b = TaskConstraint(com).compute(config, DT)
    np.testing.assert_array_equal(A, config.com_jacobian)
    np.testing.assert_allclose(b, [0.07, 0.0, 0.0], atol=1e-12)
