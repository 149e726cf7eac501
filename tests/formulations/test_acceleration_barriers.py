"""The kinematic CoM-polygon and self-collision constraints held at the acceleration level (inverse dynamics) by
the same objects, under the same names (wbc.constraints.barrier.AccelerationBarrier).

Independent references: Pinocchio's CoM and wbc.geometry's signed distance (CoM polygon), coal distances
(self-collision), finite differences along the motion for ḣ and ḧ, and closed-loop runs of the ID QP integrated
with Pinocchio in which the constrained quantity, measured independently, stays on the safe side — and leaves it
without the constraint (so the tests can fail).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from wbc.constraints import ComPolygonConstraint, SelfCollisionConstraint
from wbc.dynamics import (
    AccelerationReference,
    DynamicsState,
    InverseDynamicsQP,
    SoleContact,
)
from wbc.exceptions import InvalidInputError, SolverError
from wbc.geometry import signed_distance
from wbc.tasks import ComTask, PositionTask, PostureTask

DT = 0.002


def _soles(robot):
    return [SoleContact(robot, robot.left_sole, name="left", mu=0.8),
            SoleContact(robot, robot.right_sole, name="right", mu=0.8)]


def _polygon(robot, margin):
    state = DynamicsState(robot, robot.q_ref)
    con = ComPolygonConstraint(robot, margin=margin)
    con.set_support([state.data.oMf[robot.frame_id(s)] for s in (robot.left_sole, robot.right_sole)])
    return con


def _com(robot, q):
    return pin.centerOfMass(robot.model, robot.model.createData(), q)


def test_com_polygon_barrier_terms_against_pinocchio_and_finite_differences(robots):
    robot = robots("talos")
    con = _polygon(robot, 0.01)
    rng = np.random.default_rng(5)
    q = robot.q_ref.copy()
    q[7:] += rng.uniform(-0.05, 0.05, robot.nq - 7)
    v = rng.normal(scale=0.3, size=robot.nv)
    h, G, drift = con.barrier(DynamicsState(robot, q, v), DT)
    k = len(con.offsets)
    assert np.all(np.isinf(h[k:]))

    def hfun(t):  # independent: Pinocchio CoM, the polygon's half-planes from its vertices
        c = _com(robot, pin.integrate(robot.model, q, v * t))[:2]
        poly = con.polygon
        edge = np.roll(poly, -1, axis=0) - poly
        n = np.stack([edge[:, 1], -edge[:, 0]], axis=1) / np.linalg.norm(edge, axis=1)[:, None]
        return np.einsum("ij,ij->i", n, poly) - 0.01 - n @ c

    eps = 1e-4
    np.testing.assert_allclose(h[:k], hfun(0.0), atol=1e-12)
    # inside, the smallest row is the distance to the shrunk boundary (wbc.geometry.signed_distance − margin)
    assert min(h[:k]) == pytest.approx(signed_distance(_com(robot, q)[:2], con.polygon) - 0.01, abs=1e-12)
    np.testing.assert_allclose(G[:k] @ v, (hfun(eps) - hfun(-eps)) / (2 * eps), atol=1e-7)
    np.testing.assert_allclose(drift[:k], (hfun(eps) - 2 * hfun(0.0) + hfun(-eps)) / eps**2, atol=1e-4)


def _run(robot, qp, ticks):
    """Semi-implicit Euler integration of the QP's v̇ (Pinocchio); a tick whose full QP is infeasible (torque or
    joint limits against the tasks' pull) takes the relaxed solve, which keeps the barrier rows."""
    q, v = robot.q_ref.copy(), np.zeros(robot.nv)
    state = DynamicsState(robot, q, v)
    qs = []
    for _ in range(ticks):
        state.update(q, v)
        try:
            sol = qp.solve(state, DT)
        except SolverError:
            sol = qp.solve_relaxed(state, DT)
        v = v + sol.dv * DT
        q = pin.integrate(robot.model, q, v * DT)
        qs.append(q)
    return qs


@pytest.mark.parametrize("with_barrier", [True, False])
def test_com_polygon_holds_under_inverse_dynamics(robots, with_barrier):
    """A CoM task pulls the CoM 0.2 m sideways, out of the support polygon; with the barrier the CoM (Pinocchio)
    stays inside the polygon shrunk by the margin, without it it leaves (measured: by tick 275)."""
    robot = robots("talos")
    margin = 0.02
    com = AccelerationReference(ComTask(), kp=30.0, weight=10.0)
    com.set_target(_com(robot, robot.q_ref) + [0.0, 0.2, 0.0])
    qp = InverseDynamicsQP(robot, [com, AccelerationReference(PostureTask(robot), kp=10.0)], _soles(robot))
    con = _polygon(robot, margin)
    if with_barrier:
        added = qp.add_constraint(con, gain=10.0)
        assert added.name == "com_polygon" and added in qp.constraints
    try:
        qs = _run(robot, qp, 600)
    except SolverError:  # only without the barrier: the CoM left the polygon and the robot falls
        assert not with_barrier
        return
    sd = np.array([signed_distance(_com(robot, q)[:2], con.polygon) for q in qs])
    if with_barrier:
        assert sd.min() >= margin - 1e-3, sd.min()
    else:
        assert sd.min() < 0.0  # the task alone takes the CoM out of the polygon


def _hand_into_torso(robot):
    hand = PositionTask(robot, robot.right_hand)
    state = DynamicsState(robot, robot.q_ref)
    torso = state.data.oMf[robot.frame_id(robot.torso)].translation
    hand.set_target(torso + [0.1, -0.05, 0.0])  # inside the torso's front: unreachable without collision
    return AccelerationReference(hand, kp=60.0, weight=10.0)


def _pair_distance(robot, con, q):
    """Smallest coal distance of the watched pairs at q (fresh Pinocchio data)."""
    data = robot.model.createData()
    pin.forwardKinematics(robot.model, data, q)
    gd = pin.GeometryData(con.geometry_model)
    pin.updateGeometryPlacements(robot.model, data, con.geometry_model, gd)
    return min(pin.computeDistance(con.geometry_model, gd, k).min_distance for k in range(len(con.pairs)))


def test_self_collision_barrier_rate_against_coal_finite_differences(robots):
    robot = robots("talos")
    con = SelfCollisionConstraint(robot, max_active=4)
    rng = np.random.default_rng(6)
    q = robot.q_ref.copy()  # half_sitting: the thighs are 11.9 mm apart, an active pair
    q[7:] += rng.uniform(-0.02, 0.02, robot.nq - 7)
    v = rng.normal(scale=0.3, size=robot.nv)
    h, G, drift = con.barrier(DynamicsState(robot, q, v), DT)
    assert np.isfinite(h[0]) and np.all(np.isinf(h[len(con.active):]))
    eps = 1e-6
    d = con.active[0][2]
    names = con.active[0][:2]
    k = con.pair_names.index(tuple(names))

    def dist(t):
        data = robot.model.createData()
        pin.forwardKinematics(robot.model, data, pin.integrate(robot.model, q, v * t))
        gd = pin.GeometryData(con.geometry_model)
        pin.updateGeometryPlacements(robot.model, data, con.geometry_model, gd)
        return pin.computeDistance(con.geometry_model, gd, k).min_distance

    assert dist(0.0) == pytest.approx(d, abs=1e-9)
    assert G[0] @ v == pytest.approx((dist(eps) - dist(-eps)) / (2 * eps), abs=1e-5)


@pytest.mark.parametrize("with_barrier", [True, False])
def test_self_collision_holds_under_inverse_dynamics(robots, with_barrier):
    """The right hand is pulled into the torso; with the self-collision barrier the coal distance of the watched
    pairs stays above min_distance, without it it drops below."""
    robot = robots("talos")
    hand = ["arm_right_5_link", "arm_right_6_link", "arm_right_7_link", "gripper_right_base_link"]
    con = SelfCollisionConstraint(robot, min_distance=0.02, safety_margin=0.0, max_active=8,
                                  pairs=[(link, robot.torso) for link in hand])
    assert _pair_distance(robot, con, robot.q_ref) > 0.05
    qp = InverseDynamicsQP(robot, [_hand_into_torso(robot), AccelerationReference(PostureTask(robot), kp=5.0)],
                           _soles(robot))
    if with_barrier:
        assert qp.add_constraint(con, gain=20.0).name == "self_collision"
    qs = _run(robot, qp, 300)
    d = min(_pair_distance(robot, con, q) for q in qs[::10])
    if with_barrier:
        assert d >= 0.02 - 2e-3, d
    else:
        assert d < 0.02, d


def test_barrier_typed_errors(robots):
    robot = robots("talos")
    qp = InverseDynamicsQP(robot, [], _soles(robot))
    with pytest.raises(InvalidInputError):
        qp.add_constraint(object())
    con = _polygon(robot, 0.01)
    qp.add_constraint(con)
    with pytest.raises(InvalidInputError):
        qp.add_constraint(con)  # same name twice
    with pytest.raises(InvalidInputError):
        InverseDynamicsQP(robot, []).add_constraint(_polygon(robot, 0.01), gain=-1.0)
    qp.remove_constraint(con)
    assert all(c.name != "com_polygon" for c in qp.constraints)
